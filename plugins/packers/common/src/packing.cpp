// Shared packer machinery: options, chart preparation (exact-copy anchoring after the M-method,
// Maggiordomo et al. 2021, section "packing": anchors shifted onto the input texel grid; minimum-
// area rectangle orientation after Liu et al. 2024, section 2.3), page sizing and layout output.
#include "texdefrag/packers/packing.h"

#include "texdefrag/util/parallel.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>
#include <tuple>

namespace texdefrag::packing {

std::vector<OptionSpec> common_options(bool free_rotation_default, int width_trials_default) {
  return {
      opt_int("gutter", 4, "Empty texels kept between charts (and half of it at the page border)")
          .range(0, 64)
          .unit("texels"),
      opt_int("max_page_size", 8192, "Largest page width and height; more pages are opened when charts do not fit")
          .range(64, 32768)
          .unit("texels"),
      opt_int("page_multiple", 32, "Page sides are trimmed to the used area and rounded up to this multiple")
          .range(1, 4096)
          .unit("texels"),
      opt_bool("power_of_two", false, "Round page sides up to a power of two instead of page_multiple"),
      opt_bool("allow_rotation", true, "Charts may be turned by 90, 180 or 270 degrees (exact, no resampling)"),
      opt_bool("free_rotation", free_rotation_default,
               "Charts that will be resampled anyway (not exact) are rotated to their minimum-area rectangle"),
      opt_double("rotation_gain", 0.05,
                 "A free rotation is applied only when it shrinks the bounding rectangle by more than this fraction")
          .range(0, 1),
      opt_double("exact_fraction", 0.25,
                 "A chart whose grid-exact faces cover at least this fraction of its UV area keeps whole-texel "
                 "placement (copied without resampling)")
          .range(0, 1),
      opt_int("width_trials", width_trials_default, "Page widths tried (keeping the smallest result) when all charts fit on one page")
          .range(1, 16),
  };
}

CommonSettings read_common(const Options& o) {
  CommonSettings s;
  s.gutter = static_cast<int>(o.get_int("gutter"));
  s.max_page_size = static_cast<int>(o.get_int("max_page_size"));
  s.page_multiple = static_cast<int>(o.get_int("page_multiple"));
  s.power_of_two = o.get_bool("power_of_two");
  s.allow_rotation = o.get_bool("allow_rotation");
  s.free_rotation = o.get_bool("free_rotation");
  s.rotation_gain = o.get_double("rotation_gain");
  s.exact_fraction = o.get_double("exact_fraction");
  s.width_trials = static_cast<int>(o.get_int("width_trials"));
  return s;
}

Mask PackChart::raster(int q) const {
  Mask m;
  m.width = w[q];
  m.height = h[q];
  m.cells.assign(static_cast<size_t>(m.width) * static_cast<size_t>(m.height), 0);
  const Vec2 o(ox[q], oy[q]);
  for (const auto& t : tris)
    rasterise_triangle(rotate90(base[static_cast<size_t>(t[0])], q) - o,
                       rotate90(base[static_cast<size_t>(t[1])], q) - o,
                       rotate90(base[static_cast<size_t>(t[2])], q) - o, m);
  return m;
}

namespace {

double tri_area(const Vec2& a, const Vec2& b, const Vec2& c) {
  return 0.5 * std::abs((b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x()));
}

constexpr double kExactTol = 1e-6;  // texels: UV round-off allowed in a grid-exact face

/// Quantised fractional part (1e-6 texel steps, in [0, 1e6)).
long long frac_key(double t) {
  long long k = std::llround((t - std::floor(t)) * 1e6);
  return k >= 1000000 ? 0 : k;
}

void compute_boxes(PackChart& c) {
  for (int q = 0; q < 4; ++q) {
    double xmin = 1e300, ymin = 1e300, xmax = -1e300, ymax = -1e300;
    for (const Vec2& b : c.base) {
      const Vec2 p = rotate90(b, q);
      xmin = std::min(xmin, p.x());
      xmax = std::max(xmax, p.x());
      ymin = std::min(ymin, p.y());
      ymax = std::max(ymax, p.y());
    }
    if (c.base.empty()) xmin = xmax = ymin = ymax = 0;
    c.ox[q] = static_cast<int>(std::floor(xmin));
    c.oy[q] = static_cast<int>(std::floor(ymin));
    c.w[q] = std::max(1, static_cast<int>(std::ceil(xmax)) - c.ox[q]);
    c.h[q] = std::max(1, static_cast<int>(std::ceil(ymax)) - c.oy[q]);
  }
}

/// Block grid residues of an exact chart (PackChart::bx, by). Its anchor maps input texel point
/// `in` to base point R_m(in) + k (k integral); orientation q places base point b at
/// R_q(b) - (ox[q], oy[q]) + (x, y). Input blocks have corners at (0, H_in) + G Z^2 (rows counted
/// from the image's top), output blocks at G Z^2 (page heights are multiples of G), and quarter
/// turns about the origin keep G Z^2, so the anchor's blocks land on output blocks exactly when
/// R_{q+m}((0, H_in)) + R_q(k) - (ox[q], oy[q]) + (x, y) is in G Z^2.
void block_residues(PackChart& c, const Vec2& k, int m, int page_height, int g) {
  auto mod = [g](double v) {
    const long long r = std::llround(v) % g;
    return static_cast<int>(r < 0 ? r + g : r);
  };
  c.block_aligned = true;
  for (int q = 0; q < 4; ++q) {
    const Vec2 shift = rotate90(Vec2(0.0, static_cast<double>(page_height)), (q + m) % 4) + rotate90(k, q) -
                       Vec2(static_cast<double>(c.ox[q]), static_cast<double>(c.oy[q]));
    c.bx[q] = mod(-shift.x());
    c.by[q] = mod(-shift.y());
  }
}

/// Splits the atlas's faces into in.charts (faces, wedges, corner indices); throws StageError on a
/// chart id out of range, a missing wedge or a wedge shared by two charts.
void collect_chart_faces(PackInput& in, const Atlas& a, const std::string& stage) {
  std::vector<int> wedge_chart(a.wedge_uv.size(), -1);
  std::vector<int> wedge_local(a.wedge_uv.size(), -1);
  for (size_t f = 0; f < a.face_chart.size(); ++f) {
    const int ch = a.face_chart[f];
    if (ch < 0) continue;
    if (ch >= a.num_charts)
      throw StageError(stage + ": face " + std::to_string(f) + " has chart " + std::to_string(ch) +
                       " but the atlas has " + std::to_string(a.num_charts) + " charts");
    PackChart& c = in.charts[static_cast<size_t>(ch)];
    std::array<int, 3> t{};
    for (int k = 0; k < 3; ++k) {
      const int wdg = a.face_wedge[f][static_cast<size_t>(k)];
      if (wdg < 0 || static_cast<size_t>(wdg) >= a.wedge_uv.size())
        throw StageError(stage + ": face " + std::to_string(f) + " of chart " + std::to_string(ch) +
                         " has no valid wedge at corner " + std::to_string(k));
      int& owner = wedge_chart[static_cast<size_t>(wdg)];
      if (owner >= 0 && owner != ch)
        throw StageError(stage + ": wedge " + std::to_string(wdg) + " is shared by charts " +
                         std::to_string(owner) + " and " + std::to_string(ch));
      if (owner < 0) {
        owner = ch;
        wedge_local[static_cast<size_t>(wdg)] = static_cast<int>(c.wedges.size());
        c.wedges.push_back(wdg);
      }
      t[static_cast<size_t>(k)] = wedge_local[static_cast<size_t>(wdg)];
    }
    c.faces.push_back(static_cast<int>(f));
    c.tris.push_back(t);
  }
}

/// A chart's anchor: its largest group of grid-exact faces (same quarter turn, same fractional
/// translation), or area 0 when it has none.
struct Anchor {
  double area = 0;         ///< texels^2 of the group's UV area
  Vec2 t = Vec2::Zero();   ///< translation of the group's first face (uv = R_m(input) + t)
  int m = 0;               ///< quarter turns from input to working UVs
  int page_height = 0;     ///< the group's input page height (block grid), 0 without a mesh
};

/// Sums c.uv_area (face order) and returns c's anchor. Input UVs from ctx.mesh, or the atlas UVs
/// without a mesh.
Anchor find_anchor(const StageContext& ctx, PackChart& c) {
  const Atlas& a = ctx.atlas;
  // Grid-exact face groups: (quarter turn m, fractional translation) -> UV area, first t and page
  // height (groups ordered by key, so ties keep the smallest key whatever the face order).
  std::map<std::tuple<int, long long, long long>, Anchor> groups;
  for (size_t i = 0; i < c.faces.size(); ++i) {
    const int f = c.faces[i];
    Vec2 uv[3], inp[3];
    for (int k = 0; k < 3; ++k) {
      uv[k] = a.wedge_uv[static_cast<size_t>(a.face_wedge[static_cast<size_t>(f)][static_cast<size_t>(k)])];
      inp[k] = ctx.mesh ? ctx.mesh->corner_texel(static_cast<size_t>(f), k) : uv[k];
    }
    const double area = tri_area(uv[0], uv[1], uv[2]);
    c.uv_area += area;
    if (area <= 0) continue;
    for (int m = 0; m < 4; ++m) {
      const Vec2 t = uv[0] - rotate90(inp[0], m);
      if ((uv[1] - rotate90(inp[1], m) - t).cwiseAbs().maxCoeff() > kExactTol) continue;
      if ((uv[2] - rotate90(inp[2], m) - t).cwiseAbs().maxCoeff() > kExactTol) continue;
      const auto key = std::make_tuple(m, frac_key(t.x()), frac_key(t.y()));
      const int h = ctx.mesh ? ctx.mesh->pages[static_cast<size_t>(ctx.mesh->faces[static_cast<size_t>(f)].page)].height : 0;
      groups.try_emplace(key, Anchor{0.0, t, m, h}).first->second.area += area;
      break;
    }
  }
  Anchor best;
  for (const auto& g : groups)
    if (g.second.area > best.area) best = g.second;
  return best;
}

/// Sets c.base for an exact chart: its wedges' UVs moved by the anchor's fractional translation,
/// so that the anchor's input texel grid is the integer grid.
void set_exact_base(PackChart& c, const Atlas& a, const Vec2& t) {
  c.grid_offset = Vec2(t.x() - std::floor(t.x()), t.y() - std::floor(t.y()));
  if (frac_key(t.x()) == 0) c.grid_offset.x() = 0;
  if (frac_key(t.y()) == 0) c.grid_offset.y() = 0;
  for (size_t i = 0; i < c.wedges.size(); ++i) c.base[i] = a.wedge_uv[static_cast<size_t>(c.wedges[i])] - c.grid_offset;
}

/// Sets c.base for a free chart turned by c.angle (its wedges' UVs rotated).
void set_turned_base(PackChart& c, const Atlas& a) {
  for (size_t i = 0; i < c.wedges.size(); ++i) {
    const Vec2& uv = a.wedge_uv[static_cast<size_t>(c.wedges[i])];
    c.base[i] = c.angle != 0 ? rotate(uv, c.angle) : uv;
  }
}

/// Sets c.base (and c.angle) for a free chart: its wedges' UVs, rotated to their exact minimum-area
/// rectangle when s.free_rotation is on and that shrinks the bounding box by more than
/// s.rotation_gain.
void set_free_base(PackChart& c, const Atlas& a, const CommonSettings& s) {
  std::vector<Vec2> pts(c.wedges.size());
  for (size_t i = 0; i < c.wedges.size(); ++i) pts[i] = a.wedge_uv[static_cast<size_t>(c.wedges[i])];
  if (s.free_rotation && pts.size() >= 3) {
    const OrientedRect r = min_area_rect(convex_hull(pts));
    double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
    for (const Vec2& p : pts) {
      xmin = std::min(xmin, p.x());
      xmax = std::max(xmax, p.x());
      ymin = std::min(ymin, p.y());
      ymax = std::max(ymax, p.y());
    }
    const double aabb = (xmax - xmin) * (ymax - ymin);
    if (r.angle != 0 && aabb - r.area() > s.rotation_gain * aabb) c.angle = -r.angle;
  }
  set_turned_base(c, a);
}

/// Prepares chart c (faces already collected): UV area, exactness, base points, boxes, residues.
void prepare_chart(const StageContext& ctx, const CommonSettings& s, PackChart& c) {
  const Anchor anchor = find_anchor(ctx, c);
  c.exact_area = anchor.area;
  c.exact = anchor.area > 0 && anchor.area >= s.exact_fraction * c.uv_area;
  c.base.resize(c.wedges.size());
  if (c.exact) set_exact_base(c, ctx.atlas, anchor.t);
  else set_free_base(c, ctx.atlas, s);
  compute_boxes(c);
  if (c.exact && s.block_grid > 1)
    block_residues(c, anchor.t - c.grid_offset, anchor.m, anchor.page_height, s.block_grid);
}

}  // namespace

PackInput prepare_charts(const StageContext& ctx, const CommonSettings& s, const std::string& stage) {
  PackInput in;
  in.atlas = &ctx.atlas;
  in.charts.resize(static_cast<size_t>(std::max(0, ctx.atlas.num_charts)));
  for (size_t i = 0; i < in.charts.size(); ++i) in.charts[i].id = static_cast<int>(i);
  collect_chart_faces(in, ctx.atlas, stage);
  // note: one chart per item, side by side (each writes only its chart); the UV areas are summed
  // afterwards in chart order, so the result does not depend on the thread count.
  parallel_for(in.charts.size(), [&](size_t ci) { prepare_chart(ctx, s, in.charts[ci]); });
  for (const PackChart& c : in.charts) in.total_uv_area += c.uv_area;
  return in;
}

void set_free_angle(PackChart& c, const Atlas& a, double angle) {
  if (c.exact) throw std::logic_error("set_free_angle: chart " + std::to_string(c.id) + " is exact");
  c.angle = angle;
  c.base.resize(c.wedges.size());
  set_turned_base(c, a);
  compute_boxes(c);
}

bool fits_max_page(const PackChart& c, const CommonSettings& s) {
  const int k = block_slack(c, s);  // 0 off the block grid
  const bool fits0 = c.w[0] + s.gutter + k <= s.max_page_size && c.h[0] + s.gutter + k <= s.max_page_size;
  const bool fits1 =
      s.allow_rotation && c.w[1] + s.gutter + k <= s.max_page_size && c.h[1] + s.gutter + k <= s.max_page_size;
  return fits0 || fits1;
}

void check_chart_sizes(const PackInput& in, const CommonSettings& s, const std::string& stage) {
  for (const PackChart& c : in.charts) {
    if (c.faces.empty()) continue;
    const int k = block_slack(c, s);  // 0 off the block grid
    if (!fits_max_page(c, s)) {
      std::ostringstream os;
      os << stage << ": chart " << c.id << " (" << c.faces.size() << " faces) is " << c.w[0] << " x " << c.h[0]
         << " texels, which with the gutter of " << s.gutter << (k > 0 ? " and the block grid" : "")
         << " does not fit max_page_size " << s.max_page_size;
      throw StageError(os.str());
    }
  }
}

int round_page_side(int used, const CommonSettings& s) {
  long long r = std::max(1, used);
  if (s.power_of_two) {
    long long p = 1;
    while (p < r) p *= 2;
    r = p;
  } else {
    r = (r + s.page_multiple - 1) / s.page_multiple * s.page_multiple;
  }
  return static_cast<int>(std::min<long long>(r, s.max_page_size));
}

int initial_page_width(double padded_area, int min_width, double expected_efficiency, const CommonSettings& s) {
  const double side = std::sqrt(std::max(0.0, padded_area) / std::max(1e-3, expected_efficiency));
  const int w = std::max(min_width, static_cast<int>(std::ceil(side)));
  return std::min(s.max_page_size, std::max(min_width, round_page_side(w, s)));
}

std::vector<int> order_by_area(const PackInput& in, const CommonSettings& s) {
  std::vector<int> order;
  for (const PackChart& c : in.charts)
    if (!c.faces.empty()) order.push_back(c.id);
  auto area = [&](int i) {
    const PackChart& c = in.charts[static_cast<size_t>(i)];
    return static_cast<long long>(padded_w(c, 0, s)) * padded_h(c, 0, s);
  };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return area(a) > area(b); });
  return order;
}

double padded_box_area(const PackInput& in, const CommonSettings& s) {
  double padded = 0;
  for (const PackChart& c : in.charts)
    if (!c.faces.empty()) padded += static_cast<double>(padded_w(c, 0, s)) * padded_h(c, 0, s);
  return padded;
}

PackResult pack_best_width(const PackInput& in, const CommonSettings& s,
                           const std::function<PackResult(int width, TrialBound& bound)>& pack_with_width) {
  return pack_best_width(in, s, padded_box_area(in, s), pack_with_width);
}

int min_page_width(const PackInput& in, const CommonSettings& s) {
  int min_width = 1;
  for (const PackChart& c : in.charts) {
    if (c.faces.empty()) continue;
    int mw = s.max_page_size;
    const int k = block_slack(c, s);
    for (int q = 0; q < (s.allow_rotation ? 2 : 1); ++q)
      if (padded_h(c, q, s) + k <= s.max_page_size && padded_w(c, q, s) + k <= s.max_page_size)
        mw = std::min(mw, padded_w(c, q, s) + k);
    min_width = std::max(min_width, mw);
  }
  return min_width;
}

std::vector<int> trial_widths(const PackInput& in, const CommonSettings& s, double padded) {
  const int min_width = min_page_width(in, s);
  std::vector<int> widths;
  const double page = static_cast<double>(s.max_page_size) * s.max_page_size;
  if (padded >= 0.9 * page || s.width_trials <= 1) {
    widths.push_back(padded >= 0.9 * page ? s.max_page_size : initial_page_width(padded, min_width, 0.9, s));
  } else {
    for (int k = 0; k < s.width_trials; ++k) {
      const double eff = 1.0 - 0.4 * k / std::max(1, s.width_trials - 1);
      const int w = initial_page_width(padded, min_width, eff, s);
      if (std::find(widths.begin(), widths.end(), w) == widths.end()) widths.push_back(w);
    }
    const double boxes = padded_box_area(in, s);
    if (boxes != padded)
      for (int k = 0; k < s.width_trials; ++k) {
        const double eff = 1.0 - 0.4 * k / std::max(1, s.width_trials - 1);
        const int w = initial_page_width(boxes, min_width, eff, s);
        if (std::find(widths.begin(), widths.end(), w) == widths.end()) widths.push_back(w);
      }
  }
  return widths;
}

PackResult pack_best_width(const PackInput& in, const CommonSettings& s, double padded,
                           const std::function<PackResult(int width, TrialBound& bound)>& pack_with_width) {
  return pack_widths(in, s, trial_widths(in, s, padded), pack_with_width);
}

bool better_result(const PackResult& a, const PackResult& b) {
  return a.pages < b.pages || (a.pages == b.pages && a.total_area() < b.total_area());
}

namespace {

/// The leader among the finished trials (done) and the incumbent, as pack_widths and its caller
/// would choose if no other trial finished: the best finished trial (ties: the lower index)
/// unless the incumbent is at least as good. Returns its index, -1 for the incumbent, or -2 when
/// there is neither.
int leader_of(const std::vector<PackResult>& results, const std::vector<uint8_t>& done, const PackResult* incumbent) {
  int best = -2;
  for (size_t i = 0; i < results.size(); ++i)
    if (done[i] && (best < 0 || better_result(results[i], results[static_cast<size_t>(best)]))) best = static_cast<int>(i);
  if (incumbent && (best < 0 || !better_result(results[static_cast<size_t>(best)], *incumbent))) return -1;
  return best;
}

}  // namespace

PackResult pack_widths(const PackInput& in, const CommonSettings& s, const std::vector<int>& widths,
                       const std::function<PackResult(int width, TrialBound& bound)>& pack_with_width, int* chosen,
                       const PackResult* incumbent, double bar, const BesideJob& beside) {
  TrialBoard board(widths.size());
  if (incumbent && incumbent->pages == 1) board.seed(incumbent->total_area());
  else if (!incumbent && bar > 0) board.seed(bar, false);
  std::vector<PackResult> results(widths.size());
  std::vector<uint8_t> done(widths.size(), 0);  // guarded by `mutex` (read by the beside job)
  std::mutex mutex;
  // note: the beside job is one more item after the trials, so it starts once every trial has
  // started, on the first thread left without one; a finished result is never written again, so
  // the leader's result may be read outside the lock.
  parallel_for(widths.size() + (beside ? 1 : 0), [&](size_t i) {
    if (i == widths.size()) {
      int leader = 0;
      {
        std::lock_guard<std::mutex> lock(mutex);
        leader = leader_of(results, done, incumbent);
      }
      if (leader >= -1) beside(leader, leader < 0 ? *incumbent : results[static_cast<size_t>(leader)]);
      return;
    }
    TrialBound bound(board, i);
    PackResult r = pack_with_width(widths[i], bound);
    size_pages(in, s, r);
    board.record(i, r);
    std::lock_guard<std::mutex> lock(mutex);
    results[i] = std::move(r);
    done[i] = 1;
  });
  size_t best = 0;
  for (size_t i = 1; i < results.size(); ++i)
    if (better_result(results[i], results[best])) best = i;
  if (chosen) *chosen = widths[best];
  return std::move(results[best]);
}

void TrialBoard::record(size_t index, const PackResult& r) {
  if (r.pages != 1) return;
  std::lock_guard<std::mutex> lock(mutex_);
  single_[index] = r.total_area();
}

bool TrialBoard::beaten(size_t index, size_t pages, double area) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (seed_ >= 0 && (pages > 1 || area > seed_ || (seed_ties_lose_ && area >= seed_))) return true;
  for (size_t j = 0; j < single_.size(); ++j) {
    const double a = single_[j];
    if (j == index || a < 0) continue;
    if (pages > 1 || area > a || (j < index && area >= a)) return true;
  }
  return false;
}

void TrialBound::placed(const PackChart& c, const Placement& p, const CommonSettings& s) {
  if (p.page != 0) return;
  const int hi = s.gutter - s.gutter / 2;
  used_w_ = std::max(used_w_, p.x + c.w[p.q] + hi);
  used_h_ = std::max(used_h_, p.y + c.h[p.q] + hi);
}

double TrialBound::area(const CommonSettings& s) const {
  return static_cast<double>(round_page_side(used_w_, s)) * round_page_side(used_h_, s);
}

bool TrialBound::hopeless(size_t pages, const CommonSettings& s) const { return board_->beaten(index_, pages, area(s)); }

void TrialBound::lose(PackResult& r, size_t pages) { r.pages = std::max(2, static_cast<int>(pages) + 1); }

double PackResult::total_area() const {
  double a = 0;
  for (const auto& p : sizes) a += static_cast<double>(p.width) * p.height;
  return a;
}

void size_pages(const PackInput& in, const CommonSettings& s, PackResult& r) {
  const int hi = s.gutter - s.gutter / 2;
  std::vector<int> uw(static_cast<size_t>(r.pages), 0), uh(static_cast<size_t>(r.pages), 0);
  for (size_t i = 0; i < in.charts.size(); ++i) {
    const Placement& p = r.placements[i];
    if (p.page < 0) continue;
    const PackChart& c = in.charts[i];
    uw[static_cast<size_t>(p.page)] = std::max(uw[static_cast<size_t>(p.page)], p.x + c.w[p.q] + hi);
    uh[static_cast<size_t>(p.page)] = std::max(uh[static_cast<size_t>(p.page)], p.y + c.h[p.q] + hi);
  }
  r.sizes.resize(static_cast<size_t>(r.pages));
  for (size_t k = 0; k < r.sizes.size(); ++k) {
    r.sizes[k].width = round_page_side(uw[k], s);
    r.sizes[k].height = round_page_side(uh[k], s);
  }
}

Vec2 place_point(const PackChart& c, const Placement& p, const Vec2& b) {
  // note: integer shift applied to an exactly rotated point, so exact charts stay on the grid.
  return rotate90(b, p.q) + Vec2(static_cast<double>(p.x - c.ox[p.q]), static_cast<double>(p.y - c.oy[p.q]));
}

void write_layout(StageContext& ctx, const PackInput& in, const PackResult& r) {
  Layout& L = ctx.layout;
  L.pages = r.sizes;
  L.chart_page.assign(in.charts.size(), -1);
  L.wedge_uv.assign(in.atlas->wedge_uv.size(), Vec2::Zero());
  size_t exact = 0, turned = 0, free_rot = 0;
  for (size_t i = 0; i < in.charts.size(); ++i) {
    const PackChart& c = in.charts[i];
    const Placement& p = r.placements[i];
    L.chart_page[i] = p.page;
    if (c.faces.empty()) continue;
    for (size_t k = 0; k < c.wedges.size(); ++k)
      L.wedge_uv[static_cast<size_t>(c.wedges[k])] = place_point(c, p, c.base[k]);
    exact += c.exact ? 1 : 0;
    turned += p.q != 0 ? 1 : 0;
    free_rot += c.angle != 0 ? 1 : 0;
  }
  if (!ctx.report) return;
  json& rep = *ctx.report;
  const double page_area = r.total_area();
  rep["pages"] = r.pages;
  json sizes = json::array();
  for (const auto& s : r.sizes) sizes.push_back({s.width, s.height});
  rep["page_sizes"] = sizes;
  rep["page_megapixels"] = page_area / 1e6;
  rep["chart_uv_area"] = in.total_uv_area;
  rep["packing_efficiency"] = page_area > 0 ? in.total_uv_area / page_area : 0.0;
  rep["charts"] = in.charts.size();
  rep["charts_exact"] = exact;
  rep["charts_turned_90"] = turned;
  rep["charts_rotated_free"] = free_rot;
}

}  // namespace texdefrag::packing
