// The software rasteriser of the eval harness (docs/eval.md, "The rasteriser"): scan conversion
// of triangles in pixel coordinates with the top-left fill rule and an optional z-buffer. The
// rendered-view fidelity (eval/metrics), the texel clashes' chart maps (eval/metrics) and the
// bench's chart views and 3D renders (eval/bench) all draw through it.
//
// Conventions: pixel (x, y) is the unit square [x, x+1) x [y, y+1); it is covered by a triangle
// when its centre (x + 0.5, y + 0.5) is inside, or on an edge the triangle owns. Ownership follows
// the top-left rule in the triangle's positive orientation (corners turning so that the signed
// area (t1 - t0) x (t2 - t0) is positive): an edge a -> b is owned when b.y < a.y, or b.y == a.y and
// b.x < a.x. Two triangles sharing an edge (the same two corner positions, bit for bit) and lying
// on its two sides therefore never both cover, and never both miss, a pixel centre on it: the
// edge function of every edge is evaluated in one canonical corner order, so its value at a
// point is the same number for both triangles up to its sign. Which axis points "up" does not
// matter to this guarantee (both y-down screens and y-up texel grids use it).
#pragma once

#include "texdefrag/core/mesh.h"

#include <array>
#include <limits>
#include <vector>

namespace texdefrag::raster {

/// A covered pixel: column, row, barycentric coordinates of its centre with respect to the
/// triangle's corners in the order given (they sum to 1), and the depth interpolated from the
/// corners' z.
struct Fragment {
  int x = 0, y = 0;
  std::array<double, 3> bary{};
  double z = 0;
};

/// What scan_triangle needs of a triangle, computed once: its clipped pixel box, signed area and
/// edges in canonical order (see the file comment).
struct TriangleSetup {
  bool empty = true;          ///< zero or non-finite area, or no pixel centre in the image's box
  int x0 = 0, x1 = -1, y0 = 0, y1 = -1;  ///< pixel box to test, clipped to the image
  std::array<Vec3, 3> t;      ///< the corners (x, y in pixels, z depth)
  double area = 0;            ///< (t1 - t0) x (t2 - t0), non-zero when !empty
  /// Edge k (opposite corner k) runs between corners k+1 and k+2; its edge function is evaluated
  /// from corner from[k] to corner to[k] (canonical order) and multiplied by sign[k] so that it is
  /// positive inside the triangle.
  std::array<int, 3> from{}, to{};
  std::array<double, 3> sign{};
  std::array<bool, 3> owns{};  ///< top-left rule: centres exactly on edge k are inside
};

/// The setup of triangle `t` (x, y in pixels, z depth) for an image of width x height pixels.
TriangleSetup setup_triangle(const std::array<Vec3, 3>& t, int width, int height);

/// Calls visit(const Fragment&) for every pixel of a width x height image that triangle `t`
/// covers (top-left rule), row by row. Degenerate (zero-area) and non-finite triangles cover
/// nothing.
template <class Visit>
void scan_triangle(const std::array<Vec3, 3>& t, int width, int height, Visit&& visit) {
  const TriangleSetup s = setup_triangle(t, width, height);
  if (s.empty) return;
  Fragment fr;
  for (int y = s.y0; y <= s.y1; ++y)
    for (int x = s.x0; x <= s.x1; ++x) {
      const double cx = x + 0.5, cy = y + 0.5;
      bool inside = true;
      for (size_t k = 0; k < 3 && inside; ++k) {
        const Vec3& a = s.t[static_cast<size_t>(s.from[k])];
        const Vec3& b = s.t[static_cast<size_t>(s.to[k])];
        const double e = s.sign[k] * ((b.x() - a.x()) * (cy - a.y()) - (b.y() - a.y()) * (cx - a.x()));
        inside = e > 0 || (e == 0 && s.owns[k]);
      }
      if (!inside) continue;
      fr.x = x, fr.y = y;
      // Barycentrics from the edges in the given corner order (the canonical value only decides
      // coverage), so they and the depth do not depend on which corner comes first in x.
      for (size_t k = 0; k < 3; ++k) {
        const Vec3& a = s.t[(k + 1) % 3];
        const Vec3& b = s.t[(k + 2) % 3];
        fr.bary[k] = ((b.x() - a.x()) * (cy - a.y()) - (b.y() - a.y()) * (cx - a.x())) / s.area;
      }
      fr.z = fr.bary[0] * s.t[0].z() + fr.bary[1] * s.t[1].z() + fr.bary[2] * s.t[2].z();
      visit(static_cast<const Fragment&>(fr));
    }
}

/// A z-buffer over a width x height image: larger z is nearer; a fragment is drawn when it is
/// strictly nearer than every earlier one at its pixel (so of equal depths the first stays).
class DepthBuffer {
 public:
  DepthBuffer(int width, int height);
  int width() const { return width_; }
  int height() const { return height_; }
  /// Depth stored at (x, y): -infinity where nothing was drawn.
  double depth(int x, int y) const { return depth_[index(x, y)]; }
  /// Scan-converts `t` (scan_triangle) and calls visit(const Fragment&) for each fragment nearer
  /// than the stored depth, after storing its depth.
  template <class Visit>
  void draw(const std::array<Vec3, 3>& t, Visit&& visit) {
    scan_triangle(t, width_, height_, [&](const Fragment& f) {
      double& d = depth_[index(f.x, f.y)];
      if (!(f.z > d)) return;
      d = f.z;
      visit(f);
    });
  }

 private:
  size_t index(int x, int y) const { return static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x); }
  int width_ = 0, height_ = 0;
  std::vector<double> depth_;
};

}  // namespace texdefrag::raster
