// The merge engine's steps one by one (align, weld, free region, solve, checks, commit, rollback) on
// two unit squares sharing an edge, small enough to check by hand.
#include "arap_solver.h"
#include "engine_internal.h"
#include "test_support.h"

#include <gtest/gtest.h>

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
  TexturedMesh m;
  Page pg;
  pg.material = "m";
  pg.width = pg.height = 64;
  pg.image_path = "unused.png";
  m.pages.push_back(pg);
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

}  // namespace
}  // namespace texdefrag::merge
