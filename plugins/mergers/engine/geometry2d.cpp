// Rigid 2D registration (Kabsch 1976 / Umeyama 1991 restricted to rotations) and the segment
// crossing test behind the merge engine's self-overlap check.
#include "geometry2d.h"

#include <algorithm>
#include <cmath>

namespace texdefrag::merge {

using Eigen::Vector2d;

namespace {
/// Item ids per cell of a uniform grid in compressed rows (one allocation pair per grid, not one
/// vector per cell): items of cell c are items[start[c], start[c + 1]), in increasing id order.
/// Callers keep one per thread (grid_scratch()), so the vectors' memory is reused between calls.
struct CsrGrid {
  std::vector<int> start, items, fill;
  std::vector<int> seen;  ///< the caller's per-item stamps (any_triangle_overlap)
  /// cells(i, visit) calls visit(cell) for every cell item i covers.
  template <class CellsFn>
  void build(size_t num_cells, size_t num_items, CellsFn&& cells) {
    start.assign(num_cells + 1, 0);
    for (size_t i = 0; i < num_items; ++i) cells(i, [&](size_t c) { ++start[c + 1]; });
    for (size_t c = 0; c < num_cells; ++c) start[c + 1] += start[c];
    items.resize(static_cast<size_t>(start.back()));
    fill.assign(start.begin(), start.end() - 1);
    for (size_t i = 0; i < num_items; ++i)
      cells(i, [&](size_t c) { items[static_cast<size_t>(fill[c]++)] = static_cast<int>(i); });
  }
  const int* begin(size_t c) const { return items.data() + start[c]; }
  const int* end(size_t c) const { return items.data() + start[c + 1]; }
};

/// This thread's grid (any_crossing and any_triangle_overlap never run inside each other: their
/// is_new callbacks test single pairs).
CsrGrid& grid_scratch() {
  thread_local CsrGrid g;
  return g;
}
}  // namespace

Rigid2 fit_rigid(const std::vector<Vector2d>& p, const std::vector<Vector2d>& q) {
  Rigid2 m;
  if (p.empty() || p.size() != q.size()) return m;
  Vector2d cp = Vector2d::Zero(), cq = Vector2d::Zero();
  for (size_t i = 0; i < p.size(); ++i) {
    cp += p[i];
    cq += q[i];
  }
  cp /= static_cast<double>(p.size());
  cq /= static_cast<double>(q.size());
  double sdot = 0, scross = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const Vector2d a = p[i] - cp, b = q[i] - cq;
    sdot += a.dot(b);
    scross += a.x() * b.y() - a.y() * b.x();
  }
  const double th = (sdot == 0 && scross == 0) ? 0.0 : std::atan2(scross, sdot);
  const double c = std::cos(th), s = std::sin(th);
  m.R << c, -s, s, c;
  m.t = cq - m.R * cp;
  return m;
}

Rigid2 fit_improper(const std::vector<Vector2d>& p, const std::vector<Vector2d>& q) {
  std::vector<Vector2d> mp(p);
  for (Vector2d& x : mp) x.y() = -x.y();
  Rigid2 m = fit_rigid(mp, q);
  m.R.col(1) = -m.R.col(1);  // R S with S = diag(1, -1)
  return m;
}

bool segments_cross(const Vector2d& a, const Vector2d& b, const Vector2d& c, const Vector2d& d) {
  const double o1 = orient2d(a, b, c), o2 = orient2d(a, b, d);
  const double o3 = orient2d(c, d, a), o4 = orient2d(c, d, b);
  return ((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0));
}

namespace {
// note: endpoints within this fraction of the longer segment count as shared. After a rigid motion
// two wedges of one vertex that coincided (a chart touching itself at a vertex) differ by rounding
// only; an exact comparison would report such touching segments as crossing about 1 time in 4.
constexpr double kTouch = 1e-7;

bool skip_pair(const Segment& s, const Segment& t) {
  if (s.w0 == t.w0 || s.w0 == t.w1 || s.w1 == t.w0 || s.w1 == t.w1) return true;
  const double tol2 = kTouch * kTouch * std::max((s.b - s.a).squaredNorm(), (t.b - t.a).squaredNorm());
  return (s.a - t.a).squaredNorm() <= tol2 || (s.a - t.b).squaredNorm() <= tol2 ||
         (s.b - t.a).squaredNorm() <= tol2 || (s.b - t.b).squaredNorm() <= tol2;
}
}  // namespace

bool any_crossing(const std::vector<Segment>& moved, const std::vector<Segment>& all,
                  const std::function<bool(const Segment&, const Segment&)>& is_new) {
  if (moved.empty()) return false;
  Vector2d lo = moved[0].a, hi = moved[0].a;
  double len = 0;
  for (const Segment& s : moved) {
    lo = lo.cwiseMin(s.a).cwiseMin(s.b);
    hi = hi.cwiseMax(s.a).cwiseMax(s.b);
    len += (s.b - s.a).norm();
  }
  const Vector2d ext = hi - lo;
  // Cell about the mean segment length, at most ~4 cells per moved segment overall.
  double cell = std::max(len / static_cast<double>(moved.size()), 1e-9);
  const double max_cells = 4.0 * static_cast<double>(moved.size()) + 16;
  while ((ext.x() / cell + 1) * (ext.y() / cell + 1) > max_cells) cell *= 1.5;
  const int nx = static_cast<int>(ext.x() / cell) + 1, ny = static_cast<int>(ext.y() / cell) + 1;
  auto cell_range = [&](const Segment& s, int& x0, int& x1, int& y0, int& y1) {
    const Vector2d a = s.a.cwiseMin(s.b), b = s.a.cwiseMax(s.b);
    x0 = std::max(0, static_cast<int>(std::floor((a.x() - lo.x()) / cell)));
    y0 = std::max(0, static_cast<int>(std::floor((a.y() - lo.y()) / cell)));
    x1 = std::min(nx - 1, static_cast<int>(std::floor((b.x() - lo.x()) / cell)));
    y1 = std::min(ny - 1, static_cast<int>(std::floor((b.y() - lo.y()) / cell)));
  };
  CsrGrid& grid = grid_scratch();
  grid.build(static_cast<size_t>(nx) * static_cast<size_t>(ny), moved.size(), [&](size_t i, auto&& visit) {
    int x0, x1, y0, y1;
    cell_range(moved[i], x0, x1, y0, y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) visit(static_cast<size_t>(y) * static_cast<size_t>(nx) + static_cast<size_t>(x));
  });
  auto test = [&](const Segment& s) {
    const Vector2d a = s.a.cwiseMin(s.b), b = s.a.cwiseMax(s.b);
    if (b.x() < lo.x() || b.y() < lo.y() || a.x() > hi.x() || a.y() > hi.y()) return false;
    int x0, x1, y0, y1;
    cell_range(s, x0, x1, y0, y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x)
        for (const int* it = grid.begin(static_cast<size_t>(y) * static_cast<size_t>(nx) + static_cast<size_t>(x));
             it != grid.end(static_cast<size_t>(y) * static_cast<size_t>(nx) + static_cast<size_t>(x)); ++it) {
          const int i = *it;
          const Segment& m = moved[static_cast<size_t>(i)];
          if (skip_pair(s, m)) continue;
          if (segments_cross(s.a, s.b, m.a, m.b) && (!is_new || is_new(s, m))) return true;
        }
    return false;
  };
  for (const Segment& s : all)
    if (test(s)) return true;
  for (const Segment& s : moved)
    if (test(s)) return true;
  return false;
}

namespace {
/// q strictly inside t, by more than `eps` in orient2d units (twice an area).
bool strictly_inside(const Vector2d& q, const std::array<Vector2d, 3>& t, double eps) {
  const double s0 = orient2d(t[0], t[1], q), s1 = orient2d(t[1], t[2], q), s2 = orient2d(t[2], t[0], q);
  return (s0 > eps && s1 > eps && s2 > eps) || (s0 < -eps && s1 < -eps && s2 < -eps);
}
/// Proper crossing of [a, b] and [c, d] with every orientation beyond `eps`.
bool segments_cross_eps(const Vector2d& a, const Vector2d& b, const Vector2d& c, const Vector2d& d, double eps) {
  const double o1 = orient2d(a, b, c), o2 = orient2d(a, b, d);
  const double o3 = orient2d(c, d, a), o4 = orient2d(c, d, b);
  return ((o1 > eps && o2 < -eps) || (o1 < -eps && o2 > eps)) && ((o3 > eps && o4 < -eps) || (o3 < -eps && o4 > eps));
}
}  // namespace

namespace {
/// Whether a and b certainly do not overlap by their bounding boxes alone, with the same answer
/// triangles_overlap's predicates would give (a fast exit, never a different result): no wedge id in
/// common, the boxes apart by more than the touching tolerance (so no corner is shared by position),
/// and both within 1e5 x the longest edge l of each other. Then every orientation those predicates
/// read errs by at most ~7e-16 l D < 1e-10 l^2 (Shewchuk's orient2d bound, edge length <= l, other
/// point within D <= 1e5 l), far below their eps = 1e-7 l^2, so each test they pass would hold
/// exactly, and a proper crossing or a corner strictly inside needs the boxes to meet. Every
/// coordinate must be finite (a NaN could leave a corner out of its box) and l2 far from underflow.
bool boxes_apart(const Tri2& a, const Tri2& b, double l2, double tol2) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (a.w[static_cast<size_t>(i)] == b.w[static_cast<size_t>(j)]) return false;
  double sum = 0;
  for (size_t k = 0; k < 3; ++k) sum += a.p[k].x() + a.p[k].y() + b.p[k].x() + b.p[k].y();
  if (!std::isfinite(sum) || !(l2 > 1e-200)) return false;
  Vector2d alo = a.p[0], ahi = a.p[0], blo = b.p[0], bhi = b.p[0];
  for (size_t k = 1; k < 3; ++k) {
    alo = alo.cwiseMin(a.p[k]);
    ahi = ahi.cwiseMax(a.p[k]);
    blo = blo.cwiseMin(b.p[k]);
    bhi = bhi.cwiseMax(b.p[k]);
  }
  const double gap = std::max(std::max(blo.x() - ahi.x(), alo.x() - bhi.x()),
                              std::max(blo.y() - ahi.y(), alo.y() - bhi.y()));
  if (!(gap > 0) || !(gap * gap > tol2)) return false;
  const Vector2d ext = ahi.cwiseMax(bhi) - alo.cwiseMin(blo);
  return ext.squaredNorm() <= 1e10 * l2;
}
}  // namespace

bool triangles_overlap(const Tri2& a, const Tri2& b) {
  // note: corners within kTouch of the longest edge count as shared, and orientations within kTouch *
  // (longest edge)^2 as zero: after the weld and rigid motions, faces of one chart that touch along an
  // unwelded edge or at a vertex (a chart touching itself) differ by rounding only, and the exact
  // predicates would report such contacts as overlaps (the folded-grid tests did).
  double l2 = 0;
  for (int k = 0; k < 3; ++k) {
    l2 = std::max(l2, (a.p[static_cast<size_t>(k)] - a.p[static_cast<size_t>((k + 1) % 3)]).squaredNorm());
    l2 = std::max(l2, (b.p[static_cast<size_t>(k)] - b.p[static_cast<size_t>((k + 1) % 3)]).squaredNorm());
  }
  const double tol2 = kTouch * kTouch * l2, eps = kTouch * l2;
  if (boxes_apart(a, b, l2, tol2)) return false;
  int shared = 0, sa[3] = {0, 0, 0}, sb[3] = {0, 0, 0};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (!sa[i] && !sb[j] &&
          (a.w[static_cast<size_t>(i)] == b.w[static_cast<size_t>(j)] ||
           (a.p[static_cast<size_t>(i)] - b.p[static_cast<size_t>(j)]).squaredNorm() <= tol2)) {
        ++shared;
        sa[i] = sb[j] = 1;
      }
  if (shared >= 3) return true;  // the same corners twice: a duplicated triangle
  if (shared == 2) {
    int i = 0, j = 0;
    while (sa[i]) ++i;
    while (sb[j]) ++j;
    int e0 = -1, e1 = -1;
    for (int k = 0; k < 3; ++k)
      if (sa[k]) (e0 < 0 ? e0 : e1) = k;
    const double o1 = orient2d(a.p[static_cast<size_t>(e0)], a.p[static_cast<size_t>(e1)], a.p[static_cast<size_t>(i)]);
    const double o2 = orient2d(a.p[static_cast<size_t>(e0)], a.p[static_cast<size_t>(e1)], b.p[static_cast<size_t>(j)]);
    return (o1 > eps && o2 > eps) || (o1 < -eps && o2 < -eps);
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (segments_cross_eps(a.p[static_cast<size_t>(i)], a.p[static_cast<size_t>((i + 1) % 3)],
                             b.p[static_cast<size_t>(j)], b.p[static_cast<size_t>((j + 1) % 3)], eps))
        return true;
  for (int i = 0; i < 3; ++i)
    if (!sa[i] && strictly_inside(a.p[static_cast<size_t>(i)], b.p, eps)) return true;
  for (int j = 0; j < 3; ++j)
    if (!sb[j] && strictly_inside(b.p[static_cast<size_t>(j)], a.p, eps)) return true;
  return false;
}

bool any_triangle_overlap(const std::vector<Tri2>& moved, const std::vector<Tri2>& all, size_t rigid,
                          const std::function<bool(const Tri2&, const Tri2&)>& is_new) {
  if (moved.empty()) return false;
  Vector2d lo = moved[0].p[0], hi = lo;
  double len = 0;
  for (const Tri2& t : moved)
    for (int k = 0; k < 3; ++k) {
      lo = lo.cwiseMin(t.p[static_cast<size_t>(k)]);
      hi = hi.cwiseMax(t.p[static_cast<size_t>(k)]);
      len += (t.p[static_cast<size_t>(k)] - t.p[static_cast<size_t>((k + 1) % 3)]).norm();
    }
  const Vector2d ext = hi - lo;
  double cell = std::max(len / (3.0 * static_cast<double>(moved.size())), 1e-9);
  const double max_cells = 4.0 * static_cast<double>(moved.size()) + 16;
  while ((ext.x() / cell + 1) * (ext.y() / cell + 1) > max_cells) cell *= 1.5;
  const int nx = static_cast<int>(ext.x() / cell) + 1, ny = static_cast<int>(ext.y() / cell) + 1;
  auto range = [&](const Tri2& t, int& x0, int& x1, int& y0, int& y1) {
    Vector2d a = t.p[0], b = t.p[0];
    for (int k = 1; k < 3; ++k) {
      a = a.cwiseMin(t.p[static_cast<size_t>(k)]);
      b = b.cwiseMax(t.p[static_cast<size_t>(k)]);
    }
    if (b.x() < lo.x() || b.y() < lo.y() || a.x() > hi.x() || a.y() > hi.y()) return false;
    x0 = std::max(0, static_cast<int>(std::floor((a.x() - lo.x()) / cell)));
    y0 = std::max(0, static_cast<int>(std::floor((a.y() - lo.y()) / cell)));
    x1 = std::min(nx - 1, static_cast<int>(std::floor((b.x() - lo.x()) / cell)));
    y1 = std::min(ny - 1, static_cast<int>(std::floor((b.y() - lo.y()) / cell)));
    return true;
  };
  CsrGrid& grid = grid_scratch();
  grid.build(static_cast<size_t>(nx) * static_cast<size_t>(ny), moved.size(), [&](size_t i, auto&& visit) {
    int x0, x1, y0, y1;
    if (!range(moved[i], x0, x1, y0, y1)) return;
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) visit(static_cast<size_t>(y) * static_cast<size_t>(nx) + static_cast<size_t>(x));
  });
  std::vector<int>& seen = grid.seen;
  seen.assign(moved.size(), -1);
  auto test = [&](const Tri2& t, int self, int stamp) {
    int x0, x1, y0, y1;
    if (!range(t, x0, x1, y0, y1)) return false;
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x)
        for (const int* it = grid.begin(static_cast<size_t>(y) * static_cast<size_t>(nx) + static_cast<size_t>(x));
             it != grid.end(static_cast<size_t>(y) * static_cast<size_t>(nx) + static_cast<size_t>(x)); ++it) {
          const int i = *it;
          if (i == self || seen[static_cast<size_t>(i)] == stamp) continue;
          seen[static_cast<size_t>(i)] = stamp;
          if (self >= 0 && static_cast<size_t>(self) < rigid && static_cast<size_t>(i) < rigid) continue;
          const Tri2& m = moved[static_cast<size_t>(i)];
          if (m.w == t.w) continue;
          if (triangles_overlap(t, m) && (!is_new || is_new(t, m))) return true;
        }
    return false;
  };
  int stamp = 0;
  for (const Tri2& t : all)
    if (test(t, -1, stamp++)) return true;
  for (size_t i = 0; i < moved.size(); ++i)
    if (test(moved[i], static_cast<int>(i), stamp++)) return true;
  return false;
}

namespace {
/// Whether p lies inside or on triangle (a, b, c) of orientation sign s (+1 or -1).
bool in_triangle(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                 const Eigen::Vector2d& c, double s) {
  return s * orient2d(a, b, p) >= 0 && s * orient2d(b, c, p) >= 0 && s * orient2d(c, a, p) >= 0;
}

/// Whether corner i of the remaining polygon `idx` is an ear of orientation s.
bool is_ear(const std::vector<Eigen::Vector2d>& poly, const std::vector<int>& idx, size_t i, double s) {
  const size_t n = idx.size();
  const int ia = idx[(i + n - 1) % n], ib = idx[i], ic = idx[(i + 1) % n];
  const Eigen::Vector2d &a = poly[static_cast<size_t>(ia)], &b = poly[static_cast<size_t>(ib)],
                        &c = poly[static_cast<size_t>(ic)];
  if (s * orient2d(a, b, c) <= 0) return false;  // reflex or flat corner
  for (int j : idx) {
    if (j == ia || j == ib || j == ic) continue;
    if (in_triangle(poly[static_cast<size_t>(j)], a, b, c, s)) return false;
  }
  return true;
}
}  // namespace

bool ear_clip(const std::vector<Eigen::Vector2d>& poly, std::vector<std::array<int, 3>>& out) {
  out.clear();
  const size_t n = poly.size();
  if (n < 3) return false;
  double area2 = 0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d &p = poly[i], &q = poly[(i + 1) % n];
    area2 += p.x() * q.y() - p.y() * q.x();
  }
  if (area2 == 0 || !std::isfinite(area2)) return false;
  const double s = area2 > 0 ? 1.0 : -1.0;
  std::vector<int> idx(n);
  for (size_t i = 0; i < n; ++i) idx[i] = static_cast<int>(i);
  size_t since_cut = 0, i = 0;
  while (idx.size() > 3) {
    if (since_cut > idx.size()) return false;  // a whole turn without an ear: not simple
    i %= idx.size();
    if (!is_ear(poly, idx, i, s)) {
      ++i;
      ++since_cut;
      continue;
    }
    const size_t m = idx.size();
    out.push_back({idx[(i + m - 1) % m], idx[i], idx[(i + 1) % m]});
    idx.erase(idx.begin() + static_cast<std::ptrdiff_t>(i));
    since_cut = 0;
  }
  const Eigen::Vector2d &a = poly[static_cast<size_t>(idx[0])], &b = poly[static_cast<size_t>(idx[1])],
                        &c = poly[static_cast<size_t>(idx[2])];
  if (s * orient2d(a, b, c) <= 0) return false;
  out.push_back({idx[0], idx[1], idx[2]});
  return true;
}

}  // namespace texdefrag::merge
