// The column-profile horizon search shared by packers.tetris and packers.square_tetris
// (horizon.h): profiles of turned charts, and best_drop against an exhaustive search.
#include "texdefrag/packers/horizon.h"

#include <gtest/gtest.h>

#include <climits>
#include <cmath>
#include <random>

using namespace texdefrag;
using namespace texdefrag::packing;

namespace {

/// A chart made of the given triangles (texel coordinates), prepared as prepare_charts would for
/// an exact chart: base = the points, boxes from their rotated extents.
PackChart chart_of(const std::vector<std::array<Vec2, 3>>& tris) {
  PackChart c;
  c.id = 0;
  for (const auto& t : tris) {
    const int i = static_cast<int>(c.base.size());
    for (const Vec2& p : t) c.base.push_back(p);
    c.tris.push_back({i, i + 1, i + 2});
  }
  for (int q = 0; q < 4; ++q) {
    double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
    for (const Vec2& b : c.base) {
      const Vec2 p = rotate90(b, q);
      x0 = std::min(x0, p.x()); y0 = std::min(y0, p.y());
      x1 = std::max(x1, p.x()); y1 = std::max(y1, p.y());
    }
    c.ox[q] = static_cast<int>(std::floor(x0));
    c.oy[q] = static_cast<int>(std::floor(y0));
    c.w[q] = std::max(1, static_cast<int>(std::ceil(x1)) - c.ox[q]);
    c.h[q] = std::max(1, static_cast<int>(std::ceil(y1)) - c.oy[q]);
  }
  return c;
}

/// Exhaustive reference of best_drop: every offset, drop height from every column.
Drop reference_drop(const std::vector<int>& H, int used, int Hmax, const Profile& p) {
  Drop best;
  const int W = static_cast<int>(H.size());
  for (int x = 0; x + p.w <= W; ++x) {
    int y = 0;
    for (int c = 0; c < p.w; ++c)
      if (p.bottom[static_cast<size_t>(c)] != INT_MAX)
        y = std::max(y, H[static_cast<size_t>(x + c)] - p.bottom[static_cast<size_t>(c)]);
    if (y + p.h > Hmax) continue;
    long long cost = static_cast<long long>(std::max(0, y + p.h - used)) * W;
    for (int c = 0; c < p.w; ++c)
      if (p.bottom[static_cast<size_t>(c)] != INT_MAX) cost += y + p.bottom[static_cast<size_t>(c)] - H[static_cast<size_t>(x + c)];
    const int top = y + p.h;
    if (!best.found || cost < best.cost || (cost == best.cost && (top < best.top || (top == best.top && x < best.x))))
      best = Drop{true, x, y, cost, top};
  }
  return best;
}

/// A random profile of width w: flat, jagged, or with empty columns.
Profile random_profile(std::mt19937& rng, int w, int kind) {
  Profile p;
  p.w = w;
  p.h = 1 + static_cast<int>(rng() % 30);
  p.bottom.assign(static_cast<size_t>(w), 0);
  p.top.assign(static_cast<size_t>(w), p.h);
  for (int c = 0; c < w; ++c) {
    if (kind == 1) p.bottom[static_cast<size_t>(c)] = static_cast<int>(rng() % static_cast<unsigned>(p.h));
    if (kind == 2 && c > 0 && c + 1 < w && rng() % 3 == 0) { p.bottom[static_cast<size_t>(c)] = INT_MAX; p.top[static_cast<size_t>(c)] = 0; }
  }
  for (int b : p.bottom)
    if (b != INT_MAX) { p.bmax = std::max(p.bmax, b); p.bsum += b; ++p.filled; }
  return p;
}

}  // namespace

TEST(PackersHorizon, TurnedProfilesMatchTurnedRasters) {
  // make_profiles derives all quarter turns from one raster; each must equal the profile of the
  // turned chart's own raster (make_profile), for whole-texel and arbitrary coordinates.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 40);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<std::array<Vec2, 3>> tris;
    const int nt = 1 + trial % 3;
    for (int t = 0; t < nt; ++t) {
      std::array<Vec2, 3> tri;
      for (Vec2& p : tri) p = trial % 2 == 0 ? Vec2(std::round(u(rng)), std::round(u(rng))) : Vec2(u(rng), u(rng));
      tris.push_back(tri);
    }
    const PackChart c = chart_of(tris);
    CommonSettings s;
    s.gutter = trial % 6;
    const std::vector<Profile> profs = make_profiles(c, s);
    ASSERT_EQ(profs.size(), 4u);
    for (int q = 0; q < 4; ++q) {
      const Profile ref = make_profile(c, q, s);
      const Profile& p = profs[static_cast<size_t>(q)];
      ASSERT_EQ(p.w, ref.w) << trial << " q " << q;
      ASSERT_EQ(p.h, ref.h) << trial << " q " << q;
      EXPECT_EQ(p.bottom, ref.bottom) << trial << " q " << q;
      EXPECT_EQ(p.top, ref.top) << trial << " q " << q;
      EXPECT_EQ(p.filled, ref.filled);
      EXPECT_EQ(p.bmax, ref.bmax);
      EXPECT_EQ(p.bsum, ref.bsum);
    }
  }
  // A box turned by 180 degrees repeats itself: marked duplicate.
  const PackChart box = chart_of({{{{0, 0}, {10, 0}, {10, 4}}}, {{{0, 0}, {10, 4}, {0, 4}}}});
  const std::vector<Profile> bp = make_profiles(box, CommonSettings{});
  EXPECT_FALSE(bp[0].duplicate);
  EXPECT_FALSE(bp[1].duplicate);
  EXPECT_TRUE(bp[2].duplicate);
  EXPECT_TRUE(bp[3].duplicate);
}

TEST(PackersHorizon, BestDropMatchesExhaustiveSearch) {
  // Random staircase horizons and flat, jagged and gappy profiles of every width class (narrow:
  // every column; wide: window maximum + sampled columns), on small and on huge pages (64-bit
  // costs), after a sequence of placements.
  std::mt19937 rng(7);
  for (int trial = 0; trial < 120; ++trial) {
    const bool huge = trial % 10 == 9;
    const int W = huge ? 20000 : 40 + static_cast<int>(rng() % 400);
    const int Hmax = huge ? 20000 : 60 + static_cast<int>(rng() % 100);
    Horizon hz(W);
    for (int step = 0; step < 25; ++step) {
      const int kind = static_cast<int>(rng() % 3);
      const int w = 1 + static_cast<int>(rng() % (step % 2 == 0 ? 12 : 60));
      const Profile p = random_profile(rng, std::min(w, W), kind);
      const Drop got = best_drop(hz, Hmax, p);
      const Drop want = reference_drop(hz.H, hz.used, Hmax, p);
      ASSERT_EQ(got.found, want.found) << "trial " << trial << " step " << step;
      if (!want.found) break;
      ASSERT_EQ(got.x, want.x) << "trial " << trial << " step " << step << " w " << p.w << " kind " << kind;
      ASSERT_EQ(got.y, want.y) << "trial " << trial << " step " << step;
      ASSERT_EQ(got.cost, want.cost) << "trial " << trial << " step " << step;
      ASSERT_EQ(got.top, want.top);
      hz.place(p, got);
      // prefix sums follow the horizon
      long long sum = 0;
      for (int x = 0; x < W; ++x) sum += hz.H[static_cast<size_t>(x)];
      ASSERT_EQ(hz.prefix.back(), sum);
    }
  }
}
