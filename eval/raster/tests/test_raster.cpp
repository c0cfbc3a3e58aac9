// The shared rasteriser (raster.h) on hand-built triangles: the pixels of a known triangle,
// pixels on a shared edge covered exactly once (axis-aligned, diagonal and random meshes, both
// orientations), barycentric coordinates and depth, the z-buffer's order, degenerate and
// off-image triangles.
#include "texdefrag/eval/raster.h"

#include <gtest/gtest.h>

#include <random>
#include <set>
#include <utility>

using namespace texdefrag;
using namespace texdefrag::raster;

namespace {

std::set<std::pair<int, int>> covered(const std::array<Vec3, 3>& t, int w, int h) {
  std::set<std::pair<int, int>> s;
  scan_triangle(t, w, h, [&](const Fragment& f) { EXPECT_TRUE(s.insert({f.x, f.y}).second); });
  return s;
}

std::vector<int> coverage_count(const std::vector<std::array<Vec3, 3>>& tris, int w, int h) {
  std::vector<int> n(static_cast<size_t>(w) * static_cast<size_t>(h), 0);
  for (const auto& t : tris) scan_triangle(t, w, h, [&](const Fragment& f) { ++n[static_cast<size_t>(f.y * w + f.x)]; });
  return n;
}

}  // namespace

// The right triangle (0,0), (4,0), (0,4): pixel centres (x+0.5, y+0.5) with x + y + 1 < 4 are
// inside (6 pixels). The four centres on the hypotenuse x + y + 1 = 4 are not: in the positive
// orientation the hypotenuse runs (4,0) -> (0,4), y increasing, so the triangle does not own it.
TEST(Raster, KnownTriangleCoverage) {
  const std::array<Vec3, 3> t = {Vec3(0, 0, 0), Vec3(4, 0, 0), Vec3(0, 4, 0)};
  const auto s = covered(t, 8, 8);
  std::set<std::pair<int, int>> strict;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x)
      if (x + y + 1 < 4) strict.insert({x, y});
  EXPECT_EQ(strict.size(), 6u);
  EXPECT_EQ(s, strict);
  // The same triangle given clockwise covers the same pixels.
  EXPECT_EQ(covered({t[0], t[2], t[1]}, 8, 8), s);
  // Its mirror across the hypotenuse, (4,0), (4,4), (0,4), owns that edge (it runs (0,4) -> (4,0)
  // there): the two together cover the 4x4 square exactly once.
  const std::array<Vec3, 3> u = {Vec3(4, 0, 0), Vec3(4, 4, 0), Vec3(0, 4, 0)};
  const auto n = coverage_count({t, u}, 8, 8);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) EXPECT_EQ(n[static_cast<size_t>(y * 8 + x)], x < 4 && y < 4 ? 1 : 0) << x << "," << y;
}

// Edges through pixel centres: a column of quads at half-integer x, split both ways, cover every
// pixel of their union exactly once; so do triangles fanned around a centre.
TEST(Raster, SharedEdgesThroughPixelCentresCoveredOnce) {
  std::vector<std::array<Vec3, 3>> tris;
  const double xs[] = {0.5, 2.5, 3.5, 7.5};
  for (int i = 0; i < 3; ++i) {
    const double a = xs[i], b = xs[i + 1];
    if (i % 2) tris.push_back({Vec3(a, 0.5, 0), Vec3(b, 0.5, 0), Vec3(b, 6.5, 0)}), tris.push_back({Vec3(a, 0.5, 0), Vec3(b, 6.5, 0), Vec3(a, 6.5, 0)});
    else tris.push_back({Vec3(a, 0.5, 0), Vec3(b, 0.5, 0), Vec3(a, 6.5, 0)}), tris.push_back({Vec3(b, 0.5, 0), Vec3(b, 6.5, 0), Vec3(a, 6.5, 0)});
  }
  const auto n = coverage_count(tris, 8, 8);
  int total = 0;
  for (int c : n) {
    EXPECT_LE(c, 1);
    total += c;
  }
  // Union [0.5, 7.5] x [0.5, 6.5]: interior centres are columns 1..6, rows 1..5 (30); of the
  // centres on its boundary the rule keeps the left edge x = 0.5 (it runs towards -y in positive
  // orientation) and the bottom edge y = 6.5 (towards -x), not the right and top ones: columns
  // 0..6 of rows 1..6.
  EXPECT_EQ(total, 7 * 6);
  // A fan of 8 triangles around (4.5, 4.5), every spoke through pixel centres.
  const Vec3 c(4.5, 4.5, 0);
  const Vec3 ring[] = {Vec3(0.5, 0.5, 0), Vec3(4.5, 0.5, 0), Vec3(8.5, 0.5, 0), Vec3(8.5, 4.5, 0),
                       Vec3(8.5, 8.5, 0), Vec3(4.5, 8.5, 0), Vec3(0.5, 8.5, 0), Vec3(0.5, 4.5, 0)};
  std::vector<std::array<Vec3, 3>> fan;
  for (int i = 0; i < 8; ++i) fan.push_back({c, ring[i], ring[(i + 1) % 8]});
  const auto m = coverage_count(fan, 10, 10);
  EXPECT_EQ(m[static_cast<size_t>(4 * 10 + 4)], 1);  // the centre pixel, on every spoke
  for (int y = 1; y < 8; ++y)
    for (int x = 1; x < 8; ++x) EXPECT_EQ(m[static_cast<size_t>(y * 10 + x)], 1) << x << "," << y;
}

// A grid of random (jittered) vertices, triangulated with random diagonals and random corner
// orders, covering the image: every pixel is covered exactly once, although edge functions are
// evaluated in floating point.
TEST(Raster, RandomMeshCoversEveryPixelOnce) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.2, 0.2);  // quads stay convex
  const int g = 12, size = 64;
  const double step = static_cast<double>(size) / g;
  std::vector<Vec3> v;
  for (int j = 0; j <= g; ++j)
    for (int i = 0; i <= g; ++i) {
      const bool border_x = i == 0 || i == g, border_y = j == 0 || j == g;
      v.emplace_back(i * step + (border_x ? 0 : jitter(rng) * step), j * step + (border_y ? 0 : jitter(rng) * step), 0);
    }
  auto at = [&](int i, int j) { return v[static_cast<size_t>(j * (g + 1) + i)]; };
  std::vector<std::array<Vec3, 3>> tris;
  for (int j = 0; j < g; ++j)
    for (int i = 0; i < g; ++i) {
      const Vec3 a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
      std::array<Vec3, 3> t1 = {a, b, c}, t2 = {a, c, d};
      if (rng() & 1u) t1 = {a, b, d}, t2 = {b, c, d};
      if (rng() & 1u) std::swap(t1[1], t1[2]);
      if (rng() & 1u) std::swap(t2[0], t2[1]);
      tris.push_back(t1), tris.push_back(t2);
    }
  const auto n = coverage_count(tris, size, size);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) ASSERT_EQ(n[static_cast<size_t>(y * size + x)], 1) << x << "," << y;
}

TEST(Raster, BarycentricsAndDepthInterpolate) {
  const std::array<Vec3, 3> t = {Vec3(0, 0, 1), Vec3(8, 0, 3), Vec3(0, 8, 5)};
  int n = 0;
  scan_triangle(t, 8, 8, [&](const Fragment& f) {
    ++n;
    const double cx = f.x + 0.5, cy = f.y + 0.5;
    EXPECT_NEAR(f.bary[0] + f.bary[1] + f.bary[2], 1.0, 1e-12);
    EXPECT_NEAR(f.bary[1] * 8, cx, 1e-12);  // corner 1 is (8, 0)
    EXPECT_NEAR(f.bary[2] * 8, cy, 1e-12);
    EXPECT_NEAR(f.z, 1 + 2 * cx / 8 + 4 * cy / 8, 1e-12);
  });
  EXPECT_EQ(n, 28);  // centres with x + y + 1 < 8 (the hypotenuse is not owned)
}

// The z-buffer keeps the nearest (largest z) fragment whatever the drawing order; of equal depths
// the first drawn stays.
TEST(Raster, DepthOrder) {
  const std::array<Vec3, 3> far = {Vec3(0, 0, 1), Vec3(8, 0, 1), Vec3(0, 8, 1)};
  const std::array<Vec3, 3> near = {Vec3(0, 0, 2), Vec3(8, 0, 2), Vec3(0, 8, 2)};
  for (bool near_first : {false, true}) {
    DepthBuffer zb(8, 8);
    std::vector<int> id(64, -1);
    auto draw = [&](const std::array<Vec3, 3>& t, int which) { zb.draw(t, [&](const Fragment& f) { id[static_cast<size_t>(f.y * 8 + f.x)] = which; }); };
    if (near_first) draw(near, 1), draw(far, 0);
    else draw(far, 0), draw(near, 1);
    EXPECT_EQ(id[0], 1);
    EXPECT_EQ(zb.depth(0, 0), 2.0);
    EXPECT_EQ(id[63], -1);
    EXPECT_EQ(zb.depth(7, 7), -std::numeric_limits<double>::infinity());
  }
  // A tilted triangle crossing a flat one: each pixel shows whichever is nearer there.
  DepthBuffer zb(8, 8);
  std::vector<int> id(64, -1);
  const std::array<Vec3, 3> flat = {Vec3(0, 0, 4), Vec3(16, 0, 4), Vec3(0, 16, 4)};
  const std::array<Vec3, 3> tilt = {Vec3(0, 0, 0), Vec3(16, 0, 16), Vec3(0, 16, 0)};  // z = x
  zb.draw(flat, [&](const Fragment& f) { id[static_cast<size_t>(f.y * 8 + f.x)] = 0; });
  zb.draw(tilt, [&](const Fragment& f) { id[static_cast<size_t>(f.y * 8 + f.x)] = 1; });
  for (int x = 0; x < 8; ++x) EXPECT_EQ(id[static_cast<size_t>(x)], x + 0.5 > 4 ? 1 : 0) << x;
  // Equal depth: the first stays.
  DepthBuffer eq(8, 8);
  int second = 0;
  eq.draw(far, [](const Fragment&) {});
  eq.draw(far, [&](const Fragment&) { ++second; });
  EXPECT_EQ(second, 0);
}

TEST(Raster, DegenerateAndOffImageTrianglesCoverNothing) {
  int n = 0;
  auto count = [&](const Fragment&) { ++n; };
  scan_triangle({Vec3(0, 0, 0), Vec3(4, 4, 0), Vec3(8, 8, 0)}, 8, 8, count);  // collinear
  scan_triangle({Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(8, 0, 0)}, 8, 8, count);  // repeated corner
  scan_triangle({Vec3(20, 20, 0), Vec3(30, 20, 0), Vec3(20, 30, 0)}, 8, 8, count);  // off the image
  scan_triangle({Vec3(-1e300, 0, 0), Vec3(1e300, 0, 0), Vec3(0, 1e300, 0)}, 8, 8, count);  // area overflows
  scan_triangle({Vec3(std::nan(""), 0, 0), Vec3(4, 0, 0), Vec3(0, 4, 0)}, 8, 8, count);
  EXPECT_EQ(n, 0);
  // A huge finite triangle is clipped to the image: every pixel once.
  scan_triangle({Vec3(-1e6, -1e6, 0), Vec3(3e6, -1e6, 0), Vec3(-1e6, 3e6, 0)}, 8, 8, count);
  EXPECT_EQ(n, 64);
}
