// Planar geometry for the packers: convex hull, exact minimum-area bounding rectangle (rotating
// calipers, Toussaint 1983 / Freeman & Shapira 1975: the optimal rectangle has one side collinear
// with a hull edge), exact 90-degree rotations, and conservative rasterisation of triangles onto
// the texel grid.
//
// Grid convention: cell (i, j) is the closed square [i, i+1] x [j, j+1] in texels (y up). A
// triangle covers a cell when they intersect (touching counts), so covered cells contain the whole
// triangle. A shape's footprint is the cell box [floor(min), ceil(max)) of its bounding box (at
// least one cell per axis): every point of the shape lies in the union of its closed cells, and a
// shape whose corners are whole texels covers exactly its area (a 10 x 4 rectangle at integer
// corners is 10 x 4 cells). Outlines are rasterised clipped to the footprint, so two footprints
// `g` empty cells apart keep their shapes at least g texels apart.
#pragma once

#include "texdefrag/core/mesh.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace texdefrag::packing {

/// Convex hull by Andrew's monotone chain.
/// points: any number, duplicates allowed, consumed (taken by value).
/// Returns the hull counter-clockwise without collinear points; 0, 1 or 2 points when the input
/// has fewer than 3 non-collinear points (2: the segment's ends).
std::vector<Vec2> convex_hull(std::vector<Vec2> points);

/// A rectangle of any orientation.
struct OrientedRect {
  double angle = 0;   ///< radians: direction of the rectangle's `width` side from the +x axis, in [0, pi/2)
  double width = 0;   ///< texels, along `angle`
  double height = 0;  ///< texels, perpendicular to `angle`
  double area() const { return width * height; }
};

/// Exact minimum-area enclosing rectangle of a convex polygon by rotating calipers, O(n).
/// hull: counter-clockwise convex polygon as returned by convex_hull (any size; 0-2 points give a
/// degenerate rectangle of zero area aligned with the points).
/// Returns the rectangle; rotating the points by -angle makes it axis-aligned with size width x height.
OrientedRect min_area_rect(const std::vector<Vec2>& hull);

/// Reference implementation: tries every hull edge direction with a full projection, O(n^2).
/// Used by tests to check min_area_rect. Same contract.
OrientedRect min_area_rect_brute(const std::vector<Vec2>& hull);

/// Rotation of p by `angle` radians counter-clockwise about the origin.
Vec2 rotate(const Vec2& p, double angle);

/// Rotation of p by quarter_turns * 90 degrees counter-clockwise; exact (only swaps and negations).
/// quarter_turns: any integer (taken modulo 4).
Vec2 rotate90(const Vec2& p, int quarter_turns);

/// True when the closed triangle (a, b, c) intersects the closed cell [i, i+1] x [j, j+1].
/// Works for degenerate triangles (segments, points) as well.
bool triangle_touches_cell(const Vec2& a, const Vec2& b, const Vec2& c, int i, int j);

/// A binary raster of cells, row-major, row 0 at the bottom (y up).
struct Mask {
  int width = 0, height = 0;
  std::vector<uint8_t> cells;  ///< width*height, 1 = covered
  bool at(int x, int y) const { return cells[static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x)] != 0; }
  void set(int x, int y) { cells[static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x)] = 1; }
};

/// Marks the cells of `mask` touched by triangle (a, b, c), given in the mask's cell coordinates
/// (cell (0,0) is [0,1]^2). Cells outside the mask are ignored.
void rasterise_triangle(const Vec2& a, const Vec2& b, const Vec2& c, Mask& mask);

/// Box dilation: the result has size (w + lo + hi) x (h + lo + hi); input cell (x, y) marks every
/// result cell (x + dx, y + dy) with dx, dy in [0, lo + hi]. Two masks dilated this way and placed
/// without overlap keep at least lo + hi empty cells between their original cells.
/// lo, hi: >= 0 cells.
Mask dilate(const Mask& m, int lo, int hi);

}  // namespace texdefrag::packing
