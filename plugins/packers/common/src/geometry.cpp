// Convex hull (Andrew 1979, monotone chain), minimum-area enclosing rectangle by rotating calipers
// (Toussaint 1983, "Solving geometric problems with the rotating calipers"; optimality of an
// edge-collinear side: Freeman & Shapira 1975), and conservative triangle rasterisation by the
// separating axis theorem.
#include "texdefrag/packers/geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace texdefrag::packing {
namespace {

double cross(const Vec2& o, const Vec2& a, const Vec2& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

constexpr double kHalfPi = 1.57079632679489661923;

/// Normalises an edge angle to [0, pi/2), swapping the sides when a quarter turn is removed.
OrientedRect make_rect(double angle, double along, double across) {
  double k = std::floor(angle / kHalfPi);
  double a = angle - k * kHalfPi;
  if (a >= kHalfPi) { a -= kHalfPi; k += 1; }
  if (a < 0) { a = 0; }
  OrientedRect r;
  r.angle = a;
  const bool odd = (static_cast<long long>(k) % 2) != 0;
  r.width = odd ? across : along;
  r.height = odd ? along : across;
  return r;
}

OrientedRect degenerate_rect(const std::vector<Vec2>& hull) {
  if (hull.size() < 2) return OrientedRect{};
  const Vec2 d = hull[1] - hull[0];
  return make_rect(std::atan2(d.y(), d.x()), d.norm(), 0.0);
}

}  // namespace

std::vector<Vec2> convex_hull(std::vector<Vec2> pts) {
  std::sort(pts.begin(), pts.end(), [](const Vec2& a, const Vec2& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  pts.erase(std::unique(pts.begin(), pts.end()), pts.end());
  if (pts.size() < 3) return pts;
  std::vector<Vec2> h(2 * pts.size());
  size_t k = 0;
  for (size_t i = 0; i < pts.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], pts[i]) <= 0) --k;
    h[k++] = pts[i];
  }
  for (size_t i = pts.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(h[k - 2], h[k - 1], pts[i - 1]) <= 0) --k;
    h[k++] = pts[i - 1];
  }
  h.resize(k - 1);  // the last point repeats the first
  return h;
}

OrientedRect min_area_rect(const std::vector<Vec2>& hull) {
  const size_t n = hull.size();
  if (n < 3) return degenerate_rect(hull);
  auto at = [&](size_t i) -> const Vec2& { return hull[i % n]; };
  // Calipers for edge 0 found by a full scan; then each pointer only moves forward (the extreme
  // points of a convex polygon turn with the edge direction), n steps in all per pointer.
  size_t right = 0, top = 0, left = 0;
  double best_area = std::numeric_limits<double>::infinity();
  OrientedRect best;
  for (size_t i = 0; i < n; ++i) {
    const Vec2 d = at(i + 1) - at(i);
    const double len = d.norm();
    if (len == 0) continue;
    const Vec2 e = d / len;
    const Vec2 nrm(-e.y(), e.x());  // inward for a counter-clockwise hull
    const Vec2& p0 = at(i);
    auto pe = [&](size_t j) { return (at(j) - p0).dot(e); };
    auto pn = [&](size_t j) { return (at(j) - p0).dot(nrm); };
    if (i == 0) {
      for (size_t j = 0; j < n; ++j) {
        if (pe(j) > pe(right)) right = j;
        if (pn(j) > pn(top)) top = j;
        if (pe(j) < pe(left)) left = j;
      }
    } else {
      if (right < i) right = i;
      for (size_t s = 0; s < n && pe(right + 1) >= pe(right); ++s) ++right;
      if (top < right) top = right;
      for (size_t s = 0; s < n && pn(top + 1) >= pn(top); ++s) ++top;
      if (left < top) left = top;
      for (size_t s = 0; s < n && pe(left + 1) <= pe(left); ++s) ++left;
    }
    const double along = pe(right) - pe(left);
    const double across = pn(top);
    const double area = along * across;
    if (area < best_area) {
      best_area = area;
      best = make_rect(std::atan2(e.y(), e.x()), along, across);
    }
  }
  return best;
}

OrientedRect min_area_rect_brute(const std::vector<Vec2>& hull) {
  const size_t n = hull.size();
  if (n < 3) return degenerate_rect(hull);
  double best_area = std::numeric_limits<double>::infinity();
  OrientedRect best;
  for (size_t i = 0; i < n; ++i) {
    const Vec2 d = hull[(i + 1) % n] - hull[i];
    if (d.norm() == 0) continue;
    const Vec2 e = d.normalized();
    const Vec2 nrm(-e.y(), e.x());
    double lo_e = 1e300, hi_e = -1e300, lo_n = 1e300, hi_n = -1e300;
    for (const Vec2& p : hull) {
      lo_e = std::min(lo_e, p.dot(e));
      hi_e = std::max(hi_e, p.dot(e));
      lo_n = std::min(lo_n, p.dot(nrm));
      hi_n = std::max(hi_n, p.dot(nrm));
    }
    const double area = (hi_e - lo_e) * (hi_n - lo_n);
    if (area < best_area) {
      best_area = area;
      best = make_rect(std::atan2(e.y(), e.x()), hi_e - lo_e, hi_n - lo_n);
    }
  }
  return best;
}

Vec2 rotate(const Vec2& p, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return {c * p.x() - s * p.y(), s * p.x() + c * p.y()};
}

Vec2 rotate90(const Vec2& p, int quarter_turns) {
  switch (((quarter_turns % 4) + 4) % 4) {
    case 1: return {-p.y(), p.x()};
    case 2: return {-p.x(), -p.y()};
    case 3: return {p.y(), -p.x()};
    default: return p;
  }
}

bool triangle_touches_cell(const Vec2& a, const Vec2& b, const Vec2& c, int i, int j) {
  const double x0 = i, x1 = i + 1.0, y0 = j, y1 = j + 1.0;
  if (std::max({a.x(), b.x(), c.x()}) < x0 || std::min({a.x(), b.x(), c.x()}) > x1) return false;
  if (std::max({a.y(), b.y(), c.y()}) < y0 || std::min({a.y(), b.y(), c.y()}) > y1) return false;
  const Vec2* v[3] = {&a, &b, &c};
  for (int k = 0; k < 3; ++k) {
    const Vec2 d = *v[(k + 1) % 3] - *v[k];
    const Vec2 nrm(-d.y(), d.x());
    if (nrm.x() == 0 && nrm.y() == 0) continue;
    double tlo = 1e300, thi = -1e300;
    for (int m = 0; m < 3; ++m) {
      const double t = nrm.dot(*v[m]);
      tlo = std::min(tlo, t);
      thi = std::max(thi, t);
    }
    const double c00 = nrm.x() * x0 + nrm.y() * y0, c10 = nrm.x() * x1 + nrm.y() * y0;
    const double c01 = nrm.x() * x0 + nrm.y() * y1, c11 = nrm.x() * x1 + nrm.y() * y1;
    const double blo = std::min({c00, c10, c01, c11}), bhi = std::max({c00, c10, c01, c11});
    if (bhi < tlo || blo > thi) return false;
  }
  return true;
}

void rasterise_triangle(const Vec2& a, const Vec2& b, const Vec2& c, Mask& mask) {
  // Row by row: the triangle's intersection with the slab y in [j, j+1] is convex; its x-range
  // [lo, hi] comes from the vertices inside the slab and the edges' crossings of y = j and y = j+1.
  // Cell i touches it when i <= hi and i + 1 >= lo (closed cells), the same as triangle_touches_cell.
  const Vec2* v[3] = {&a, &b, &c};
  const double ymin = std::min({a.y(), b.y(), c.y()}), ymax = std::max({a.y(), b.y(), c.y()});
  const int j0 = std::max(0, static_cast<int>(std::ceil(ymin)) - 1);
  const int j1 = std::min(mask.height - 1, static_cast<int>(std::floor(ymax)));
  for (int j = j0; j <= j1; ++j) {
    const double y0 = j, y1 = j + 1.0;
    double lo = 1e300, hi = -1e300;
    for (int k = 0; k < 3; ++k) {
      const Vec2& p = *v[k];
      if (p.y() >= y0 && p.y() <= y1) {
        lo = std::min(lo, p.x());
        hi = std::max(hi, p.x());
      }
      const Vec2& q = *v[(k + 1) % 3];
      if (p.y() == q.y()) continue;
      for (double yl : {y0, y1}) {
        if ((p.y() < yl && q.y() > yl) || (p.y() > yl && q.y() < yl)) {
          const double t = (yl - p.y()) / (q.y() - p.y());
          const double x = p.x() + t * (q.x() - p.x());
          lo = std::min(lo, x);
          hi = std::max(hi, x);
        }
      }
    }
    if (lo > hi) continue;
    const int i0 = std::max(0, static_cast<int>(std::ceil(lo)) - 1);
    const int i1 = std::min(mask.width - 1, static_cast<int>(std::floor(hi)));
    for (int i = i0; i <= i1; ++i) mask.set(i, j);
  }
}

Mask dilate(const Mask& m, int lo, int hi) {
  // note: as shifted ORs of whole rows (byte loops the compiler vectorises): result cell (x, y) is
  // set when some input cell (x - dx, y - dy), dx, dy in [0, r], is.
  const int r = lo + hi;
  const size_t mw = static_cast<size_t>(m.width);
  Mask out;
  out.width = m.width + r;
  out.height = m.height + r;
  const size_t ow = static_cast<size_t>(out.width);
  out.cells.assign(ow * static_cast<size_t>(out.height), 0);
  // Horizontal pass into rows 0 .. m.height - 1 of the result.
  for (int y = 0; y < m.height; ++y) {
    const uint8_t* src = m.cells.data() + static_cast<size_t>(y) * mw;
    uint8_t* dst = out.cells.data() + static_cast<size_t>(y) * ow;
    for (int d = 0; d <= r; ++d)
      for (size_t x = 0; x < mw; ++x) dst[x + static_cast<size_t>(d)] |= src[x];
  }
  // Vertical pass, top row first so each source row is read before it is changed.
  for (int y = out.height - 1; y >= 0; --y) {
    uint8_t* dst = out.cells.data() + static_cast<size_t>(y) * ow;
    for (int d = (y < m.height ? 1 : y - m.height + 1); d <= r && d <= y; ++d) {
      const uint8_t* src = out.cells.data() + static_cast<size_t>(y - d) * ow;
      for (size_t x = 0; x < ow; ++x) dst[x] |= src[x];
    }
  }
  return out;
}

}  // namespace texdefrag::packing
