// Plane fitting and the Comprehensive Planarity Index (Liu et al. 2024, section 2.1, Eq. 1-3).
#include "common/planarity.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace texdefrag::detectors {

void PlaneMoments::add(const PlaneMoments& o) {
  area += o.area;
  first += o.first;
  second += o.second;
  normal_sum += o.normal_sum;
  faces += o.faces;
}

void PlaneMoments::add_triangle(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a);
  const double A = 0.5 * n.norm();
  const Vec3 s = a + b + c;
  // note: exact integrals over the triangle: int p dA = A s/3,
  // int p p^T dA = A/12 (a a^T + b b^T + c c^T + s s^T).
  area += A;
  first += A * s / 3.0;
  second += A / 12.0 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  normal_sum += 0.5 * n;
  ++faces;
}

PlaneMoments face_moments(const TexturedMesh& mesh, size_t f, const Vec3& ref) {
  PlaneMoments m;
  m.add_triangle(mesh.corner_position(f, 0) - ref, mesh.corner_position(f, 1) - ref,
                 mesh.corner_position(f, 2) - ref);
  return m;
}

PlaneFit fit_plane(const PlaneMoments& m) {
  PlaneFit fit;
  if (!(m.area > 0)) return fit;
  const Vec3 mu = m.first / m.area;
  Eigen::Matrix3d cov = m.second / m.area - mu * mu.transpose();
  cov = 0.5 * (cov + cov.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(cov);
  fit.valid = true;
  fit.centroid = mu;
  fit.eigenvalues = es.eigenvalues().cwiseMax(0.0);
  fit.normal = es.eigenvectors().col(0).normalized();
  if (fit.normal.dot(m.normal_sum) < 0) fit.normal = -fit.normal;
  return fit;
}

double plane_rms_distance(const PlaneMoments& m, const Vec3& point, const Vec3& normal) {
  if (!(m.area > 0)) return 0;
  // integral((p.n - c.n)^2) = n^T M2 n - 2 (c.n)(M1.n) + A (c.n)^2
  const double cn = point.dot(normal);
  const double ss = normal.dot(m.second * normal) - 2 * cn * m.first.dot(normal) + m.area * cn * cn;
  return std::sqrt(std::max(0.0, ss / m.area));
}

double normal_angle(const Vec3& a, const Vec3& b) {
  const double na = a.norm(), nb = b.norm();
  if (!(na > 0) || !(nb > 0)) return M_PI / 2;
  // note: atan2 of |cross| and dot is accurate near 0 and pi, where acos is not.
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

double flatness_term(double s1, double s2) {
  if (!(s2 > 0)) return 0;
  return std::clamp(1.0 - s1 / s2, 0.0, 1.0);
}

double compactness_term(double s2, double s3) {
  if (!(s3 > 0)) return 0;
  return std::clamp(s2 / s3, 0.0, 1.0);
}

double normal_consistency_term(double theta) {
  if (theta >= M_PI / 2) return 0;
  return 1.0 - std::sin(std::max(theta, 0.0));
}

double planarity_index(const PlaneFit& fit, double theta, const CpiWeights& w) {
  if (!fit.valid) return 0;
  const Vec3& s = fit.eigenvalues;
  return w.flatness * flatness_term(s[0], s[1]) + w.compactness * compactness_term(s[1], s[2]) +
         w.normal * normal_consistency_term(theta);
}

}  // namespace texdefrag::detectors
