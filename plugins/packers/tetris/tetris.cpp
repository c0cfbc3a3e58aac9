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
  bool duplicate = false;   ///< same outline as a smaller quarter turn of the same chart
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

/// A page's horizon with its prefix sums and scratch space (reused across drops).
struct Horizon {
  std::vector<int> H;             ///< top of the filled area per column
  std::vector<long long> prefix;  ///< prefix[x] = H[0] + ... + H[x-1]
  std::vector<int> lb;            ///< scratch: lower bound of the drop height per offset
  std::vector<int> dq;            ///< scratch: block prefix maxima of H
  int used = 0;                   ///< highest row in use
  explicit Horizon(int width)
      : H(static_cast<size_t>(width), 0), prefix(static_cast<size_t>(width) + 1, 0),
        lb(static_cast<size_t>(width), 0), dq(static_cast<size_t>(width), 0) {}
  void update_prefix(int from) {
    for (size_t x = static_cast<size_t>(from); x < H.size(); ++x) prefix[x + 1] = prefix[x] + H[x];
  }
};

/// Best drop of profile p on horizon `hz` (height limit Hmax).
/// Cost = area wasted between the horizon and the chart's bottom profile + page area added above
/// the current used height (rows the chart adds times the page width). Ties: lower top, then left.
/// note: for profiles without empty columns, the window maximum of H bounds the drop height from
/// below (y >= max H - max bottom) and the cost grows with y, so offsets whose bound cannot beat
/// the best are skipped without scanning the profile; the offset with the lowest bound is
/// evaluated first to get a good best early.
Drop best_drop(Horizon& hz, int Hmax, const Profile& p) {
  Drop best;
  const std::vector<int>& H = hz.H;
  const int W = static_cast<int>(H.size());
  if (p.w > W || p.h > Hmax) return best;
  int bmax = 0, filled = 0;
  long long bsum = 0;
  for (int c = 0; c < p.w; ++c) {
    const int b = p.bottom[static_cast<size_t>(c)];
    if (b == INT_MAX) continue;
    bmax = std::max(bmax, b);
    bsum += b;
    ++filled;
  }
  if (filled == 0) return best;
  const bool solid = filled == p.w;
  auto exact_y = [&](int x) {
    int y = 0;
    for (int c = 0; c < p.w; ++c)
      if (p.bottom[static_cast<size_t>(c)] != INT_MAX)
        y = std::max(y, H[static_cast<size_t>(x + c)] - p.bottom[static_cast<size_t>(c)]);
    return y;
  };
  auto cost_of = [&](int x, int y) {
    long long waste;
    if (solid) {
      waste = static_cast<long long>(filled) * y + bsum -
              (hz.prefix[static_cast<size_t>(x + p.w)] - hz.prefix[static_cast<size_t>(x)]);
    } else {
      waste = 0;
      for (int c = 0; c < p.w; ++c)
        if (p.bottom[static_cast<size_t>(c)] != INT_MAX)
          waste += y + p.bottom[static_cast<size_t>(c)] - H[static_cast<size_t>(x + c)];
    }
    return waste + static_cast<long long>(std::max(0, y + p.h - hz.used)) * W;
  };
  auto consider = [&](int x) {
    const int y = exact_y(x);
    if (y + p.h > Hmax) return;
    const long long cost = cost_of(x, y);
    const int top = y + p.h;
    if (!best.found || cost < best.cost || (cost == best.cost && (top < best.top || (top == best.top && x < best.x))))
      best = Drop{true, x, y, cost, top};
  };
  const int n = W - p.w + 1;
  if (!solid) {
    for (int x = 0; x < n; ++x) consider(x);
    return best;
  }
  // Window maximum of H over [x, x + w) (van Herk / Gil-Werman: per-block prefix and suffix
  // maxima), then the lower bound of the drop height and of the cost at every offset.
  std::vector<int>& g = hz.dq;  // prefix maxima within blocks of w columns
  std::vector<int>& lbv = hz.lb;
  for (int i = 0; i < W; ++i)
    g[static_cast<size_t>(i)] = (i % p.w == 0) ? H[static_cast<size_t>(i)] : std::max(g[static_cast<size_t>(i - 1)], H[static_cast<size_t>(i)]);
  int run = 0;  // suffix maximum within the block, computed right to left into lbv
  for (int i = W - 1; i >= 0; --i) {
    run = (i == W - 1 || (i + 1) % p.w == 0) ? H[static_cast<size_t>(i)] : std::max(run, H[static_cast<size_t>(i)]);
    lbv[static_cast<size_t>(i)] = run;
  }
  // A few profile columns sharpen the bound: y >= H[x + c] - bottom[c] for any column c.
  int samples[4] = {0, p.w - 1, p.w / 2, 0};
  for (int c = 0; c < p.w; ++c)
    if (p.bottom[static_cast<size_t>(c)] < p.bottom[static_cast<size_t>(samples[3])]) samples[3] = c;
  long long best_lb_cost = 0;
  int first = -1;
  for (int x = 0; x < n; ++x) {
    const int wmax = std::max(lbv[static_cast<size_t>(x)], g[static_cast<size_t>(x + p.w - 1)]);
    int lb = std::max(0, wmax - bmax);
    for (int c : samples) lb = std::max(lb, H[static_cast<size_t>(x + c)] - p.bottom[static_cast<size_t>(c)]);
    lbv[static_cast<size_t>(x)] = lb;  // note: lbv[x] is not read again as a suffix maximum
    if (lb + p.h > Hmax) continue;
    const long long c = cost_of(x, lb);
    if (first < 0 || c < best_lb_cost) {
      best_lb_cost = c;
      first = x;
    }
  }
  if (first < 0) return best;
  consider(first);
  for (int x = 0; x < n; ++x) {
    if (x == first) continue;
    const int lb = lbv[static_cast<size_t>(x)];
    if (lb + p.h > Hmax) continue;
    if (best.found) {  // skip offsets that cannot win even at the lowest possible height
      const long long clb = cost_of(x, lb);
      const int tlb = lb + p.h;
      if (clb > best.cost || (clb == best.cost && (tlb > best.top || (tlb == best.top && x > best.x)))) continue;
    }
    consider(x);
  }
  return best;
}

PackResult pack_tetris(const PackInput& in, const CommonSettings& s, const std::vector<int>& order,
                       const std::vector<std::vector<Profile>>& profiles, int width, const StageContext& ctx) {
  PackResult r;
  r.placements.assign(in.charts.size(), Placement{});
  std::vector<Horizon> horizons;
  const int lo = s.gutter / 2;
  for (size_t n = 0; n < order.size(); ++n) {
    if ((n & 255) == 0) ctx.step("packers.tetris", static_cast<double>(n) / static_cast<double>(order.size()));
    const int id = order[n];
    const auto& profs = profiles[static_cast<size_t>(id)];
    bool placed = false;
    for (size_t pg = 0; pg <= horizons.size() && !placed; ++pg) {
      const bool fresh = pg == horizons.size();
      if (fresh) horizons.emplace_back(width);
      Horizon& hz = horizons[pg];
      Drop best;
      int best_q = 0;
      for (size_t q = 0; q < profs.size(); ++q) {
        if (profs[q].duplicate) continue;
        const Drop d = best_drop(hz, s.max_page_size, profs[q]);
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
          hz.H[static_cast<size_t>(best.x + c)] = best.y + p.top[static_cast<size_t>(c)];
      hz.update_prefix(best.x);
      hz.used = std::max(hz.used, best.top);
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
    i.options = packing::common_options(false, 2);
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
      auto& profs = profiles[static_cast<size_t>(id)];
      for (int q = 0; q < (s.allow_rotation ? 4 : 1); ++q) {
        profs.push_back(make_profile(c, q, s));
        // A turn giving the same outline as an earlier one (boxes: 180 degrees) is not tried again.
        for (int e = 0; e < q; ++e)
          if (profs[static_cast<size_t>(e)].bottom == profs.back().bottom && profs[static_cast<size_t>(e)].top == profs.back().top &&
              profs[static_cast<size_t>(e)].h == profs.back().h) {
            profs.back().duplicate = true;
            break;
          }
      }
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
