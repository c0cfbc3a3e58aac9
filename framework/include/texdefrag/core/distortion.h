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
#include <map>
#include <utility>

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
  size_t flipped = 0;              ///< faces whose orientation the map reverses or collapses (within their group)
  size_t mirrored = 0;             ///< faces measured through the mirror (their group is a mirror image)
  size_t zero_area_input = 0;      ///< faces with zero original UV area (weight 0)
  double weight = 0;               ///< total original UV area (texels^2)
};

/// The mirror rule of atlas_distortion (and of eval's uv_distortion, which measures a written model
/// the same way): faces are grouped by (output chart, input chart); a group whose faces reverse
/// their input's orientation over most of its input UV area (area-weighted sign of det J < 0) while
/// its output UV triangles turn like the rest of its output chart's (area-weighted majority; neither
/// sum zero) is measured through the mirror y -> -y. Feed every measured face with add(), then ask
/// mirrored().
class MirrorGroups {
 public:
  /// One face: its output and input chart, input UV area w, map J (input -> output UV) and
  /// output UV triangle `now` (its corner order gives the turn).
  void add(int out_chart, int in_chart, double w, const Eigen::Matrix2d& J, const Vec2 now[3]);
  /// Whether the faces of group (out_chart, in_chart) are measured through the mirror.
  bool mirrored(int out_chart, int in_chart) const;

 private:
  std::map<std::pair<int, int>, std::pair<double, double>> group_sign_;  ///< (sum w sign det, sum w sign turn)
  std::map<int, double> chart_turn_;                                   ///< per output chart: sum w sign turn
};

/// Area-weighted sums of the measure over faces with input UV area w > 0; J is taken as given
/// (already through the mirror where the face's group is mirrored). det J <= 0 counts as flipped
/// and is left out of the symmetric Dirichlet mean (infinite there), not out of the ARAP mean.
struct DistortionSums {
  double arap = 0, symmetric_dirichlet = 0, symmetric_dirichlet_weight = 0, weight = 0;
  size_t flipped = 0;
  void add(double w, const Eigen::Matrix2d& J);
  double mean_arap() const { return weight > 0 ? arap / weight : 0; }
  double mean_symmetric_dirichlet() const {
    return symmetric_dirichlet_weight > 0 ? symmetric_dirichlet / symmetric_dirichlet_weight : 0;
  }
};

/// Distortion of atlas UVs (texels) against the mesh's input UVs, over textured faces.
/// A group is the faces of one input chart inside one output chart. A group laid out as a mirror
/// image of its input over most of its input UV area (area-weighted sign of det J negative) whose
/// output UV triangles turn like the rest of its output chart's (area-weighted majority) is a
/// reflected, consistently welded piece (mergers weld a chart mirrored relative to its neighbour
/// that way; it shows the same texture once resampled): it is measured through the mirror
/// y -> -y, and only its faces whose orientation still disagrees count as flipped. A group that
/// turns against its chart (a folded piece) is measured as is: its faces are flipped. Without
/// mirrored groups this is the plain per-face measure.
/// @param input_face_chart  input chart per face (ChartSet::atlas.face_chart of the input), or
///                          empty: computed from the mesh (build_topology + build_charts)
DistortionSummary atlas_distortion(const TexturedMesh& mesh, const Atlas& atlas,
                                   const std::vector<int>& input_face_chart);
/// The same with the input charts computed from the mesh.
DistortionSummary atlas_distortion(const TexturedMesh& mesh, const Atlas& atlas);

}  // namespace texdefrag
