// UV overlap predicates and counts (see texdefrag/core/uv_overlap.h). Exact predicates after J. R.
// Shewchuk, "Adaptive Precision Floating-Point Arithmetic and Fast Robust Geometric Predicates"
// (Discrete Comput. Geom. 18, 1997): a floating-point filter, then an exact sum of the
// determinant's products as a nonoverlapping expansion. Interior overlap by the separating axis
// theorem: two convex polygons have disjoint interiors iff the supporting line of an edge of one of
// them has the other in its closed outer half-plane.
#include "texdefrag/core/uv_overlap.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace texdefrag {
namespace {

int sign_of(double d) { return (d > 0) - (d < 0); }

/// Adds x to the nonoverlapping expansion e (increasing magnitude), exactly (Grow-Expansion with
/// zero elimination).
void grow_expansion(std::vector<double>& e, double x) {
  double q = x;
  size_t out = 0;
  for (size_t i = 0; i < e.size(); ++i) {
    const double s = q + e[i];
    const double bv = s - q;
    const double av = s - bv;
    const double err = (q - av) + (e[i] - bv);
    q = s;
    if (err != 0.0) e[out++] = err;
  }
  e.resize(out);
  if (q != 0.0) e.push_back(q);
}

int orient2d_exact(const Vec2& a, const Vec2& b, const Vec2& c) {
  // det = ax*by - ax*cy - cx*by - ay*bx + ay*cx + cy*bx, each product split exactly by fma.
  const double p[6][2] = {{a.x(), b.y()}, {-a.x(), c.y()}, {-c.x(), b.y()},
                          {-a.y(), b.x()}, {a.y(), c.x()}, {c.y(), b.x()}};
  std::vector<double> e;
  e.reserve(16);
  for (const auto& pr : p) {
    const double hi = pr[0] * pr[1];
    const double lo = std::fma(pr[0], pr[1], -hi);
    grow_expansion(e, lo);
    grow_expansion(e, hi);
  }
  return e.empty() ? 0 : sign_of(e.back());
}

struct Box {
  double x0, y0, x1, y1;
};

}  // namespace

int orient2d(const Vec2& a, const Vec2& b, const Vec2& c) {
  const double detleft = (a.x() - c.x()) * (b.y() - c.y());
  const double detright = (a.y() - c.y()) * (b.x() - c.x());
  const double det = detleft - detright;
  double detsum;
  if (detleft > 0) {
    if (detright <= 0) return sign_of(det);
    detsum = detleft + detright;
  } else if (detleft < 0) {
    if (detright >= 0) return sign_of(det);
    detsum = -detleft - detright;
  } else {
    return sign_of(det);
  }
  constexpr double eps = std::numeric_limits<double>::epsilon() / 2;  // Shewchuk's epsilon
  constexpr double kErrBoundA = (3.0 + 16.0 * eps) * eps;
  if (std::abs(det) >= kErrBoundA * detsum) return sign_of(det);
  return orient2d_exact(a, b, c);
}

bool triangle_interiors_overlap(const std::array<Vec2, 3>& a, const std::array<Vec2, 3>& b) {
  // note: an edge of one triangle separates when no vertex of the other lies strictly on the
  // triangle's own (interior) side of the edge's supporting line.
  auto separated_by_edges_of = [](const std::array<Vec2, 3>& t, const std::array<Vec2, 3>& o) {
    const int s = orient2d(t[0], t[1], t[2]);
    for (int k = 0; k < 3; ++k) {
      const Vec2& p = t[static_cast<size_t>(k)];
      const Vec2& q = t[static_cast<size_t>((k + 1) % 3)];
      bool inside = false;
      for (const Vec2& v : o)
        if (orient2d(p, q, v) * s > 0) {
          inside = true;
          break;
        }
      if (!inside) return true;
    }
    return false;
  };
  return !separated_by_edges_of(a, b) && !separated_by_edges_of(b, a);
}

double triangle_intersection_area(const std::array<Vec2, 3>& a, const std::array<Vec2, 3>& b) {
  const auto cross = [](const Vec2& u, const Vec2& v) { return u.x() * v.y() - u.y() * v.x(); };
  const double sb = cross(b[1] - b[0], b[2] - b[0]);
  if (sb == 0 || cross(a[1] - a[0], a[2] - a[0]) == 0) return 0;
  // Sutherland-Hodgman: keep the part of `a` on the inner side of each edge of `b`.
  std::vector<Vec2> poly(a.begin(), a.end()), out;
  for (size_t k = 0; k < 3 && !poly.empty(); ++k) {
    const Vec2& p = b[k];
    const Vec2 e = b[(k + 1) % 3] - p;
    const auto side = [&](const Vec2& v) { return sb > 0 ? cross(e, v - p) : -cross(e, v - p); };
    out.clear();
    for (size_t i = 0; i < poly.size(); ++i) {
      const Vec2& u = poly[i];
      const Vec2& v = poly[(i + 1) % poly.size()];
      const double su = side(u), sv = side(v);
      if (su >= 0) out.push_back(u);
      if ((su >= 0) != (sv >= 0)) out.push_back(u + (v - u) * (su / (su - sv)));
    }
    poly.swap(out);
  }
  double twice = 0;
  for (size_t i = 0; i < poly.size(); ++i) twice += cross(poly[i], poly[(i + 1) % poly.size()]);
  return std::abs(twice) / 2;
}

size_t count_overlapping_pairs(const std::vector<std::array<Vec2, 3>>& all, double min_area) {
  std::vector<const std::array<Vec2, 3>*> tris;
  tris.reserve(all.size());
  for (const auto& t : all)
    if (orient2d(t[0], t[1], t[2]) != 0) tris.push_back(&t);
  const size_t n = tris.size();
  if (n < 2) return 0;

  std::vector<Box> box(n);
  Box ext{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
          -std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  double mean_extent = 0;
  for (size_t i = 0; i < n; ++i) {
    const auto& t = *tris[i];
    Box& b = box[i];
    b.x0 = std::min({t[0].x(), t[1].x(), t[2].x()});
    b.x1 = std::max({t[0].x(), t[1].x(), t[2].x()});
    b.y0 = std::min({t[0].y(), t[1].y(), t[2].y()});
    b.y1 = std::max({t[0].y(), t[1].y(), t[2].y()});
    ext.x0 = std::min(ext.x0, b.x0);
    ext.y0 = std::min(ext.y0, b.y0);
    ext.x1 = std::max(ext.x1, b.x1);
    ext.y1 = std::max(ext.y1, b.y1);
    mean_extent += std::max(b.x1 - b.x0, b.y1 - b.y0);
  }
  mean_extent /= static_cast<double>(n);

  // Uniform grid, cell about the mean triangle extent, at most ~4 cells per triangle.
  const double w = std::max(ext.x1 - ext.x0, 1e-300), h = std::max(ext.y1 - ext.y0, 1e-300);
  double cell = std::max(mean_extent, std::sqrt(w * h / (4.0 * static_cast<double>(n))));
  if (!(cell > 0) || !std::isfinite(cell)) cell = std::max(w, h);
  const auto dim = [&](double len) { return std::max<long long>(1, std::min<long long>(1 << 20, static_cast<long long>(len / cell) + 1)); };
  const long long nx = dim(w), ny = dim(h);
  const auto cx = [&](double x) { return std::min(nx - 1, std::max(0LL, static_cast<long long>((x - ext.x0) / cell))); };
  const auto cy = [&](double y) { return std::min(ny - 1, std::max(0LL, static_cast<long long>((y - ext.y0) / cell))); };

  // Buckets as CSR: cell -> triangles whose bounding box touches it.
  std::vector<size_t> start(static_cast<size_t>(nx * ny) + 1, 0);
  for (size_t i = 0; i < n; ++i)
    for (long long y = cy(box[i].y0); y <= cy(box[i].y1); ++y)
      for (long long x = cx(box[i].x0); x <= cx(box[i].x1); ++x) ++start[static_cast<size_t>(y * nx + x) + 1];
  for (size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
  std::vector<uint32_t> items(start.back());
  {
    std::vector<size_t> fill(start.begin(), start.end() - 1);
    for (size_t i = 0; i < n; ++i)
      for (long long y = cy(box[i].y0); y <= cy(box[i].y1); ++y)
        for (long long x = cx(box[i].x0); x <= cx(box[i].x1); ++x)
          items[fill[static_cast<size_t>(y * nx + x)]++] = static_cast<uint32_t>(i);
  }

  size_t count = 0;
  for (long long y = 0; y < ny; ++y)
    for (long long x = 0; x < nx; ++x) {
      const size_t c = static_cast<size_t>(y * nx + x);
      for (size_t p = start[c]; p < start[c + 1]; ++p)
        for (size_t q = p + 1; q < start[c + 1]; ++q) {
          const Box& a = box[items[p]];
          const Box& b = box[items[q]];
          // Interiors can only meet when the boxes overlap with positive area.
          if (!(a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1)) continue;
          // Test each pair once: in the cell holding the low corner of the boxes' intersection.
          if (cx(std::max(a.x0, b.x0)) != x || cy(std::max(a.y0, b.y0)) != y) continue;
          if (!triangle_interiors_overlap(*tris[items[p]], *tris[items[q]])) continue;
          if (min_area > 0 && triangle_intersection_area(*tris[items[p]], *tris[items[q]]) <= min_area) continue;
          ++count;
        }
    }
  return count;
}

}  // namespace texdefrag
