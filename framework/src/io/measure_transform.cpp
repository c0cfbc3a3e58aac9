// See texdefrag/io/measure_transform.h.
#include "texdefrag/io/measure_transform.h"

#include <Eigen/SVD>

#include <cmath>

namespace texdefrag {

Mat3 stretch_part(const Mat3& m) {
  const Eigen::JacobiSVD<Mat3> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d sigma = svd.singularValues();
  if ((sigma.array() - 1.0).abs().maxCoeff() <= 1e-9) return Mat3::Identity();
  return svd.matrixV() * sigma.asDiagonal() * svd.matrixV().transpose();
}

bool is_identity(const Mat3& s) { return s == Mat3::Identity(); }

size_t apply_stretch(std::vector<Vec3>& positions, size_t first, const Mat3& s) {
  if (is_identity(s) || first >= positions.size()) return 0;
  for (size_t i = first; i < positions.size(); ++i) positions[i] = s * positions[i];
  return positions.size() - first;
}

}  // namespace texdefrag
