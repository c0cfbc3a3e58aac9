// Overlap of UV triangles: the exact test and a grid-accelerated count. Used by the framework's
// check after packing (no overlaps beyond the input's) and by eval's `uv_overlaps` measure.
#pragma once

#include "texdefrag/core/mesh.h"

#include <array>
#include <cstddef>
#include <vector>

namespace texdefrag {

/// Texels^2: the framework's contract checks (pipeline: no stage may add overlapping UV triangle pairs)
/// count a pair only when its overlap area exceeds this. Moving a chart (a translation, a quarter
/// turn, a free rotation, a rigid alignment) rounds its coordinates, and the exact predicates then
/// see faces of zero UV area turn into slivers and faces that touch along an unwelded edge cross by
/// ~1e-13 texels^2 (issue 12, Cedar Creek: every pair a packer added there measured <= 1e-8
/// texels^2); such a pair covers no texel. Genuine overlaps start orders of magnitude higher (the
/// smallest a merger added there: ~1e-4 texels^2). Mergers use it to tell which pairs they add.
constexpr double kCountedOverlapArea = 1e-6;

/// Number of pairs of triangles whose interiors intersect. Triangles sharing only an edge or a
/// vertex do not overlap; triangles of zero area (exactly collinear corners) never count.
/// Exact: orientation predicates with an exact fallback. Broad phase: a uniform grid; O(n) for
/// evenly sized triangles (100k triangles in well under a second).
/// tris: triangles in any 2D units (for an atlas: texels of one page); may be empty.
/// min_area: a pair counts only when the area of its intersection (triangle_intersection_area)
/// exceeds this, in the squared units of `tris`; 0 (default): every interior intersection counts.
size_t count_overlapping_pairs(const std::vector<std::array<Vec2, 3>>& tris, double min_area = 0);

/// Area of the intersection of two triangles (any orientation; 0 when either has zero area), by
/// clipping one with the other's edges in double precision: accurate to about the rounding of the
/// coordinates times the triangles' extent (area units of the inputs).
double triangle_intersection_area(const std::array<Vec2, 3>& a, const std::array<Vec2, 3>& b);

/// Sign of the orientation of (a, b, c): +1 counter-clockwise, -1 clockwise, 0 collinear. Exact for
/// all finite inputs (floating-point filter, then exact expansion arithmetic).
int orient2d(const Vec2& a, const Vec2& b, const Vec2& c);

/// True when the interiors of two non-degenerate triangles intersect (exact).
/// a, b: triangles, any orientation; callers must exclude zero-area ones.
bool triangle_interiors_overlap(const std::array<Vec2, 3>& a, const std::array<Vec2, 3>& b);

}  // namespace texdefrag
