// The merge engine's steps one by one (align, weld, free region, solve, checks, commit, rollback) on
// two unit squares sharing an edge, small enough to check by hand.
#include "arap_solver.h"
#include "engine_internal.h"
#include "test_support.h"
#include "test_engine_run.h"
#include "test_overlaps.h"

#include "texdefrag/core/distortion.h"
#include "texdefrag/core/uv_overlap.h"
#include "texdefrag/texture/resample.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace texdefrag::merge {
namespace {

/// Two unit squares in z = 0, left [0,1]x[0,1] and right [1,2]x[0,1], two triangles each, every face
/// counter-clockwise seen from +z; positions 1 = (1,0) and 4 = (1,1) form the shared edge. Page 64^2.
/// The left chart's texels are (8 + 16x, 8 + 16y). The right chart's are 16 texels per unit too, with
/// its local coordinates (a, b) = (x - 1, y) mapped to (56 - 16 b, 8 + 16 a) (rotated 90 degrees) or,
/// when `mirrored`, to (40 + 16 b, 8 + 16 a) (a reflection: its UV triangles turn clockwise), scaled
/// by `scale` about (40, 8).
TexturedMesh two_squares(bool mirrored, double scale = 1) {
  TexturedMesh m = test::one_page_mesh(64);
  for (int j = 0; j <= 1; ++j)
    for (int i = 0; i <= 2; ++i) m.positions.emplace_back(i, j, 0);
  const int tris[4][3] = {{0, 1, 4}, {0, 4, 3}, {1, 2, 5}, {1, 5, 4}};
  for (int t = 0; t < 4; ++t) {
    Face f;
    f.page = 0;
    f.source_line = t + 1;
    for (int k = 0; k < 3; ++k) {
      const Vec3& p = m.positions[static_cast<size_t>(tris[t][k])];
      Vec2 tx;
      if (t < 2) {
        tx = Vec2(8 + 16 * p.x(), 8 + 16 * p.y());
      } else {
        const double a = p.x() - 1, b = p.y();
        tx = mirrored ? Vec2(40 + 16 * b, 8 + 16 * a) : Vec2(56 - 16 * b, 8 + 16 * a);
        tx = Vec2(40, 8) + scale * (tx - Vec2(40, 8));
      }
      f.v[static_cast<size_t>(k)] = tris[t][k];
      f.vt[static_cast<size_t>(k)] = static_cast<int>(m.texcoords.size());
      m.texcoords.push_back(tx / 64.0);
    }
    m.faces.push_back(f);
  }
  return m;
}

struct Steps {
  test::Run run;
  ArapSolver solver;
  detail::Engine engine;
  int left, right;
  explicit Steps(TexturedMesh m, const MergeOptions& opt = {})
      : run(std::move(m)),
        engine(run.mesh, run.topo, run.ctx.atlas, run.ctx.regions.face_region, opt, solver),
        left(run.ctx.atlas.face_chart[0]),
        right(run.ctx.atlas.face_chart[2]) {
    engine.setup();
  }
  /// The move of `right` into `left` aligned, welded, its free region chosen and solved (not checked).
  detail::Move solved_move() {
    detail::Move mv = engine.begin_move(left, right);
    engine.align(mv);
    engine.weld(mv);
    engine.free_region(mv);
    engine.solve(mv);
    return mv;
  }
  Vec2 uv(int f, int k) const {
    const Atlas& at = run.ctx.atlas;
    return at.wedge_uv[static_cast<size_t>(at.face_wedge[static_cast<size_t>(f)][static_cast<size_t>(k)])];
  }
};

TEST(MergeEngineSteps, TwoSquaresAreTwoCharts) {
  Steps s(two_squares(false));
  EXPECT_EQ(s.run.ctx.atlas.num_charts, 2);
  EXPECT_NE(s.left, s.right);
  EXPECT_EQ(s.run.ctx.atlas.face_chart[1], s.left);
  EXPECT_EQ(s.run.ctx.atlas.face_chart[3], s.right);
  EXPECT_DOUBLE_EQ(s.engine.chart_info(s.left).uv_area, 256.0);  // 16 x 16 texels
}

TEST(MergeEngineSteps, AlignWeldFreeSolveCommit) {
  MergeOptions opt;
  opt.priority = Priority::MMethod;
  Steps s(two_squares(false), opt);
  detail::Move mv = s.engine.begin_move(s.left, s.right);
  EXPECT_EQ(mv.big, s.left);  // equal areas: the first chart stays
  EXPECT_EQ(mv.small, s.right);
  EXPECT_EQ(mv.seam_edges.size(), 1u);
  EXPECT_EQ(mv.pairs.size(), 2u);  // one wedge pair per seam vertex
  s.engine.align(mv);
  // The right square rotated back by -90 degrees and put against the left one: face 2's corners
  // (1,0), (2,0), (2,1) at texels (24,8), (40,8), (40,24).
  EXPECT_NEAR((s.uv(2, 0) - Vec2(24, 8)).norm(), 0, 1e-9);
  EXPECT_NEAR((s.uv(2, 1) - Vec2(40, 8)).norm(), 0, 1e-9);
  EXPECT_NEAR((s.uv(2, 2) - Vec2(40, 24)).norm(), 0, 1e-9);
  s.engine.weld(mv);
  EXPECT_EQ(mv.reps.size(), 2u);
  EXPECT_NEAR(mv.dmax, 0, 1e-9);
  // Both faces at position 1 = (1,0) now use one wedge, the left chart's.
  EXPECT_EQ(s.run.ctx.atlas.face_wedge[2][0], s.run.ctx.atlas.face_wedge[0][1]);
  EXPECT_EQ(s.run.ctx.atlas.face_chart[2], s.left);
  EXPECT_FALSE(s.engine.seam_mostly_folded(mv));
  s.engine.free_region(mv);
  EXPECT_EQ(mv.free_w.size(), 2u);  // radius alpha * 0: only the welded wedges
  s.engine.solve(mv);
  EXPECT_TRUE(mv.solved);
  EXPECT_EQ(mv.changed.size(), 4u);  // every face touches the seam
  EXPECT_EQ(s.engine.check(mv), nullptr);
  s.engine.commit(mv);
  EXPECT_FALSE(s.engine.chart_info(s.right).alive);
  EXPECT_EQ(s.engine.chart_info(s.left).faces.size(), 4u);
  EXPECT_DOUBLE_EQ(s.engine.chart_info(s.left).uv_area, 512.0);
  EXPECT_LT(s.engine.global_distortion(), 1e-18);
  // One boundary loop of 6 unit edges of 16 texels (the seam edge died; the M-method order keeps it).
  EXPECT_NEAR(s.engine.chart_info(s.left).border, 96, 1e-9);
}

TEST(MergeEngineSteps, CheckRejectsAndRollbackRestoresExactly) {
  MergeOptions opt;
  opt.global_bound = 1e-4;
  Steps s(two_squares(false, 1.5), opt);  // the right square has 1.5 x the texel density
  const Atlas before = s.run.ctx.atlas;
  detail::Move mv = s.engine.begin_move(s.left, s.right);
  EXPECT_EQ(mv.big, s.right);  // 2.25 x the area
  s.engine.align(mv);
  s.engine.weld(mv);
  EXPECT_GT(mv.dmax, 1.0);     // the 16-texel edge welded onto a 24-texel one
  s.engine.free_region(mv);
  EXPECT_GE(mv.free_w.size(), 2u);
  s.engine.solve(mv);
  EXPECT_STREQ(s.engine.check(mv), "global_distortion");
  s.engine.rollback();
  EXPECT_EQ(s.run.ctx.atlas.wedge_uv, before.wedge_uv);
  EXPECT_EQ(s.run.ctx.atlas.face_wedge, before.face_wedge);
  EXPECT_EQ(s.run.ctx.atlas.face_chart, before.face_chart);
  std::string reason;
  EXPECT_FALSE(s.engine.try_merge(s.left, s.right, reason));
  EXPECT_EQ(reason, "global_distortion");
  EXPECT_EQ(s.run.ctx.atlas.wedge_uv, before.wedge_uv);
}

TEST(MergeEngineSteps, CheckNamesTheFirstFailingTest) {
  // A solver that reports failure: "flip" before any other test.
  struct Failing : LocalSolver {
    SolveResult solve(LocalProblem&) override {
      SolveResult r;
      r.ok = false;
      return r;
    }
  } failing;
  test::Run run(two_squares(false));
  detail::Engine e(run.mesh, run.topo, run.ctx.atlas, run.ctx.regions.face_region, MergeOptions{}, failing);
  e.setup();
  std::string reason;
  EXPECT_FALSE(e.try_merge(run.ctx.atlas.face_chart[0], run.ctx.atlas.face_chart[2], reason));
  EXPECT_EQ(reason, "flip");
}

// A face of zero input UV area has no Jacobian, so the flip test used to skip it: a merge could
// turn it over onto its neighbours (a real 3D Tiles producer's atlas has many such faces). Here
// the right square's face 2 (positions 1, 2, 5) has its corner 2 midway from corner 1 to corner 5
// (zero area; position 2 belongs to face 2 alone). Aligned, welded and solved, it stays flat:
// accepted. Its corner 2 moved across the line 1-5 (only face 2 turns over): "flip".
TEST(MergeEngineSteps, AZeroUvAreaFaceMayNotTurnOver) {
  TexturedMesh m = two_squares(false);
  m.texcoords[static_cast<size_t>(m.faces[2].vt[1])] = Vec2(48, 16) / 64.0;  // midway from (56,8) to (40,24)
  MergeOptions opt;
  opt.priority = Priority::MMethod;
  Steps s(m, opt);
  ASSERT_EQ(s.run.ctx.atlas.face_chart[2], s.right);
  EXPECT_EQ(s.engine.chart_info(s.right).uv_area, 128.0);  // face 3 only
  detail::Move mv = s.solved_move();
  ASSERT_TRUE(mv.solved);
  {
    const char* why = s.engine.check(mv);
    EXPECT_EQ(why, nullptr) << why;
  }
  const Vec2 c1 = s.uv(2, 0), c5 = s.uv(2, 2);
  Vec2& c2 = s.run.ctx.atlas.wedge_uv[static_cast<size_t>(s.run.ctx.atlas.face_wedge[2][1])];
  const Vec2 e = c5 - c1, n(-e.y(), e.x());  // n: left of 1 -> 5
  c2 = 0.5 * (c1 + c5) + 0.25 * n;
  const Vec2 a = c2 - c1;
  ASSERT_LT(a.x() * e.y() - a.y() * e.x(), 0);  // face 2 (1, 2, 5) is clockwise now
  EXPECT_STREQ(s.engine.check(mv), "flip");
  s.engine.rollback();
}

double signed_area(const Atlas& at, int f) {
  const auto& w = at.face_wedge[static_cast<size_t>(f)];
  const Vec2 a = at.wedge_uv[static_cast<size_t>(w[0])], b = at.wedge_uv[static_cast<size_t>(w[1])],
             c = at.wedge_uv[static_cast<size_t>(w[2])];
  return 0.5 * ((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
}

TEST(MergeEngineSteps, MirroredSquareIsWeldedWithAReflection) {
  // The right square's texels are a mirror image (its UV triangles turn clockwise, the left one's
  // counter-clockwise, for the same 3D winding): a proper motion would fold the seam.
  Steps s(two_squares(true));
  EXPECT_LT(signed_area(s.run.ctx.atlas, 2), 0);
  EXPECT_GT(signed_area(s.run.ctx.atlas, 0), 0);
  EXPECT_TRUE(s.engine.seam_mirrored(s.left, s.right));
  detail::Move mv = s.engine.begin_move(s.left, s.right);
  s.engine.align(mv);
  EXPECT_TRUE(mv.mirrored);
  // Reflected onto the left square's right side: face 2 = (1,0), (2,0), (2,1) at (24,8), (40,8), (40,24).
  EXPECT_NEAR((s.uv(2, 0) - Vec2(24, 8)).norm(), 0, 1e-9);
  EXPECT_NEAR((s.uv(2, 1) - Vec2(40, 8)).norm(), 0, 1e-9);
  EXPECT_NEAR((s.uv(2, 2) - Vec2(40, 24)).norm(), 0, 1e-9);
  EXPECT_TRUE(s.engine.face_mirrored(2));
  EXPECT_TRUE(s.engine.face_mirrored(3));
  EXPECT_FALSE(s.engine.face_mirrored(0));
  s.engine.weld(mv);
  EXPECT_FALSE(s.engine.seam_mostly_folded(mv));
  s.engine.free_region(mv);
  s.engine.solve(mv);
  EXPECT_EQ(s.engine.check(mv), nullptr);
  s.engine.commit(mv);
  EXPECT_LT(s.engine.global_distortion(), 1e-18);
  // Every face keeps its UV area (128 texels^2) and now turns like its neighbours.
  for (int f = 0; f < 4; ++f) EXPECT_NEAR(signed_area(s.run.ctx.atlas, f), 128, 1e-9) << f;
}

TEST(MergeEngineSteps, MirroredMergeRollsBackTheHandedness) {
  MergeOptions opt;
  opt.global_bound = 1e-4;
  Steps s(two_squares(true, 1.5), opt);  // mirrored and 1.5 x denser: rejected on distortion
  const Atlas before = s.run.ctx.atlas;
  std::string reason;
  EXPECT_FALSE(s.engine.try_merge(s.left, s.right, reason));
  EXPECT_EQ(reason, "global_distortion");
  EXPECT_EQ(s.run.ctx.atlas.wedge_uv, before.wedge_uv);
  EXPECT_EQ(s.run.ctx.atlas.face_wedge, before.face_wedge);
  for (int f = 0; f < 4; ++f) EXPECT_FALSE(s.engine.face_mirrored(f)) << f;
}

/// two_squares with the right square's faces wound the other way in 3D (corners 0, 2, 1: positions
/// and texels together): the seam's two faces traverse the shared edge (1,0)-(1,1) in the same
/// direction, so the fold-free weld gives the two squares opposite UV turns.
TexturedMesh two_squares_inconsistently_wound(bool mirrored, double scale = 1) {
  TexturedMesh m = two_squares(mirrored, scale);
  for (size_t f = 2; f < 4; ++f) {
    std::swap(m.faces[f].v[1], m.faces[f].v[2]);
    std::swap(m.faces[f].vt[1], m.faces[f].vt[2]);
  }
  return m;
}

/// Every merge of `run` with the default options and the ARAP solver (the engine's whole loop).
MergeReport merge_all(test::Run& run) {
  ArapSolver solver;
  return run_merges(run.mesh, run.topo, run.ctx.atlas, run.ctx.regions.face_region, MergeOptions{}, solver, {});
}

TEST(MergeEngineSteps, AReflectionThatWouldTurnAgainstTheChartIsRefused) {
  // By hand: the left square turns counter-clockwise in UV (+128 texels^2 per face), so does the
  // right one (mirrored texels, reversed corners: +122.9 at scale 0.98). Their 3D windings disagree
  // across the seam, so a proper motion folds it: the engine reflects the right square. The weld is
  // then fold-free and every face keeps its (mirrored) rest shape, but the merged chart turns both
  // ways: the framework's measure (core/distortion.h) sees a reflected input chart turning against
  // its chart's majority (the left square's 256 > 245.8 texels^2) and counts its 2 faces flipped.
  MergeOptions opt;
  opt.priority = Priority::MMethod;
  const TexturedMesh mesh = two_squares_inconsistently_wound(true, 0.98);
  {
    Steps s(mesh, opt);
    EXPECT_GT(signed_area(s.run.ctx.atlas, 0), 0);
    EXPECT_GT(signed_area(s.run.ctx.atlas, 2), 0);
    EXPECT_TRUE(s.engine.seam_mirrored(s.left, s.right));
    // The move carried on past the orientation check: every other check passes, the framework
    // counts flips.
    detail::Move mv = s.engine.begin_move(s.left, s.right);
    s.engine.align(mv);
    EXPECT_TRUE(mv.mirrored);
    EXPECT_STREQ(s.engine.check_orientation(mv), "mirror_orientation");
    s.engine.weld(mv);
    EXPECT_FALSE(s.engine.seam_mostly_folded(mv));
    s.engine.free_region(mv);
    s.engine.solve(mv);
    EXPECT_EQ(s.engine.check(mv), nullptr);
    s.engine.commit(mv);
    EXPECT_GT(signed_area(s.run.ctx.atlas, 0), 0);
    EXPECT_LT(signed_area(s.run.ctx.atlas, 2), 0);
    Atlas at = s.run.ctx.atlas;
    at.compact();
    const DistortionSummary d = atlas_distortion(s.run.mesh, at, s.run.charts.atlas.face_chart);
    EXPECT_EQ(d.flipped, 2u);
    EXPECT_EQ(d.mirrored, 0u);
    EXPECT_GT(d.arap, 1.9);  // the reflected faces' error is (1 - 1)^2 + (-1 - 1)^2 = 4, on half the weight
  }
  // try_merge refuses it and restores the atlas.
  Steps s(mesh, opt);
  const Atlas before = s.run.ctx.atlas;
  std::string reason;
  EXPECT_FALSE(s.engine.try_merge(s.left, s.right, reason));
  EXPECT_EQ(reason, "mirror_orientation");
  EXPECT_EQ(s.run.ctx.atlas.wedge_uv, before.wedge_uv);
  EXPECT_EQ(s.run.ctx.atlas.face_wedge, before.face_wedge);
  for (int f = 0; f < 4; ++f) EXPECT_FALSE(s.engine.face_mirrored(f)) << f;
}

TEST(MergeEngineSteps, AnInconsistentlyWoundSeamWithoutReflectionMerges) {
  // The right square's texels are not mirrored: with its reversed corners it turns clockwise, the
  // left one counter-clockwise, and the proper weld is fold-free. Nothing is reflected, so the
  // framework measures every face as is: one chart, nothing flipped, no distortion.
  test::Run run(two_squares_inconsistently_wound(false));
  const MergeReport r = merge_all(run);
  EXPECT_EQ(r.charts_out, 1u);
  EXPECT_EQ(r.accepted_mirrored, 0u);
  EXPECT_EQ(r.flipped_out, 0u);
  const DistortionSummary d = atlas_distortion(run.mesh, run.ctx.atlas, run.charts.atlas.face_chart);
  EXPECT_EQ(d.flipped, 0u);
  EXPECT_LT(d.arap, 1e-12);
  EXPECT_LT(signed_area(run.ctx.atlas, 0) * signed_area(run.ctx.atlas, 2), 0);  // opposite turns, no fold
}

TEST(MergeEngineSteps, InconsistentlyWoundMirroredSquaresStayTwoCharts) {
  test::Run run(two_squares_inconsistently_wound(true, 0.98));
  const MergeReport r = merge_all(run);
  EXPECT_EQ(r.charts_out, 2u);
  EXPECT_EQ(r.rejected.count("mirror_orientation"), 1u);
  EXPECT_EQ(r.flipped_out, 0u);
  EXPECT_LT(r.distortion_out, 1e-12);
}

TEST(MergeEngineSteps, MirroredChartsMergeIntoOneWithoutFlipsAndTheTextureIsReproduced) {
  test::Run run(two_squares(true));
  const MergeReport r = merge_all(run);
  EXPECT_EQ(r.charts_out, 1u);
  EXPECT_EQ(r.accepted_mirrored, 1u);
  EXPECT_EQ(r.mirrored_faces_out, 2u);
  EXPECT_EQ(r.rejected.count("orientation"), 0u);
  EXPECT_EQ(r.flipped_out, 0u);
  EXPECT_LT(r.distortion_out, 1e-12);
  const Atlas& at = run.ctx.atlas;
  // The core measure: the right square is a mirrored group, no face flipped, no distortion.
  const DistortionSummary d = atlas_distortion(run.mesh, at, run.charts.atlas.face_chart);
  EXPECT_EQ(d.flipped, 0u);
  EXPECT_EQ(d.mirrored, 2u);
  EXPECT_LT(d.arap, 1e-12);
  for (int f = 0; f < 4; ++f) EXPECT_NEAR(std::abs(signed_area(at, f)), 128, 1e-9) << f;

  // Texture: an input page linear in the texel position (y up), value = x + 2 y, read through each
  // face's own affine map; every output texel well inside a face shows the input's value there.
  auto value = [](const Vec2& p) { return p.x() + 2 * p.y(); };
  Image in;
  in.width = in.height = 64;
  in.channels = 1;
  in.pixels.resize(64 * 64);
  for (int row = 0; row < 64; ++row)
    for (int x = 0; x < 64; ++x) *in.at(x, row) = static_cast<uint8_t>(std::lround(value(Vec2(x + 0.5, 63.5 - row))));
  Layout layout;
  layout.pages.push_back({64, 64});
  layout.chart_page.assign(static_cast<size_t>(at.num_charts), 0);
  layout.wedge_uv = at.wedge_uv;  // the merged chart lies in [8, 40] x [8, 24]
  ResampleOptions ro;
  ro.fit = TexelFit::Sample;
  const std::vector<Image> out = resample_atlas(run.mesh, {in}, at, layout, ro);
  ASSERT_EQ(out.size(), 1u);
  size_t checked = 0;
  for (int f = 0; f < 4; ++f) {
    Vec2 o[3], n[3];
    for (int k = 0; k < 3; ++k) {
      o[k] = run.mesh.corner_texel(static_cast<size_t>(f), k);
      n[k] = at.wedge_uv[static_cast<size_t>(at.face_wedge[static_cast<size_t>(f)][static_cast<size_t>(k)])];
    }
    const double det = (n[1] - n[0]).x() * (n[2] - n[0]).y() - (n[1] - n[0]).y() * (n[2] - n[0]).x();
    for (int row = 0; row < 64; ++row)
      for (int x = 0; x < 64; ++x) {
        const Vec2 c(x + 0.5, 63.5 - row);
        // Barycentric coordinates of the texel centre in the output triangle.
        const double b1 = ((c - n[0]).x() * (n[2] - n[0]).y() - (c - n[0]).y() * (n[2] - n[0]).x()) / det;
        const double b2 = ((n[1] - n[0]).x() * (c - n[0]).y() - (n[1] - n[0]).y() * (c - n[0]).x()) / det;
        const double b0 = 1 - b1 - b2;
        if (b0 < 0.15 || b1 < 0.15 || b2 < 0.15) continue;
        const Vec2 p = b0 * o[0] + b1 * o[1] + b2 * o[2];  // its pre-image in the input page
        EXPECT_NEAR(*out[0].at(x, row), value(p), 1.01) << "face " << f << " texel " << x << "," << row;
        ++checked;
      }
  }
  EXPECT_GT(checked, 100u);
}


// An input chart that overlaps itself (multi-sheeted photogrammetry charts: t078_L15 has 149 such
// pairs) used to refuse every merge it took part in: the triangle test counted its own old pair.
// Here the right square gets a fifth face (positions 2, 6, 5; 6 = (2.5, 0.5)) whose UV corner 6 lies
// folded back inside face 2's UV triangle, sharing edge 2-5 with it on the same side: one
// overlapping pair inside the right chart, far from the seam. The merge moves that chart rigidly and
// welds at exact texels, so it adds no pair: accepted, and the merged chart holds the same one pair.
TEST(MergeEngineSteps, AnInputChartsOwnOverlapDoesNotRefuseTheMerge) {
  TexturedMesh m = two_squares(false);
  m.positions.emplace_back(2.5, 0.5, 0);
  Face f;
  f.page = 0;
  f.source_line = 5;
  const int v[3] = {2, 6, 5};
  const Vec2 tx[3] = {Vec2(56, 24), Vec2(52, 20), Vec2(40, 24)};  // (52, 20) is inside face 2's (56,8) (56,24) (40,24)
  for (int k = 0; k < 3; ++k) {
    f.v[static_cast<size_t>(k)] = v[k];
    f.vt[static_cast<size_t>(k)] = static_cast<int>(m.texcoords.size());
    m.texcoords.push_back(tx[k] / 64.0);
  }
  m.faces.push_back(f);
  MergeOptions opt;
  opt.priority = Priority::MMethod;
  Steps s(m, opt);
  ASSERT_EQ(s.run.ctx.atlas.num_charts, 2);
  ASSERT_EQ(s.run.ctx.atlas.face_chart[4], s.right);
  EXPECT_TRUE(s.engine.chart_info(s.right).self_overlap);
  std::string reason;
  EXPECT_TRUE(s.engine.try_merge(s.left, s.right, reason)) << reason;
  const auto [in, out] = test::overlaps_in_out(s.run);
  EXPECT_EQ(in, 1u);
  EXPECT_EQ(out, 1u);
  EXPECT_EQ(s.run.ctx.atlas.face_chart[0], s.run.ctx.atlas.face_chart[4]);  // one chart
}
/// Two columns of n unit squares side by side in z = 0 ([0,1]x[0,n] and [1,2]x[0,n]), one chart
/// each, sharing the n-edge seam x = 1. The left chart's texels are (8 + 16x, 8 + 16y); the right
/// chart's are (40 + 16 s (x - 1), 8 + 16 s y): the same layout scaled by s. Page 1024^2.
TexturedMesh two_columns(int n, double s) {
  TexturedMesh m = test::one_page_mesh(1024);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= 2; ++i) m.positions.emplace_back(i, j, 0);
  auto id = [](int i, int j) { return j * 3 + i; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < 2; ++i) {
      const int q[2][3] = {{id(i, j), id(i + 1, j), id(i + 1, j + 1)}, {id(i, j), id(i + 1, j + 1), id(i, j + 1)}};
      for (const auto& t : q) {
        Face f;
        f.page = 0;
        f.source_line = static_cast<int>(m.faces.size()) + 1;
        for (int k = 0; k < 3; ++k) {
          const Vec3& p = m.positions[static_cast<size_t>(t[k])];
          const Vec2 tx = i == 0 ? Vec2(8 + 16 * p.x(), 8 + 16 * p.y()) : Vec2(40 + 16 * s * (p.x() - 1), 8 + 16 * s * p.y());
          f.v[static_cast<size_t>(k)] = t[k];
          f.vt[static_cast<size_t>(k)] = static_cast<int>(m.texcoords.size());
          m.texcoords.push_back(tx / 1024.0);
        }
        m.faces.push_back(f);
      }
    }
  return m;
}

/// The M-method's alignment refusal, by hand. Two columns of n = 16 squares, the right one's texels
/// scaled by s = 2. The seam's 17 wedge pairs lie on one line each side (left at 16 j, right at 32 j
/// texels, j = 0..16); the best rigid motion only matches their centres, so pair j stays 16 |j - 8|
/// texels apart: mean error 16 x 72 / 17 = 67.8 texels. The seam's UV length is 256 texels on the
/// left and 512 on the right: mean 384, mean edge 24. The program's rule refuses above 2 x 384 = 768
/// (not here); the per-edge rule refused above 2 x 24 = 48 (here). Once attempted, the weld of a
/// 2x-scaled column cannot meet the 0.025 budget, so either way the charts stay apart, and the seam
/// left is reported under the reason that stopped it (16 edges of 3D length 1).
TEST(MergeEngineSteps, TheAlignmentRefusalScalesWithTheWholeSeam) {
  for (bool per_edge : {true, false}) {
    test::Run run(two_columns(16, 2));
    ASSERT_EQ(run.ctx.atlas.num_charts, 2);
    MergeOptions o;
    o.priority = Priority::MMethod;
    o.alignment_per_edge = per_edge;
    ArapSolver solver;
    const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, {}, o, solver, {});
    EXPECT_EQ(r.charts_out, 2u);
    EXPECT_EQ(r.rejected.count("alignment_error"), per_edge ? 1u : 0u);
    EXPECT_EQ(r.attempted, per_edge ? 0u : 1u);  // a refused pair is never welded
    ASSERT_EQ(r.seam_left.size(), 1u);
    const auto& [why, left] = *r.seam_left.begin();
    if (per_edge) EXPECT_EQ(why, "alignment_error");
    else EXPECT_NE(why, "alignment_error");
    EXPECT_EQ(left.pairs, 1u);
    EXPECT_EQ(left.edges, 16u);
    EXPECT_NEAR(left.length_3d, 16.0, 1e-12);
    test::expect_valid_atlas(run);
  }
  // Scaled by 1.5 the error is 16 x 0.5 x 72 / 17 = 33.9 texels, under both rules' limits (2 x 20
  // per edge): the pair is attempted under either.
  for (bool per_edge : {true, false}) {
    test::Run run(two_columns(16, 1.5));
    MergeOptions o;
    o.priority = Priority::MMethod;
    o.alignment_per_edge = per_edge;
    ArapSolver solver;
    const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, {}, o, solver, {});
    EXPECT_EQ(r.rejected.count("alignment_error"), 0u);
    EXPECT_EQ(r.attempted, 1u);
  }
}

TEST(MergeEngineSteps, TheUnconstrainedTrialIsKeptOnlyWhenItLeavesLessSeam) {
  // By hand: the two squares in two regions (faces 0-1 and 2-3) and no second pass: with regions the
  // pair is no candidate, so 2 charts stay and their shared edge (3D length 1) is left cut. The merge
  // costs nothing (the right square is the left one's texel density, turned 90 degrees), so the
  // distortion after it (0) is under 0.8 x the bound: the trial merges without regions into one
  // chart, leaves no seam (0 < 1) and is kept.
  const std::vector<int> regions{0, 0, 1, 1};
  ArapSolver solver;
  {
    test::Run run(two_squares(false));
    MergeOptions o;
    o.unconstrained_trial = true;
    const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, regions, o, solver, {});
    EXPECT_TRUE(r.unconstrained_trial_run);
    EXPECT_TRUE(r.unconstrained_trial_kept);
    EXPECT_NEAR(r.regions_seam_left_length_3d, 1.0, 1e-12);
    EXPECT_EQ(r.seam_left_length_3d(), 0.0);
    EXPECT_EQ(r.charts_out, 1u);
    EXPECT_EQ(run.ctx.atlas.num_charts, 1);
    EXPECT_EQ(r.flipped_out, 0u);
    test::expect_valid_atlas(run);
  }
  // Off, or with a share of 0 (no distortion is below 0 x the bound): the regions' 2 charts.
  for (bool on : {false, true}) {
    test::Run run(two_squares(false));
    MergeOptions o;
    o.unconstrained_trial = on;
    o.unconstrained_trial_share = 0;
    const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, regions, o, solver, {});
    EXPECT_FALSE(r.unconstrained_trial_run);
    EXPECT_EQ(r.charts_out, 2u);
    EXPECT_NEAR(r.seam_left_length_3d(), 1.0, 1e-12);
  }
  // The right square 1.5x denser: welding it costs ARAP error far above a bound of 1e-4, so the trial
  // runs (0 < 0.8e-4) but is refused the same merge (global_distortion) and leaves the same seam
  // (1 = 1): the regions' atlas stays, bit for bit.
  {
    test::Run run(two_squares(false, 1.5));
    const Atlas input = run.ctx.atlas;
    MergeOptions o;
    o.unconstrained_trial = true;
    o.global_bound = 1e-4;
    const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, regions, o, solver, {});
    EXPECT_TRUE(r.unconstrained_trial_run);
    EXPECT_FALSE(r.unconstrained_trial_kept);
    EXPECT_EQ(r.charts_out, 2u);
    EXPECT_EQ(run.ctx.atlas.wedge_uv, input.wedge_uv);
    EXPECT_EQ(run.ctx.atlas.face_wedge, input.face_wedge);
  }
}

/// The distortion left by welding the two squares, the right one 1.5x denser, in one region with a
/// budget that never refuses the weld (global_bound 1): the price of that merge times the bound.
double denser_square_weld_distortion() {
  test::Run run(two_squares(false, 1.5));
  ArapSolver solver;
  MergeOptions o;
  o.global_bound = 1;
  const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, {0, 0, 0, 0}, o, solver, {});
  EXPECT_EQ(r.charts_out, 1u);
  return r.distortion_out;
}

TEST(MergeEngineSteps, TheSeamPriceRefusesAFirstPassMergeThatSpendsTheBudgetOutOfProportion) {
  // By hand: the two squares in one region, the right one 1.5x denser, so welding them costs ARAP
  // error. Their shared edge (3D length 1) is the input's whole seam, so the merge's share of the seam
  // is 1 and its price is its share of the budget: D / global_bound, D the distortion it leaves (the
  // input's is 0). A cap just under that price refuses it (`price`, the edge left cut under that
  // reason); just over, it merges; with the second pass (no cap there) it merges after the refusal.
  const std::vector<int> one_region{0, 0, 0, 0};
  ArapSolver solver;
  MergeOptions o;
  o.global_bound = 1;  // the budget itself never refuses the weld
  const double price = denser_square_weld_distortion() / o.global_bound;
  ASSERT_GT(price, 1e-4);
  o.seam_price = SeamPrice::On;
  for (const bool merged : {false, true}) {
    test::Run run(two_squares(false, 1.5));
    const Atlas input = run.ctx.atlas;
    o.max_seam_price = price * (merged ? 1.01 : 0.99);
    const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, one_region, o, solver, {});
    EXPECT_EQ(r.charts_out, merged ? 1u : 2u) << o.max_seam_price;
    EXPECT_EQ(r.rejected.count("price"), merged ? 0u : 1u);
    if (!merged) {
      EXPECT_EQ(r.rejected.at("price"), 1u);
      EXPECT_NEAR(r.seam_left.at("price").length_3d, 1.0, 1e-12);
      EXPECT_EQ(run.ctx.atlas.wedge_uv, input.wedge_uv);
      EXPECT_EQ(run.ctx.atlas.face_wedge, input.face_wedge);
    }
    EXPECT_EQ(r.flipped_out, 0u);
  }
  {
    test::Run run(two_squares(false, 1.5));
    o.max_seam_price = price * 0.99;
    o.second_pass = SecondPass::AcrossRegions;
    const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, one_region, o, solver, {});
    EXPECT_EQ(r.charts_out, 1u);
    EXPECT_EQ(r.rejected.at("price"), 1u);
    EXPECT_EQ(r.accepted_second_pass, 1u);
    EXPECT_NEAR(r.distortion_out, price * o.global_bound, 1e-9);
    test::expect_valid_atlas(run);
  }
}

TEST(MergeEngineSteps, SeamPriceBothKeepsTheAtlasWithLessSeamAndTheTrialIsPricedOnlyWhenAsked) {
  // The two squares of the test above, the cap just under the weld's price, no second pass.
  const std::vector<int> one_region{0, 0, 0, 0};
  ArapSolver solver;
  MergeOptions o;
  o.global_bound = 1;
  const double price = denser_square_weld_distortion() / o.global_bound;
  o.max_seam_price = price * 0.99;
  // Both ways: the run without the price merges (seam left 0), the priced one leaves the edge cut
  // (1): the unpriced atlas is kept.
  {
    test::Run run(two_squares(false, 1.5));
    o.second_pass = SecondPass::None;
    o.seam_price = SeamPrice::Both;
    const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, one_region, o, solver, {});
    EXPECT_EQ(r.charts_out, 1u);
    EXPECT_FALSE(r.seam_price_kept);
    EXPECT_EQ(r.unpriced_seam_left_length_3d, 0.0);
    EXPECT_EQ(r.rejected.count("price"), 0u);
    test::expect_valid_atlas(run);
    o.seam_price = SeamPrice::On;
  }
  // The unconstrained trial (two regions, no second pass: only the trial can weld the pair) merges
  // without the price unless unconstrained_trial_seam_price says otherwise.
  o.second_pass = SecondPass::None;
  o.unconstrained_trial = true;
  for (const bool priced : {false, true}) {
    test::Run run(two_squares(false, 1.5));
    o.unconstrained_trial_seam_price = priced;
    const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, {0, 0, 1, 1}, o, solver, {});
    EXPECT_TRUE(r.unconstrained_trial_run);
    EXPECT_EQ(r.unconstrained_trial_kept, !priced);
    EXPECT_EQ(r.charts_out, priced ? 2u : 1u);
  }
  // Declared once: off by default, the cap 5, never 0 or below (no cap that refuses everything).
  const std::vector<OptionSpec> specs = merge_option_specs();
  json values = json::object();
  for (const OptionSpec& sp : specs) {
    values[sp.key] = sp.default_value;
    if (sp.key == "max_seam_price") {
      EXPECT_EQ(check_option_value(sp, 0), "= 0 outside [1e-06, 1e+06]");
    }
  }
  const MergeOptions d = merge_options_from(Options(values));
  EXPECT_EQ(d.seam_price, SeamPrice::Off);
  EXPECT_FALSE(d.unconstrained_trial_seam_price);
  EXPECT_EQ(d.max_seam_price, 5);
  EXPECT_EQ(d.seam_price_both_max_faces, 300000u);
  values["seam_price"] = "both";
  values["max_seam_price"] = 3.5;
  values["seam_price_both_max_faces"] = 7;
  const MergeOptions m = merge_options_from(Options(values));
  EXPECT_EQ(m.seam_price, SeamPrice::Both);
  EXPECT_EQ(m.max_seam_price, 3.5);
  EXPECT_EQ(m.seam_price_both_max_faces, 7u);
}

/// Runs run_merges on the two squares of `run` (two regions, the unconstrained trial on in `o`) and
/// checks that the trial ran and, as `merged` says, was kept with one chart and no seam left, or not
/// kept with two charts and the shared edge (3D length 1) left cut.
void expect_trial_merged(test::Run& run, const std::vector<int>& regions, const MergeOptions& o, bool merged,
                         const std::string& what) {
  ArapSolver solver;
  const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, regions, o, solver, {});
  EXPECT_TRUE(r.unconstrained_trial_run) << what;
  EXPECT_EQ(r.unconstrained_trial_kept, merged) << what;
  EXPECT_EQ(r.charts_out, merged ? 1u : 2u) << what;
  EXPECT_NEAR(r.seam_left_length_3d(), merged ? 0.0 : 1.0, 1e-12) << what;
}

TEST(MergeEngineSteps, TheTrialRefusesCollapsedTrianglesByItsOwnLimit) {
  // By hand: the two squares in two regions and no second pass, so only the unconstrained trial can
  // merge them; the right square is 1.5x denser, so the weld squeezes triangles of it (or stretches
  // the left one's) to well under 0.95 of their input size in some direction, at an ARAP cost far
  // under a bound of 1. With a collapse limit of 0.95 the trial is refused the merge (2 charts, the
  // seam of length 1 left, not kept); without one it merges into one chart with that squeeze.
  // unconstrained_trial_min_singular_value decides, whatever min_singular_value says; negative
  // takes min_singular_value's.
  const std::vector<int> regions{0, 0, 1, 1};
  struct Case {
    double run_limit, trial_limit;
    bool merged;
  };
  for (const Case c : {Case{0.95, -1, false}, Case{0.95, 0, true}, Case{0, 0.95, false}, Case{0, -1, true}}) {
    const std::string what = "min_singular_value " + std::to_string(c.run_limit) + ", the trial's " +
                             std::to_string(c.trial_limit);
    test::Run run(two_squares(false, 1.5));
    MergeOptions o;
    o.unconstrained_trial = true;
    o.global_bound = 1;
    o.min_singular_value = c.run_limit;
    o.unconstrained_trial_min_singular_value = c.trial_limit;
    expect_trial_merged(run, regions, o, c.merged, what);
    if (c.merged) EXPECT_LT(test::smallest_singular_value(run), 0.95) << what;
    else EXPECT_NEAR(test::smallest_singular_value(run), 1.0, 1e-9) << what;
    test::expect_valid_atlas(run);
  }
}

TEST(MergeEngineSteps, TheTrialsOwnLimitsAreDeclaredWithRangesAndRead) {
  const std::vector<OptionSpec> specs = merge_option_specs();
  json values = json::object();
  for (const OptionSpec& sp : specs) values[sp.key] = sp.default_value;
  auto check = [&](const std::string& key, const json& v) {
    for (const OptionSpec& sp : specs)
      if (sp.key == key) return check_option_value(sp, v);
    ADD_FAILURE() << "no option " << key;
    return std::string();
  };
  EXPECT_EQ(check("unconstrained_trial_max_attempts", -1), "= -1 outside [0, 1000]");
  EXPECT_EQ(check("unconstrained_trial_repaired_global_share", 1.5), "= 1.5 outside [-1, 1]");
  EXPECT_EQ(check("unconstrained_trial_second_pass_local_bound", -2), "= -2 outside [-1, 1e+06]");
  // The defaults are "the run's own".
  const MergeOptions d = merge_options_from(Options(values));
  EXPECT_EQ(d.unconstrained_trial_max_attempts, 0);
  EXPECT_LT(d.unconstrained_trial_repaired_global_share, 0);
  EXPECT_LT(d.unconstrained_trial_second_pass_local_bound, 0);
  values["unconstrained_trial_max_attempts"] = 6;
  values["unconstrained_trial_repaired_global_share"] = 1.0;
  values["unconstrained_trial_second_pass_local_bound"] = 0.5;
  const MergeOptions m = merge_options_from(Options(values));
  EXPECT_EQ(m.unconstrained_trial_max_attempts, 6);
  EXPECT_EQ(m.unconstrained_trial_repaired_global_share, 1.0);
  EXPECT_EQ(m.unconstrained_trial_second_pass_local_bound, 0.5);
}

TEST(MergeEngineSteps, TheTrialMergesWithItsOwnAttemptsAndSecondPassBound) {
  // By hand: the two squares of the test above (right one 1.5x denser), in two regions, merged by a
  // second pass across regions only. Every first pass refuses the weld (local_bound 1e-9: any
  // squeeze is over it) and spends one attempt on the pair. The run with regions never has the
  // pair in its first pass, and its second pass refuses it too (second_pass_local_bound 1e-9). The
  // trial's first pass refuses it; its second pass can merge it only with an attempt left
  // (max_attempts 1 spends the one attempt in the first pass) and a bound over the weld's error.
  const std::vector<int> regions{0, 0, 1, 1};
  struct Case {
    int trial_attempts;
    double trial_bound;
    bool merged;
  };
  for (const Case c : {Case{0, -1, false}, Case{2, -1, false}, Case{0, 10, false}, Case{2, 10, true}}) {
    const std::string what = "the trial's max_attempts " + std::to_string(c.trial_attempts) +
                             ", second_pass_local_bound " + std::to_string(c.trial_bound);
    test::Run run(two_squares(false, 1.5));
    MergeOptions o;
    o.unconstrained_trial = true;
    o.global_bound = 1;
    o.local_bound = 1e-9;
    o.second_pass = SecondPass::AcrossRegions;
    o.second_pass_local_bound = 1e-9;
    o.max_attempts = 1;
    o.unconstrained_trial_max_attempts = c.trial_attempts;
    o.unconstrained_trial_second_pass_local_bound = c.trial_bound;
    expect_trial_merged(run, regions, o, c.merged, what);
    test::expect_valid_atlas(run);
  }
}

/// A 64 x 64-texel square (two faces) on a 4096^2 page, around texel (2032, 2032), and a sliver
/// (positions 1, 4, 2) on its right edge whose corner 4 lies `delta` texels off that edge: its UV
/// altitude is delta, its UV area 32 delta. In 3D the sliver stands up (position 4 at z = 0.5).
TexturedMesh square_with_sliver(double delta) {
  TexturedMesh m = test::one_page_mesh(4096);
  m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0), Vec3(1, 0.5, 0.5)};
  const std::vector<Vec2> tx = {Vec2(2000, 2000), Vec2(2064, 2000), Vec2(2064, 2064), Vec2(2000, 2064),
                                Vec2(2064 + delta, 2032)};
  for (const Vec2& t : tx) m.texcoords.push_back(t / 4096.0);
  const int tris[3][3] = {{0, 1, 2}, {0, 2, 3}, {1, 4, 2}};
  for (int t = 0; t < 3; ++t) {
    Face f;
    f.page = 0;
    f.source_line = t + 1;
    for (int k = 0; k < 3; ++k) f.v[static_cast<size_t>(k)] = f.vt[static_cast<size_t>(k)] = tris[t][k];
    m.faces.push_back(f);
  }
  return m;
}

/// Twice the signed area of face f's UV triangle once the atlas is turned by `deg` degrees about the
/// page centre and stored as normalised float32 coordinates (as the glTF writer stores them).
double stored_twice_area(const Atlas& at, int f, double deg) {
  const double c = std::cos(deg * M_PI / 180), s = std::sin(deg * M_PI / 180);
  Vec2 p[3];
  for (int k = 0; k < 3; ++k) {
    const Vec2 q = at.wedge_uv[static_cast<size_t>(at.face_wedge[static_cast<size_t>(f)][static_cast<size_t>(k)])] -
                   Vec2(2048, 2048);
    const Vec2 r = Vec2(2048, 2048) + Vec2(c * q.x() - s * q.y(), s * q.x() + c * q.y());
    const float u = static_cast<float>(r.x() / 4096.0), v = static_cast<float>(r.y() / 4096.0);
    p[k] = Vec2(static_cast<double>(u) * 4096.0, static_cast<double>(v) * 4096.0);
  }
  return (p[1] - p[0]).x() * (p[2] - p[0]).y() - (p[1] - p[0]).y() * (p[2] - p[0]).x();
}

TEST(MergeEngineSteps, AThinFaceIsOpenedSoThatAFloat32FileKeepsItsOrientation) {
  // By hand: the sliver's altitude is 1e-5 texel, far below float32's resolution at texel 2064 of a
  // 4096 page (half a unit in the last place: 1.2e-4 texel), so turned by some angle and stored it
  // has zero or negative area (eval counted such faces as flipped on Cedar Creek GLBs). The engine
  // opens it to kThinAltitude (2e-3): corner 4 moves 2e-3 - 1e-5 texel away from the edge 1-2, the
  // square does not move. Its Jacobian is then diag(200, 1) in the edge's frame, ARAP error 199^2
  // weighted by its UV area 3.2e-4: E = 12.672 / 4096.00032 = 0.0030938 over the model.
  test::Run input(square_with_sliver(1e-5));
  int bad = 0;
  for (int deg = 0; deg < 360; ++deg) bad += stored_twice_area(input.ctx.atlas, 2, deg) <= 0;
  EXPECT_GT(bad, 0);

  test::Run run(square_with_sliver(1e-5));
  const Atlas before = run.ctx.atlas;
  ArapSolver solver;
  const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, {}, MergeOptions{}, solver, {});
  EXPECT_EQ(r.thin_faces, 1u);
  EXPECT_EQ(r.thin_faces_opened, 1u);
  const Atlas& at = run.ctx.atlas;
  const Vec2 apex = at.wedge_uv[static_cast<size_t>(at.face_wedge[2][1])];
  EXPECT_NEAR(apex.x(), 2064 + 2e-3, 1e-9);
  EXPECT_NEAR(apex.y(), 2032, 1e-9);
  for (int f = 0; f < 2; ++f)
    for (size_t k = 0; k < 3; ++k)
      EXPECT_EQ(at.wedge_uv[static_cast<size_t>(at.face_wedge[static_cast<size_t>(f)][k])],
                before.wedge_uv[static_cast<size_t>(before.face_wedge[static_cast<size_t>(f)][k])]);
  for (int deg = 0; deg < 360; ++deg) EXPECT_GT(stored_twice_area(at, 2, deg), 0) << deg;
  EXPECT_NEAR(r.distortion_out, 199.0 * 199.0 * 3.2e-4 / (4096 + 3.2e-4), 1e-9);
  EXPECT_EQ(r.flipped_out, 0u);
  // An altitude of kThinAltitude or more is left alone.
  test::Run wide(square_with_sliver(3e-3));
  const Atlas wide_before = wide.ctx.atlas;
  const MergeReport rw = run_merges(wide.mesh, wide.topo, wide.ctx.atlas, {}, MergeOptions{}, solver, {});
  EXPECT_EQ(rw.thin_faces, 0u);
  EXPECT_EQ(wide.ctx.atlas.wedge_uv, wide_before.wedge_uv);
}

/// square_with_sliver(delta) plus a second sliver (positions 1, 5, 4) outside the first, sharing its
/// apex 4: corner 5 at (2064 + 2 delta, 2016), so its longest edge is 1-4 and its altitude 1.5 delta.
/// In 3D it stands up further (position 5 at (1, 0.25, 0.75)).
TexturedMesh square_with_two_slivers(double delta) {
  TexturedMesh m = square_with_sliver(delta);
  m.positions.emplace_back(1, 0.25, 0.75);
  m.texcoords.push_back(Vec2(2064 + 2 * delta, 2016) / 4096.0);
  Face f;
  f.page = 0;
  f.source_line = 4;
  const int tri[3] = {1, 5, 4};
  for (int k = 0; k < 3; ++k) f.v[static_cast<size_t>(k)] = f.vt[static_cast<size_t>(k)] = tri[k];
  m.faces.push_back(f);
  return m;
}

TEST(MergeEngineSteps, TwoSliversSharingAnApexAreBothOpened) {
  // By hand (delta 1e-5): opening the first sliver at its apex 4 (out to x = 2064 + 2e-3) would turn
  // the second over (its apex 5 sits 2e-5 texel out, under the new edge 1-4), and opening the
  // second first (5 out to 2e-3 over edge 1-4) leaves the first unable to open at 4 without closing
  // the second below 2e-3 again. So the first opens at an end of its longest edge 1-2: corner 2 moves
  // off the line 1-4, 4e-3 texel from it (the height over a 32-texel edge that gives a 64-texel
  // triangle the altitude 2e-3). Both end at altitude 2e-3 or more and keep their orientation at
  // every angle when stored as float32 (each one alone: zero or negative area at some angles).
  test::Run input(square_with_two_slivers(1e-5));
  for (int f : {2, 3}) {
    int bad = 0;
    for (int deg = 0; deg < 360; ++deg) bad += stored_twice_area(input.ctx.atlas, f, deg) <= 0;
    EXPECT_GT(bad, 0) << "face " << f;
  }
  test::Run run(square_with_two_slivers(1e-5));
  ArapSolver solver;
  const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, {}, MergeOptions{}, solver, {});
  EXPECT_EQ(r.thin_faces, 2u);
  EXPECT_EQ(r.thin_faces_opened, 2u);
  for (int f : {2, 3})
    for (int deg = 0; deg < 360; ++deg) EXPECT_GT(stored_twice_area(run.ctx.atlas, f, deg), 0) << f << " " << deg;
  for (int f : {2, 3}) {
    const auto& w = run.ctx.atlas.face_wedge[static_cast<size_t>(f)];
    const Vec2 a = run.ctx.atlas.wedge_uv[static_cast<size_t>(w[0])], b = run.ctx.atlas.wedge_uv[static_cast<size_t>(w[1])],
               c = run.ctx.atlas.wedge_uv[static_cast<size_t>(w[2])];
    const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    const double twice = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
    EXPECT_GE(twice / longest, 2e-3 * (1 - 1e-6)) << "face " << f;
  }
  EXPECT_EQ(r.flipped_out, 0u);
}

/// One chart of four faces on a 4096 page, texels offset by (2000, 2000), 3D = the texels (z = 0):
/// A = (p0, p1, pa) a sliver over the edge p0 p1 (apex pa = (32, delta)), C = (p0, p2, p1) under that
/// edge, E = (p2, p3, p1) and B = (p1, p3, pb) to its right, pb = (30, 1e-3): B reaches back over the
/// sliver (with fold_y 1e-3 its edge p1 pb passes 9.4e-4 texel above the apex at x = 32, touching A
/// only at p1).
TexturedMesh sliver_under_a_fold(double delta, double fold_y = 1e-3) {
  TexturedMesh m = test::one_page_mesh(4096);
  const std::vector<Vec2> tx = {Vec2(0, 0), Vec2(64, 0), Vec2(32, -30), Vec2(90, 5), Vec2(32, delta), Vec2(30, fold_y)};
  for (const Vec2& t : tx) m.positions.emplace_back(t.x() / 64, t.y() / 64, 0);
  for (const std::array<int, 3>& v : {std::array<int, 3>{0, 1, 4}, {0, 2, 1}, {2, 3, 1}, {1, 3, 5}}) {
    const Vec2 o(2000, 2000);
    test::add_texel_face(m, v, {tx[static_cast<size_t>(v[0])] + o, tx[static_cast<size_t>(v[1])] + o, tx[static_cast<size_t>(v[2])] + o});
  }
  return m;
}

TEST(MergeEngineSteps, OpeningASliverNeverPushesItIntoAnotherTriangleOfItsChart) {
  // By hand: opening A at its apex (out to y = 2e-3 at x = 32) would put the apex inside B (B spans
  // y = 9.4e-4 .. 4.7 there): a pair of the chart overlapping that the input does not have (Cedar
  // Creek lod0_room6: 6 such pairs, which the pipeline refused). So A opens at an end of its longest
  // edge p0 p1 instead (nothing lies under C), with altitude >= kThinAltitude and no overlap added.
  test::Run run(sliver_under_a_fold(1e-5));
  ASSERT_EQ(run.ctx.atlas.num_charts, 1);
  const Vec2 apex_before = run.ctx.atlas.wedge_uv[static_cast<size_t>(run.ctx.atlas.face_wedge[0][2])];
  ArapSolver solver;
  const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, {}, MergeOptions{}, solver, {});
  EXPECT_EQ(r.thin_faces, 1u);
  EXPECT_EQ(r.thin_faces_opened, 1u);
  const auto [in, out] = test::overlaps_in_out(run);
  EXPECT_EQ(in, 0u);
  EXPECT_EQ(out, 0u);
  const Atlas& at = run.ctx.atlas;
  EXPECT_EQ(at.wedge_uv[static_cast<size_t>(at.face_wedge[0][2])], apex_before);  // the apex stayed
  const auto& w = at.face_wedge[0];
  const Vec2 a = at.wedge_uv[static_cast<size_t>(w[0])], b = at.wedge_uv[static_cast<size_t>(w[1])],
             c = at.wedge_uv[static_cast<size_t>(w[2])];
  const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
  EXPECT_GE(((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x()) / longest, 2e-3 * (1 - 1e-6));
  EXPECT_EQ(r.flipped_out, 0u);
}

TEST(MergeEngineSteps, OpeningASliverNeverGrowsAnOverlapPastWhatThePipelineCounts) {
  // The same chart with the fold just under the apex (apex 5e-8 texel high, B's edge 2.35e-8 under it
  // at x = 32): A and B overlap in the input by a sliver of about 4e-7 texel^2, under the 1e-6 the
  // pipeline counts (Cedar Creek lod0_room5 had 4 such pairs grown past it). Opened at its apex, A would
  // cover about 0.03 texel^2 of B; so it opens at an end of its longest edge, and no pair of the chart
  // overlaps by more than 1e-6 afterwards.
  test::Run run(sliver_under_a_fold(5e-8, 2.5e-8));
  const auto tri = [&](int f) {
    const auto& w = run.ctx.atlas.face_wedge[static_cast<size_t>(f)];
    return std::array<Vec2, 3>{run.ctx.atlas.wedge_uv[static_cast<size_t>(w[0])], run.ctx.atlas.wedge_uv[static_cast<size_t>(w[1])],
                               run.ctx.atlas.wedge_uv[static_cast<size_t>(w[2])]};
  };
  const double before = triangle_intersection_area(tri(0), tri(3));
  EXPECT_GT(before, 0.0);
  EXPECT_LT(before, 1e-6);
  ArapSolver solver;
  const MergeReport r = run_merges(run.mesh, run.topo, run.ctx.atlas, {}, MergeOptions{}, solver, {});
  EXPECT_EQ(r.thin_faces_opened, 1u);
  std::vector<std::array<Vec2, 3>> tris;
  for (int f = 0; f < 4; ++f) tris.push_back(tri(f));
  EXPECT_EQ(count_overlapping_pairs(tris, 1e-6), 0u);
  EXPECT_LT(triangle_intersection_area(tri(0), tri(3)), 1e-6);
}

TEST(MergeEngineSteps, AMoveMayNotLeaveATriangleTooLowForAFloat32File) {
  // The two squares aligned, welded and solved (accepted as they are). Then face 2's corner 2 (its
  // own wedge) is put on face 2's side of the line 1-5 at a height h over it: with h = 5e-4 texel, under
  // half of kThinAltitude, the triangle turns the right way in doubles but not once turned and stored
  // as float32, so the move is refused as "flip" even without a collapse limit; with h = 0.05 it is
  // refused too, but for its distortion.
  for (double h : {5e-4, 0.05}) {
    MergeOptions opt;
    opt.priority = Priority::MMethod;
    Steps s(two_squares(false), opt);
    detail::Move mv = s.solved_move();
    ASSERT_TRUE(mv.solved);
    ASSERT_EQ(s.engine.check(mv), nullptr);
    const Vec2 c1 = s.uv(2, 0), c5 = s.uv(2, 2);
    Vec2& c2 = s.run.ctx.atlas.wedge_uv[static_cast<size_t>(s.run.ctx.atlas.face_wedge[2][1])];
    const Vec2 e = (c5 - c1).normalized(), n(-e.y(), e.x());  // n: left of 1 -> 5
    c2 = 0.5 * (c1 + c5) - h * n;
    const Vec2 a = c2 - c1;
    ASSERT_GT(a.x() * e.y() - a.y() * e.x(), 0);  // face 2 (1, 2, 5) still turns as its rest shape
    const char* why = s.engine.check(mv);
    ASSERT_NE(why, nullptr);
    if (h < 1e-3) EXPECT_STREQ(why, "flip");
    else EXPECT_STRNE(why, "flip");
    s.engine.rollback();
  }
}

/// Position 0 is the centre C of a fan of five triangles (C, P_i, P_i+1), i = 0..4, over the rim
/// positions 1..6 (P_i = position i + 1): P_i = (cos 72i, sin 72i, +-h), +h for even i, with
/// h^2 = (cos 72 - cos 80) / (1 + cos 80), so every triangle's angle at C is 80 degrees. C is on the
/// mesh boundary (P_0 and P_5 differ) and its fan adds up to 400 degrees: its UVs, the exact
/// development (16 texels per unit, P_i at 80i degrees around (64, 64)), overlap themselves. Face 5
/// is (P_2, P_1, Q) with Q = P_1 + P_2, a copy of face 1 across the rim edge P_1-P_2, laid out
/// 1.5x too large elsewhere on the page: the second chart, whose weld moves the seam wedges.
TexturedMesh over_full_fan() {
  TexturedMesh m = test::one_page_mesh(256);
  const double d2r = 3.141592653589793 / 180;
  const double h = std::sqrt((std::cos(72 * d2r) - std::cos(80 * d2r)) / (1 + std::cos(80 * d2r)));
  m.positions.emplace_back(0, 0, 0);
  std::vector<Vec2> t{Vec2(64, 64)};
  for (int i = 0; i <= 5; ++i) {
    m.positions.emplace_back(std::cos(72 * i * d2r), std::sin(72 * i * d2r), i % 2 ? -h : h);
    t.push_back(Vec2(64, 64) + 16 * std::sqrt(1 + h * h) * Vec2(std::cos(80 * i * d2r), std::sin(80 * i * d2r)));
  }
  for (int i = 0; i < 5; ++i) test::add_texel_face(m, {0, i + 1, i + 2}, {t[0], t[size_t(i) + 1], t[size_t(i) + 2]});
  m.positions.push_back(m.positions[2] + m.positions[3]);
  const Vec2 q = t[1] + t[2] - t[0], shift(120, 40), mid = (t[1] + t[2] + q) / 3 + shift;
  auto far = [&](const Vec2& p) { return mid + 1.5 * (p + shift - mid); };
  test::add_texel_face(m, {3, 2, 7}, {far(t[2]), far(t[1]), far(q)});
  return m;
}

TEST(MergeEngineSteps, HeldFansKeepAnOverFullBoundaryFanAndItsRingPinned) {
  MergeOptions opt;
  opt.priority = Priority::MMethod;
  opt.alpha = 100;  // the whole merged chart within reach of the weld
  test::Run run(over_full_fan());
  ArapSolver solver;
  detail::Engine engine(run.mesh, run.topo, run.ctx.atlas, run.ctx.regions.face_region, opt, solver);
  engine.setup();
  const Atlas& at = run.ctx.atlas;
  const int fan = at.face_chart[0], tri = at.face_chart[5];
  ASSERT_EQ(at.num_charts, 2);
  for (int f = 1; f < 5; ++f) ASSERT_EQ(at.face_chart[static_cast<size_t>(f)], fan);
  auto w = [&](int f, int k) { return at.face_wedge[static_cast<size_t>(f)][static_cast<size_t>(k)]; };
  const int c = w(0, 0), p0 = w(0, 1), p1 = w(0, 2), p2 = w(1, 2), p3 = w(2, 2), p4 = w(3, 2), p5 = w(4, 2);
  detail::Move mv = engine.begin_move(fan, tri);
  EXPECT_EQ(mv.big, fan);  // five 80-degree triangles against one 1.5x as large
  engine.align(mv);
  engine.weld(mv);
  // The rim edge is 16 x 2 sqrt(1 + h^2) sin 40 = 21.72 texels, the 1.5x copy's 32.58: centred by the
  // rigid fit, each end's two wedges lie 5.43 apart and move 2.715 to their mean.
  EXPECT_NEAR(mv.dmax, 2.715, 1e-3);
  const int q = w(5, 2);
  engine.free_region(mv);
  auto sorted = [](std::vector<int> v) {
    std::sort(v.begin(), v.end());
    return v;
  };
  EXPECT_EQ(sorted(mv.free_w), sorted({c, p0, p1, p2, p3, p4, p5, q}));
  EXPECT_TRUE(engine.full_boundary_fan(c, fan));    // 400 degrees on the boundary
  EXPECT_FALSE(engine.full_boundary_fan(p1, fan));  // 50 + 50 + 50 degrees
  // C and its ring leave the free region, except the welded P_1 and P_2; Q (not in C's ring) stays.
  engine.hold_full_fans(mv);
  EXPECT_EQ(sorted(mv.free_w), sorted({p1, p2, q}));
  const Vec2 c_before = at.wedge_uv[static_cast<size_t>(c)];
  engine.solve(mv);
  EXPECT_TRUE(mv.solved);
  EXPECT_EQ(at.wedge_uv[static_cast<size_t>(c)], c_before);  // held where it was
  engine.rollback();
}

}  // namespace
}  // namespace texdefrag::merge
