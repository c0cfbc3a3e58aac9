#include "texdefrag/core/distortion.h"

#include <Eigen/LU>
#include <Eigen/SVD>
#include <cmath>
#include <limits>

namespace texdefrag {

bool uv_jacobian(const Vec2 orig[3], const Vec2 now[3], Eigen::Matrix2d& J) {
  Eigen::Matrix2d A, B;
  A.col(0) = orig[1] - orig[0];
  A.col(1) = orig[2] - orig[0];
  B.col(0) = now[1] - now[0];
  B.col(1) = now[2] - now[0];
  const double d = A.determinant();
  if (d == 0.0 || !std::isfinite(d)) return false;
  J = B * A.inverse();
  return true;
}

Eigen::Vector2d signed_singular_values(const Eigen::Matrix2d& J) {
  Eigen::JacobiSVD<Eigen::Matrix2d> svd(J);
  Eigen::Vector2d s = svd.singularValues();
  if (J.determinant() < 0) s.y() = -s.y();
  return s;
}

double arap_error(const Eigen::Matrix2d& J) {
  const Eigen::Vector2d s = signed_singular_values(J);
  return (s.x() - 1) * (s.x() - 1) + (s.y() - 1) * (s.y() - 1);
}

double symmetric_dirichlet(const Eigen::Matrix2d& J) {
  if (J.determinant() <= 0) return std::numeric_limits<double>::infinity();
  const Eigen::Vector2d s = signed_singular_values(J);
  return s.x() * s.x() + s.y() * s.y() + 1 / (s.x() * s.x()) + 1 / (s.y() * s.y());
}

DistortionSummary atlas_distortion(const TexturedMesh& mesh, const Atlas& atlas) {
  DistortionSummary r;
  double wsd = 0;
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    if (mesh.faces[f].page == kNoPage || atlas.face_wedge[f][0] < 0) continue;
    Vec2 o[3], n[3];
    for (int k = 0; k < 3; ++k) {
      o[k] = mesh.corner_texel(f, k);
      n[k] = atlas.wedge_uv[static_cast<size_t>(atlas.face_wedge[f][static_cast<size_t>(k)])];
    }
    const double w = 0.5 * std::abs((o[1] - o[0]).x() * (o[2] - o[0]).y() - (o[1] - o[0]).y() * (o[2] - o[0]).x());
    Eigen::Matrix2d J;
    if (w == 0 || !uv_jacobian(o, n, J)) {
      ++r.zero_area_input;
      continue;
    }
    const double det = J.determinant();
    if (det <= 0) ++r.flipped;
    r.arap += w * arap_error(J);
    r.weight += w;
    if (det > 0) {
      r.symmetric_dirichlet += w * symmetric_dirichlet(J);
      wsd += w;
    }
  }
  if (r.weight > 0) r.arap /= r.weight;
  if (wsd > 0) r.symmetric_dirichlet /= wsd;
  return r;
}

}  // namespace texdefrag
