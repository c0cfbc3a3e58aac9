// Column-profile horizon packing (Lévy et al. 2002, section 5; the M-method's packer): profiles,
// horizon, and the drop search. See horizon.h.
#include "texdefrag/packers/horizon.h"

#include <algorithm>
#include <climits>
#include <cstdint>
#include <limits>

namespace texdefrag::packing {

namespace {

/// Fills p.filled, p.bmax and p.bsum from p.bottom.
void summarise(Profile& p) {
  for (int b : p.bottom) {
    if (b == INT_MAX) continue;
    p.bmax = std::max(p.bmax, b);
    p.bsum += b;
    ++p.filled;
  }
}

}  // namespace

Profile make_profile(const PackChart& c, int q, const CommonSettings& s) {
  const Mask m = dilate(c.raster(q), s.gutter / 2, s.gutter - s.gutter / 2);
  Profile p;
  p.w = m.width;
  p.h = m.height;
  p.bottom.assign(static_cast<size_t>(m.width), INT_MAX);
  p.top.assign(static_cast<size_t>(m.width), 0);
  // note: row by row (the mask is row-major), rows ascending: the first hit is the bottom.
  for (int y = 0; y < m.height; ++y) {
    const uint8_t* row = m.cells.data() + static_cast<size_t>(y) * static_cast<size_t>(m.width);
    for (int x = 0; x < m.width; ++x)
      if (row[x]) {
        if (p.bottom[static_cast<size_t>(x)] == INT_MAX) p.bottom[static_cast<size_t>(x)] = y;
        p.top[static_cast<size_t>(x)] = y + 1;
      }
  }
  summarise(p);
  return p;
}

namespace {

// The drop search's passes over all column offsets are plain loops over int arrays written for the
// auto-vectoriser; on x86-64 Linux with GCC they are also compiled for AVX2 and picked at run time
// (ifunc), since SSE2 has no 32-bit integer max.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define TEXDEFRAG_SIMD_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define TEXDEFRAG_SIMD_CLONES
#endif

/// dst[x] = max(src[x], src[x + k]) for x in [0, count). src: count + k values.
TEXDEFRAG_SIMD_CLONES
void max_shift(const int* __restrict src, int k, int count, int* __restrict dst) {
  for (int x = 0; x < count; ++x) dst[x] = std::max(src[x], src[x + k]);
}

/// lb[x] = max(lb[x], col[x] - b) for x in [0, count).
inline void max_column(const int* __restrict col, int b, int count, int* __restrict lb) {
  for (int x = 0; x < count; ++x) lb[x] = std::max(lb[x], col[x] - b);
}

/// lb[x] = max(lb[x], H[x + c] - bottom[i]) for x in [0, count) and each of the `ncols` columns
/// c = cols[i]. H: count + max(c) values.
TEXDEFRAG_SIMD_CLONES
void max_columns(const int* __restrict H, const int* cols, const int* bottom, int ncols, int count,
                 int* __restrict lb) {
  // note: in chunks that stay in L1 across the columns.
  constexpr int kChunk = 1024;
  for (int x0 = 0; x0 < count; x0 += kChunk) {
    const int x1 = std::min(count, x0 + kChunk);
    for (int i = 0; i < ncols; ++i) max_column(H + cols[i] + x0, bottom[i], x1 - x0, lb + x0);
  }
}

/// Lower bound of the drop cost at every offset from the height bound lb (see best_drop);
/// offsets whose bound top exceeds Hmax get the largest C. Returns the smallest bound.
/// C: int when every term stays below 2^30 (pages up to 16384^2), else long long.
template <class C>
inline C cost_bounds_t(const int* __restrict lb, const int* __restrict pre, int count, int w, C filled, C bsum,
                       int h, int used, C W, int Hmax, C* __restrict cl) {
  constexpr C kNone = std::numeric_limits<C>::max();
  const int lim = Hmax - h;  // highest drop height that fits
  // note: two loops; GCC does not vectorise the select and the min reduction in one.
  for (int x = 0; x < count; ++x) {
    const int l = lb[x];
    const C add = static_cast<C>(std::max(0, l + h - used));
    const C window = static_cast<C>(pre[x + w]) - static_cast<C>(pre[x]);
    const C c = filled * static_cast<C>(l) + bsum - window + add * W;
    cl[x] = l > lim ? kNone : c;
  }
  C best = kNone;
  for (int x = 0; x < count; ++x) best = std::min(best, cl[x]);
  return best;
}
TEXDEFRAG_SIMD_CLONES
int cost_bounds(const int* __restrict lb, const int* __restrict pre, int count, int w, int filled, int bsum,
                int h, int used, int W, int Hmax, int* __restrict cl) {
  return cost_bounds_t<int>(lb, pre, count, w, filled, bsum, h, used, W, Hmax, cl);
}
long long cost_bounds(const int* __restrict lb, const int* __restrict pre, int count, int w, long long filled,
                      long long bsum, int h, int used, long long W, int Hmax, long long* __restrict cl) {
  return cost_bounds_t<long long>(lb, pre, count, w, filled, bsum, h, used, W, Hmax, cl);
}

/// Smallest lb[x] among the offsets whose cost bound is `cost`.
template <class C>
inline int lowest_at_cost_t(const int* __restrict lb, const C* __restrict cl, int count, C cost) {
  // note: lb < 2^30; offsets at another cost are pushed above it without a select (vectorises).
  int best = INT_MAX;
  for (int x = 0; x < count; ++x) best = std::min(best, lb[x] + (static_cast<int>(cl[x] != cost) << 30));
  return best;
}
TEXDEFRAG_SIMD_CLONES
int lowest_at_cost(const int* __restrict lb, const int* __restrict cl, int count, int cost) {
  return lowest_at_cost_t<int>(lb, cl, count, cost);
}
int lowest_at_cost(const int* __restrict lb, const long long* __restrict cl, int count, long long cost) {
  return lowest_at_cost_t<long long>(lb, cl, count, cost);
}

/// Whether some cl[x], x in [0, count), is at most `cost`.
template <class C>
inline bool any_at_most(const C* __restrict cl, int count, long long cost) {
  int hits = 0;
  const C c = static_cast<C>(std::min<long long>(cost, std::numeric_limits<C>::max()));
  for (int x = 0; x < count; ++x) hits += cl[x] <= c;
  return hits > 0;
}

/// The cost-bound stage of best_drop with cost type C (see cost_bounds): fills `clv`, finds the
/// offset with the least (bound, height bound, x), evaluates it, and, unless the bound is exact,
/// every offset whose bound can still win. consider(x) evaluates offset x exactly into `best`.
template <class C, class Consider>
void search_offsets(const int* lb, const int* pre, int n, const Profile& p, int used, int W, int Hmax,
                    bool exact, std::vector<C>& clv, const Drop& best, Consider&& consider) {
  clv.resize(static_cast<size_t>(n));
  C* cl = clv.data();
  const C least = cost_bounds(lb, pre, n, p.w, static_cast<C>(p.filled), static_cast<C>(p.bsum), p.h, used,
                              static_cast<C>(W), Hmax, cl);
  if (least == std::numeric_limits<C>::max()) return;
  const int low = lowest_at_cost(lb, cl, n, least);
  int first = 0;
  while (cl[first] != least || lb[first] != low) ++first;
  consider(first);
  if (exact) return;
  constexpr int kBlock = 32;
  for (int x0 = 0; x0 < n; x0 += kBlock) {
    const int x1 = std::min(n, x0 + kBlock);
    if (!any_at_most(cl + x0, x1 - x0, best.cost)) continue;
    for (int x = x0; x < x1; ++x) {
      // skip offsets that cannot win even at the lowest possible height
      if (cl[x] > best.cost || x == first) continue;
      const int tlb = lb[x] + p.h;
      if (cl[x] == best.cost && (tlb > best.top || (tlb == best.top && x > best.x))) continue;
      consider(x);
    }
  }
}

}  // namespace

/// Best drop of profile p on horizon `hz` (height limit Hmax).
/// Cost = area wasted between the horizon and the chart's bottom profile + page area added above
/// the current used height (rows the chart adds times the page width). Ties: lower top, then left.
/// note: for profiles without empty columns, the drop height at offset x is y(x) = max over the
/// columns c of H[x + c] - bottom[c], and the cost is a function of y(x) and the window sum of H
/// (prefix sums). A lower bound of y(x) at every offset comes from vectorised passes: every column
/// for narrow profiles (then it is exact), otherwise the window maximum of H (log2(w) doubling
/// passes) minus the highest bottom, sharpened by a few columns. The offset with the least bound
/// (cost, then top, then x) is evaluated first; with an exact bound it is the answer, otherwise
/// only offsets whose bound can still win are evaluated (blocks without one are skipped).
Drop best_drop(Horizon& hz, int Hmax, const Profile& p) {
  Drop best;
  const std::vector<int>& H = hz.H;
  const int W = static_cast<int>(H.size());
  if (p.w > W || p.h > Hmax || p.filled == 0) return best;
  const bool solid = p.filled == p.w;
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
      waste = static_cast<long long>(p.filled) * y + p.bsum -
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
  if (!solid) {  // outlines with empty columns (rare): every offset
    for (int x = 0; x < n; ++x) consider(x);
    return best;
  }
  const int w = p.w;
  const int* Hp = H.data();
  int* lb = hz.lb.data();
  int bmin = INT_MAX, deep = 0;
  for (int c = 0; c < w; ++c)
    if (p.bottom[static_cast<size_t>(c)] < bmin) { bmin = p.bottom[static_cast<size_t>(c)]; deep = c; }
  const bool flat = bmin == p.bmax;  // flat bottom: y = window maximum of H - bottom, exactly
  constexpr int kAllColumns = 16;    // narrower uneven profiles: every column, exact bound
  const bool all_columns = !flat && w <= kAllColumns;
  const bool exact = all_columns || flat;
  std::fill(lb, lb + n, 0);
  std::vector<int>& cols = hz.cols;
  std::vector<int>& bots = hz.col_bottoms;
  cols.clear();
  bots.clear();
  if (all_columns) {
    for (int c = 0; c < w; ++c) cols.push_back(c);
  } else {
    // Window maximum of H over [x, x + w): two overlapping power-of-two windows of the horizon's
    // kept window maxima (Horizon::window_max).
    int k = 0;
    while (2 << k <= w) ++k;
    int* dst = hz.wmax.data();
    max_shift(hz.window_max(k), w - (1 << k), n, dst);
    const int zero = 0;
    max_columns(dst, &zero, &p.bmax, 1, n, lb);
    if (!exact)
      for (int c : {0, w - 1, deep, w / 8, w / 4, 3 * w / 8, w / 2, 5 * w / 8, 3 * w / 4, 7 * w / 8}) cols.push_back(c);
  }
  for (int c : cols) bots.push_back(p.bottom[static_cast<size_t>(c)]);
  max_columns(Hp, cols.data(), bots.data(), static_cast<int>(cols.size()), n, lb);
  // note: int costs (vectorised) while every term stays below 2^30, i.e. pages up to 16384^2.
  if (static_cast<long long>(W) * Hmax <= (1LL << 28))
    search_offsets<int>(lb, hz.prefix.data(), n, p, hz.used, W, Hmax, exact, hz.cost_lb32, best, consider);
  else
    search_offsets<long long>(lb, hz.prefix.data(), n, p, hz.used, W, Hmax, exact, hz.cost_lb, best, consider);
  return best;
}

namespace {

/// Column profile of a (w x h) outline turned by `q` quarter turns (counter-clockwise) from the
/// row and column extents of its unturned raster, then dilated by the gutter in profile space.
/// cb/ct: bottom and top + 1 per column of the unturned raster (INT_MAX / 0 when empty);
/// rl/rr: leftmost and rightmost + 1 per row (INT_MAX / 0 when empty).
Profile turned_profile(const std::vector<int>& cb, const std::vector<int>& ct, const std::vector<int>& rl,
                       const std::vector<int>& rr, int q, const CommonSettings& s) {
  const int w0 = static_cast<int>(cb.size()), h0 = static_cast<int>(rl.size());
  const int w = q % 2 == 0 ? w0 : h0, h = q % 2 == 0 ? h0 : w0;
  std::vector<int> bottom(static_cast<size_t>(w), INT_MAX), top(static_cast<size_t>(w), 0);
  // note: a quarter turn maps the cell grid onto itself: cell (i, j) of the unturned box goes to
  // (h0 - 1 - j, i) (q = 1), (w0 - 1 - i, h0 - 1 - j) (q = 2) or (j, w0 - 1 - i) (q = 3).
  for (int x = 0; x < w; ++x) {
    int lo = INT_MAX, hi = 0;
    if (q == 0) { lo = cb[static_cast<size_t>(x)]; hi = ct[static_cast<size_t>(x)]; }
    if (q == 1) { lo = rl[static_cast<size_t>(h0 - 1 - x)]; hi = rr[static_cast<size_t>(h0 - 1 - x)]; }
    if (q == 2 && ct[static_cast<size_t>(w0 - 1 - x)] > 0) {
      lo = h0 - ct[static_cast<size_t>(w0 - 1 - x)];
      hi = h0 - cb[static_cast<size_t>(w0 - 1 - x)];
    }
    if (q == 3 && rr[static_cast<size_t>(x)] > 0) {
      lo = w0 - rr[static_cast<size_t>(x)];
      hi = w0 - rl[static_cast<size_t>(x)];
    }
    if (hi > 0) { bottom[static_cast<size_t>(x)] = lo; top[static_cast<size_t>(x)] = hi; }
  }
  // Box dilation (geometry.h: dilate) of the column extents: result column x covers the union of
  // columns x - r .. x, grown by r at the top.
  const int r = s.gutter;
  Profile p;
  p.w = w + r;
  p.h = h + r;
  p.bottom.assign(static_cast<size_t>(p.w), INT_MAX);
  p.top.assign(static_cast<size_t>(p.w), 0);
  for (int x = 0; x < w; ++x) {
    if (top[static_cast<size_t>(x)] == 0) continue;
    for (int d = 0; d <= r; ++d) {
      const size_t o = static_cast<size_t>(x + d);
      p.bottom[o] = std::min(p.bottom[o], bottom[static_cast<size_t>(x)]);
      p.top[o] = std::max(p.top[o], top[static_cast<size_t>(x)] + r);
    }
  }
  summarise(p);
  return p;
}

}  // namespace

std::vector<Profile> make_profiles(const PackChart& c, const CommonSettings& s) {
  return make_profiles(c.raster(0), s);
}

std::vector<Profile> make_profiles(const Mask& m, const CommonSettings& s) {
  // note: one raster for all turns (rasterising each turn and dilating the mask took a third of
  // packers.tetris's time on 10,000 charts).
  std::vector<int> cb(static_cast<size_t>(m.width), INT_MAX), ct(static_cast<size_t>(m.width), 0);
  std::vector<int> rl(static_cast<size_t>(m.height), INT_MAX), rr(static_cast<size_t>(m.height), 0);
  // note: rows top down, branch-free per column (vectorised): the last row seen is the bottom.
  int* cbp = cb.data();
  int* ctp = ct.data();
  for (int y = m.height - 1; y >= 0; --y) {
    const uint8_t* row = m.cells.data() + static_cast<size_t>(y) * static_cast<size_t>(m.width);
    for (int x = 0; x < m.width; ++x) {
      cbp[x] = row[x] ? y : cbp[x];
      ctp[x] = row[x] && ctp[x] == 0 ? y + 1 : ctp[x];
    }
    int x0 = 0, x1 = m.width;
    while (x0 < m.width && !row[x0]) ++x0;
    while (x1 > x0 && !row[x1 - 1]) --x1;
    if (x0 < x1) {
      rl[static_cast<size_t>(y)] = x0;
      rr[static_cast<size_t>(y)] = x1;
    }
  }
  std::vector<Profile> profs;
  for (int q = 0; q < (s.allow_rotation ? 4 : 1); ++q) {
    profs.push_back(turned_profile(cb, ct, rl, rr, q, s));
    // A turn giving the same outline as an earlier one (boxes: 180 degrees) is not tried again.
    for (int e = 0; e < q; ++e) {
      const Profile& a = profs[static_cast<size_t>(e)];
      if (!a.duplicate && a.bottom == profs.back().bottom && a.top == profs.back().top && a.h == profs.back().h) {
        profs.back().duplicate = true;
        break;
      }
    }
  }
  return profs;
}

Horizon::Horizon(int width)
    : H(static_cast<size_t>(width), 0), prefix(static_cast<size_t>(width) + 1, 0), lb(static_cast<size_t>(width), 0),
      wmax(static_cast<size_t>(width), 0) {}

Horizon::Horizon(std::vector<int> heights) : Horizon(static_cast<int>(heights.size())) {
  H = std::move(heights);
  for (int h : H) used = std::max(used, h);
  update(0);
}

void Horizon::update(int from) {
  for (size_t x = static_cast<size_t>(from); x < H.size(); ++x) prefix[x + 1] = prefix[x] + H[x];
  levels.clear();
}

void Horizon::place(const Profile& p, const Drop& d) {
  for (int c = 0; c < p.w; ++c)
    if (p.top[static_cast<size_t>(c)] > 0) H[static_cast<size_t>(d.x + c)] = d.y + p.top[static_cast<size_t>(c)];
  for (size_t x = static_cast<size_t>(d.x); x < H.size(); ++x) prefix[x + 1] = prefix[x] + H[x];
  // Window maxima whose window meets the changed columns [d.x, d.x + p.w), level by level.
  const int W = static_cast<int>(H.size());
  const int* prev = H.data();
  for (size_t j = 0; j < levels.size(); ++j) {
    const int half = 1 << j, span = 2 << j;
    const int x0 = std::max(0, d.x - span + 1), x1 = std::min(d.x + p.w, W - span + 1);
    if (x1 > x0) max_shift(prev + x0, half, x1 - x0, levels[j].data() + x0);
    prev = levels[j].data();
  }
  used = std::max(used, d.top);
}

const int* Horizon::window_max(int k) {
  if (k == 0) return H.data();
  const int W = static_cast<int>(H.size());
  while (static_cast<int>(levels.size()) < k) {
    const int j = static_cast<int>(levels.size());
    const int* prev = j == 0 ? H.data() : levels[static_cast<size_t>(j - 1)].data();
    levels.emplace_back(static_cast<size_t>(W), 0);
    max_shift(prev, 1 << j, W - (2 << j) + 1, levels.back().data());
  }
  return levels[static_cast<size_t>(k - 1)].data();
}

}  // namespace texdefrag::packing
