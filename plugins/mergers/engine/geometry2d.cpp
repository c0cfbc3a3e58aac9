// Rigid 2D registration (Kabsch 1976 / Umeyama 1991 restricted to rotations) and the segment
// crossing test behind the merge engine's self-overlap check.
#include "geometry2d.h"

#include <algorithm>
#include <cmath>

namespace texdefrag::merge {

using Eigen::Vector2d;

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

bool any_crossing(const std::vector<Segment>& moved, const std::vector<Segment>& all) {
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
  std::vector<std::vector<int>> grid(static_cast<size_t>(nx) * static_cast<size_t>(ny));
  auto cell_range = [&](const Segment& s, int& x0, int& x1, int& y0, int& y1) {
    const Vector2d a = s.a.cwiseMin(s.b), b = s.a.cwiseMax(s.b);
    x0 = std::max(0, static_cast<int>(std::floor((a.x() - lo.x()) / cell)));
    y0 = std::max(0, static_cast<int>(std::floor((a.y() - lo.y()) / cell)));
    x1 = std::min(nx - 1, static_cast<int>(std::floor((b.x() - lo.x()) / cell)));
    y1 = std::min(ny - 1, static_cast<int>(std::floor((b.y() - lo.y()) / cell)));
  };
  for (size_t i = 0; i < moved.size(); ++i) {
    int x0, x1, y0, y1;
    cell_range(moved[i], x0, x1, y0, y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x)
        grid[static_cast<size_t>(y) * static_cast<size_t>(nx) + static_cast<size_t>(x)].push_back(static_cast<int>(i));
  }
  auto test = [&](const Segment& s) {
    const Vector2d a = s.a.cwiseMin(s.b), b = s.a.cwiseMax(s.b);
    if (b.x() < lo.x() || b.y() < lo.y() || a.x() > hi.x() || a.y() > hi.y()) return false;
    int x0, x1, y0, y1;
    cell_range(s, x0, x1, y0, y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x)
        for (int i : grid[static_cast<size_t>(y) * static_cast<size_t>(nx) + static_cast<size_t>(x)]) {
          const Segment& m = moved[static_cast<size_t>(i)];
          if (skip_pair(s, m)) continue;
          if (segments_cross(s.a, s.b, m.a, m.b)) return true;
        }
    return false;
  };
  for (const Segment& s : all)
    if (test(s)) return true;
  for (const Segment& s : moved)
    if (test(s)) return true;
  return false;
}

}  // namespace texdefrag::merge
