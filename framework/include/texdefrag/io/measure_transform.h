// Node transforms and what texdefrag measures (docs/io.md, "Node transforms").
//
// Readers of scene formats (OSGB MatrixTransform, glTF node matrices) keep every position as the
// file stores it, local to its node, and writers write the stored arrays back untouched. But the
// user sees a mesh through its node transforms, and a merge's distortion, a face's 3D area (texel
// density) and seam lengths must be measured in those positions. Only the transform's linear part
// M matters (a translation changes no length, angle or area), and of M only the symmetric factor S
// of its polar decomposition M = R S (R orthogonal: a rotation or a reflection, which changes no
// length either). So a reader multiplies a node's local positions by S: the mesh's lengths, angles
// and areas are then exactly those the user sees, while a rigid transform (a rotation, the glTF
// y-up turn, a geo-reference frame: S = identity) leaves the positions bit for bit as stored.
#pragma once

#include "texdefrag/core/mesh.h"

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace texdefrag {

using Mat3 = Eigen::Matrix3d;

/// S of the polar decomposition M = R S (S = V diag(sigma) V^T from M = U diag(sigma) V^T),
/// snapped to exactly the identity when every singular value is within 1e-9 of 1 (M rigid).
Mat3 stretch_part(const Mat3& m);

/// True when `s` is exactly the identity (nothing to apply).
bool is_identity(const Mat3& s);

/// positions[first..] = S * positions[first..]; no change at all when S is the identity.
/// Returns the number of positions changed (0 or positions.size() - first).
size_t apply_stretch(std::vector<Vec3>& positions, size_t first, const Mat3& s);

}  // namespace texdefrag
