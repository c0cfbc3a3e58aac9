// Closing cuts inside one chart (docs/mergers.md, "Closing cuts") on meshes small enough to check by
// hand: a slit that can close (the chart stays a disk) and a ring of squares cut open once (closing
// the cut would make a cylinder, which cannot be flattened).
#include "test_engine_run.h"

#include "texdefrag/core/distortion.h"

#include <gtest/gtest.h>

#include <set>

namespace texdefrag::merge {
namespace {

using test::add_texel_face;

/// A 2 x 2 grid of unit squares in z = 0 (vertex (i, j) = 3j + i, two counter-clockwise triangles
/// per square, 16 texels per unit at offset 8), slit along the edge from (1, 0) to (1, 1): the left
/// square's corner at (1, 0) sits at x = 1 - d, the right square's at x = 1 + d (8 texels apart for
/// d = 0.25); (1, 1) is one wedge (the slit's tip). One chart, 10 wedges, one self-seam edge.
TexturedMesh slit_grid(double d) {
  TexturedMesh m = test::one_page_mesh(64);
  for (int j = 0; j <= 2; ++j)
    for (int i = 0; i <= 2; ++i) m.positions.emplace_back(i, j, 0);
  auto tex = [&](int v, int side) {
    const double x = v % 3, y = v / 3;
    const double dx = v == 1 ? (side < 0 ? -d : d) : 0;
    return Vec2(8 + 16 * (x + dx), 8 + 16 * y);
  };
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      const int a = 3 * j + i, b = a + 1, c = a + 4, e = a + 3;
      const int side = i == 0 ? -1 : 1;  // which copy of vertex 1 the square uses
      add_texel_face(m, {a, b, c}, {tex(a, side), tex(b, side), tex(c, side)});
      add_texel_face(m, {a, c, e}, {tex(a, side), tex(c, side), tex(e, side)});
    }
  return m;
}

/// Four unit squares around the sides of a unit box (a ring: a cylinder in 3D), unrolled into one
/// strip of texels u = 8 + 12 s, v = 8 + 12 z: the box corner (0, 0) has two copies, at u = 8 (the
/// first square) and u = 56 (the last one). One chart; its only self-seam is the vertical edge at
/// that corner.
TexturedMesh ring_strip() {
  TexturedMesh m = test::one_page_mesh(64);
  const double cx[4] = {0, 1, 1, 0}, cy[4] = {0, 0, 1, 1};
  for (int h = 0; h <= 1; ++h)
    for (int k = 0; k < 4; ++k) m.positions.emplace_back(cx[k], cy[k], h);
  for (int s = 0; s < 4; ++s) {
    const int n = (s + 1) % 4;
    const int a = s, b = n, c = n + 4, e = s + 4;
    const Vec2 ta(8 + 12 * s, 8), tb(8 + 12 * (s + 1), 8), tc(8 + 12 * (s + 1), 20), te(8 + 12 * s, 20);
    add_texel_face(m, {a, b, c}, {ta, tb, tc});
    add_texel_face(m, {a, c, e}, {ta, tc, te});
  }
  return m;
}

using CutRun = test::EngineRun;

TEST(MergeEngineCuts, ASlitIsOneChainOfOneEdgeAndClosesIntoADisk) {
  CutRun r(slit_grid(0.25));
  ASSERT_EQ(r.run.ctx.atlas.num_charts, 1);
  EXPECT_EQ(r.wedges(), 10u);
  const auto chains = r.engine.cut_chains(0);
  ASSERT_EQ(chains.size(), 1u);
  ASSERT_EQ(chains[0].size(), 1u);
  const Edge& e = r.run.topo.edges[static_cast<size_t>(chains[0][0])];
  const auto& vp = r.run.topo.vertex_of_position;
  EXPECT_EQ(std::set<int>({e.a, e.b}), std::set<int>({vp[1], vp[4]}));  // (1, 0) and (1, 1)
  const detail::Engine::CutTopology before = r.engine.chart_topology(0);
  EXPECT_EQ(before.chi, 1);  // a disk: 10 wedges - 17 UV edges + 8 faces
  EXPECT_EQ(before.loops, 1);
  std::string reason;
  ASSERT_TRUE(r.engine.try_close(0, chains[0], reason)) << reason;
  // One wedge fewer; the slit's two copies of (1, 0) are one; no cut left; still a disk.
  EXPECT_EQ(r.wedges(), 9u);
  const Atlas& at = r.run.ctx.atlas;
  EXPECT_EQ(at.face_wedge[0][1], at.face_wedge[2][0]);
  EXPECT_TRUE(r.engine.cut_chains(0).empty());
  const detail::Engine::CutTopology after = r.engine.chart_topology(0);
  EXPECT_EQ(after.chi, 1);  // 9 - 16 + 8
  EXPECT_EQ(after.loops, 1);
  // The slit's faces were sheared by +-d in the input; closing costs a little distortion, no flip.
  const DistortionSummary ds = atlas_distortion(r.run.mesh, at);
  EXPECT_EQ(ds.flipped, 0u);
  EXPECT_GT(ds.arap, 0.0);
  EXPECT_LT(ds.arap, 0.025);
  EXPECT_NEAR(r.engine.global_distortion(), ds.arap, 1e-9);
}

TEST(MergeEngineCuts, AWideSlitOverTheBudgetIsRefusedAndRestored) {
  MergeOptions opt;
  opt.global_bound = 1e-4;
  CutRun r(slit_grid(0.25), opt);
  const Atlas before = r.run.ctx.atlas;
  std::string reason;
  EXPECT_FALSE(r.engine.try_close(0, r.engine.cut_chains(0)[0], reason));
  EXPECT_EQ(reason, "global_distortion");
  EXPECT_EQ(r.run.ctx.atlas.wedge_uv, before.wedge_uv);
  EXPECT_EQ(r.run.ctx.atlas.face_wedge, before.face_wedge);
}

TEST(MergeEngineCuts, TheCutOfARingIsKeptBecauseACylinderCannotBeFlattened) {
  CutRun r(ring_strip());
  ASSERT_EQ(r.run.ctx.atlas.num_charts, 1);
  EXPECT_EQ(r.wedges(), 10u);
  const auto chains = r.engine.cut_chains(0);
  ASSERT_EQ(chains.size(), 1u);
  ASSERT_EQ(chains[0].size(), 1u);
  const Edge& e = r.run.topo.edges[static_cast<size_t>(chains[0][0])];
  const auto& vp = r.run.topo.vertex_of_position;
  EXPECT_EQ(std::set<int>({e.a, e.b}), std::set<int>({vp[0], vp[4]}));  // the box corner (0, 0) at z = 0 and 1
  const Atlas before = r.run.ctx.atlas;
  std::string reason;
  EXPECT_FALSE(r.engine.try_close(0, chains[0], reason));
  EXPECT_EQ(reason, "topology");  // closed: 8 wedges - 16 + 8 = 0, two boundary loops
  EXPECT_EQ(r.run.ctx.atlas.wedge_uv, before.wedge_uv);
  EXPECT_EQ(r.run.ctx.atlas.face_wedge, before.face_wedge);
  EXPECT_EQ(r.engine.cut_chains(0).size(), 1u);
}


/// Five triangles around vertex 0 (an open fan: ring points 1..6 at 72 degree steps in 3D, point 6
/// above point 1 so the fan does not close), laid out as two charts whose UV triangles each open 80
/// degrees at vertex 0 (texels: ring radius 16 about (32, 32)): faces 0-2 (0 to 240 degrees) and
/// faces 3-4 (its own frame, rotated by 100 degrees), sharing the seam edge 0-4. Merged, the fan at
/// vertex 0 would turn 400 degrees: more than a turn, on the chart's boundary.
TexturedMesh overfull_fan() {
  TexturedMesh m = test::one_page_mesh(64);
  m.positions.emplace_back(0, 0, 0);
  for (int i = 0; i <= 5; ++i) {
    const double t = i * 72.0 * 3.141592653589793 / 180.0;
    m.positions.emplace_back(std::cos(t), std::sin(t), i == 5 ? 0.5 : 0.0);
  }
  auto ring = [](double deg) {
    const double t = deg * 3.141592653589793 / 180.0;
    return Vec2(32 + 16 * std::cos(t), 32 + 16 * std::sin(t));
  };
  for (int i = 0; i < 5; ++i) {
    const double base = i < 3 ? 80.0 * i : 80.0 * i + 100.0;
    add_texel_face(m, {0, i + 1, i + 2}, {Vec2(32, 32), ring(base), ring(base + 80)});
  }
  return m;
}

/// Sum of the UV angles at wedge w of the faces using it.
double fan_angle(const Atlas& at, int w) {
  double sum = 0;
  for (const auto& fw : at.face_wedge)
    for (size_t k = 0; k < 3; ++k)
      if (fw[k] == w) {
        const Vec2 p = at.wedge_uv[static_cast<size_t>(w)], a = at.wedge_uv[static_cast<size_t>(fw[(k + 1) % 3])] - p,
                   b = at.wedge_uv[static_cast<size_t>(fw[(k + 2) % 3])] - p;
        sum += std::abs(std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b)));
      }
  return sum;
}

TEST(MergeEngineCuts, FanTargetsCloseAnOverfullBoundaryFan) {
  for (bool targets : {false, true}) {
    MergeOptions opt;
    opt.global_bound = 1;  // the compression's cost is not the question here
    opt.fan_targets = targets;
    // note: a converged solve: from the 400-degree start, the default 10 local/global steps leave the
    // fan at 369 degrees (fan_overlap still); 500 reach the targets' 356.4.
    test::Run run(overfull_fan());
    ArapSettings settings;
    settings.iterations = 500;
    settings.tolerance = 1e-14;
    ArapSolver solver(settings);
    detail::Engine engine(run.mesh, run.topo, run.ctx.atlas, run.ctx.regions.face_region, opt, solver);
    engine.setup();
    struct {
      test::Run& run;
      detail::Engine& engine;
    } r{run, engine};
    const Atlas& at = r.run.ctx.atlas;
    ASSERT_EQ(at.num_charts, 2);
    std::string reason;
    const bool ok = r.engine.try_merge(at.face_chart[0], at.face_chart[3], reason);
    if (!targets) {
      EXPECT_FALSE(ok);
      EXPECT_EQ(reason, "fan_overlap");  // the weld moves nothing: only the two welded wedges are free
      continue;
    }
    ASSERT_TRUE(ok) << reason;
    EXPECT_EQ(at.face_chart[0], at.face_chart[4]);
    // The five faces close at 2 pi (1 - fan_margin) around vertex 0 instead of 400 degrees.
    EXPECT_NEAR(fan_angle(at, at.face_wedge[0][0]), 2 * 3.141592653589793 * 0.99, 0.05);
    EXPECT_EQ(atlas_distortion(r.run.mesh, at).flipped, 0u);
    EXPECT_GT(r.engine.global_distortion(), 0.0);
  }
}

/// Two charts A (faces 0-3) and B (faces 4-7) sharing the two-edge seam v - s1 - s0 (vertices 0, 1,
/// 2), v on the mesh boundary. In texels (x 8 about (32, 32)) A is v (0, 0), s1 (1, 0), s0 (2, 0),
/// a1 (1, 1), a2 (2, 1), a0 (-0.983, -0.688): its fan at v opens 45 + 170 = 215 degrees, at s1 180.
/// B's input layout turns v about s1: v (0.826, -0.985), b1 (1.6, -1.039), b2 (2.039, -0.6),
/// b0 (-0.253, -1.511), s1 and s0 as A's, all moved by (0.25, -2.2): its fan at v opens 84 + 150 =
/// 234 degrees, at s1 100.
/// Welded whole, the boundary fan at v would turn 449 degrees; with v left unwelded A and B join
/// along s1 - s0 as they are (B moved back onto A's s1 and s0), the fan at s1 turns 280 degrees and the
/// edge v - s1 stays cut, a slit opening 80 degrees between A's v and B's.
TexturedMesh overfull_seam_end() {
  TexturedMesh m = test::one_page_mesh(64);
  for (const Vec3& p : {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0), Vec3(1, 1, 0), Vec3(2, 1, 0), Vec3(-1, 1, 0),
                        Vec3(1, -1, 0), Vec3(2, -1, 0), Vec3(-1, -1, 0)})
    m.positions.push_back(p);
  auto t = [](double x, double y) { return Vec2(32 + 8 * x, 32 + 8 * y); };
  const Vec2 v = t(0, 0), s1 = t(1, 0), s0 = t(2, 0), a1 = t(1, 1), a2 = t(2, 1), a0 = t(-0.983, -0.688);
  add_texel_face(m, {0, 1, 3}, {v, s1, a1});
  add_texel_face(m, {1, 2, 4}, {s1, s0, a2});
  add_texel_face(m, {1, 4, 3}, {s1, a2, a1});
  add_texel_face(m, {0, 3, 5}, {v, a1, a0});
  // B lies 2.2 lower on the page than the seam it shares with A (a chart of its own, not joined).
  auto tb = [&](double x, double y) { return t(x + 0.25, y - 2.2); };
  const Vec2 vb = tb(0.826, -0.985), b1 = tb(1.6, -1.039), b2 = tb(2.039, -0.6), b0 = tb(-0.253, -1.511),
             s1b = tb(1, 0), s0b = tb(2, 0);
  add_texel_face(m, {0, 6, 1}, {vb, b1, s1b});
  add_texel_face(m, {0, 8, 6}, {vb, b0, b1});
  add_texel_face(m, {1, 6, 7}, {s1b, b1, b2});
  add_texel_face(m, {1, 7, 2}, {s1b, b2, s0b});
  return m;
}

TEST(MergeEngineCuts, APartialWeldLeavesAnOverfullSeamEndCut) {
  for (int tries : {0, 1}) {
    MergeOptions opt;
    opt.partial_weld_tries = tries;
    opt.global_bound = 1;  // the whole weld's cost is not the question: its fan is
    test::EngineRun er(overfull_seam_end(), opt);
    detail::Engine& engine = er.engine;
    test::Run& run = er.run;
    const Atlas& at = run.ctx.atlas;
    ASSERT_EQ(at.num_charts, 2);
    std::string reason;
    const bool ok = engine.try_merge(at.face_chart[0], at.face_chart[4], reason);
    if (tries == 0) {
      EXPECT_FALSE(ok);
      EXPECT_EQ(reason, "fan_overlap");
      continue;
    }
    ASSERT_TRUE(ok) << reason;
    EXPECT_EQ(at.face_chart[0], at.face_chart[4]);
    // s1 and s0 welded (one wedge each), v not: A's v and B's v are two wedges 80 degrees apart about s1.
    EXPECT_EQ(at.face_wedge[0][1], at.face_wedge[4][2]);  // s1
    EXPECT_EQ(at.face_wedge[1][1], at.face_wedge[7][2]);  // s0
    EXPECT_NE(at.face_wedge[0][0], at.face_wedge[4][0]);  // v
    EXPECT_NEAR(fan_angle(at, at.face_wedge[0][1]) * 180 / 3.141592653589793, 280, 0.5);
    // Nothing had to bend: B's seam wedges fit A's exactly, so no face changed shape.
    EXPECT_NEAR(engine.global_distortion(), 0.0, 1e-12);
    EXPECT_EQ(atlas_distortion(run.mesh, at).flipped, 0u);
    EXPECT_EQ(engine.main_counters().partial_weld_retries, 1u);
    EXPECT_EQ(engine.main_counters().partial_welds_accepted, 1u);
  }
}

/// The stage: mergers.arap with close_cuts closes the slit (and reports it) and keeps the ring's cut;
/// without it both stay (the behaviour before close_cuts existed).
TEST(MergeEngineCuts, TheStageClosesCutsOnlyWhenAsked) {
  for (bool close : {false, true}) {
    test::Run slit(slit_grid(0.25));
    slit.merge("mergers.arap", {{"close_cuts", close}});
    test::expect_valid_atlas(slit);
    EXPECT_EQ(slit.report["cuts_closed"].get<int>(), close ? 1 : 0);
    EXPECT_EQ(slit.report["cut_edges_in"].get<int>(), close ? 1 : 0);
    std::set<int> w;
    for (const auto& fw : slit.ctx.atlas.face_wedge) w.insert(fw.begin(), fw.end());
    EXPECT_EQ(w.size(), close ? 9u : 10u);
    test::Run ring(ring_strip());
    ring.merge("mergers.arap", {{"close_cuts", close}});
    test::expect_valid_atlas(ring);
    EXPECT_EQ(ring.report["cuts_closed"].get<int>(), 0);
    if (close) {
      EXPECT_EQ(ring.report["cut_rejected"]["topology"].get<int>(), 1);
    }
  }
}

}  // namespace
}  // namespace texdefrag::merge
