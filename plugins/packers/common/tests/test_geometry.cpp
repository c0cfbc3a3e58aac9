// Hand-checked geometry of the packers: hull, exact minimum-area rectangle, rotations, rasterisation.
#include "texdefrag/packers/geometry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace texdefrag;
using namespace texdefrag::packing;

namespace {
constexpr double kPi = 3.14159265358979323846;
}

TEST(PackersGeometry, HullOfSquareWithInteriorAndCollinearPoints) {
  const auto h = convex_hull({{0, 0}, {2, 0}, {1, 0}, {2, 2}, {0, 2}, {1, 1}, {0, 1}, {2, 2}});
  ASSERT_EQ(h.size(), 4u);
  double area = 0;
  for (size_t i = 0; i < h.size(); ++i) {
    const Vec2& a = h[i];
    const Vec2& b = h[(i + 1) % h.size()];
    area += a.x() * b.y() - a.y() * b.x();
  }
  EXPECT_DOUBLE_EQ(area / 2, 4.0);  // counter-clockwise: positive
}

TEST(PackersGeometry, HullDegenerate) {
  EXPECT_TRUE(convex_hull({}).empty());
  EXPECT_EQ(convex_hull({{1, 1}, {1, 1}}).size(), 1u);
  EXPECT_EQ(convex_hull({{0, 0}, {1, 1}, {2, 2}}).size(), 2u);
}

TEST(PackersGeometry, MinAreaRectOfRotatedSquareIsTheSquare) {
  // A 10x10 square rotated by 30 degrees: its axis-aligned box is 13.66^2 = 186.6; the minimum
  // rectangle is the square itself (area 100) at 30 degrees.
  std::vector<Vec2> pts;
  for (const Vec2& q : {Vec2(0, 0), Vec2(10, 0), Vec2(10, 10), Vec2(0, 10)}) pts.push_back(rotate(q, kPi / 6) + Vec2(5, 7));
  const OrientedRect r = min_area_rect(convex_hull(pts));
  EXPECT_NEAR(r.area(), 100.0, 1e-9);
  EXPECT_NEAR(r.width, 10.0, 1e-9);
  EXPECT_NEAR(r.height, 10.0, 1e-9);
  EXPECT_NEAR(r.angle, kPi / 6, 1e-12);
  // Rotating back by -angle makes it axis-aligned with the same area.
  double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
  for (const Vec2& p : pts) {
    const Vec2 q = rotate(p, -r.angle);
    x0 = std::min(x0, q.x()); x1 = std::max(x1, q.x());
    y0 = std::min(y0, q.y()); y1 = std::max(y1, q.y());
  }
  EXPECT_NEAR((x1 - x0) * (y1 - y0), 100.0, 1e-9);
}

TEST(PackersGeometry, MinAreaRectOfRotatedRectangleKeepsSides) {
  // 20 x 4 rectangle rotated by 100 degrees: normalised angle 10 degrees, sides swapped.
  std::vector<Vec2> pts;
  for (const Vec2& q : {Vec2(0, 0), Vec2(20, 0), Vec2(20, 4), Vec2(0, 4)}) pts.push_back(rotate(q, 100 * kPi / 180));
  const OrientedRect r = min_area_rect(convex_hull(pts));
  EXPECT_NEAR(r.area(), 80.0, 1e-9);
  EXPECT_NEAR(r.angle, 10 * kPi / 180, 1e-12);
  EXPECT_NEAR(r.width, 4.0, 1e-9);   // along 10 degrees: the short side
  EXPECT_NEAR(r.height, 20.0, 1e-9);
}

TEST(PackersGeometry, MinAreaRectOfRightTriangle) {
  // Right triangle with legs 3 and 4: the best rectangle is on a leg, area 12 (hypotenuse gives 12 too).
  const OrientedRect r = min_area_rect(convex_hull({{0, 0}, {4, 0}, {0, 3}}));
  EXPECT_NEAR(r.area(), 12.0, 1e-9);
}

TEST(PackersGeometry, MinAreaRectOfSegmentAndPoint) {
  const OrientedRect s = min_area_rect(convex_hull({{0, 0}, {3, 4}}));
  EXPECT_DOUBLE_EQ(s.area(), 0.0);
  EXPECT_NEAR(std::max(s.width, s.height), 5.0, 1e-12);
  EXPECT_DOUBLE_EQ(min_area_rect(convex_hull({{2, 2}})).area(), 0.0);
}

TEST(PackersGeometry, CalipersMatchBruteForceOnRandomPolygons) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-50, 50);
  std::uniform_int_distribution<int> n(3, 60);
  for (int t = 0; t < 500; ++t) {
    std::vector<Vec2> pts(static_cast<size_t>(n(rng)));
    for (Vec2& p : pts) p = Vec2(u(rng), u(rng) * (t % 3 == 0 ? 0.1 : 1.0));
    const auto h = convex_hull(pts);
    const OrientedRect a = min_area_rect(h), b = min_area_rect_brute(h);
    ASSERT_NEAR(a.area(), b.area(), 1e-9 * std::max(1.0, b.area())) << "trial " << t;
    // And no point lies outside the rectangle (rotate by -angle, compare extents).
    double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
    for (const Vec2& p : pts) {
      const Vec2 q = rotate(p, -a.angle);
      x0 = std::min(x0, q.x()); x1 = std::max(x1, q.x());
      y0 = std::min(y0, q.y()); y1 = std::max(y1, q.y());
    }
    EXPECT_NEAR(x1 - x0, a.width, 1e-7);
    EXPECT_NEAR(y1 - y0, a.height, 1e-7);
    EXPECT_GE(a.angle, 0);
    EXPECT_LT(a.angle, kPi / 2);
  }
}

TEST(PackersGeometry, Rotate90IsExact) {
  const Vec2 p(0.1, 1234.3);
  EXPECT_EQ(rotate90(p, 1), Vec2(-1234.3, 0.1));
  EXPECT_EQ(rotate90(p, 2), Vec2(-0.1, -1234.3));
  EXPECT_EQ(rotate90(p, 3), Vec2(1234.3, -0.1));
  EXPECT_EQ(rotate90(p, -1), rotate90(p, 3));
  EXPECT_EQ(rotate90(rotate90(p, 1), 3), p);
}

TEST(PackersGeometry, TriangleCellTouch) {
  const Vec2 a(0.5, 0.5), b(3.5, 0.5), c(0.5, 3.5);
  EXPECT_TRUE(triangle_touches_cell(a, b, c, 0, 0));
  EXPECT_TRUE(triangle_touches_cell(a, b, c, 2, 0));
  EXPECT_TRUE(triangle_touches_cell(a, b, c, 1, 1));
  EXPECT_TRUE(triangle_touches_cell(a, b, c, 2, 2));   // corner (2, 2) lies on the hypotenuse x + y = 4
  EXPECT_FALSE(triangle_touches_cell(a, b, c, 3, 2));  // beyond the hypotenuse
  EXPECT_FALSE(triangle_touches_cell(a, b, c, 4, 0));
  EXPECT_TRUE(triangle_touches_cell({1, 1}, {1, 1}, {1, 1}, 0, 0));  // a point on a corner touches
  EXPECT_TRUE(triangle_touches_cell({0, 0}, {5, 5}, {5, 5}, 3, 3));  // a segment through the diagonal
  EXPECT_FALSE(triangle_touches_cell({0, 0}, {5, 5}, {5, 5}, 3, 1));
}

TEST(PackersGeometry, RasterIsConservative) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 20), w(0, 1);
  for (int t = 0; t < 200; ++t) {
    const Vec2 a(u(rng), u(rng)), b(u(rng), u(rng)), c(u(rng), u(rng));
    Mask m;
    m.width = m.height = 21;
    m.cells.assign(21 * 21, 0);
    rasterise_triangle(a, b, c, m);
    for (int s = 0; s < 200; ++s) {  // random points of the triangle land on marked cells
      double l1 = w(rng), l2 = w(rng);
      if (l1 + l2 > 1) { l1 = 1 - l1; l2 = 1 - l2; }
      const Vec2 p = a + l1 * (b - a) + l2 * (c - a);
      ASSERT_TRUE(m.at(static_cast<int>(std::floor(p.x())), static_cast<int>(std::floor(p.y()))));
    }
  }
}

TEST(PackersGeometry, RasterMatchesCellTest) {
  // The row-by-row rasteriser marks exactly the cells triangle_touches_cell accepts, including
  // triangles with whole-texel corners and degenerate ones.
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(0, 15);
  std::uniform_int_distribution<int> iu(0, 15);
  for (int t = 0; t < 400; ++t) {
    Vec2 p[3];
    for (Vec2& q : p) q = t % 2 ? Vec2(u(rng), u(rng)) : Vec2(iu(rng), iu(rng));
    if (t % 7 == 0) p[2] = p[1];
    Mask m;
    m.width = m.height = 16;
    m.cells.assign(256, 0);
    rasterise_triangle(p[0], p[1], p[2], m);
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 16; ++i)
        ASSERT_EQ(m.at(i, j), triangle_touches_cell(p[0], p[1], p[2], i, j))
            << "trial " << t << " cell " << i << "," << j;
  }
}

TEST(PackersGeometry, DilateKeepsGutter) {
  Mask m;
  m.width = 3;
  m.height = 2;
  m.cells = {1, 0, 0,
             0, 0, 1};
  const Mask d = dilate(m, 1, 2);
  ASSERT_EQ(d.width, 6);
  ASSERT_EQ(d.height, 5);
  // (0,0) covers x 0..3, y 0..3; (2,1) covers x 2..5, y 1..4.
  EXPECT_TRUE(d.at(3, 3));
  EXPECT_TRUE(d.at(5, 4));
  EXPECT_FALSE(d.at(4, 0));
  EXPECT_FALSE(d.at(0, 4));
  EXPECT_FALSE(d.at(1, 4));
  int n = 0;
  for (uint8_t c : d.cells) n += c;
  EXPECT_EQ(n, 16 + 16 - 6);  // two 4x4 blocks overlapping on a 2x3 block
}

TEST(PackersGeometry, DilateMatchesDefinitionOnRandomMasks) {
  // Every result cell is set exactly when some input cell lies within [0, lo + hi] below-left of it.
  std::mt19937 rng(11);
  for (int trial = 0; trial < 50; ++trial) {
    Mask m;
    m.width = 1 + static_cast<int>(rng() % 20);
    m.height = 1 + static_cast<int>(rng() % 20);
    m.cells.resize(static_cast<size_t>(m.width * m.height));
    for (auto& c : m.cells) c = rng() % 5 == 0;
    const int lo = static_cast<int>(rng() % 4), hi = static_cast<int>(rng() % 4);
    const Mask d = dilate(m, lo, hi);
    const int r = lo + hi;
    ASSERT_EQ(d.width, m.width + r);
    ASSERT_EQ(d.height, m.height + r);
    for (int y = 0; y < d.height; ++y)
      for (int x = 0; x < d.width; ++x) {
        bool want = false;
        for (int dy = 0; dy <= r && !want; ++dy)
          for (int dx = 0; dx <= r && !want; ++dx) {
            const int sx = x - dx, sy = y - dy;
            want = sx >= 0 && sy >= 0 && sx < m.width && sy < m.height && m.at(sx, sy);
          }
        ASSERT_EQ(d.at(x, y), want) << "trial " << trial << " cell " << x << "," << y;
      }
  }
}
