// Hole filling (docs/mergers.md, "Hole filling") on meshes small enough to check by hand:
// ear clipping of small polygons, the hole loop of a square ring of eight squares, merges onto that
// ring (accepted at once, refused as collapse, refused as fan_overlap at the hole's border).
#include "geometry2d.h"
#include "test_engine_run.h"

#include "texdefrag/core/distortion.h"

#include <gtest/gtest.h>

#include <map>
#include <set>

namespace texdefrag::merge {
namespace {

double polygon_area2(const std::vector<Vec2>& p) {
  double a = 0;
  for (size_t i = 0; i < p.size(); ++i) a += p[i].x() * p[(i + 1) % p.size()].y() - p[i].y() * p[(i + 1) % p.size()].x();
  return a;
}

/// Every triangle has the polygon's orientation and the areas add up to the polygon's.
void expect_triangulates(const std::vector<Vec2>& p, const std::vector<std::array<int, 3>>& tris) {
  ASSERT_EQ(tris.size(), p.size() - 2);
  const double whole = polygon_area2(p);
  double sum = 0;
  for (const auto& t : tris) {
    const double a = orient2d(p[static_cast<size_t>(t[0])], p[static_cast<size_t>(t[1])], p[static_cast<size_t>(t[2])]);
    EXPECT_GT(a * whole, 0);
    sum += a;
  }
  EXPECT_NEAR(sum, whole, 1e-12);
}

TEST(MergeEngineHoles, EarClipCutsASquareIntoTwoTrianglesOfItsOrientation) {
  std::vector<Vec2> sq{{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  std::vector<std::array<int, 3>> tris;
  ASSERT_TRUE(ear_clip(sq, tris));
  expect_triangulates(sq, tris);
  std::reverse(sq.begin(), sq.end());  // clockwise: the triangles turn clockwise too
  ASSERT_TRUE(ear_clip(sq, tris));
  expect_triangulates(sq, tris);
}

TEST(MergeEngineHoles, EarClipSkipsTheReflexCornerOfAnLShape) {
  // An L of three unit squares; (1, 1) is reflex, so no triangle may have it as its ear tip.
  const std::vector<Vec2> l{{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}};
  std::vector<std::array<int, 3>> tris;
  ASSERT_TRUE(ear_clip(l, tris));
  expect_triangulates(l, tris);
  EXPECT_NEAR(polygon_area2(l), 6.0, 1e-12);  // twice the area of three unit squares
}

TEST(MergeEngineHoles, EarClipRefusesABowTieAndAFlatPolygon) {
  std::vector<std::array<int, 3>> tris;
  EXPECT_FALSE(ear_clip({{0, 0}, {1, 1}, {1, 0}, {0, 1}}, tris));  // edges cross
  EXPECT_FALSE(ear_clip({{0, 0}, {1, 0}, {2, 0}}, tris));          // zero area
  EXPECT_FALSE(ear_clip({{0, 0}, {1, 0}}, tris));                  // two corners
}

using test::add_texel_face;

/// A 3 x 3 grid of unit squares in z = 0 without its middle square (vertex (i, j) = 4j + i), laid
/// out at 16 texels per unit from (16, 16): one chart, a ring with a square hole (corners 5, 6, 10,
/// 9). With `tab`, one more square (vertices 16-17 at y = -1 under the ring's bottom edge 1 - 2)
/// laid out elsewhere on the page, `stretch` times wider and turned: a chart of its own.
TexturedMesh square_ring(bool tab, double stretch = 1.5) {
  TexturedMesh m = test::one_page_mesh(128);
  for (int j = 0; j <= 3; ++j)
    for (int i = 0; i <= 3; ++i) m.positions.emplace_back(i, j, 0);
  auto t = [](int v) { return Vec2(16 + 16 * (v % 4), 16 + 16 * (v / 4)); };
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) {
      if (i == 1 && j == 1) continue;
      const int a = 4 * j + i, b = a + 1, c = a + 5, e = a + 4;
      add_texel_face(m, {a, b, c}, {t(a), t(b), t(c)});
      add_texel_face(m, {a, c, e}, {t(a), t(c), t(e)});
    }
  if (tab) {
    m.positions.emplace_back(1, -1, 0);
    m.positions.emplace_back(2, -1, 0);
    // The tab's texels: 1.5 times wider than the ring's (24 texels for its edge 1 - 2 against 16),
    // turned by 0.3 rad, away from the ring: after the rigid fit each end of the seam is 4 texels from
    // its twin, so the free region (5 x 4 texels) reaches the hole 16 texels away.
    const double c = std::cos(0.3), s = std::sin(0.3);
    auto tt = [&](double x, double y) {
      return Vec2(80 + 16 * (c * stretch * x - s * y), 70 + 16 * (s * stretch * x + c * y));
    };
    add_texel_face(m, {16, 17, 2}, {tt(0, 0), tt(1, 0), tt(1, 1)});
    add_texel_face(m, {16, 2, 1}, {tt(0, 0), tt(1, 1), tt(0, 1)});
  }
  return m;
}

TEST(MergeEngineHoles, TheRingHasOneHoleLoopOfFourWedgesAgainstItsFaces) {
  test::EngineRun er(square_ring(false));
  detail::Engine& engine = er.engine;
  test::Run& run = er.run;
  const Atlas& at = run.ctx.atlas;
  ASSERT_EQ(at.num_charts, 1);
  detail::Move mv;
  mv.big = at.face_chart[0];
  for (int f = 0; f < 16; ++f) mv.prob_faces.push_back(f);
  for (const auto& fw : at.face_wedge) mv.free_w.insert(mv.free_w.end(), fw.begin(), fw.end());
  const auto holes = engine.hole_loops(mv);
  ASSERT_EQ(holes.size(), 1u);  // the outer loop (12 wedges) runs with the faces: not a hole
  // The hole's corners: vertices 5, 6, 10, 9 at texels (32, 32), (48, 32), (48, 48), (32, 48).
  std::set<std::pair<double, double>> corners;
  for (int w : holes[0]) corners.emplace(at.wedge_uv[static_cast<size_t>(w)].x(), at.wedge_uv[static_cast<size_t>(w)].y());
  EXPECT_EQ(corners, (std::set<std::pair<double, double>>{{32, 32}, {48, 32}, {48, 48}, {32, 48}}));
}

TEST(MergeEngineHoles, AMergeOntoTheRingNeedsNoRetryWhenItsSolveIsAccepted) {
  MergeOptions opt;
  opt.fill_holes = true;
  opt.global_bound = 1;  // the weld's cost is not the question here
  test::EngineRun er(square_ring(true), opt);
  detail::Engine& engine = er.engine;
  test::Run& run = er.run;
  const Atlas& at = run.ctx.atlas;
  std::string reason;
  ASSERT_TRUE(engine.try_merge(at.face_chart[0], at.face_chart[16], reason)) << reason;
  for (int f = 1; f < 18; ++f) EXPECT_EQ(at.face_chart[static_cast<size_t>(f)], at.face_chart[0]);
  EXPECT_EQ(atlas_distortion(run.mesh, at).flipped, 0u);
  EXPECT_EQ(engine.main_counters().hole_fill_retries, 0u);  // accepted as it was: never filled
  EXPECT_EQ(engine.main_counters().holes_filled, 0u);
}

/// With min_singular_value 0.95 the weld of a tab 2.5 times wider (seam ends 12 texels from their
/// twins: the free region, 60 texels, holds the whole ring) compresses the ring's squares too much:
/// refused as collapse. Only fan_overlap refusals are tried again with the holes filled, so this one
/// is not, and the atlas comes back bit for bit.
TEST(MergeEngineHoles, ACollapseRefusalIsNotTriedAgain) {
  MergeOptions opt;
  opt.fill_holes = true;
  opt.global_bound = 1;
  opt.min_singular_value = 0.95;
  test::EngineRun er(square_ring(true, 2.5), opt);
  detail::Engine& engine = er.engine;
  test::Run& run = er.run;
  const Atlas& at = run.ctx.atlas;
  const Atlas before = at;
  std::string reason;
  EXPECT_FALSE(engine.try_merge(at.face_chart[0], at.face_chart[16], reason));
  EXPECT_EQ(reason, "collapse");
  EXPECT_EQ(at.wedge_uv, before.wedge_uv);
  EXPECT_EQ(at.face_wedge, before.face_wedge);
  EXPECT_EQ(engine.main_counters().hole_fill_retries, 0u);
}

/// The ring of square_ring(false) and a triangle (5, 6, c) inside its hole (c = vertex 16 at the
/// hole's centre (1.5, 1.5)), a chart of its own whose input UV angle at vertex 6 is 100 degrees
/// instead of 45: welded along 5 - 6 with nothing else free (its seam edge has the ring's length, so
/// the weld moves nothing), the boundary fan at 6 would turn 270 + 100 = 370 degrees: fan_overlap.
/// The hole left (5, c, 6, 10, 9) touches the free wedges 5 and 6, so with fill_holes the move is
/// tried once more; but that loop crosses itself where the triangle overlaps the ring at 6, so no
/// triangle can be laid across it and the move is refused as before, without a second solve.
TexturedMesh ring_with_wide_wedge() {
  TexturedMesh m = square_ring(false);
  m.positions.emplace_back(1.5, 1.5, 0);
  // Texels of the triangle: 5 at (80, 80), 6 at (96, 80), c where the edge from 6 turns 100 degrees.
  const double t = 100.0 * 3.141592653589793 / 180.0;
  const Vec2 t5(80, 80), t6(96, 80), tc = t6 + 12 * Vec2(-std::cos(t), std::sin(t));
  add_texel_face(m, {5, 6, 16}, {t5, t6, tc});
  return m;
}

TEST(MergeEngineHoles, AFanOverlapAtAHoleIsTriedAgainAndRefusedWhenTheHoleCannotBeFilled) {
  for (bool fill : {false, true}) {
    MergeOptions opt;
    opt.fill_holes = fill;
    opt.global_bound = 1;
    test::EngineRun er(ring_with_wide_wedge(), opt);
    detail::Engine& engine = er.engine;
    test::Run& run = er.run;
    const Atlas& at = run.ctx.atlas;
    ASSERT_EQ(at.num_charts, 2);
    const Atlas before = at;
    std::string reason;
    EXPECT_FALSE(engine.try_merge(at.face_chart[0], at.face_chart[16], reason));
    EXPECT_EQ(reason, "fan_overlap");
    EXPECT_EQ(at.wedge_uv, before.wedge_uv);
    EXPECT_EQ(at.face_wedge, before.face_wedge);
    const MergeReport& r = engine.main_counters();
    EXPECT_EQ(r.attempted, 1u);  // a retry is the same move, counted once
    EXPECT_EQ(r.hole_fill_retries, fill ? 1u : 0u);
    EXPECT_EQ(r.holes_filled, 0u);
    EXPECT_EQ(r.hole_fills_accepted, 0u);
  }
}

/// add_hole_faces on the ring alone with its hole's four wedges free: two triangles across the
/// 16 x 16-texel hole, each at rest as it is (deformation gradient the identity), weight its area 128.
TEST(MergeEngineHoles, TheRingsHoleGetsTwoTrianglesAtRestAsTheyAre) {
  test::EngineRun er(square_ring(false));
  detail::Engine& engine = er.engine;
  test::Run& run = er.run;
  const Atlas& at = run.ctx.atlas;
  detail::Move mv;
  mv.big = at.face_chart[0];
  for (int f = 0; f < 16; ++f) mv.prob_faces.push_back(f);
  const auto loops = engine.hole_loops([&] {
    detail::Move all = mv;
    for (const auto& fw : at.face_wedge) all.free_w.insert(all.free_w.end(), fw.begin(), fw.end());
    return all;
  }());
  ASSERT_EQ(loops.size(), 1u);
  mv.free_w = loops[0];  // only the hole's corners are free
  LocalProblem lp;
  std::map<int, int> local;
  for (int w : mv.free_w) {
    local[w] = static_cast<int>(lp.x.size());
    lp.x.push_back(at.wedge_uv[static_cast<size_t>(w)]);
  }
  lp.num_free = static_cast<int>(lp.x.size());
  const auto local_of = [&](int w) {
    if (!local.count(w)) {
      local[w] = static_cast<int>(lp.x.size());
      lp.x.push_back(at.wedge_uv[static_cast<size_t>(w)]);
    }
    return local[w];
  };
  EXPECT_EQ(engine.add_hole_faces(mv, lp, local_of), 1u);
  ASSERT_EQ(lp.tri.size(), 2u);
  EXPECT_EQ(lp.x.size(), 4u);  // no wedge beyond the hole's four
  for (size_t t = 0; t < 2; ++t) {
    EXPECT_TRUE(deformation_gradient(lp, t).isApprox(Mat2::Identity(), 1e-12));
    EXPECT_DOUBLE_EQ(lp.weight[t], 128.0);
    // Oriented as the ring's faces (counter-clockwise texels): rest edge matrix determinant > 0.
    EXPECT_GT(lp.rest_inv[t].determinant(), 0);
  }
}

}  // namespace
}  // namespace texdefrag::merge
