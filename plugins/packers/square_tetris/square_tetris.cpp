// packers.square_tetris: "Square Tetris" packing of Liu et al. 2024, "Planar feature-preserving
// texture defragmentation method for 3D urban building models", Remote Sensing, section 2.3.
//
// Each chart is replaced by its minimum-area bounding rectangle (exact charts: their axis-aligned
// cell box, since they may only turn by 90 degrees; free charts: rotated to the exact minimum-area
// rectangle when that shrinks it), placed at 0 or 90 degrees, in decreasing area. The horizon h(u)
// is a piecewise-constant skyline (segments). A rectangle placed on the horizon above lower
// segments encloses unused space; those spaces are kept as maximal free rectangles (holes) sorted by
// area, and each new rectangle first tries them (best area fit: the smallest hole it fits);
// otherwise it is set on the horizon at the position (left to right, segment starts and right-
// aligned segment ends) minimising the new local peak y + h, ties broken by the space it encloses
// and then the leftmost position. A page that cannot take a rectangle under max_page_size passes it
// to the next page.
#include "texdefrag/packers/horizon.h"
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

struct Seg { int x, w, y; };
struct Rect {
  int x, y, w, h;
  long long area() const { return static_cast<long long>(w) * h; }
  bool contains(const Rect& o) const { return o.x >= x && o.y >= y && o.x + o.w <= x + w && o.y + o.h <= y + h; }
  bool intersects(const Rect& o) const { return o.x < x + w && x < o.x + o.w && o.y < y + h && y < o.y + o.h; }
};

class PageState {
 public:
  PageState(int width, int height) : width_(width), height_(height) { sky_.push_back({0, width, 0}); }

  /// Best hole for a (w x h) rectangle: returns leftover area, or -1 when none fits.
  long long best_hole(int w, int h, int min_side, size_t& which) {
    long long best = -1;
    int best_short = INT_MAX;
    for (size_t i = 0; i < holes_.size();) {
      const Rect& r = holes_[i];
      if (r.w < min_side || r.h < min_side) {  // can never be used again: drop
        holes_[i] = holes_.back();
        holes_.pop_back();
        continue;
      }
      if (w <= r.w && h <= r.h) {
        const long long left = r.area() - static_cast<long long>(w) * h;
        const int short_side = std::min(r.w - w, r.h - h);
        if (best < 0 || left < best || (left == best && short_side < best_short)) {
          best = left;
          best_short = short_side;
          which = i;
        }
      }
      ++i;
    }
    return best;
  }

  /// Best horizon position for a (w x h) rectangle: returns false when it does not fit the page.
  bool best_on_horizon(int w, int h, int& bx, int& by, long long& bwaste) const {
    bool found = false;
    long long best_peak = 0;
    for (size_t i = 0; i < sky_.size(); ++i) {
      for (int side = 0; side < 2; ++side) {
        const int x = side == 0 ? sky_[i].x : sky_[i].x + sky_[i].w - w;
        if (x < 0 || x + w > width_) continue;
        if (side == 1 && x == sky_[i].x) continue;
        // Both candidates cover segment i, so the rectangle rests at y >= sky_[i].y.
        if (found && static_cast<long long>(sky_[i].y) + h > best_peak) continue;
        size_t j = i;
        while (j > 0 && sky_[j].x > x) --j;
        int y = 0;
        for (size_t k = j; k < sky_.size() && sky_[k].x < x + w; ++k) {
          y = std::max(y, sky_[k].y);
          if (found && static_cast<long long>(y) + h > best_peak) break;
        }
        if (y + h > height_) continue;
        if (found && static_cast<long long>(y) + h > best_peak) continue;
        long long waste = 0;
        for (size_t k = j; k < sky_.size() && sky_[k].x < x + w; ++k) {
          const int lo = std::max(x, sky_[k].x), hi = std::min(x + w, sky_[k].x + sky_[k].w);
          waste += static_cast<long long>(hi - lo) * (y - sky_[k].y);
        }
        const long long peak = y + h;
        if (!found || peak < best_peak || (peak == best_peak && (waste < bwaste || (waste == bwaste && x < bx)))) {
          found = true;
          best_peak = peak;
          bwaste = waste;
          bx = x;
          by = y;
        }
      }
    }
    return found;
  }

  /// Places a rectangle inside hole `which`, at its lower-left corner.
  Rect place_in_hole(size_t which, int w, int h, int min_side) {
    const Rect r{holes_[which].x, holes_[which].y, w, h};
    std::vector<Rect> pieces;
    for (size_t i = 0; i < holes_.size();) {
      const Rect f = holes_[i];
      if (!f.intersects(r)) { ++i; continue; }
      holes_[i] = holes_.back();
      holes_.pop_back();
      if (r.x > f.x) pieces.push_back({f.x, f.y, r.x - f.x, f.h});
      if (r.x + r.w < f.x + f.w) pieces.push_back({r.x + r.w, f.y, f.x + f.w - r.x - r.w, f.h});
      if (r.y > f.y) pieces.push_back({f.x, f.y, f.w, r.y - f.y});
      if (r.y + r.h < f.y + f.h) pieces.push_back({f.x, r.y + r.h, f.w, f.y + f.h - r.y - r.h});
    }
    add_holes(pieces, min_side);
    return r;
  }

  /// Places a rectangle on the horizon at (x, y) (from best_on_horizon), recording enclosed space.
  Rect place_on_horizon(int x, int y, int w, int h, int min_side) {
    std::vector<Seg> covered, next;
    for (const Seg& s : sky_) {
      const int lo = std::max(x, s.x), hi = std::min(x + w, s.x + s.w);
      if (hi <= lo) { next.push_back(s); continue; }
      if (s.x < lo) next.push_back({s.x, lo - s.x, s.y});
      if (covered.empty()) next.push_back({x, w, y + h});
      covered.push_back({lo, hi - lo, s.y});
      if (hi < s.x + s.w) next.push_back({hi, s.x + s.w - hi, s.y});
    }
    sky_.clear();
    for (const Seg& s : next) {
      if (!sky_.empty() && sky_.back().y == s.y) sky_.back().w += s.w;
      else sky_.push_back(s);
    }
    // Enclosed space under the rectangle: maximal rectangles over runs of covered segments.
    std::vector<Rect> pieces;
    constexpr size_t kMaxRun = 16;
    for (size_t a = 0; a < covered.size(); ++a) {
      int bottom = covered[a].y;
      for (size_t e = a; e < covered.size() && e < a + kMaxRun; ++e) {
        bottom = std::max(bottom, covered[e].y);
        if (bottom >= y) break;
        pieces.push_back({covered[a].x, bottom, covered[e].x + covered[e].w - covered[a].x, y - bottom});
      }
    }
    add_holes(pieces, min_side);
    return {x, y, w, h};
  }

  /// The horizon's height per column (texels), for the outline tail.
  std::vector<int> heights() const {
    std::vector<int> h(static_cast<size_t>(width_), 0);
    for (const Seg& s : sky_)
      for (int x = s.x; x < s.x + s.w; ++x) h[static_cast<size_t>(x)] = s.y;
    return h;
  }

 private:
  void add_holes(const std::vector<Rect>& pieces, int min_side) {
    for (const Rect& p : pieces) {
      if (p.w < min_side || p.h < min_side) continue;
      bool inside = false;
      for (const Rect& h : holes_)
        if (h.contains(p)) { inside = true; break; }
      if (inside) continue;
      holes_.erase(std::remove_if(holes_.begin(), holes_.end(), [&](const Rect& h) { return p.contains(h); }),
                   holes_.end());
      holes_.push_back(p);
    }
    // note: fragment-heavy atlases enclose thousands of tiny spaces; keeping the kMaxHoles largest
    // bounds the cost per chart (measured on the real tiles: efficiency unchanged on six, -0.6% on
    // t016_L19).
    if (holes_.size() > 2 * kMaxHoles) {
      std::nth_element(holes_.begin(), holes_.begin() + kMaxHoles, holes_.end(),
                       [](const Rect& a, const Rect& b) { return a.area() > b.area(); });
      holes_.resize(kMaxHoles);
    }
  }
  static constexpr size_t kMaxHoles = 256;

  int width_, height_;
  std::vector<Seg> sky_;    ///< the horizon h(u): consecutive segments covering [0, width)
  std::vector<Rect> holes_; ///< enclosed unused space, as possibly overlapping maximal rectangles
};

/// tail: charts from order[tail] on are small; after the enclosed spaces they are dropped by their
/// outline on the horizon (Tetris drop), with `profiles` per chart id.
PackResult pack_square_tetris(const PackInput& in, const CommonSettings& s, const std::vector<int>& order,
                              size_t tail, const std::vector<std::vector<packing::Profile>>& profiles,
                              int width, const StageContext& ctx) {
  PackResult r;
  r.placements.assign(in.charts.size(), Placement{});
  std::vector<PageState> pages;
  std::vector<packing::Horizon> horizons;  // the pages' horizons once the tail starts
  // Smallest short side among the charts still to come: holes narrower than that are dropped.
  std::vector<int> suffix_min(order.size() + 1, INT_MAX);
  for (size_t i = order.size(); i-- > 0;) {
    const PackChart& c = in.charts[static_cast<size_t>(order[i])];
    suffix_min[i] = std::min({suffix_min[i + 1], packing::padded_w(c, 0, s), packing::padded_h(c, 0, s),
                              packing::padded_w(c, 1, s), packing::padded_h(c, 1, s)});
  }
  const int lo = s.gutter / 2;
  for (size_t n = 0; n < order.size(); ++n) {
    if ((n & 1023) == 0) ctx.step("packers.square_tetris", static_cast<double>(n) / static_cast<double>(order.size()));
    const PackChart& c = in.charts[static_cast<size_t>(order[n])];
    const int min_side = suffix_min[n + 1];
    const int nq = s.allow_rotation ? 2 : 1;
    bool placed = false;
    for (size_t p = 0; p <= pages.size() && !placed; ++p) {
      const bool fresh = p == pages.size();
      if (fresh) pages.emplace_back(width, s.max_page_size);
      PageState& pg = pages[p];
      // 1. enclosed unused spaces first.
      long long best = -1;
      size_t best_hole = 0;
      int best_q = 0;
      for (int q = 0; q < nq; ++q) {
        size_t which = 0;
        const long long left =
            pg.best_hole(packing::padded_w(c, q, s), packing::padded_h(c, q, s), suffix_min[n], which);
        if (left >= 0 && (best < 0 || left < best)) {
          best = left;
          best_hole = which;
          best_q = q;
        }
      }
      Rect at{};
      if (best >= 0) {
        at = pg.place_in_hole(best_hole, packing::padded_w(c, best_q, s), packing::padded_h(c, best_q, s), min_side);
        ++r.hole_fills;
      } else if (n >= tail) {
        // 3. small charts: outline drop on the horizon.
        while (horizons.size() < pages.size()) horizons.emplace_back(pages[horizons.size()].heights());
        packing::Horizon& hz = horizons[p];
        const auto& profs = profiles[static_cast<size_t>(c.id)];
        packing::Drop d;
        for (size_t q = 0; q < profs.size(); ++q) {
          if (profs[q].duplicate) continue;
          const packing::Drop e = packing::best_drop(hz, s.max_page_size, profs[q]);
          if (e.found && (!d.found || e.cost < d.cost || (e.cost == d.cost && e.top < d.top))) {
            d = e;
            best_q = static_cast<int>(q);
          }
        }
        if (!d.found) {
          if (fresh) break;
          continue;
        }
        hz.place(profs[static_cast<size_t>(best_q)], d);
        ++r.outline_drops;
        at = Rect{d.x, d.y, 0, 0};
      } else {
        // 2. on the horizon, lowest new peak.
        bool found = false;
        int bx = 0, by = 0;
        long long bpeak = 0, bwaste = 0;
        for (int q = 0; q < nq; ++q) {
          int x = 0, y = 0;
          long long waste = 0;
          const int w = packing::padded_w(c, q, s), h = packing::padded_h(c, q, s);
          if (!pg.best_on_horizon(w, h, x, y, waste)) continue;
          const long long peak = y + h;
          if (!found || peak < bpeak || (peak == bpeak && waste < bwaste)) {
            found = true;
            bpeak = peak;
            bwaste = waste;
            bx = x;
            by = y;
            best_q = q;
          }
        }
        if (!found) {
          if (fresh) break;  // does not fit even an empty page: reported below
          continue;
        }
        at = pg.place_on_horizon(bx, by, packing::padded_w(c, best_q, s), packing::padded_h(c, best_q, s), min_side);
      }
      r.placements[static_cast<size_t>(c.id)] = Placement{static_cast<int>(p), at.x + lo, at.y + lo, best_q};
      placed = true;
    }
    if (!placed)
      throw StageError("packers.square_tetris: chart " + std::to_string(c.id) + " fits no page of width " +
                       std::to_string(width));
  }
  r.pages = static_cast<int>(pages.size());
  return r;
}

class SquareTetris : public Packer {
 public:
  static StageInfo info() {
    StageInfo i;
    i.name = "packers.square_tetris";
    i.kind = StageKind::Packer;
    i.description = "Square Tetris (Liu et al. 2024): minimum-area rectangles on a horizon, enclosed spaces filled first";
    i.doc = "docs/packers.md";
    i.options = packing::common_options(true, 5);
    i.options.push_back(opt_int("tail_side", 0,
                                "Charts whose padded box is smaller than tail_side^2 texels are packed last: into enclosed "
                                "spaces, else dropped by their outline on the horizon (0: rectangles only)")
                            .range(0, 4096)
                            .unit("texels"));
    i.create = [] { return std::make_unique<SquareTetris>(); };
    return i;
  }

  void pack(StageContext& ctx) override {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string name = "packers.square_tetris";
    const CommonSettings s = packing::read_common(options());
    const PackInput in = packing::prepare_charts(ctx, s, name);
    packing::check_chart_sizes(in, s, name);
    const std::vector<int> order = packing::order_by_area(in, s);
    const long long tail_side = options().get_int("tail_side");
    size_t tail = order.size();
    while (tail > 0) {
      const PackChart& c = in.charts[static_cast<size_t>(order[tail - 1])];
      if (static_cast<long long>(packing::padded_w(c, 0, s)) * packing::padded_h(c, 0, s) >= tail_side * tail_side) break;
      --tail;
    }
    std::vector<std::vector<packing::Profile>> profiles(in.charts.size());
    for (size_t n = tail; n < order.size(); ++n)
      profiles[static_cast<size_t>(order[n])] = packing::make_profiles(in.charts[static_cast<size_t>(order[n])], s);
    const PackResult r = packing::pack_best_width(
        in, s, [&](int width) { return pack_square_tetris(in, s, order, tail, profiles, width, ctx); });
    ctx.step(name, 1.0);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    packing::write_layout(ctx, in, r, ms);
    if (ctx.report) {
      (*ctx.report)["hole_fills"] = r.hole_fills;
      (*ctx.report)["outline_drops"] = r.outline_drops;
    }
  }
};

}  // namespace
}  // namespace texdefrag

TEXDEFRAG_PLUGIN(texdefrag::SquareTetris)
