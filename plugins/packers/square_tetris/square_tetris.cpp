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
// Outline tail (tail_side > 0): charts whose padded box is below tail_side^2 come last and are
// placed by their dilated outline at the lowest, then leftmost, free position anywhere on the page
// (bottom-left fill on a per-row run-length occupancy raster), which fills the enclosed spaces and
// the empty corners of the rectangles' boxes with outlines; the charts placed as rectangles occupy
// only their dilated outline there.
#include "texdefrag/packers/horizon.h"
#include "texdefrag/packers/packing.h"
#include "texdefrag/stage/registry.h"
#include "texdefrag/util/parallel.h"

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstring>
#include <random>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <tuple>

namespace texdefrag {
namespace {

using packing::CommonSettings;
using packing::PackChart;
using packing::PackInput;
using packing::PackResult;
using packing::Placement;

struct Seg { int x, w, y; };

/// Block grid of a placement (CommonSettings::block_grid): positions v with v = r modulo g; g <= 1
/// allows every position.
struct Grid {
  int g = 1, rx = 0, ry = 0;
  bool on() const { return g > 1; }
  /// Smallest v' >= v with v' = r (mod g).
  static int up(int v, int r, int g) { return g <= 1 ? v : v + (((r - v) % g) + g) % g; }
  /// Largest v' <= v with v' = r (mod g).
  static int down(int v, int r, int g) { return g <= 1 ? v : v - (((v - r) % g) + g) % g; }
  int up_x(int v) const { return up(v, rx, g); }
  int up_y(int v) const { return up(v, ry, g); }
  int down_x(int v) const { return down(v, rx, g); }
};
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
  /// With a block grid the rectangle goes to the hole's lowest-left grid position (hx, hy).
  long long best_hole(int w, int h, int min_side, size_t& which, const Grid& grid, int& hx, int& hy) {
    long long best = -1;
    int best_short = INT_MAX;
    for (size_t i = 0; i < holes_.size();) {
      const Rect& r = holes_[i];
      if (r.w < min_side || r.h < min_side) {  // can never be used again: drop
        holes_[i] = holes_.back();
        holes_.pop_back();
        continue;
      }
      const int x = grid.up_x(r.x), y = grid.up_y(r.y);
      if (x + w <= r.x + r.w && y + h <= r.y + r.h) {
        const long long left = r.area() - static_cast<long long>(w) * h;
        const int short_side = std::min(r.w - w, r.h - h);
        if (best < 0 || left < best || (left == best && short_side < best_short)) {
          best = left;
          best_short = short_side;
          which = i;
          hx = x;
          hy = y;
        }
      }
      ++i;
    }
    return best;
  }

  /// Best horizon position for a (w x h) rectangle: returns false when it does not fit the page.
  /// With a block grid, candidates move right (segment starts) or left (right-aligned ends) to the
  /// nearest grid column and the rectangle rests on the first grid row at or above the horizon.
  bool best_on_horizon(int w, int h, int& bx, int& by, long long& bwaste, const Grid& grid) const {
    bool found = false;
    long long best_peak = 0;
    for (size_t i = 0; i < sky_.size(); ++i) {
      for (int side = 0; side < 2; ++side) {
        int x = side == 0 ? sky_[i].x : sky_[i].x + sky_[i].w - w;
        if (grid.on()) x = side == 0 ? grid.up_x(x) : grid.down_x(x);
        if (x < 0 || x + w > width_) continue;
        if (side == 1 && x == (grid.on() ? grid.up_x(sky_[i].x) : sky_[i].x)) continue;
        // Both candidates cover segment i (off the block grid), so the rectangle rests at y >= sky_[i].y.
        if (!grid.on() && found && static_cast<long long>(sky_[i].y) + h > best_peak) continue;
        size_t j = std::min(i, sky_.size() - 1);
        while (j > 0 && sky_[j].x > x) --j;
        while (j + 1 < sky_.size() && sky_[j].x + sky_[j].w <= x) ++j;
        int y = 0;
        for (size_t k = j; k < sky_.size() && sky_[k].x < x + w; ++k) {
          y = std::max(y, sky_[k].y);
          if (found && static_cast<long long>(y) + h > best_peak) break;
        }
        y = grid.up_y(y);
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

  /// Places a rectangle at (x, y) inside a hole (best_hole's position: the hole's lower-left
  /// corner, or its lowest-left block grid position), splitting every hole it meets.
  Rect place_in_hole(int x, int y, int w, int h, int min_side) {
    const Rect r{x, y, w, h};
    placed_.push_back(r);
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
    placed_.push_back({x, y, w, h});
    return {x, y, w, h};
  }

  /// Padded boxes placed on this page.
  const std::vector<Rect>& placed() const { return placed_; }

  /// The horizon as one height per column (cells).
  std::vector<int> heights() const {
    std::vector<int> h(static_cast<size_t>(width_), 0);
    for (const Seg& g : sky_) std::fill(h.begin() + g.x, h.begin() + g.x + g.w, g.y);
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
  std::vector<Rect> placed_;
  std::vector<Rect> holes_; ///< enclosed unused space, as possibly overlapping maximal rectangles
};


/// The cells of a dilated outline mask: per row, runs [a, a + len) of covered cells (relative to
/// the padded box's lower-left corner), and what the search derives from them.
struct RunCells {
  std::vector<std::vector<std::pair<int, int>>> rows;  ///< (a, len) per row
  int wide_row = 0, wide_a = 0, wide_len = 0;  ///< the longest run (checked first)
  std::vector<std::pair<int, int>> longest;     ///< (row, its longest run), longest first
  std::vector<std::tuple<int, int, int>> checks;  ///< every run (row, a, len), in checking order
  int core_w = 0, core_h = 0, core_y = 0;  ///< a solid rectangle inside the mask: size, lowest row
  long long outline_cells = 0, cells = 0;  ///< cells of the outline before and after dilation
  int shortest = INT_MAX;  ///< the shortest run (INT_MAX: no cells)
};

/// The cells of an empty mask (a duplicate turn, or a turn a rectangle is never placed in).
const std::shared_ptr<const RunCells>& no_cells() {
  static const std::shared_ptr<const RunCells> none = std::make_shared<const RunCells>();
  return none;
}

/// Outline of a chart in one quarter turn, dilated by the gutter.
/// note: the cells are shared (the plans with and without block grid have the same cells, and
/// the block-grid trial's plan is made while the other's width trials still search theirs:
/// copying them cost 5-8% of the packer's CPU on the real tiles).
struct RunMask {
  int w = 0, h = 0;
  std::shared_ptr<const RunCells> runs = no_cells();  ///< never null
  bool duplicate = false;
  int shape = -1;  ///< masks with the same cells share a shape id (RasterPage's resume rows)
  Grid grid;  ///< block grid of the padded box's position (an exact chart with block_grid; else off)
};

/// raw0: the chart's raster in turn 0 when the caller has it (used for q = 0), else null.
RunMask make_run_mask(const PackChart& c, int q, const CommonSettings& s, const packing::Mask* raw0) {
  packing::Mask own;
  if (q != 0 || !raw0) own = c.raster(q);
  const packing::Mask& raw = q != 0 || !raw0 ? own : *raw0;
  const packing::Mask m = packing::dilate(raw, s.gutter / 2, s.gutter - s.gutter / 2);
  RunCells r;
  r.outline_cells = std::count(raw.cells.begin(), raw.cells.end(), 1);
  r.cells = std::count(m.cells.begin(), m.cells.end(), 1);
  r.rows.resize(static_cast<size_t>(m.height));
  // note: runs found with memchr (cells are 0 or 1): the cell-by-cell scan was a third of YCB
  // banana's packer CPU with the angle search (masks of ~3000^2 cells per candidate).
  for (int y = 0; y < m.height; ++y) {
    const uint8_t* row = m.cells.data() + static_cast<size_t>(y) * static_cast<size_t>(m.width);
    for (int x = 0; x < m.width;) {
      const void* one = std::memchr(row + x, 1, static_cast<size_t>(m.width - x));
      if (!one) break;
      x = static_cast<int>(static_cast<const uint8_t*>(one) - row);
      const void* zero = std::memchr(row + x, 0, static_cast<size_t>(m.width - x));
      const int e = zero ? static_cast<int>(static_cast<const uint8_t*>(zero) - row) : m.width;
      r.rows[static_cast<size_t>(y)].push_back({x, e - x});
      if (e - x > r.wide_len) { r.wide_row = y; r.wide_a = x; r.wide_len = e - x; }
      r.shortest = std::min(r.shortest, e - x);
      x = e;
    }
  }
  for (int y = 0; y < m.height; ++y) {
    int k = 0;
    for (const auto& run : r.rows[static_cast<size_t>(y)]) k = std::max(k, run.second);
    if (k > 0) r.longest.emplace_back(y, k);
  }
  std::stable_sort(r.longest.begin(), r.longest.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
  // Checking order of the runs: the widest row, the bottom and top rows, then rows spread by
  // bisection (neighbouring rows of an outline mostly fail together).
  std::vector<int> order;
  std::vector<uint8_t> seen(static_cast<size_t>(m.height), 0);
  auto add = [&](int y) {
    if (y >= 0 && y < m.height && !seen[static_cast<size_t>(y)]) { seen[static_cast<size_t>(y)] = 1; order.push_back(y); }
  };
  add(r.wide_row);
  add(0);
  add(m.height - 1);
  for (int step = m.height / 2; step >= 1; step /= 2)
    for (int y = step; y < m.height; y += step) add(y);
  for (int y = 0; y < m.height; ++y) add(y);
  for (int y : order)
    for (const auto& [a, len] : r.rows[static_cast<size_t>(y)]) r.checks.emplace_back(y, a, len);
  // Core: the longest run of one of the 4 longest rows, extended up and down over the rows that
  // contain it; the largest such rectangle.
  auto contains = [&](int y, int a, int len) {
    for (const auto& [b, l] : r.rows[static_cast<size_t>(y)])
      if (b <= a && a + len <= b + l) return true;
    return false;
  };
  for (size_t i = 0; i < std::min<size_t>(4, r.longest.size()); ++i) {
    const int y = r.longest[i].first;
    for (const auto& [a, len] : r.rows[static_cast<size_t>(y)]) {
      if (len != r.longest[i].second) continue;
      int y0 = y, y1 = y + 1;
      while (y0 > 0 && contains(y0 - 1, a, len)) --y0;
      while (y1 < m.height && contains(y1, a, len)) ++y1;
      if (static_cast<long long>(len) * (y1 - y0) > static_cast<long long>(r.core_w) * r.core_h) {
        r.core_w = len;
        r.core_h = y1 - y0;
        r.core_y = y0;
      }
      break;
    }
  }
  RunMask out;
  out.w = m.width;
  out.h = m.height;
  out.runs = std::make_shared<const RunCells>(std::move(r));
  return out;
}

/// A page's occupancy for the outline tail: per row, its free runs (sorted intervals), its longest
/// free run, and per block of rows the longest free run (to skip rows that cannot hold a mask's
/// widest row). Rows above the allocated ones are empty. Filling a run splits at most one interval.
/// Free runs shorter than `min_run` (the shortest run of any mask searched on this page) are not
/// kept: no mask run can lie in one, so every search gives the same answer without them.
/// note: with gutter g every dilated run is at least g + 1 cells long; on t016_L19 (best.json's
/// merged atlas, one page width) a third of the 55k free runs left were shorter than 5 cells, and
/// the 6.2M run checks of its searches stepped over 62M free runs. Also tried: the runs kept again
/// at lengths 4x and 16x the shortest, so long mask runs step over fewer short free runs (fewer
/// instructions, but 8-21% more CPU on bench_packers' 8192-wide pages: three copies of each row).
class RasterPage {
 public:
  // note: min_run is INT_MAX when no mask is searched (no tail): clamped, nothing is dropped then.
  RasterPage(int width, int height, int min_run)
      : width_(width), height_(height), min_run_(std::clamp(min_run, 1, width + 1)) {}
  int used() const { return used_; }

  void fill_rect(int x, int y, int w, int h) {
    for (int r = y; r < y + h; ++r) occupy(r, x, x + w);
    used_ = std::max(used_, y + h);
  }
  void fill_mask(const RunMask& m, int x, int y) {
    for (int r = 0; r < m.h; ++r)
      for (const auto& [a, len] : m.runs->rows[static_cast<size_t>(r)]) occupy(y + r, x + a, x + a + len);
    used_ = std::max(used_, y + m.h);
  }

  /// Where the best turn of a chart fits: the turn (index into the masks), its lowest-left corner.
  struct Fit {
    int q = -1, x = 0, y = 0;
  };
  /// The position among `masks` (one per quarter turn; duplicates skipped) with the lowest top,
  /// then the lowest index, then the lowest and leftmost corner; q = -1 when none fits the page.
  /// Same result as searching each mask bottom-up in turn and keeping the lowest top.
  /// note: the turns are searched side by side, always at the row of the one whose next candidate
  /// row has the lowest top, so no turn scans rows above the answer's top. Searched one after the
  /// other, turns that do not win took 81% of the row attempts (t016_L19, best.json, width 1632).
  /// note: cells only ever become occupied, so a mask never fits below a row where it (or a mask
  /// with the same cells) did not fit before: each search resumes there (resume_, per shape id).
  Fit lowest_fit(const std::vector<RunMask>& masks) {
    struct Cursor {
      const RunMask* m;
      int y;  ///< next candidate row (every lower row ruled out); y + m->h > height_: none left
      int killer;  ///< page row where its last test failed (-1: none yet)
    };
    std::array<Cursor, 4> cur{};
    size_t n = 0;
    for (const RunMask& m : masks)
      if (!m.duplicate && n < cur.size()) cur[n++] = Cursor{&m, start_row(m), -1};
    Fit f;
    for (;;) {
      size_t best = n;  // the live cursor with the lowest top, ties to the lower index
      for (size_t i = 0; i < n; ++i)
        if (cur[i].y + cur[i].m->h <= height_ &&
            (best == n || cur[i].y + cur[i].m->h < cur[best].y + cur[best].m->h))
          best = i;
      if (best == n) break;
      Cursor& c = cur[best];
      const int x = leftmost_at(*c.m, c.y, c.killer);
      if (x >= 0) {
        f.q = static_cast<int>(c.m - masks.data());
        f.x = x;
        f.y = c.y;
        break;
      }
      c.y = candidate_row(*c.m, c.m->grid.up_y(c.y + 1));
    }
    for (size_t i = 0; i < n; ++i)  // every row below a cursor was ruled out (the winner's: below its fit)
      if (cur[i].m->shape >= 0) resume_[static_cast<size_t>(cur[i].m->shape)] = cur[i].y;
    return f;
  }

 private:
  /// The first candidate row of mask m: from its resume row, the lowest where its core rectangle
  /// fits, then the first that passes the longest-run filter (candidate_row); beyond height_ - m.h
  /// when m cannot fit the page.
  int start_row(const RunMask& m) {
    const RunCells& k = *m.runs;
    if (m.w > width_ || k.wide_len == 0) return height_;
    int start = 0;
    if (m.shape >= 0) {
      if (resume_.size() <= static_cast<size_t>(m.shape)) resume_.resize(static_cast<size_t>(m.shape) + 1, 0);
      start = resume_[static_cast<size_t>(m.shape)];
    }
    // m fits at row y only if its core rectangle fits at row y + core_y.
    if (k.core_w > 0) {
      const int yc = lowest_rect(k.core_w, k.core_h, start + k.core_y, height_ - m.h + k.core_y);
      if (yc < 0) return std::max(start, height_ - m.h + 1);
      start = yc - k.core_y;
    }
    return candidate_row(m, m.grid.up_y(start));
  }
  /// The first grid row y' >= y (y on m's grid) where each of m's 4 longest rows finds a page row
  /// whose longest free run holds it (block maxima skip rows that cannot); may exceed height_ - m.h.
  int candidate_row(const RunMask& m, int y) const {
    const int rows = static_cast<int>(free_.size());
    constexpr size_t kFilterRows = 4;  // the rest is left to leftmost_at
    const std::vector<std::pair<int, int>>& longest = m.runs->longest;
    while (y + m.h <= height_) {
      int skip = -1;
      for (size_t i = 0; i < std::min(kFilterRows, longest.size()); ++i) {
        const auto& [r, k] = longest[i];
        if (y + r >= rows) continue;
        if (maxrun_[static_cast<size_t>(y + r)] < k) {
          skip = next_row(y + r, k) - r;
          break;
        }
      }
      if (skip < 0) return y;
      y = m.grid.up_y(skip);
    }
    return y;
  }

  struct Run {
    int a, b;  ///< free cells [a, b)
  };
  static constexpr int kBlock = 64;  ///< rows per block of the longest-run maxima

  /// Index of the first run of `row` that ends after cell v (b > v), or row.size().
  /// note: the branch-free binary search (conditional moves) was 19% of leftmost_at's samples as
  /// std::upper_bound, whose branches the processor cannot predict.
  /// note: the first run is looked at before searching: a row test's first check starts at offset
  /// 0, where the first free run almost always ends after v (lowest_fit, 1 thread: t016_L19 14.40G
  /// -> 13.92G instructions, t015_L18 2.11G -> 2.00G).
  static size_t first_ending_after(const std::vector<Run>& row, int v) {
    if (row.empty() || row.front().b > v) return 0;
    const Run* base = row.data();
    size_t n = row.size();
    while (n > 1) {
      const size_t half = n / 2;
      base = base[half - 1].b <= v ? base + half : base;
      n -= half;
    }
    return static_cast<size_t>(base - row.data()) + (base->b <= v ? 1 : 0);
  }

  /// Offsets x in [lo, hi) where cells [x + a, x + a + len) lie in one free run of `row`, as sorted
  /// disjoint intervals written to out (room for row.size() of them); returns their count.
  /// note: branch-free (every free run in the span is written, the count advances only when the
  /// run is long enough): on t016_L19 (best.json, one thread) the searches step over 402M free
  /// runs, 45% of them long enough, and that branch was unpredictable.
  static size_t allowed_offsets(const std::vector<Run>& row, int a, int len, int lo, int hi, Run* out) {
    size_t k = 0;
    const Run* end = row.data() + row.size();
    for (const Run* it = row.data() + first_ending_after(row, lo + a); it != end && it->a - a < hi; ++it) {
      const int l = std::max(it->a - a, lo), h = std::min(it->b - len - a + 1, hi);
      out[k] = Run{l, h};
      k += l < h ? 1 : 0;
    }
    return k;
  }
  /// Grows v to at least n entries (scratch buffers: contents beyond the counts kept are unused).
  static void fit(std::vector<Run>& v, size_t n) {
    if (v.size() < n) v.resize(std::max(n, 2 * v.size()));
  }
  /// Narrows the offset set cand_[0, nx) (sorted disjoint intervals, nx >= 1) to the offsets x where
  /// cells [x + a, x + a + len) of `row` are free; returns the new count (0: no offset left).
  size_t narrow(const std::vector<Run>& row, int a, int len, size_t nx) const {
    fit(scratch_, row.size());
    const size_t nt = allowed_offsets(row, a, len, cand_[0].a, cand_[nx - 1].b, scratch_.data());
    if (nx == 1 || nt == 0) {  // one interval: allowed_offsets clipped to it already
      std::swap(cand_, scratch_);
      return nt;
    }
    fit(merged_, nx + nt);
    const Run *X = cand_.data(), *T = scratch_.data();
    Run* out = merged_.data();
    size_t i = 0, j = 0, k = 0;
    while (i < nx && j < nt) {  // intersection of two sorted disjoint interval lists
      const int l = std::max(X[i].a, T[j].a), h = std::min(X[i].b, T[j].b);
      out[k] = Run{l, h};
      k += l < h ? 1 : 0;
      const bool x_first = X[i].b < T[j].b;
      i += x_first ? 1 : 0;
      j += x_first ? 0 : 1;
    }
    std::swap(cand_, merged_);
    return k;
  }

  /// Leftmost x where m fits with its lower-left corner at row y, or -1.
  /// killer: in, the page row whose check failed the mask's previous test (any value: none); out,
  /// the page row of the check that fails this test (unchanged when m fits).
  /// note: the set of offsets where every run of m lies in a free run, as sorted intervals,
  /// intersected run by run (in m.checks order: widest, bottom, top, then spread rows) until it is
  /// empty or every run was checked; each intersection touches only the free runs in its span.
  /// note: the runs on the previous test's failing page row go second: the rows tested one after
  /// the other mostly fail on the same obstacle (t016_L19: 35M run checks for 9.2M rows tested,
  /// the first check almost never empty, the core rectangle fitting at 94% of the failed rows).
  /// The set intersected is the same in any order, so the answer is too.
  int leftmost_at(const RunMask& m, int y, int& killer) const {
    fit(cand_, 1);
    cand_[0] = Run{0, width_ - m.w + 1};
    size_t nx = 1;
    auto check = [&](int r, int a, int len) {
      const size_t yr = static_cast<size_t>(y + r);
      if (yr >= free_.size()) return true;  // an empty row
      nx = narrow(free_[yr], a, len, nx);
      if (nx == 0) killer = y + r;
      return nx != 0;
    };
    const RunCells& k = *m.runs;
    const int first = std::get<0>(k.checks.front());
    const int hint = killer - y >= 0 && killer - y < m.h && killer - y != first ? killer - y : -1;
    if (!check(first, std::get<1>(k.checks.front()), std::get<2>(k.checks.front()))) return -1;
    if (hint >= 0)
      for (const auto& [a, len] : k.rows[static_cast<size_t>(hint)])
        if (!check(hint, a, len)) return -1;
    for (size_t i = 1; i < k.checks.size(); ++i) {
      const auto& [r, a, len] = k.checks[i];
      if (r != hint && !check(r, a, len)) return -1;
    }
    for (size_t i = 0; i < nx; ++i) {  // the leftmost offset on the block grid
      const int x = m.grid.up_x(cand_[i].a);
      if (x < cand_[i].b) return x;
    }
    return -1;
  }
  /// Lowest row y in [from, last] such that rows y .. y + h - 1 share a free interval of w cells
  /// (a free w x h rectangle at row y), or -1.
  /// note: rows are checked from the top of the rectangle down; when rows y + r .. y + h - 1 have
  /// no common free w-interval, no rectangle whose rows include them fits, so y jumps to y + r + 1.
  int lowest_rect(int w, int h, int from, int last) const {
    const int rows = static_cast<int>(free_.size());
    for (int y = std::max(0, from); y <= last;) {
      fit(cand_, 1);
      cand_[0] = Run{0, width_ - w + 1};
      size_t nx = 1;
      int fail = -1;
      for (int r = std::min(h, rows - y) - 1; r >= 0; --r) {
        const size_t yr = static_cast<size_t>(y + r);
        if (maxrun_[yr] < w || (nx = narrow(free_[yr], 0, w, nx)) == 0) {
          fail = r;
          break;
        }
      }
      if (fail < 0) return y;
      y += fail + 1;
    }
    return -1;
  }
  /// First row >= from whose longest free run is at least k (rows above the used ones are free).
  int next_row(int from, int k) const {
    const int rows = static_cast<int>(free_.size());
    int r = from;
    while (r < rows) {
      if (r % kBlock == 0 && blockmax_[static_cast<size_t>(r / kBlock)] < k) {
        r += kBlock;
        continue;
      }
      if (maxrun_[static_cast<size_t>(r)] >= k) return r;
      ++r;
    }
    return rows;
  }
  /// Marks cells [a, b) of row r occupied.
  void occupy(int r, int a, int b) {
    while (static_cast<int>(free_.size()) <= r) {
      free_.push_back({Run{0, width_}});
      maxrun_.push_back(width_);
      if (blockmax_.size() * kBlock < free_.size()) blockmax_.push_back(width_);
    }
    std::vector<Run>& row = free_[static_cast<size_t>(r)];
    auto it = std::upper_bound(row.begin(), row.end(), a, [](int v, const Run& f) { return v < f.b; });
    while (it != row.end() && it->a < b) {
      const Run f = *it;
      it = row.erase(it);
      if (f.b - b >= min_run_) it = row.insert(it, Run{b, f.b});
      if (a - f.a >= min_run_) it = std::next(row.insert(it, Run{f.a, a}));
      if (f.b > b) break;
    }
    int best = 0;
    for (const Run& f : row) best = std::max(best, f.b - f.a);
    maxrun_[static_cast<size_t>(r)] = best;
    const size_t blk = static_cast<size_t>(r / kBlock);
    const int r0 = static_cast<int>(blk) * kBlock, r1 = std::min(static_cast<int>(free_.size()), r0 + kBlock);
    int bm = 0;
    for (int i = r0; i < r1; ++i) bm = std::max(bm, maxrun_[static_cast<size_t>(i)]);
    blockmax_[blk] = bm;
  }
  int width_, height_, used_ = 0;
  int min_run_;                         ///< free runs shorter than this are dropped
  std::vector<std::vector<Run>> free_;  ///< per row: free runs of at least min_run_ cells, left to right
  std::vector<int> maxrun_;             ///< per row: longest free run
  std::vector<int> blockmax_;           ///< per block of kBlock rows: longest free run
  mutable std::vector<Run> cand_, scratch_, merged_;  ///< offset sets of narrow (sizes: capacity, not counts)
  std::vector<int> resume_;                  ///< per mask shape: lowest row where it may still fit
};

/// The block grid of chart c's padded box in turn q (off unless c is block-aligned).
Grid block_grid_of(const PackChart& c, int q, const CommonSettings& s) {
  Grid g;
  if (!c.block_aligned || s.block_grid <= 1) return g;
  g.g = s.block_grid;
  g.rx = c.bx[q] - s.gutter / 2;  // Placement = padded box + gutter / 2
  g.ry = c.by[q] - s.gutter / 2;
  return g;
}

/// One packing of the charts in `order` with pages of one width (a width trial): the pages' state
/// and each placement step of pack_square_tetris.
class TetrisTrial {
 public:
  TetrisTrial(const PackInput& in, const CommonSettings& s, const std::vector<int>& order, size_t tail,
              const std::vector<std::vector<RunMask>>& profiles, const std::vector<std::vector<packing::Profile>>& drops,
              int width)
      : in_(in), s_(s), order_(order), tail_(tail), profiles_(profiles), drops_(drops), width_(width) {
    // Smallest short side among the charts still to come: holes narrower than that are dropped.
    suffix_min_.assign(order.size() + 1, INT_MAX);
    for (size_t i = order.size(); i-- > 0;) {
      const PackChart& c = chart(i);
      suffix_min_[i] = std::min({suffix_min_[i + 1], packing::padded_w(c, 0, s), packing::padded_h(c, 0, s),
                                 packing::padded_w(c, 1, s), packing::padded_h(c, 1, s)});
    }
    // Shortest run of any tail mask: the rasters keep only free runs at least this long.
    // note: each mask's shortest run is kept with its cells (every run of the tail's masks was read
    // here per width trial: 14% of t078_L17's packer CPU with the angle search opened).
    for (size_t n = tail; n < order.size() && drops.empty(); ++n)
      for (const RunMask& m : profiles[static_cast<size_t>(order[n])]) min_run_ = std::min(min_run_, m.runs->shortest);
  }

  /// Makes run() take the first n charts of the order at `placed` (their placements, in order, on
  /// page 0, from a trial of the same charts with the same masks and page width) instead of
  /// searching: for an outline tail with no rectangles only (n = 0 otherwise).
  /// note: the raster's resume rows (RasterPage::lowest_fit) only ever skip rows, so searches after
  /// the replay give the same positions without the replayed charts' entries.
  void replay(const std::vector<Placement>& placed, size_t n) {
    replay_ = &placed;
    replay_n_ = tail_ == 0 && drops_.empty() ? std::min(n, placed.size()) : 0;
  }

  /// Places every chart (pages opened as needed); stops early, marked losing, when `bound` says the
  /// trial cannot win. areas: when given, gets page 0's area (TrialBound::area) after each chart
  /// placed, infinity once a second page is open.
  /// progress: the context to report progress to (the set's first trial only), or null.
  PackResult run(packing::TrialBound& bound, const StageContext* progress, std::vector<double>* areas) {
    bound.start();
    r_.placements.assign(in_.charts.size(), Placement{});
    for (size_t n = 0; n < order_.size(); ++n) {
      if (progress && bound.reports_progress() && (n & 1023) == 0)
        progress->step("packers.square_tetris", static_cast<double>(n) / static_cast<double>(order_.size()));
      const PackChart& c = chart(n);
      if (n < replay_n_)
        replay_outline(c, (*replay_)[n], bound);
      else
        packing::place_on_pages(pages_, [&] { return PageState(width_, s_.max_page_size); },
                                [&](size_t p) { return try_page(n, p, bound); }, "packers.square_tetris", c.id, width_);
      if (areas) areas->push_back(pages_.size() > 1 ? std::numeric_limits<double>::infinity() : bound.area(s_));
      // A better single-page width was already found: this width cannot beat it (pages only grow).
      if (bound.hopeless(pages_.size(), s_)) {
        packing::TrialBound::lose(r_, pages_.size());
        return std::move(r_);
      }
    }
    r_.pages = static_cast<int>(pages_.size());
    return std::move(r_);
  }

 private:
  const PackChart& chart(size_t n) const { return in_.charts[static_cast<size_t>(order_[n])]; }

  /// Places the n-th chart of the order on page p (an enclosed space, the horizon, or the tail's
  /// search); false, page unchanged, when it does not fit there.
  bool try_page(size_t n, size_t p, packing::TrialBound& bound) {
    const PackChart& c = chart(n);
    int q = 0;
    Rect at{};
    if (n < tail_ && place_in_hole(c, n, p, q, at)) ++r_.hole_fills;
    else if (n >= tail_ && !drops_.empty() && drop(c, p, q, at)) ++r_.outline_drops;
    else if (n >= tail_ && drops_.empty() && place_outline(c, p, q, at)) ++r_.outline_drops;
    else if (n >= tail_ || !place_on_horizon(c, n, p, q, at)) return false;
    if (n < tail_) {
      if (boxes_.size() <= p) boxes_.resize(p + 1);
      boxes_[p].emplace_back(c.id, q, at);
    }
    const int lo = s_.gutter / 2;
    r_.placements[static_cast<size_t>(c.id)] = Placement{static_cast<int>(p), at.x + lo, at.y + lo, q};
    bound.placed(c, r_.placements[static_cast<size_t>(c.id)], s_);
    return true;
  }

  /// 1. A rectangle into the best-fitting enclosed unused space of page p, if any.
  bool place_in_hole(const PackChart& c, size_t n, size_t p, int& best_q, Rect& at) {
    PageState& pg = pages_[p];
    long long best = -1;
    int hole_x = 0, hole_y = 0;
    for (int q = 0; q < (s_.allow_rotation ? 2 : 1); ++q) {
      size_t which = 0;
      int x = 0, y = 0;
      const long long left = pg.best_hole(packing::padded_w(c, q, s_), packing::padded_h(c, q, s_), suffix_min_[n],
                                          which, block_grid_of(c, q, s_), x, y);
      if (left >= 0 && (best < 0 || left < best)) {
        best = left;
        hole_x = x;
        hole_y = y;
        best_q = q;
      }
    }
    if (best < 0) return false;
    at = pg.place_in_hole(hole_x, hole_y, packing::padded_w(c, best_q, s_), packing::padded_h(c, best_q, s_),
                          suffix_min_[n + 1]);
    return true;
  }

  /// 2. A rectangle on the horizon of page p, lowest new peak (then least enclosed area).
  bool place_on_horizon(const PackChart& c, size_t n, size_t p, int& best_q, Rect& at) {
    PageState& pg = pages_[p];
    bool found = false;
    int bx = 0, by = 0;
    long long bpeak = 0, bwaste = 0;
    for (int q = 0; q < (s_.allow_rotation ? 2 : 1); ++q) {
      int x = 0, y = 0;
      long long waste = 0;
      const int w = packing::padded_w(c, q, s_), h = packing::padded_h(c, q, s_);
      if (!pg.best_on_horizon(w, h, x, y, waste, block_grid_of(c, q, s_))) continue;
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
    if (!found) return false;  // does not fit even an empty page: place_on_pages reports it
    at = pg.place_on_horizon(bx, by, packing::padded_w(c, best_q, s_), packing::padded_h(c, best_q, s_),
                             suffix_min_[n + 1]);
    return true;
  }

  /// 3. A tail chart by its outline at the lowest position anywhere on page p (holes included).
  bool place_outline(const PackChart& c, size_t p, int& best_q, Rect& at) {
    if (boxes_.size() < pages_.size()) boxes_.resize(pages_.size());
    while (rasters_.size() < pages_.size()) {
      rasters_.emplace_back(width_, s_.max_page_size, min_run_);
      // Charts placed as rectangles occupy their dilated outline only: the tail may use the
      // corners of their boxes.
      for (const auto& [id, q, b] : boxes_[rasters_.size() - 1]) {
        const auto& m = profiles_[static_cast<size_t>(id)];
        if (static_cast<size_t>(q) < m.size() && !m[static_cast<size_t>(q)].duplicate)
          rasters_.back().fill_mask(m[static_cast<size_t>(q)], b.x, b.y);
        else
          rasters_.back().fill_rect(b.x, b.y, b.w, b.h);
      }
    }
    RasterPage& rp = rasters_[p];
    const auto& profs = profiles_[static_cast<size_t>(c.id)];
    const RasterPage::Fit f = rp.lowest_fit(profs);
    if (f.q < 0) return false;
    best_q = f.q;
    rp.fill_mask(profs[static_cast<size_t>(best_q)], f.x, f.y);
    at = Rect{f.x, f.y, 0, 0};
    return true;
  }

  /// 3 (replayed). Tail chart c at placement p of page 0 (replay), without searching.
  void replay_outline(const PackChart& c, const Placement& p, packing::TrialBound& bound) {
    if (pages_.empty()) pages_.emplace_back(width_, s_.max_page_size);
    if (boxes_.empty()) boxes_.resize(1);
    if (rasters_.empty()) rasters_.emplace_back(width_, s_.max_page_size, min_run_);
    const int lo = s_.gutter / 2;
    rasters_[0].fill_mask(profiles_[static_cast<size_t>(c.id)][static_cast<size_t>(p.q)], p.x - lo, p.y - lo);
    r_.placements[static_cast<size_t>(c.id)] = p;
    ++r_.outline_drops;
    bound.placed(c, p, s_);
  }

  /// 3'. A chart of a tail too large for the outline search, dropped on the horizon of page p
  /// above the rectangles (packers.tetris's drop).
  bool drop(const PackChart& c, size_t p, int& best_q, Rect& at) {
    while (horizons_.size() < pages_.size()) horizons_.emplace_back(pages_[horizons_.size()].heights());
    const auto& profs = drops_[static_cast<size_t>(c.id)];
    packing::Drop d;
    for (size_t q = 0; q < profs.size(); ++q) {
      if (profs[q].duplicate) continue;
      const packing::Drop e = packing::best_drop(horizons_[p], s_.max_page_size, profs[q]);
      if (e.found && (!d.found || e.cost < d.cost || (e.cost == d.cost && e.top < d.top))) {
        d = e;
        best_q = static_cast<int>(q);
      }
    }
    if (!d.found) return false;
    horizons_[p].place(profs[static_cast<size_t>(best_q)], d);
    at = Rect{d.x, d.y, 0, 0};
    return true;
  }

  const PackInput& in_;
  const CommonSettings& s_;
  const std::vector<int>& order_;
  size_t tail_;
  const std::vector<std::vector<RunMask>>& profiles_;
  const std::vector<std::vector<packing::Profile>>& drops_;
  int width_;
  std::vector<int> suffix_min_;
  int min_run_ = INT_MAX;
  const std::vector<Placement>* replay_ = nullptr;  ///< placements of the first replay_n_ charts
  size_t replay_n_ = 0;
  PackResult r_;
  std::vector<PageState> pages_;
  std::vector<RasterPage> rasters_;          ///< the pages' occupancy once the tail starts
  std::vector<packing::Horizon> horizons_;   ///< the pages' horizons once a dropped tail starts
  std::vector<std::vector<std::tuple<int, int, Rect>>> boxes_;  ///< per page: chart, turn, padded box
};

/// tail: charts from order[tail] on are small; they are placed by their dilated outline at the lowest
/// free position of the page (RasterPage), with `profiles` (outline run masks per turn) per chart id,
/// or, when `drops` is not empty (a tail too large for that search), dropped on the horizon above
/// the rectangles as packers.tetris drops charts, with `drops` (column profiles per turn) per chart id.
/// progress: the context the set's first trial reports progress to, or null. areas: as for
/// TetrisTrial::run. replay, replayed: as for TetrisTrial::replay (null: none).
PackResult pack_square_tetris(const PackInput& in, const CommonSettings& s, const std::vector<int>& order,
                              size_t tail, const std::vector<std::vector<RunMask>>& profiles,
                              const std::vector<std::vector<packing::Profile>>& drops, int width,
                              packing::TrialBound& bound, const StageContext* progress,
                              std::vector<double>* areas = nullptr, const std::vector<Placement>* replay = nullptr,
                              size_t replayed = 0) {
  TetrisTrial t(in, s, order, tail, profiles, drops, width);
  if (replay) t.replay(*replay, replayed);
  return t.run(bound, progress, areas);
}

/// The width trials of a packing (every tail order and page width): page 0's area after each chart
/// they placed, so that the angle search's packings of the same charts with one chart turned can
/// skip the trials bound to stop (SquareTetris::bound_to_stop). Thread-safe: width trials run side
/// by side. note: a trial stopped as hopeless logs the charts it placed, which depend on when the
/// other trials ended; what is read from it (the first chart after which the area reaches a given
/// page) lies within them and does not.
struct TrialLog {
  std::mutex mutex;
  std::map<std::pair<std::string, int>, std::vector<double>> areas;  ///< (tail order, page width) -> areas
  std::map<std::string, std::vector<int>> orders;                    ///< tail order name -> the order packed
  /// (tail order, page width) -> the placements of the charts placed, in order (outline tails
  /// without rectangles: TetrisTrial::replay)
  std::map<std::pair<std::string, int>, std::vector<Placement>> placed;
  size_t skipped = 0;   ///< trials this packing skipped as bound to stop (angle search)
  size_t replayed = 0;  ///< charts its trials took from another packing's trial (TetrisTrial::replay)
};

class SquareTetris : public Packer {
 public:
  static StageInfo info() {
    StageInfo i;
    i.name = "packers.square_tetris";
    i.kind = StageKind::Packer;
    i.description = "Square Tetris (Liu et al. 2024): minimum-area rectangles on a horizon, enclosed spaces filled first";
    i.doc = "docs/packers.md";
    i.options = packing::common_options(true, 5);
    // note: default 512 from measurements (docs/packers.md): on the merged atlases of the 6 real
    // tiles and 5 synthetic buildings it beats tetris on all 11 (+8 to +20 points) and tail 0, the
    // paper read literally, by 15-27 points (configs/paper.json and its ablations keep tail 0).
    i.options.push_back(opt_int("tail_side", 512,
                                "Charts whose padded box is smaller than tail_side^2 texels are packed last by their outline, "
                                "at the lowest free position of the page, holes and box corners included (0: rectangles only, "
                                "the paper's packer)")
                            .range(0, 4096)
                            .unit("texels"));
    // note: default 0.75 from measurements (docs/packers.md, "Big irregular charts"): best.json's
    // merged atlases, YCB banana 0.287 -> 0.541, t078_L17 0.596 -> 0.610, the 5 other real tiles and
    // 8 hard synthetic buildings unchanged; 0 keeps every big chart a rectangle (before 2026-12-01).
    i.options.push_back(opt_double("rect_min_fill", 0.75,
                                   "A chart whose box is at least tail_side^2 is packed as a rectangle only when its "
                                   "rasterised outline fills at least this share of its box; otherwise it joins the "
                                   "outline tail (0: every big chart is a rectangle)")
                            .range(0, 1));
    // note: the outline search's cost grows about quadratically with the number of tail charts:
    // best.json's merged real tiles (up to ~900 charts) take 0.05-1.3 s, paper.json's t016_L19
    // (3016 charts) 17.6 s, unmerged 6-10k-fragment tiles 18-111 s (docs/packers.md); beyond this
    // count the tail is skipped and reported. 4000 (was 1500): a held-out hard synthetic building
    // merged by best.json (b0005, more than 1500 tail charts) packs at 0.529 instead of 0.341 in
    // 2.6 s CPU; unmerged tiles (5.9k+ fragments) still skip it.
    i.options.push_back(opt_int("tail_max_charts", 4000,
                                "Most charts the outline tail's bottom-left search may hold; with more, the tail is "
                                "dropped on the horizon above the rectangles instead, as packers.tetris drops charts "
                                "(reported as outline_tail_skipped; 0: no limit)")
                            .range(0, 100000000));
    // note: default 300 from measurements (docs/packers.md, "Tail orders"): on best.json's merged
    // atlases the other orders win 2-4% of page area where few charts make the page (t078_L15 162
    // charts, t078_L17 101) and little or nothing on the 477-765-chart tiles, for one more full
    // packing per order.
    i.options.push_back(opt_int("order_trials_max_charts", 300,
                                "With at most this many outline-tail charts, the tail is also packed in decreasing UV "
                                "area and in decreasing shorter side, and the smallest result is kept (0: only the "
                                "decreasing padded box area)")
                            .range(0, 100000000));
    i.options.push_back(opt_int("order_shuffles", 0,
                                "With at most order_trials_max_charts outline-tail charts, this many more tail orders are "
                                "packed: decreasing padded box area, each scaled by a fixed pseudo-random factor in "
                                "[e^-0.5, e^0.5]; the smallest result is kept (0: off)")
                            .range(0, 256));
    // note: default from measurements (docs/packers.md, "Free trial"): YCB banana, 6 partly exact
    // peels, 7.10 -> 5.57 MP; elsewhere freeing partly exact charts saves at most ~2% of page area
    // and costs sample PSNR (resampling), so smaller gains keep the exact packing.
    i.options.push_back(opt_double("free_trial_gain", 0.05,
                                   "With at most order_trials_max_charts charts, some exact but partly resampled, the "
                                   "charts are also packed with exact_fraction 1 (those charts free to rotate); that "
                                   "packing is kept when it needs fewer pages or at least this share less page area "
                                   "(1: off)")
                            .range(0, 1));
    for (OptionSpec& o : width_options()) i.options.push_back(std::move(o));
    // note: default from measurements (docs/packers.md, "Block grid"): Cedar Creek levels 2-3
    // (JPEG pages at the input's bytes) median loss against PNG pages 0.78 -> 0.72 dB with the
    // trial kept where it costs no page area; the aligned layout alone costs 0-4% of page area.
    i.options.push_back(opt_int("block_grid", 8,
                                "The charts are also packed with every exact chart placed so that its input page's "
                                "blocks of this size (JPEG's 8 x 8) land on the output page's blocks; that packing is "
                                "kept when it needs fewer pages or at most block_grid_max_cost more page area "
                                "(0 or 1: off; no trial unless page sides are whole blocks)")
                            .range(0, 64)
                            .unit("texels"));
    i.options.push_back(opt_double("block_grid_max_cost", 0.0,
                                   "Largest share of extra page area the block-grid packing may cost and still be kept")
                            .range(0, 1));
    for (OptionSpec& o : angle_options()) i.options.push_back(std::move(o));
    i.create = [] { return std::make_unique<SquareTetris>(); };
    return i;
  }

  /// The page-width options beyond width_trials (pack_orders' refinement, pack_wide).
  static std::vector<OptionSpec> width_options() {
    std::vector<OptionSpec> out;
    out.push_back(opt_int("wide_page_trials", 2,
                          "With an outline tail of at most width_refine_max_charts charts and width_trials > 1, pages "
                          "about 2^k times as wide as high (k = 1 .. wide_page_trials) are packed too, in every tail "
                          "order, after the other widths; a smaller result is kept and its width refined (0: off)")
                      .range(0, 6));
    out.push_back(opt_int("width_refine", 8,
                          "With an outline tail of at most width_refine_max_charts charts and width_trials > 1, the page widths 1 .. width_refine "
                          "page_multiple steps narrower and wider than the best width are packed too (best tail order), "
                          "keeping the smallest result (0: off)")
                      .range(0, 64));
    // note: default 300 (order_trials_max_charts' default, which was this limit before 2026-12-05);
    // configs/best.json sets 500: Cedar lod3_room4 (449 charts) 2.1299 -> 2.0275 MP for 50 ms,
    // t015_L18 (472) unchanged for +160 ms (docs/packers.md, "Refinement beyond the tail orders").
    out.push_back(opt_int("width_refine_max_charts", 300,
                          "Most outline-tail charts with which the width refinement and the wide-page trials run "
                          "(in the tail orders that order_trials_max_charts allows; 0: never)")
                      .range(0, 100000000));
    return out;
  }

  /// The angle search's options (search_angles).
  static std::vector<OptionSpec> angle_options() {
    std::vector<OptionSpec> out;
    // note: default from measurements (docs/packers.md, "Angle search"): the minimum-area angle of
    // a concave chart (YCB banana's V-shaped peel) is often not the angle that packs best; with at
    // most 16 charts a whole packing costs milliseconds to ~0.1 s.
    out.push_back(opt_int("angle_search_max_charts", 16,
                          "With at most this many charts, the angle of each freely rotated chart (least filled box "
                          "first) is searched: its minimum-area angle plus j * angle_step_degrees, each a whole "
                          "packing, keeping a strictly smaller result (in the free trial too; 0: off)")
                      .range(0, 1000));
    out.push_back(opt_double("angle_step_degrees", 7.5,
                             "Step of the angle search: a chart's angles are its minimum-area angle plus j * step for "
                             "j = 0 .. 90 / step - 1 (quarter turns are tried by every packing)")
                      .range(0.5, 45)
                      .unit("deg"));
    out.push_back(opt_int("angle_search_rounds", 1,
                          "Rounds of the angle search's coordinate descent over the charts (a round that changes no "
                          "angle ends it)")
                      .range(1, 8));
    // note: a packing's cost grows with its page area (rasterised outlines); YCB banana's whole
    // search is 66 packings of an 8-9.5 MP page, about 600 MP (3 s of CPU).
    out.push_back(opt_double("angle_search_max_work", 2000,
                             "Work cap of the angle search: a chart's candidates are packed only while the search's "
                             "candidate packings times the page area they try to beat stay within this many "
                             "megapixels (a cap on the search's time that does not depend on the machine)")
                      .range(0, 1e6)
                      .unit("MP"));
    // note: off by default. t078_L17 (86 charts, packing factor 0.681; every other model of the
    // 28-model set 0.72-0.87 but the banana, 0.34) reaches 2.422 MP (program 2.425) with it at 0.70
    // for 2.3 s of packer CPU instead of 0.3 (docs/packers.md, "Angle search").
    out.push_back(opt_double("angle_search_packing_below", 0,
                             "Also search the angles of every free chart, whatever the chart count, when the packing "
                             "without the search fills less than this share of its page with the charts' dilated "
                             "outlines (its packing factor; outline tails only), the search then capped by "
                             "angle_search_opened_max_work (0: off)")
                      .range(0, 1));
    out.push_back(opt_double("angle_search_box_share", 0,
                             "Also search the angles of the free charts whose box (at the minimum-area angle) is at least "
                             "this share of the page area without the search, whatever the chart count, the search then "
                             "capped by angle_search_opened_max_work (0: off)")
                      .range(0, 1));
    out.push_back(opt_double("angle_search_opened_max_work", 300,
                             "Work cap (as angle_search_max_work, when lower) of a search opened by "
                             "angle_search_packing_below")
                      .range(0, 1e6)
                      .unit("MP"));
    return out;
  }

  /// What every packing of the charts needs whatever the order of the tail: how many charts are
  /// rectangles, the outline masks (or drop profiles) per chart and the area the charts need as
  /// placed. None of it depends on the order within the tail (shape ids are labels only).
  struct PackPlan {
    size_t rects = 0;                                   ///< charts [0, rects) of the order are rectangles
    std::vector<std::vector<RunMask>> profiles;         ///< per chart: outline masks of its quarter turns
    std::vector<std::vector<packing::Profile>> drops;   ///< per chart: drop profiles (dropped tail only)
    double need = 0;  ///< texels^2 the charts need as placed: padded boxes or dilated outlines
    std::vector<int> split;  ///< the order by area, rectangles first (split_rectangles), before planning
    size_t split_rects = 0;  ///< rectangles at the front of `split`
  };

  /// Outline masks of chart c per quarter turn (empty for duplicate turns, and for turns 2 and 3 of
  /// a rectangle, which is placed in turns 0 and 1 only). from: when given, the chart's masks of
  /// a plan made without block grid (their cells are shared; the block grid changes no cell), else
  /// null.
  /// note: the block-grid trial takes the first packing's masks instead of rasterising every
  /// chart again (rasterising was 39% of the 100k factory's packing profile).
  static std::vector<RunMask> chart_masks(const PackChart& c, bool rectangle, const CommonSettings& s,
                                          const std::vector<RunMask>* from) {
    std::vector<RunMask> out;
    packing::Mask raw0;
    std::vector<uint8_t> dups;  // per turn: same cells as an earlier turn
    if (from) {
      for (const RunMask& m : *from) dups.push_back(m.duplicate ? 1 : 0);
    } else {
      raw0 = c.raster(0);
      for (const packing::Profile& p : packing::make_profiles(raw0, s)) dups.push_back(p.duplicate ? 1 : 0);
    }
    const size_t turns = rectangle ? std::min<size_t>(2, dups.size()) : dups.size();
    // note: on the block grid a turn with the same cells has other residues: not a duplicate.
    const bool gridded = block_grid_of(c, 0, s).on();
    for (size_t q = 0; q < dups.size(); ++q) {
      const bool dup = dups[q] && !gridded;
      if (dup || q >= turns) out.emplace_back();
      else if (from && !dups[q]) out.push_back((*from)[q]);
      else out.push_back(make_run_mask(c, static_cast<int>(q), s, from ? nullptr : &raw0));
      out.back().duplicate = dup;
      out.back().grid = block_grid_of(c, static_cast<int>(q), s);
      out.back().shape = -1;
    }
    return out;
  }

  /// Whether charts c and d have the same base points, triangles and boxes (so the same rasters).
  static bool same_geometry(const PackChart& c, const PackChart& d) {
    return c.base == d.base && c.tris == d.tris && std::equal(c.w, c.w + 4, d.w) && std::equal(c.h, c.h + 4, d.h) &&
           std::equal(c.ox, c.ox + 4, d.ox) && std::equal(c.oy, c.oy + 4, d.oy);
  }

  /// Per chart id: whether reuse's masks serve it in plan_packing (see there; none without reuse).
  static std::vector<uint8_t> mask_donors(const PackInput& in, const std::vector<int>& order, size_t rects,
                                          const PackPlan* reuse, const PackInput* reuse_in) {
    std::vector<uint8_t> out(in.charts.size(), 0);
    if (!reuse) return out;
    for (size_t n = 0; n < order.size(); ++n) {
      const size_t id = static_cast<size_t>(order[n]);
      out[id] = id < reuse->profiles.size() && !reuse->profiles[id].empty() ? 1 : 0;
    }
    if (!reuse_in) return out;
    // note: a plan without a dropped tail packs its split as it is: rectangles [0, rects) of it.
    std::vector<uint8_t> was_rect(in.charts.size(), 0);
    for (size_t n = 0; n < reuse->split.size() && n < reuse->rects; ++n) was_rect[static_cast<size_t>(reuse->split[n])] = 1;
    for (size_t n = 0; n < order.size(); ++n) {
      const size_t id = static_cast<size_t>(order[n]);
      const PackChart &c = in.charts[id], &d = reuse_in->charts[id];
      const bool same = same_geometry(c, d) && c.block_aligned == d.block_aligned;
      out[id] = out[id] && same && (n < rects) == (was_rect[id] != 0) ? 1 : 0;
    }
    return out;
  }

  /// The plan for `order` (rectangles [0, tail), then the tail). tail_skipped: the tail is dropped
  /// on the horizon instead of placed by the bottom-left search; its rectangle-like charts are then
  /// moved to the front of the tail in `order`. reuse: another plan whose masks serve (or null):
  /// with reuse_in null, a plan of the same charts split the same way (the block grid aside);
  /// with reuse_in (its charts), each chart with the same geometry there, placed the same way
  /// (rectangle or tail).
  PackPlan plan_packing(const PackInput& in, const CommonSettings& s, std::vector<int>& order, size_t tail,
                        bool tail_skipped, const PackPlan* reuse, const PackInput* reuse_in = nullptr) const {
    const double rect_min_fill = options().get_double("rect_min_fill");
    PackPlan t;
    t.rects = tail;
    size_t& rects = t.rects;
    // A dropped tail keeps its charts that fill their box (as rect_min_fill says) as rectangles:
    // they fill the enclosed spaces; the drop never reuses space under the horizon. note: the UV
    // area decides first (no raster for the many rectangle charts: bench_packers 10k 0.50 -> ms
    // CPU), the rasterised outline otherwise.
    if (tail_skipped && rect_min_fill > 0)
      rects = static_cast<size_t>(std::stable_partition(order.begin() + static_cast<long>(tail), order.end(), [&](int id) {
                const PackChart& c = in.charts[static_cast<size_t>(id)];
                const double box = static_cast<double>(c.box_area());
                if (c.uv_area >= rect_min_fill * box) return true;
                const packing::Mask m = c.raster(0);
                return static_cast<double>(std::count(m.cells.begin(), m.cells.end(), 1)) >= rect_min_fill * box;
              }) - order.begin());
    std::vector<std::vector<RunMask>>& profiles = t.profiles;
    profiles.assign(in.charts.size(), {});
    std::vector<std::vector<packing::Profile>>& drops = t.drops;
    drops.assign(tail_skipped ? in.charts.size() : 0, {});
    double& need = t.need;
    if (tail_skipped)  // side by side, one chart per item
      parallel_for(order.size() - rects, [&](size_t i) {
        const int id = order[rects + i];
        drops[static_cast<size_t>(id)] = packing::make_profiles(in.charts[static_cast<size_t>(id)], s);
      });
    for (size_t n = 0; n < order.size(); ++n) {
      const PackChart& c = in.charts[static_cast<size_t>(order[n])];
      if (n < rects) {
        need += static_cast<double>(packing::padded_w(c, 0, s)) * packing::padded_h(c, 0, s);
      } else if (tail_skipped) {
        const packing::Profile& pr = drops[static_cast<size_t>(order[n])][0];
        for (int x = 0; x < pr.w; ++x)
          if (pr.top[static_cast<size_t>(x)] > 0) need += pr.top[static_cast<size_t>(x)] - pr.bottom[static_cast<size_t>(x)];
      }
    }
    // Outline masks: the tail's, and the outlines that charts placed as rectangles occupy on the
    // tail's raster; none without a tail (rectangles only) or with a dropped tail.
    // note: built side by side, one chart per item (each writes its own slot); the chart's turn-0
    // raster serves its turn profiles and its turn-0 mask (it was rasterised twice: 1M factory,
    // rasterising was a third of the packer's CPU).
    // note: another plan's masks serve only when it is of the same charts, split the same way.
    if (reuse && !reuse_in && (reuse->rects != rects || reuse->profiles.size() != in.charts.size())) reuse = nullptr;
    const std::vector<uint8_t> donors = mask_donors(in, order, rects, reuse, reuse_in);
    if (rects < order.size() && !tail_skipped)
      parallel_for(order.size(), [&](size_t n) {
        const size_t id = static_cast<size_t>(order[n]);
        const std::vector<RunMask>* from = donors[id] ? &reuse->profiles[id] : nullptr;
        profiles[id] = chart_masks(in.charts[id], n < rects, s, from);
      });
    // Shape ids and the tail's need, in order (labels only: the same whatever the thread count).
    std::map<std::vector<int>, int> shapes;  // tail masks' cells -> shape id
    for (size_t n = rects; n < order.size() && !tail_skipped; ++n)
      for (RunMask& m : profiles[static_cast<size_t>(order[n])]) {
        if (&m == &profiles[static_cast<size_t>(order[n])][0]) need += static_cast<double>(m.runs->cells);
        if (m.duplicate) continue;
        // note: the block grid is part of the shape: the resume row holds for one grid only.
        std::vector<int> key{m.w, m.h, m.grid.g, m.grid.rx, m.grid.ry};
        for (const auto& row : m.runs->rows) {
          key.push_back(-1);
          for (const auto& [a, len] : row) { key.push_back(a); key.push_back(len); }
        }
        m.shape = shapes.emplace(std::move(key), static_cast<int>(shapes.size())).first->second;
      }
    return t;
  }

  /// The tail orders tried: decreasing padded box area (`order` as given), then, when the tail
  /// holds at most order_trials_max_charts charts and is not skipped, decreasing UV area and
  /// decreasing shorter padded side (ties keep the box-area order); identical orders once.
  std::vector<std::pair<std::string, std::vector<int>>> tail_orders(const PackInput& in, const CommonSettings& s,
                                                                    const std::vector<int>& order, size_t tail,
                                                                    bool tail_skipped) const {
    std::vector<std::pair<std::string, std::vector<int>>> out{{"box_area", order}};
    const long long max_charts = options().get_int("order_trials_max_charts");
    if (tail_skipped || max_charts <= 0 || order.size() - tail > static_cast<size_t>(max_charts)) return out;
    auto uv = [&](int id) { return in.charts[static_cast<size_t>(id)].uv_area; };
    auto side = [&](int id) {
      const PackChart& c = in.charts[static_cast<size_t>(id)];
      return static_cast<double>(std::min(packing::padded_w(c, 0, s), packing::padded_h(c, 0, s)));
    };
    const std::pair<const char*, std::function<double(int)>> keys[] = {{"uv_area", uv}, {"shorter_side", side}};
    for (const auto& entry : keys) {
      // note: a plain reference, not a structured binding: the lambda captures it (Clang 14 refuses
      // to capture structured bindings).
      const std::function<double(int)>& key = entry.second;
      std::vector<int> o = order;
      std::stable_sort(o.begin() + static_cast<long>(tail), o.end(), [&](int a, int b) { return key(a) > key(b); });
      if (std::none_of(out.begin(), out.end(), [&](const auto& e) { return e.second == o; })) out.emplace_back(entry.first, std::move(o));
    }
    // Shuffled orders: decreasing padded box area, each area scaled by a pseudo-random factor in
    // [e^-0.5, e^0.5] (std::mt19937 with a fixed seed and its raw output only, so the orders, and
    // the layouts, are the same with every standard library).
    // note: the bottom-left fill's result varies by 1-3% of page area between orders and page
    // widths without a pattern (docs/packers.md); where few charts make the page, more orders find
    // a smaller one, as the M-method's packer tries permutations of fewer than 50 charts.
    const long long shuffles = options().get_int("order_shuffles");
    std::mt19937 rng(20261202u);
    for (long long k = 0; k < shuffles; ++k) {
      std::vector<std::pair<double, int>> keyed;
      for (size_t n = tail; n < order.size(); ++n) {
        const PackChart& c = in.charts[static_cast<size_t>(order[n])];
        const double u = static_cast<double>(rng() >> 8) / 16777216.0;  // [0, 1), 24 bits
        const double box = static_cast<double>(packing::padded_w(c, 0, s)) * packing::padded_h(c, 0, s);
        keyed.emplace_back(box * std::exp(u - 0.5), order[n]);
      }
      std::stable_sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
      std::vector<int> o(order.begin(), order.begin() + static_cast<long>(tail));
      for (const auto& e : keyed) o.push_back(e.second);
      if (std::none_of(out.begin(), out.end(), [&](const auto& e) { return e.second == o; }))
        out.emplace_back("shuffled_" + std::to_string(k + 1), std::move(o));
    }
    return out;
  }

  /// Whether refine_widths may give widths (it gives none in the cases it names).
  bool refines(const CommonSettings& s, size_t tail_charts, bool tail_skipped) const {
    const long long steps = options().get_int("width_refine");
    const long long max_charts = options().get_int("width_refine_max_charts");
    return steps > 0 && !tail_skipped && tail_charts > 0 && !s.power_of_two && s.width_trials > 1 && max_charts > 0 &&
           tail_charts <= static_cast<size_t>(max_charts);
  }

  /// The widths of the refinement (option width_refine): 1 .. width_refine page_multiple steps
  /// narrower and wider than `best` (the best width of the trials), those not tried already
  /// (`tried`), within [min_page_width, max_page_size]; none without an outline tail (rectangles
  /// only: the paper's packer), when the tail is skipped or holds more than
  /// width_refine_max_charts charts, with one width trial, or with power-of-two pages.
  std::vector<int> refine_widths(const PackInput& in, const CommonSettings& s, const std::vector<int>& tried, int best,
                                 size_t tail_charts, bool tail_skipped) const {
    std::vector<int> out;
    if (!refines(s, tail_charts, tail_skipped)) return out;
    const long long steps = options().get_int("width_refine");
    const int lo = packing::min_page_width(in, s);
    for (long long k = 1; k <= steps; ++k)
      for (const long long sign : {-1LL, 1LL}) {
        const long long w = best + sign * k * s.page_multiple;
        if (w < lo || w > s.max_page_size) continue;
        const int wi = static_cast<int>(w);
        if (std::find(tried.begin(), tried.end(), wi) == tried.end() && std::find(out.begin(), out.end(), wi) == out.end())
          out.push_back(wi);
      }
    return out;
  }

  /// One complete packing of ctx.atlas with settings s (every tail order, page width and
  /// refinement), and what the report says about it.
  struct Packed {
    PackInput in;
    PackResult r;
    size_t tail_charts = 0, orders = 0, width_trials = 0;
    int width = 0;  ///< page width of the result
    bool tail_skipped = false, refined = false;
    bool wide = false;  ///< a wide-page trial was kept (pack_wide)
    std::string order;
    long long outline = 0, padded = 0;  ///< outline cells before and after dilation (tail masks)
    PackPlan plan;  ///< the plan packed (its masks serve the block-grid trial; cleared after it)
    std::vector<int> planned;  ///< the charts as planned: by area, rectangles first (tail_orders' base)
    size_t tail = 0;           ///< rectangles at the front of the split into rectangles and tail
    size_t turned = 0;         ///< charts the angle search turned off their minimum-area angle
    std::shared_ptr<TrialLog> log = std::make_shared<TrialLog>();  ///< its width trials that stopped
  };

  /// The block-grid trial (option block_grid): the first packing's charts with every exact chart on
  /// its input page's block grid, packed in the first packing's tail order and page width, kept when
  /// that needs fewer pages or at most block_grid_max_cost more page area. It is prepared before
  /// the first packing's last width trials and packed beside them, on the thread the first one to
  /// end leaves idle, for the leader of that moment (pack_widths' BesideJob); when the first
  /// packing ends with another order or width, it is packed again after it (same result as always
  /// packing it after the first packing).
  struct GridTrial {
    bool on = false;        ///< the option is on and page sides are whole blocks
    CommonSettings g;       ///< the settings with block_grid set
    double cost = 0;        ///< block_grid_max_cost
    bool prepared = false;  ///< t holds the charts and plan (some chart is exact)
    Packed t;               ///< the trial's charts and plan, then its packing
    bool packed = false;    ///< t is packed for the first packing's result below
    std::string order;      ///< that result's tail order, page width, pages and page area
    int width = 0, pages = 0;
    double area = 0;
  };

  /// Rectangles: charts whose padded box is at least tail_side^2 and whose outline fills at least
  /// rect_min_fill of their box; every other chart joins the outline tail. Moves the rectangles to
  /// the front of `order` (both groups keep the decreasing-area order) and returns their count.
  /// note: big irregular charts (a scan's peel-like charts, L-shaped merged facades) waste their
  /// box corners as rectangles (docs/packers.md).
  /// note: decided side by side, one chart per item (the big charts' rasters: 60 charts with 78% of
  /// the 1M factory's faces), then partitioned in order.
  /// reuse, reuse_in: another packing's plan and charts (or null): a chart with the same geometry
  /// there is split as it was (the angle search turns one chart per packing: the others' rasters
  /// were 20 ms of each of YCB banana's packings).
  size_t split_rectangles(const PackInput& in, const CommonSettings& s, std::vector<int>& order,
                          const PackPlan* reuse = nullptr, const PackInput* reuse_in = nullptr) const {
    const long long tail_side = options().get_int("tail_side");
    const double rect_min_fill = options().get_double("rect_min_fill");
    std::vector<int8_t> known(in.charts.size(), -1);  // per chart: its split in reuse (1: rectangle), -1: none
    for (size_t n = 0; reuse && reuse_in && n < reuse->split.size(); ++n) {
      const size_t id = static_cast<size_t>(reuse->split[n]);
      if (same_geometry(in.charts[id], reuse_in->charts[id])) known[id] = n < reuse->split_rects ? 1 : 0;
    }
    std::vector<uint8_t> rect_flag(in.charts.size(), 0);
    parallel_for(order.size(), [&](size_t n) {
      const PackChart& c = in.charts[static_cast<size_t>(order[n])];
      if (known[static_cast<size_t>(c.id)] >= 0) {
        rect_flag[static_cast<size_t>(c.id)] = static_cast<uint8_t>(known[static_cast<size_t>(c.id)]);
        return;
      }
      bool r = static_cast<long long>(packing::padded_w(c, 0, s)) * packing::padded_h(c, 0, s) >= tail_side * tail_side;
      if (r && rect_min_fill > 0 && tail_side > 0) {
        const packing::Mask m = c.raster(0);
        const double filled = static_cast<double>(std::count(m.cells.begin(), m.cells.end(), 1));
        r = filled >= rect_min_fill * static_cast<double>(m.cells.size());
      }
      rect_flag[static_cast<size_t>(order[n])] = r ? 1 : 0;
    });
    return static_cast<size_t>(
        std::stable_partition(order.begin(), order.end(), [&](int id) { return rect_flag[static_cast<size_t>(id)] != 0; }) -
        order.begin());
  }

  /// Prepares a packing with settings s: charts, split into rectangles and tail, plan. reuse: the
  /// plan of a packing without block grid whose split and masks this one takes (the block grid
  /// changes no size or cell), or null.
  /// reuse_in: when given, reuse's charts, of which only those with the same geometry take its
  /// masks (the free trial's: every chart but the partly exact ones); the split is made again.
  /// given: the charts already prepared (taken), or null to prepare them from ctx.atlas.
  Packed prepare_packing(const StageContext& ctx, const CommonSettings& s, const PackPlan* reuse,
                         const PackInput* reuse_in = nullptr, PackInput* given = nullptr) const {
    const std::string name = "packers.square_tetris";
    Packed out;
    out.in = given ? std::move(*given) : packing::prepare_charts(ctx, s, name);
    const PackInput& in = out.in;
    packing::check_chart_sizes(in, s, name);
    // note: another plan's split serves as it is (the big charts' rasters decide it: 78% of the 1M
    // factory's faces).
    const bool resplit = !reuse || reuse_in || reuse->split.empty();
    std::vector<int> order = resplit ? packing::order_by_area(in, s) : reuse->split;
    const size_t tail = resplit ? split_rectangles(in, s, order, reuse_in ? reuse : nullptr, reuse_in) : reuse->split_rects;
    const std::vector<int> split = order;
    const long long tail_max = options().get_int("tail_max_charts");
    out.tail_charts = order.size() - tail;
    out.tail_skipped = tail_max > 0 && out.tail_charts > static_cast<size_t>(tail_max);
    out.plan = plan_packing(in, s, order, tail, out.tail_skipped, reuse, reuse_in);
    out.plan.split = split;
    out.plan.split_rects = tail;
    out.planned = std::move(order);
    out.tail = tail;
    return out;
  }

  /// The smallest padded side (either turn) of the charts order[k..] of in: the enclosed spaces a
  /// width trial keeps while placing order[k - 1] depend on it (TetrisTrial's suffix minimum).
  static int smallest_side_from(const PackInput& in, const std::vector<int>& order, size_t k, const CommonSettings& s) {
    int out = INT_MAX;
    for (size_t n = k; n < order.size(); ++n) {
      const PackChart& c = in.charts[static_cast<size_t>(order[n])];
      out = std::min({out, packing::padded_w(c, 0, s), packing::padded_h(c, 0, s), packing::padded_w(c, 1, s),
                      packing::padded_h(c, 1, s)});
    }
    return out;
  }

  /// The first count of charts after which a logged trial's page 0 (its areas, TrialLog) needed at
  /// least `area` (or a second page); areas.size() + 1 when it never did.
  static size_t charts_to_reach(const std::vector<double>& areas, double area) {
    return static_cast<size_t>(std::find_if(areas.begin(), areas.end(), [&](double v) { return v >= area; }) - areas.begin()) + 1;
  }

  /// The number of charts after which p's width trial in tail order `name` (o) at `width` is bound
  /// to stop as hopeless against inc's result, or 0 when it is not known to be; p is inc's charts
  /// with chart `turned` turned, packed against inc's result (repack_turned). inc (one page) logged
  /// that trial; k is the first count of charts after which its page 0 needed at least inc's page
  /// area (or a second page); o starts with the same k charts, none of them the turned one, with as
  /// many rectangles and the same smallest side after them. p's trial places those k charts as inc's
  /// did (same masks and boxes, same enclosed spaces kept, same page width), so its page then needs
  /// as much, and it stops there at the latest (it must beat inc's page).
  static size_t bound_to_stop(const Packed& p, const std::string& name, const std::vector<int>& o, int width,
                              const Packed& inc, int turned, const CommonSettings& s) {
    if (inc.r.pages != 1 || p.plan.rects != inc.plan.rects) return 0;
    std::lock_guard<std::mutex> lock(inc.log->mutex);
    const auto log = inc.log->areas.find({name, width});
    const auto io = inc.log->orders.find(name);
    if (log == inc.log->areas.end() || io == inc.log->orders.end()) return 0;
    const std::vector<double>& a = log->second;
    const size_t k = charts_to_reach(a, inc.r.total_area());
    if (k > a.size() || k > o.size() || io->second.size() != o.size() ||
        !std::equal(o.begin(), o.begin() + static_cast<long>(k), io->second.begin()))
      return 0;
    if (std::find(o.begin(), o.begin() + static_cast<long>(k), turned) != o.begin() + static_cast<long>(k)) return 0;
    return smallest_side_from(p.in, o, k, s) == smallest_side_from(inc.in, io->second, k, s) ? k : 0;
  }

  /// Whether p's width trials log their placements (TetrisTrial::replay applies): an outline tail
  /// with no rectangles.
  static bool replays(const Packed& p) { return p.plan.rects == 0 && p.plan.drops.empty(); }

  /// The placements p's width trial in tail order `name` (o) at `width` may take from inc's trial of
  /// that order and width (TetrisTrial::replay), p being inc's charts with chart `turned` turned:
  /// inc's placements of the charts o starts with as inc's order did, up to the turned one, on page
  /// 0, and at most up to where inc's page needed inc's page area (logged whatever the thread
  /// count, so the count replayed is the same with any). Empty when none (no log, or not an
  /// outline tail without rectangles).
  static std::vector<Placement> replayable(const Packed& p, const std::string& name, const std::vector<int>& o,
                                           int width, const Packed& inc, int turned) {
    std::vector<Placement> out;
    if (!replays(p) || !replays(inc)) return out;
    std::lock_guard<std::mutex> lock(inc.log->mutex);
    const auto placed = inc.log->placed.find({name, width});
    const auto areas = inc.log->areas.find({name, width});
    const auto io = inc.log->orders.find(name);
    if (placed == inc.log->placed.end() || areas == inc.log->areas.end() || io == inc.log->orders.end() ||
        io->second.size() != o.size())
      return out;
    const size_t reach = charts_to_reach(areas->second, inc.r.total_area());
    for (size_t n = 0; n < placed->second.size() && n < o.size() && n < reach; ++n) {
      if (o[n] != io->second[n] || o[n] == turned || placed->second[n].page != 0) break;
      out.push_back(placed->second[n]);
    }
    return out;
  }

  /// Packs p's width trial in tail order `name` (o) at `width` (pack_square_tetris), taking the
  /// placements `replayed` (replayable) for its first charts; logs its areas and, when replays(p),
  /// its placements in p.log.
  static PackResult pack_logged(const Packed& p, const CommonSettings& s, const std::string& name, const std::vector<int>& o,
                                int width, packing::TrialBound& bound, const StageContext* progress,
                                const std::vector<Placement>& replayed) {
    std::vector<double> areas;
    PackResult r = pack_square_tetris(p.in, s, o, p.plan.rects, p.plan.profiles, p.plan.drops, width, bound, progress,
                                      &areas, &replayed, replayed.size());
    std::vector<Placement> placed;
    if (replays(p))
      for (size_t n = 0; n < areas.size(); ++n) placed.push_back(r.placements[static_cast<size_t>(o[n])]);
    std::lock_guard<std::mutex> lock(p.log->mutex);
    p.log->areas[{name, width}] = std::move(areas);
    if (replays(p)) p.log->placed[{name, width}] = std::move(placed);
    p.log->replayed += replayed.size();
    return r;
  }

  /// A lost result for p's width trial in tail order `name` at `width`, bound_to_stop after its
  /// first k charts: logged (counted in p.log->skipped) with inc's areas and placements of them.
  static PackResult skip_logged(const Packed& p, const std::string& name, int width, const Packed& inc, size_t k) {
    std::vector<double> areas;
    std::vector<Placement> placed;
    {
      std::lock_guard<std::mutex> lock(inc.log->mutex);
      const std::vector<double>& a = inc.log->areas.at({name, width});
      areas.assign(a.begin(), a.begin() + static_cast<long>(k));
      const auto pl = inc.log->placed.find({name, width});
      if (pl != inc.log->placed.end() && pl->second.size() >= k)
        placed.assign(pl->second.begin(), pl->second.begin() + static_cast<long>(k));
    }
    PackResult r;
    r.placements.assign(p.in.charts.size(), Placement{});
    packing::TrialBound::lose(r, 1);
    std::lock_guard<std::mutex> lock(p.log->mutex);
    ++p.log->skipped;
    p.log->areas[{name, width}] = std::move(areas);
    if (replays(p) && placed.size() == k) p.log->placed[{name, width}] = std::move(placed);
    return r;
  }

  /// A width trial of p's plan in tail order `name` (o) (pack_widths' pack_with_width), logged in
  /// p.log; progress: as for pack_square_tetris. inc, turned: when inc is given, p is inc's charts
  /// with chart `turned` turned, packed against inc's result: a trial bound_to_stop is not packed
  /// (skip_logged); the others take inc's placements of the charts before the turned one
  /// (replayable).
  static std::function<PackResult(int, packing::TrialBound&)> trial(const Packed& p, const CommonSettings& s,
                                                                    const std::string& name, const std::vector<int>& o,
                                                                    const StageContext* progress,
                                                                    const Packed* inc = nullptr, int turned = -1) {
    return [&p, &s, &name, &o, progress, inc, turned](int width, packing::TrialBound& bound) {
      if (!inc) return pack_logged(p, s, name, o, width, bound, progress, {});
      if (const size_t k = bound_to_stop(p, name, o, width, *inc, turned, s)) return skip_logged(p, name, width, *inc, k);
      return pack_logged(p, s, name, o, width, bound, progress, replayable(p, name, o, width, *inc, turned));
    };
  }

  /// p's outline cells before and after dilation (turn 0 of every chart's masks).
  static void count_outlines(Packed& p) {
    p.outline = p.padded = 0;
    for (const auto& m : p.plan.profiles)
      if (!m.empty()) {
        p.outline += m[0].runs->outline_cells;
        p.padded += m[0].runs->cells;
      }
  }

  /// Packs p (prepared) with every tail order and page width, then the refined widths: the fewest
  /// pages, then the least page area, then the earliest order and width win. Each tail order is a
  /// full packing over every page width (pack_widths). grid: a prepared block-grid trial, packed
  /// beside the last width trials (those of the refinement, or of the last order without one), or
  /// null. rival: a packing this one must beat (the angle search's best so far), or null: its width
  /// trials stop as soon as they cannot beat it, and when no tail order beats it the widths are
  /// not refined and p.r is marked losing (TrialBound::lose: more pages than the rival). With a
  /// rival nothing reports progress (the angle search packs its candidates side by side).
  /// note: once a width gives one page, later widths stop as soon as they cannot beat its area
  /// (same result as packing them fully; t016_L19: ~2x faster); later orders stop a width as soon
  /// as it cannot beat the best so far. Page widths come from the area the charts need as placed
  /// (padded boxes of the rectangles, dilated outlines of the tail) as well as from their boxes.
  void pack_orders(const StageContext& ctx, Packed& p, const CommonSettings& s, GridTrial* grid,
                   const PackResult* rival = nullptr, const Packed* inc = nullptr, int turned = -1) const {
    const PackInput& in = p.in;
    PackResult& r = p.r;
    const auto orders = tail_orders(in, s, p.planned, p.tail, p.tail_skipped);
    {
      std::lock_guard<std::mutex> lock(p.log->mutex);
      for (const auto& [name, o] : orders) p.log->orders[name] = o;
    }
    const std::vector<int> widths = packing::trial_widths(in, s, p.plan.need);
    const bool refining = refines(s, p.tail_charts, p.tail_skipped);
    int best_width = 0;
    const std::vector<int>* best_o = nullptr;
    // the grid trial for the leader of a set of widths `ws` of tail order `phase` (BesideJob)
    auto beside = [&](const std::string& phase, const std::vector<int>& ws) -> packing::BesideJob {
      if (!grid) return {};
      return [this, grid, &phase, &ws, &p, &best_width](int leader, const PackResult& first) {
        const bool incumbent = leader < 0;
        pack_grid_beside(*grid, incumbent ? p.order : phase, incumbent ? best_width : ws[static_cast<size_t>(leader)], first);
      };
    };
    for (size_t k = 0; k < orders.size(); ++k) {
      const auto& [name, o] = orders[k];
      const bool last = !refining && k + 1 == orders.size();
      int w = 0;
      const PackResult* incumbent = best_o ? &r : rival;
      PackResult t = packing::pack_widths(in, s, widths, trial(p, s, name, o, rival ? nullptr : &ctx, inc, turned), &w, incumbent, -1,
                                          last ? beside(name, widths) : packing::BesideJob{});
      if (!incumbent || packing::better_result(t, *incumbent))
        r = std::move(t), p.order = name, best_width = w, best_o = &o;
    }
    p.orders = orders.size();
    if (!best_o) {  // every order lost to the rival
      p.width_trials = widths.size() * orders.size();
      packing::TrialBound::lose(r, static_cast<size_t>(rival->pages));
      return;
    }
    const std::vector<int> extra = refine_widths(in, s, widths, best_width, p.tail_charts, p.tail_skipped);
    if (!extra.empty()) {
      int w = 0;
      PackResult t = packing::pack_widths(in, s, extra, trial(p, s, p.order, *best_o, rival ? nullptr : &ctx, inc, turned), &w, &r, -1,
                                          beside(p.order, extra));
      if (packing::better_result(t, r)) r = std::move(t), best_width = w, p.refined = true;
    }
    std::vector<int> tried = widths;
    tried.insert(tried.end(), extra.begin(), extra.end());
    const size_t wide = pack_wide(ctx, p, s, orders, best_width, best_o, tried, rival, inc, turned);
    p.width = best_width;
    p.width_trials = widths.size() * orders.size() + extra.size() + wide;
    count_outlines(p);
  }

  /// The wide-page trials (option wide_page_trials), after pack_orders' trials and refinement:
  /// p's charts packed in every tail order `orders` at wide_widths (those not in `tried`), against
  /// p.r; when one is smaller, p takes it (p.order, best_width, best_o, p.wide) and the widths
  /// around it are refined (refine_widths, not in `tried`). rival, inc, turned: as for pack_orders.
  /// Returns the width trials packed. Never a larger result than without them.
  /// note: the width trials are near-square pages (sqrt(need / e)); with few large charts the
  /// bottom-left fill of a wider page often ends lower (Cedar lod1_room8: 448 x 288 -> 736 x 160,
  /// 0.1290 -> 0.1178 MP; docs/packers.md, "Wide pages").
  size_t pack_wide(const StageContext& ctx, Packed& p, const CommonSettings& s,
                   const std::vector<std::pair<std::string, std::vector<int>>>& orders, int& best_width,
                   const std::vector<int>*& best_o, std::vector<int>& tried, const PackResult* rival, const Packed* inc,
                   int turned) const {
    const std::vector<int> wide = wide_widths(p.in, s, p.plan.need, tried, p.tail_charts, p.tail_skipped);
    if (wide.empty()) return 0;
    tried.insert(tried.end(), wide.begin(), wide.end());
    size_t trials = wide.size() * orders.size();
    bool won = false;
    for (const auto& [name, o] : orders) {
      int w = 0;
      PackResult t = packing::pack_widths(p.in, s, wide, trial(p, s, name, o, rival ? nullptr : &ctx, inc, turned), &w, &p.r);
      if (packing::better_result(t, p.r)) p.r = std::move(t), p.order = name, best_width = w, best_o = &o, won = true;
    }
    if (!won) return trials;
    p.wide = true;
    const std::vector<int> extra = refine_widths(p.in, s, tried, best_width, p.tail_charts, p.tail_skipped);
    if (extra.empty()) return trials;
    int w = 0;
    PackResult t = packing::pack_widths(p.in, s, extra, trial(p, s, p.order, *best_o, rival ? nullptr : &ctx, inc, turned), &w, &p.r);
    if (packing::better_result(t, p.r)) p.r = std::move(t), best_width = w, p.refined = true;
    return trials + extra.size();
  }

  /// The widths of the wide-page trials: for k = 1 .. wide_page_trials, sqrt(need x 2^k / e) for e
  /// in {0.85, 0.7} (pages about 2^k times as wide as high), rounded as the width trials are
  /// (initial_page_width), those not in `tried`; none without an outline tail, when the tail is
  /// skipped or holds more than width_refine_max_charts charts, with one width trial or with
  /// power-of-two pages.
  std::vector<int> wide_widths(const PackInput& in, const CommonSettings& s, double need, const std::vector<int>& tried,
                               size_t tail_charts, bool tail_skipped) const {
    std::vector<int> out;
    const long long max_charts = options().get_int("width_refine_max_charts");
    if (tail_skipped || tail_charts == 0 || s.power_of_two || s.width_trials <= 1 || max_charts <= 0 ||
        tail_charts > static_cast<size_t>(max_charts))
      return out;
    const int lo = packing::min_page_width(in, s);
    for (long long k = 1; k <= options().get_int("wide_page_trials"); ++k)
      for (const double e : {0.85, 0.7}) {
        const int w = packing::initial_page_width(std::ldexp(need, static_cast<int>(k)), lo, e, s);
        if (std::find(tried.begin(), tried.end(), w) == tried.end() && std::find(out.begin(), out.end(), w) == out.end())
          out.push_back(w);
      }
    return out;
  }

  /// One complete packing of ctx.atlas with settings s. grid: the block-grid trial (on), prepared
  /// here when some chart is exact and packed beside the last width trials, or null.
  /// donor, donor_in: another packing's plan and charts whose masks serve the charts of the same
  /// geometry (prepare_packing's reuse, reuse_in), or null.
  Packed pack_all(const StageContext& ctx, const CommonSettings& s, GridTrial* grid = nullptr,
                  const PackPlan* donor = nullptr, const PackInput* donor_in = nullptr) const {
    Packed out = prepare_packing(ctx, s, donor, donor_in);
    if (grid && std::any_of(out.in.charts.begin(), out.in.charts.end(),
                            [](const PackChart& c) { return c.exact && !c.faces.empty(); })) {
      grid->t = prepare_packing(ctx, grid->g, &out.plan);
      grid->prepared = true;
    }
    pack_orders(ctx, out, s, grid && grid->prepared ? grid : nullptr);
    return out;
  }

  /// Packs the prepared grid trial in tail order `order` (its first order when it has no such
  /// order) at page width `width` (or the narrowest the block grid's slack allows), against the
  /// first packing's result `first`: with one page, it stops once it needs a second page or more
  /// than block_grid_max_cost more area (it could not be kept; t016_L19: it placed all 757 charts,
  /// 0.48 s of one thread, never kept). progress: as for pack_square_tetris.
  void pack_grid(GridTrial& grid, const std::string& order, int width, const PackResult& first,
                 const StageContext* progress) const {
    grid.packed = false;
    Packed& p = grid.t;
    const auto orders = tail_orders(p.in, grid.g, p.planned, p.tail, p.tail_skipped);
    auto same = std::find_if(orders.begin(), orders.end(), [&](const auto& e) { return e.first == order; });
    if (same == orders.end()) same = orders.begin();
    const std::vector<int> widths{std::max(width, packing::min_page_width(p.in, grid.g))};
    const double bar = first.pages == 1 ? (1 + grid.cost) * first.total_area() : -1;
    int w = 0;
    p.r = packing::pack_widths(p.in, grid.g, widths, trial(p, grid.g, same->first, same->second, progress), &w, nullptr, bar);
    p.order = same->first;
    p.width = w;
    p.orders = 1;
    p.width_trials = 1;
    p.refined = false;
    count_outlines(p);
    grid.order = order;
    grid.width = width;
    grid.pages = first.pages;
    grid.area = first.total_area();
    grid.packed = true;
  }

  /// pack_grid beside the first packing's width trials (a BesideJob: any thread, no progress
  /// reports, no exception: a failure leaves the trial to be packed again after).
  void pack_grid_beside(GridTrial& grid, const std::string& order, int width, const PackResult& first) const noexcept {
    try {
      pack_grid(grid, order, width, first, nullptr);
    } catch (...) {
      grid.packed = false;
    }
  }

  /// The block-grid trial for `best` (the first packing): packed again unless it was packed
  /// beside for this very result, and kept (best = the trial, s = its settings) when it needs
  /// fewer pages or at most block_grid_max_cost more page area. trials: the page widths it packed
  /// (0 without a trial). Returns whether it was kept.
  bool keep_grid_trial(const StageContext& ctx, GridTrial& grid, Packed& best, CommonSettings& s, size_t& trials) const {
    trials = 0;
    if (!grid.prepared) return false;
    if (!grid.packed || grid.order != best.order || grid.width != best.width || grid.pages != best.r.pages ||
        grid.area != best.r.total_area())
      pack_grid(grid, best.order, best.width, best.r, &ctx);
    trials = grid.t.width_trials;
    const double bar = (1 + grid.cost) * best.r.total_area();
    const PackResult& t = grid.t.r;
    if (!(t.pages < best.r.pages || (t.pages == best.r.pages && t.total_area() <= bar))) return false;
    best = std::move(grid.t);
    s = grid.g;
    return true;
  }

  /// The block-grid trial's settings: on when block_grid > 1 and page sides are whole blocks
  /// (block_grid dividing page_multiple, or power-of-two pages, and max_page_size).
  GridTrial grid_trial(const CommonSettings& s) const {
    GridTrial t;
    const int grid = static_cast<int>(options().get_int("block_grid"));
    t.on = grid > 1 && (s.power_of_two || s.page_multiple % std::max(grid, 1) == 0) && s.max_page_size % std::max(grid, 1) == 0;
    t.g = s;
    t.g.block_grid = grid;
    t.cost = options().get_double("block_grid_max_cost");
    return t;
  }

  /// Whether a packing with every partly exact chart freed (exact_fraction 1) may differ: some
  /// chart is exact under s but not wholly grid-exact, and the atlas is small enough for trials.
  bool free_trial_applies(const Packed& p, const CommonSettings& s) const {
    const double gain = options().get_double("free_trial_gain");
    const long long max_charts = options().get_int("order_trials_max_charts");
    if (gain >= 1 || s.exact_fraction >= 1 || max_charts <= 0) return false;
    size_t charts = 0;
    bool partly = false;
    for (const PackChart& c : p.in.charts) {
      if (c.faces.empty()) continue;
      ++charts;
      partly = partly || (c.exact && c.exact_area < c.uv_area);
    }
    return partly && charts <= static_cast<size_t>(max_charts);
  }

  /// What the angle search did (report).
  struct AngleStats {
    size_t packings = 0;  ///< candidate packings over every search run
    double before = 0;    ///< texels^2 of page the packer gives without the search
    double work = 0;      ///< sum over candidate packings of the page area (MP) they tried to beat
    bool capped = false;  ///< a chart's candidates were skipped: angle_search_max_work reached
    size_t trials = 0;    ///< width trials of the candidate packings, packed or skipped
    size_t skipped = 0;   ///< of those, skipped as bound to stop (bound_to_stop)
    size_t replayed = 0;  ///< chart placements the candidates' trials replayed (TetrisTrial::replay)
    bool opened = false;  ///< a search ran beyond angle_search_max_charts (angle_search_packing_below)
    bool free_trial_skipped = false;  ///< the free trial's opened search was skipped (free_trial_and_search)
  };

  /// The charts the angle search turns in p (settings s): every free chart when the search is on
  /// (angle_search_max_charts > 0), free rotation is on and p has at most angle_search_max_charts
  /// charts, or more but fills less than angle_search_packing_below of its page with the charts'
  /// dilated outlines (then *opened = true); otherwise, with more charts, the free charts whose box
  /// is at least angle_search_box_share of p's page area (then *opened = true when there is one);
  /// else none. Exact charts keep quarter turns. Ordered by
  /// increasing fill of their box (UV area / box area at the minimum-area angle; ties: chart id).
  /// note: a chart that fills its box is near its best at the minimum-area angle; a concave one is
  /// where the angle matters, and the coordinate descent's first charts choose from the most
  /// angles. YCB banana: the V-shaped peel (fill 0.12-0.2) first 8.32 MP, decreasing box area (the
  /// W-shaped peel first, its angle then fixed for the V's search) 8.91 MP.
  std::vector<int> angle_search_charts(const Packed& p, const CommonSettings& s, bool* opened) const {
    const long long max_charts = options().get_int("angle_search_max_charts");
    const double below = options().get_double("angle_search_packing_below");
    std::vector<int> out;
    const auto charts = std::count_if(p.in.charts.begin(), p.in.charts.end(), [](const PackChart& c) { return !c.faces.empty(); });
    *opened = charts > max_charts && p.padded > 0 && static_cast<double>(p.padded) < below * p.r.total_area();
    // Beyond the count (and unless opened), the free charts whose box is at least `share` of the page.
    // note: on the Cedar rooms a few large free charts (walls and floors, 20-60% of the page each)
    // decide the page; their angles are what the search finds there (lod2_room12 0.1638 -> 0.1229
    // MP with 0.3); searching them alone costs less than every free chart (angle_search_packing_below
    // 0.7: lod3_room10 1.26 against 0.65 s, lod1_room8 0.75 against 0.12 s; docs/packers.md,
    // "Large charts' angles").
    const double share = options().get_double("angle_search_box_share");
    const double big = charts > max_charts && !*opened && share > 0 ? share * p.r.total_area() : 0;
    if (max_charts <= 0 || !s.free_rotation || (charts > max_charts && !*opened && big <= 0)) return out;
    for (const PackChart& c : p.in.charts)
      if (!c.faces.empty() && !c.exact && static_cast<double>(c.box_area()) >= big) out.push_back(c.id);
    if (big > 0 && !out.empty()) *opened = true;
    auto fill = [&](int id) {
      const PackChart& c = p.in.charts[static_cast<size_t>(id)];
      return c.uv_area / static_cast<double>(c.box_area());
    };
    std::stable_sort(out.begin(), out.end(), [&](int a, int b) { return fill(a) < fill(b); });
    return out;
  }

  /// p packed again (every tail order and page width, against p's result: pack_orders' rival) with
  /// free chart `id` turned to `angle` radians; the other charts take p's masks. A losing result
  /// (more pages than p's) when the turned chart fits no max_page_size page.
  Packed repack_turned(const StageContext& ctx, const Packed& p, const CommonSettings& s, int id, double angle) const {
    PackInput in = p.in;
    PackChart& c = in.charts[static_cast<size_t>(id)];
    packing::set_free_angle(c, *in.atlas, angle);
    if (!packing::fits_max_page(c, s)) {
      Packed lost;
      packing::TrialBound::lose(lost.r, static_cast<size_t>(p.r.pages));
      return lost;
    }
    Packed t = prepare_packing(ctx, s, &p.plan, &p.in, &in);
    pack_orders(ctx, t, s, nullptr, &p.r, &p, id);
    return t;
  }

  /// The angle search (options angle_search_*), coordinate descent: each chart of
  /// angle_search_charts in turn is tried at its minimum-area angle plus j * angle_step_degrees,
  /// j = 0 .. 90 / step - 1 (quarter turns are tried by every packing), each a whole packing
  /// (repack_turned) against p, and p takes the smallest (fewest pages, then least page area, then
  /// the earliest j) when it is strictly smaller than p: the result is never larger. A chart whose
  /// candidates would take st.work past angle_search_max_work (or angle_search_opened_max_work
  /// when lower and the search is opened: angle_search_charts) (candidates x p's page area, MP) is
  /// skipped (st.capped): the cap depends on the packings alone, not on time. A chart's
  /// candidates are packed side by side (one per item; each against the same p), so the result does
  /// not depend on the thread count. st.packings counts the candidates.
  /// note: the minimum-area angle of a concave chart is often not the one that packs best (YCB
  /// banana's V-shaped peel: docs/packers.md, "Angle search").
  void search_angles(const StageContext& ctx, Packed& p, const CommonSettings& s, AngleStats& st) const {
    bool opened = false;
    const std::vector<int> ids = angle_search_charts(p, s, &opened);
    if (ids.empty()) return;
    st.opened = st.opened || opened;
    const double step = options().get_double("angle_step_degrees");
    const int steps = std::max(1, static_cast<int>(std::floor(90.0 / step + 1e-9)));
    const long long rounds = options().get_int("angle_search_rounds");
    double max_work = options().get_double("angle_search_max_work");
    if (opened) max_work = std::min(max_work, options().get_double("angle_search_opened_max_work"));
    std::vector<double> start(p.in.charts.size(), 0.0);  // the minimum-area angles
    for (const PackChart& c : p.in.charts) start[static_cast<size_t>(c.id)] = c.angle;
    constexpr double kPi = 3.14159265358979323846;
    for (long long round = 0; round < rounds; ++round) {
      bool changed = false;
      for (const int id : ids) {
        std::vector<double> angles;
        for (int j = 0; j < steps; ++j) {
          const double a = start[static_cast<size_t>(id)] + j * step * kPi / 180;
          if (a != p.in.charts[static_cast<size_t>(id)].angle) angles.push_back(a);
        }
        const double work = static_cast<double>(angles.size()) * p.r.total_area() / 1e6;
        if (st.work + work > max_work) {
          st.capped = true;
          continue;
        }
        st.work += work;
        std::vector<Packed> cands(angles.size());
        std::vector<uint8_t> wins(angles.size(), 0);  // per candidate: smaller than p
        std::vector<std::array<size_t, 3>> trials(angles.size());  // per candidate: width trials, skipped, replayed
        parallel_for(angles.size(), [&](size_t k) {
          Packed t = repack_turned(ctx, p, s, id, angles[k]);
          trials[k] = {t.width_trials, t.log->skipped, t.log->replayed};
          wins[k] = packing::better_result(t.r, p.r) ? 1 : 0;
          if (wins[k]) cands[k] = std::move(t);  // memory: only the winners are kept
        });
        st.packings += angles.size();
        for (const auto& [n, skipped, replayed] : trials) st.trials += n, st.skipped += skipped, st.replayed += replayed;
        size_t best = angles.size();
        for (size_t k = 0; k < angles.size(); ++k)
          if (wins[k] && (best == angles.size() || packing::better_result(cands[k].r, cands[best].r))) best = k;
        if (best == angles.size()) continue;
        p = std::move(cands[best]);
        changed = true;
      }
      if (!changed) break;
    }
    p.turned = 0;
    for (const PackChart& c : p.in.charts) p.turned += c.angle != start[static_cast<size_t>(c.id)] ? 1 : 0;
  }

  /// Whether the free trial's packing t is kept against b: fewer pages, or at least
  /// free_trial_gain less page area.
  bool frees(const PackResult& t, const PackResult& b) const {
    const double gain = options().get_double("free_trial_gain");
    return t.pages < b.pages || (t.pages == b.pages && t.total_area() <= (1 - gain) * b.total_area());
  }

  /// The free trial (free_trial_applies): best's charts packed with every partly exact chart free
  /// to rotate (exact_fraction 1, resampled), built from best before any angle search; then the
  /// angles of both are searched (search_angles; best's alone when the trial does not apply). Kept
  /// (best = it) when it was kept unsearched (frees against best unsearched) and best's search did
  /// not end strictly smaller, or when frees says so after both searches: never larger than without
  /// the search. A search of the free trial that would be opened (beyond angle_search_max_charts:
  /// angle_search_charts) runs only when the trial starts with at most best's pages and page area
  /// before best's search (st.free_trial_skipped otherwise). st.before: the page area without any
  /// search. Returns whether it was kept.
  /// note: its other charts take best's masks (t078_L17: preparing the free trial, its masks
  /// rasterised again, was 0.07 of the packer's 0.35 s).
  bool free_trial_and_search(const StageContext& ctx, Packed& best, const CommonSettings& s, AngleStats& st) const {
    st.before = best.r.total_area();
    if (!free_trial_applies(best, s)) {
      search_angles(ctx, best, s, st);
      return false;
    }
    CommonSettings f = s;
    f.exact_fraction = 1;
    Packed t = pack_all(ctx, f, nullptr, &best.plan, &best.in);
    const bool kept_unsearched = frees(t.r, best.r);
    if (kept_unsearched) st.before = t.r.total_area();
    const int pages0 = best.r.pages;
    const double area0 = best.r.total_area();
    search_angles(ctx, best, s, st);
    // note: an opened search (beyond angle_search_max_charts) skips a free trial that starts larger
    // than the packing before its search: on the 64 models of docs/packers.md ("Large charts'
    // angles") none was kept, and its search was a third of the rooms' packer CPU.
    bool opened = false;
    angle_search_charts(t, f, &opened);
    if (!opened || t.r.pages < pages0 || (t.r.pages == pages0 && t.r.total_area() <= area0)) search_angles(ctx, t, f, st);
    else st.free_trial_skipped = true;
    const bool keep = kept_unsearched ? !packing::better_result(best.r, t.r) : frees(t.r, best.r);
    if (keep) best = std::move(t);
    return keep;
  }

  void pack(StageContext& ctx) override {
    const std::string name = "packers.square_tetris";
    CommonSettings s = packing::read_common(options());
    // Block grid trial (GridTrial): prepared and packed beside the first packing when it applies.
    GridTrial grid = grid_trial(s);
    Packed best = pack_all(ctx, s, grid.on ? &grid : nullptr);
    size_t grid_trials = 0;  // page widths the block-grid trial packed
    const bool grid_kept = keep_grid_trial(ctx, grid, best, s, grid_trials);
    grid = GridTrial{};
    // The free trial (every partly exact chart free to rotate, resampled), kept only when it saves
    // at least free_trial_gain of the page area (or a page), and the angle search of the free charts
    // of both, which keeps only smaller packings.
    // note: a free trial built on the searched charts could end larger than without the search
    // (t015_L19p6 with the search on its 55 charts: 0.2458 against 0.2396 MP), so it starts unsearched.
    AngleStats angles;
    const bool freed = free_trial_and_search(ctx, best, s, angles);
    best.plan = PackPlan{};  // memory: 1M faces
    ctx.step(name, 1.0);
    packing::write_layout(ctx, best.in, best.r);
    if (ctx.report) write_report(*ctx.report, best, freed, grid_kept, grid_trials, angles);
  }

  /// The stage's own report fields (write_layout writes the common ones).
  static void write_report(json& rep, const Packed& best, bool freed, bool grid_kept, size_t grid_trials,
                           const AngleStats& angles) {
    const PackResult& r = best.r;
    rep["angle_search_packings"] = angles.packings;
    rep["angle_search_work_megapixels"] = angles.work;
    rep["angle_search_capped"] = angles.capped;
    rep["angle_search_width_trials"] = angles.trials;
    rep["angle_search_width_trials_skipped"] = angles.skipped;
    rep["angle_search_placements_replayed"] = angles.replayed;
    rep["angle_search_opened"] = angles.opened;
    rep["angle_search_free_trial_skipped"] = angles.free_trial_skipped;
    rep["angle_search_charts_turned"] = best.turned;
    rep["angle_search_megapixels_before"] = angles.before / 1e6;
    rep["hole_fills"] = r.hole_fills;
    rep["outline_drops"] = r.outline_drops;
    rep["tail_charts"] = best.tail_charts;
    rep["outline_tail_skipped"] = best.tail_skipped;
    rep["tail_orders_tried"] = best.orders;
    rep["tail_order"] = best.order;
    rep["page_width_trials"] = best.width_trials;
    rep["page_width_refined"] = best.refined;
    rep["page_width_wide"] = best.wide;
    rep["free_trial_kept"] = freed;
    rep["block_grid_kept"] = grid_kept;
    rep["block_grid_width_trials"] = grid_trials;
    size_t aligned = 0;
    for (const PackChart& c : best.in.charts) aligned += c.block_aligned && !c.faces.empty() ? 1 : 0;
    rep["charts_block_aligned"] = aligned;
    if (best.outline > 0) {
      rep["outline_texels"] = best.outline;
      rep["padded_outline_texels"] = best.padded;
    }
  }
};

}  // namespace
}  // namespace texdefrag

TEXDEFRAG_PLUGIN(texdefrag::SquareTetris)
