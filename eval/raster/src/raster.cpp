// Triangle setup of the shared rasteriser (raster.h): pixel box, signed area, canonical edge order
// and the top-left rule.
#include "texdefrag/eval/raster.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace texdefrag::raster {
namespace {

/// Lexicographic order of the corners' (x, y): the canonical direction of an edge.
bool before(const Vec3& a, const Vec3& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); }

/// First and last pixel index whose centre (i + 0.5) can lie in [lo, hi], clipped to [0, n - 1].
void pixel_range(double lo, double hi, int n, int& first, int& last) {
  first = static_cast<int>(std::clamp(std::floor(lo), 0.0, static_cast<double>(n)));
  last = static_cast<int>(std::clamp(std::ceil(hi), -1.0, static_cast<double>(n - 1)));
}

}  // namespace

TriangleSetup setup_triangle(const std::array<Vec3, 3>& t, int width, int height) {
  TriangleSetup s;
  s.t = t;
  s.area = (t[1].x() - t[0].x()) * (t[2].y() - t[0].y()) - (t[1].y() - t[0].y()) * (t[2].x() - t[0].x());
  if (s.area == 0 || !std::isfinite(s.area) || width <= 0 || height <= 0) return s;
  for (const Vec3& c : t)
    if (!c.allFinite()) return s;
  const double orient = s.area > 0 ? 1.0 : -1.0;
  for (size_t k = 0; k < 3; ++k) {
    const int a = static_cast<int>((k + 1) % 3), b = static_cast<int>((k + 2) % 3);  // edge a -> b of the given order
    const bool keep = !before(t[static_cast<size_t>(b)], t[static_cast<size_t>(a)]);
    s.from[k] = keep ? a : b;
    s.to[k] = keep ? b : a;
    s.sign[k] = keep ? orient : -orient;
    // The edge in the positive orientation: a -> b when the area is positive, b -> a otherwise.
    const Vec3 d = orient * (t[static_cast<size_t>(b)] - t[static_cast<size_t>(a)]);
    s.owns[k] = d.y() < 0 || (d.y() == 0 && d.x() < 0);
  }
  pixel_range(std::min({t[0].x(), t[1].x(), t[2].x()}), std::max({t[0].x(), t[1].x(), t[2].x()}), width, s.x0, s.x1);
  pixel_range(std::min({t[0].y(), t[1].y(), t[2].y()}), std::max({t[0].y(), t[1].y(), t[2].y()}), height, s.y0, s.y1);
  s.empty = s.x0 > s.x1 || s.y0 > s.y1;
  return s;
}

DepthBuffer::DepthBuffer(int width, int height) : width_(width), height_(height) {
  if (width < 0 || height < 0) throw std::invalid_argument("DepthBuffer: negative size");
  depth_.assign(static_cast<size_t>(width) * static_cast<size_t>(height), -std::numeric_limits<double>::infinity());
}

}  // namespace texdefrag::raster
