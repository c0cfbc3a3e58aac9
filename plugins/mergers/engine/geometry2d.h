// Small 2D geometry used by the merge engine: least-squares rigid fit and segment crossing tests.
#pragma once

#include <Eigen/Core>

#include <array>
#include <functional>
#include <vector>

namespace texdefrag::merge {

/// A rigid 2D motion x -> R x + t (R orthogonal: a rotation, det +1, or for fit_improper a
/// reflection, det -1).
struct Rigid2 {
  Eigen::Matrix2d R = Eigen::Matrix2d::Identity();
  Eigen::Vector2d t = Eigen::Vector2d::Zero();
  Eigen::Vector2d operator()(const Eigen::Vector2d& x) const { return R * x + t; }
};

/// Least-squares rigid motion (rotation + translation, never a reflection) taking p[i] to q[i]:
/// argmin sum |R p_i + t - q_i|^2 (2D Kabsch; the rotation angle is atan2 of the cross/dot sums,
/// which is the SVD solution with the determinant fixed to +1).
/// @param p  source points (any count >= 1; with one point R is the identity)
/// @param q  target points, same count as p
Rigid2 fit_rigid(const std::vector<Eigen::Vector2d>& p, const std::vector<Eigen::Vector2d>& q);

/// Least-squares improper rigid motion (a reflection, then rotation + translation; det R = -1)
/// taking p[i] to q[i]: fit_rigid of the points mirrored y -> -y, composed with that mirror.
/// @param p  source points (any count >= 1)
/// @param q  target points, same count as p
Rigid2 fit_improper(const std::vector<Eigen::Vector2d>& p, const std::vector<Eigen::Vector2d>& q);

/// Twice the signed area of (a, b, c): > 0 when counter-clockwise.
inline double orient2d(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

/// True when segments [a, b] and [c, d] cross at a single interior point of both (proper
/// crossing). Touching at an endpoint or collinear contact is not a crossing.
bool segments_cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                    const Eigen::Vector2d& d);

/// A segment between two wedges (its endpoints' ids let callers skip adjacent segments).
struct Segment {
  int w0 = -1, w1 = -1;
  Eigen::Vector2d a, b;
  int edge = -1;  ///< callers' tag (the engine: 3 x face + local edge; -1: none)
};

/// Whether any segment of `moved` properly crosses any segment of `all` (or another of `moved`),
/// ignoring pairs that share a wedge id or an endpoint position (within 1e-7 of the longer length). Uniform grid over the moved
/// segments' bounding box: O((|all| + |moved|) * segments per cell).
/// @param moved  segments whose positions changed (tested against everything)
/// @param all    the other segments of the same chart (may include the moved ones)
/// @param is_new optional: a crossing pair counts only when is_new(a, b) is true
bool any_crossing(const std::vector<Segment>& moved, const std::vector<Segment>& all,
                  const std::function<bool(const Segment&, const Segment&)>& is_new = {});

/// A triangle with the wedge ids of its corners (shared ids mark adjacency).
struct Tri2 {
  std::array<int, 3> w{-1, -1, -1};
  std::array<Eigen::Vector2d, 3> p;
  int face = -1;  ///< the mesh face it is (callers' tag; -1: none)
};

/// True when the interiors of a and b intersect: two edges cross properly, a corner of one that is
/// not a corner of the other lies strictly inside it, or (sharing an edge) both lie on the same side
/// of it. Corners are shared when their wedge ids are equal.
bool triangles_overlap(const Tri2& a, const Tri2& b);

/// Whether any triangle of `moved` overlaps (triangles_overlap) another triangle of `moved` or any
/// triangle of `all` (entries of `all` equal to a moved triangle, by wedge ids, are skipped). Uniform
/// grid over the moved triangles' bounding box.
/// @param moved  triangles whose positions changed
/// @param all    the other triangles of the same chart
/// @param rigid  moved[0, rigid) moved together rigidly and are known not to overlap each other (the
///               caller's invariant): pairs within that prefix are not tested (0: test every pair)
/// @param is_new optional: an overlapping pair counts only when is_new(a, b) is true (e.g. the pair did
///               not overlap before a move); pairs it dismisses are skipped and the search goes on
bool any_triangle_overlap(const std::vector<Tri2>& moved, const std::vector<Tri2>& all, size_t rigid = 0,
                          const std::function<bool(const Tri2&, const Tri2&)>& is_new = {});

/// Ear-clipping triangulation of a simple polygon (no repeated corner, no crossing edges), in
/// either orientation: every triangle has the polygon's orientation and a positive area
/// (|orient2d| > 0), corners index `poly`; n - 2 triangles. Returns false (out unspecified) when the
/// polygon has fewer than 3 corners, zero area, or no ear can be cut (it is not simple). O(n^2) for
/// polygons whose ears are found early, O(n^3) at worst: callers bound n.
bool ear_clip(const std::vector<Eigen::Vector2d>& poly, std::vector<std::array<int, 3>>& out);

}  // namespace texdefrag::merge
