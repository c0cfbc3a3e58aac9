// packers.tetris: horizon ("Tetris") packing of rasterised chart outlines, after Lévy, Petitjean,
// Ray & Maillot 2002, "Least squares conformal maps for automatic texture atlas generation"
// (section 5, packing), as used by the M-method (Maggiordomo et al. 2021: rasterised outlines, four
// 90-degree rotations, gutter cells around each outline).
//
// Each chart is rasterised on the texel grid (conservatively, see geometry.h) and dilated by the
// gutter. Its bottom profile (lowest covered cell per column) and top profile (highest) are taken.
// Charts are dropped in decreasing area onto the page's top horizon H(x): for every column offset
// and every allowed rotation, the chart rests where its bottom profile first touches the horizon;
// the position with the least cost wins: area wasted between horizon and bottom profile plus the
// page area the drop adds above the page's current height (ties: lower resulting top, then
// leftmost). Lévy et al. minimise the wasted area; the added-area term stops charts from being
// stacked into towers when the page width is fixed. The horizon then becomes the chart's top profile over its columns.
// Space below the horizon is never reused (classic Tetris). Pages fill in order; a chart that fits
// no existing page under max_page_size opens a new one.
#include "texdefrag/packers/packing.h"
#include "texdefrag/stage/registry.h"

#include <algorithm>
#include <chrono>
#include <climits>

namespace texdefrag {
namespace {

using packing::CommonSettings;
using packing::PackChart;
using packing::PackInput;
using packing::PackResult;
using packing::Placement;

/// A dilated outline's column profiles (cells, relative to the padded box's lower-left corner).
struct Profile {
  int w = 0, h = 0;
  std::vector<int> bottom;  ///< lowest covered row per column, INT_MAX for an empty column
  std::vector<int> top;     ///< highest covered row + 1 per column, 0 for an empty column
};

Profile make_profile(const PackChart& c, int q, const CommonSettings& s) {
  const packing::Mask m = packing::dilate(c.raster(q), s.gutter / 2, s.gutter - s.gutter / 2);
  Profile p;
  p.w = m.width;
  p.h = m.height;
  p.bottom.assign(static_cast<size_t>(m.width), INT_MAX);
  p.top.assign(static_cast<size_t>(m.width), 0);
  for (int x = 0; x < m.width; ++x)
    for (int y = 0; y < m.height; ++y)
      if (m.at(x, y)) {
        p.bottom[static_cast<size_t>(x)] = std::min(p.bottom[static_cast<size_t>(x)], y);
        p.top[static_cast<size_t>(x)] = y + 1;
      }
  return p;
}

struct Drop {
  bool found = false;
  int x = 0, y = 0;
  long long cost = 0;
  int top = 0;
};

/// Best drop of profile p on horizon H (width W, height limit Hmax, current page height `used`).
/// Cost = area wasted between the horizon and the chart's bottom profile + page area added above
/// the current used height (rows the chart adds times the page width). Ties: lower top, then left.
/// note: for profiles without empty columns, the window maximum of H bounds the drop height from
/// below (y >= max H - max bottom), and the cost grows with y, so most offsets are skipped without
/// scanning the profile.
Drop best_drop(const std::vector<int>& H, int Hmax, int used, const Profile& p) {
  Drop best;
  const int W = static_cast<int>(H.size());
  if (p.w > W || p.h > Hmax) return best;
  int bmin = INT_MAX, bmax = 0, filled = 0;
  long long bsum = 0;
  for (int c = 0; c < p.w; ++c) {
    const int b = p.bottom[static_cast<size_t>(c)];
    if (b == INT_MAX) continue;
    bmin = std::min(bmin, b);
    bmax = std::max(bmax, b);
    bsum += b;
    ++filled;
  }
  if (filled == 0) return best;
  const bool solid = filled == p.w;
  std::vector<long long> prefix(static_cast<size_t>(W) + 1, 0);
  for (int x = 0; x < W; ++x) prefix[static_cast<size_t>(x) + 1] = prefix[static_cast<size_t>(x)] + H[static_cast<size_t>(x)];
  auto cost_of = [&](int x, int y) {
    const long long waste = static_cast<long long>(filled) * y + bsum -
                            (solid ? prefix[static_cast<size_t>(x + p.w)] - prefix[static_cast<size_t>(x)] : 0);
    const long long grow = std::max(0, y + p.h - used);
    return waste + grow * W;
  };
  std::vector<int> dq(static_cast<size_t>(W));  // sliding-window maximum of H (indices)
  size_t head = 0, tail = 0;
  for (int x = 0; x + p.w <= W; ++x) {
    if (solid) {
      if (x == 0)
        for (int c = 0; c < p.w - 1; ++c) {
          while (tail > head && H[static_cast<size_t>(dq[tail - 1])] <= H[static_cast<size_t>(c)]) --tail;
          dq[tail++] = c;
        }
      const int in = x + p.w - 1;
      while (tail > head && H[static_cast<size_t>(dq[tail - 1])] <= H[static_cast<size_t>(in)]) --tail;
      dq[tail++] = in;
      while (dq[head] < x) ++head;
      const int lb = std::max(0, H[static_cast<size_t>(dq[head])] - bmax);
      if (best.found && cost_of(x, lb) > best.cost) continue;
    }
    int y = 0;
    for (int c = 0; c < p.w; ++c)
      if (p.bottom[static_cast<size_t>(c)] != INT_MAX)
        y = std::max(y, H[static_cast<size_t>(x + c)] - p.bottom[static_cast<size_t>(c)]);
    if (y + p.h > Hmax) continue;
    long long cost;
    if (solid) {
      cost = cost_of(x, y);
    } else {
      long long waste = 0;
      for (int c = 0; c < p.w; ++c)
        if (p.bottom[static_cast<size_t>(c)] != INT_MAX)
          waste += y + p.bottom[static_cast<size_t>(c)] - H[static_cast<size_t>(x + c)];
      cost = waste + static_cast<long long>(std::max(0, y + p.h - used)) * W;
    }
    const int top = y + p.h;
    if (!best.found || cost < best.cost || (cost == best.cost && top < best.top)) best = Drop{true, x, y, cost, top};
  }
  return best;
}

PackResult pack_tetris(const PackInput& in, const CommonSettings& s, const std::vector<int>& order,
                       const std::vector<std::vector<Profile>>& profiles, int width, const StageContext& ctx) {
  PackResult r;
  r.placements.assign(in.charts.size(), Placement{});
  std::vector<std::vector<int>> horizons;
  std::vector<int> used;  // per page: highest cell row in use
  const int lo = s.gutter / 2;
  for (size_t n = 0; n < order.size(); ++n) {
    if ((n & 255) == 0) ctx.step("packers.tetris", static_cast<double>(n) / static_cast<double>(order.size()));
    const int id = order[n];
    const auto& profs = profiles[static_cast<size_t>(id)];
    bool placed = false;
    for (size_t pg = 0; pg <= horizons.size() && !placed; ++pg) {
      const bool fresh = pg == horizons.size();
      if (fresh) {
        horizons.emplace_back(static_cast<size_t>(width), 0);
        used.push_back(0);
      }
      std::vector<int>& H = horizons[pg];
      Drop best;
      int best_q = 0;
      for (size_t q = 0; q < profs.size(); ++q) {
        const Drop d = best_drop(H, s.max_page_size, used[pg], profs[q]);
        if (d.found && (!best.found || d.cost < best.cost || (d.cost == best.cost && d.top < best.top))) {
          best = d;
          best_q = static_cast<int>(q);
        }
      }
      if (!best.found) {
        if (fresh) break;
        continue;
      }
      const Profile& p = profs[static_cast<size_t>(best_q)];
      for (int c = 0; c < p.w; ++c)
        if (p.top[static_cast<size_t>(c)] > 0)
          H[static_cast<size_t>(best.x + c)] = best.y + p.top[static_cast<size_t>(c)];
      used[pg] = std::max(used[pg], best.top);
      r.placements[static_cast<size_t>(id)] = Placement{static_cast<int>(pg), best.x + lo, best.y + lo, best_q};
      placed = true;
    }
    if (!placed)
      throw StageError("packers.tetris: chart " + std::to_string(id) + " fits no page of width " +
                       std::to_string(width));
  }
  r.pages = static_cast<int>(horizons.size());
  return r;
}

class Tetris : public Packer {
 public:
  static StageInfo info() {
    StageInfo i;
    i.name = "packers.tetris";
    i.kind = StageKind::Packer;
    i.description = "Classic horizon Tetris of rasterised outlines, 4 rotations (Levy et al. 2002, M-method)";
    i.doc = "docs/packers.md";
    i.options = packing::common_options(false);
    i.create = [] { return std::make_unique<Tetris>(); };
    return i;
  }

  void pack(StageContext& ctx) override {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string name = "packers.tetris";
    const CommonSettings s = packing::read_common(options());
    const PackInput in = packing::prepare_charts(ctx, s, name);
    packing::check_chart_sizes(in, s, name);
    const std::vector<int> order = packing::order_by_area(in, s);
    std::vector<std::vector<Profile>> profiles(in.charts.size());
    for (int id : order) {
      const PackChart& c = in.charts[static_cast<size_t>(id)];
      // note: index = quarter turn; an orientation too large for the page never finds a drop.
      for (int q = 0; q < (s.allow_rotation ? 4 : 1); ++q)
        profiles[static_cast<size_t>(id)].push_back(make_profile(c, q, s));
    }
    const PackResult r = packing::pack_best_width(
        in, s, [&](int width) { return pack_tetris(in, s, order, profiles, width, ctx); });
    ctx.step(name, 1.0);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    packing::write_layout(ctx, in, r, ms);
  }
};

}  // namespace
}  // namespace texdefrag

TEXDEFRAG_PLUGIN(texdefrag::Tetris)
