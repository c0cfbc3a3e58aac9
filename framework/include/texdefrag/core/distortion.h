// Distortion of a UV map against the input UVs (../shared/docs/METHOD.md section 3). Shared by the
// mergers (acceptance tests) and eval (reported metrics), so both measure the same thing.
//
// Per face, J is the 2x2 linear part of the affine map from the ORIGINAL UV triangle (texels of
// its input page) to the NEW UV triangle (texels); s1 >= s2 its singular values (signed: s2 < 0
// when the map flips orientation).
//   ARAP error       (s1 - 1)^2 + (s2 - 1)^2
//   symmetric Dirichlet  s1^2 + s2^2 + s1^-2 + s2^-2  (infinite for flipped or collapsed faces)
// Both are weighted by the original UV area; faces with zero original UV area have weight 0 and
// are counted separately.
#pragma once

#include "texdefrag/core/charts.h"
#include "texdefrag/core/mesh.h"

#include <Eigen/Core>

namespace texdefrag {

/// Jacobian of the map original -> now. Returns false when the original triangle has zero area.
bool uv_jacobian(const Vec2 orig[3], const Vec2 now[3], Eigen::Matrix2d& J);
/// Signed singular values (s1 >= |s2|, s2 negative when det J < 0).
Eigen::Vector2d signed_singular_values(const Eigen::Matrix2d& J);
double arap_error(const Eigen::Matrix2d& J);
/// +infinity when det J <= 0.
double symmetric_dirichlet(const Eigen::Matrix2d& J);

struct DistortionSummary {
  double arap = 0;                 ///< area-weighted mean ARAP error
  double symmetric_dirichlet = 0;  ///< area-weighted mean over non-flipped faces
  size_t flipped = 0;              ///< faces whose orientation the map reverses or collapses
  size_t zero_area_input = 0;      ///< faces with zero original UV area (weight 0)
  double weight = 0;               ///< total original UV area (texels^2)
};

/// Distortion of atlas UVs (texels) against the mesh's input UVs, over textured faces.
DistortionSummary atlas_distortion(const TexturedMesh& mesh, const Atlas& atlas);

}  // namespace texdefrag
