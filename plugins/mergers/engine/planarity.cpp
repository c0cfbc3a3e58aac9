// Comprehensive Planarity Index: Liu, Ke, Xiao, Wu et al., "Planar feature-preserving texture
// defragmentation method for 3D urban building models", Remote Sensing 16(22) 4154, 2024, eq. 3.
#include "planarity.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>

namespace texdefrag::merge {

double planarity_flat(const Eigen::Vector3d& ev) { return ev[1] > 0 ? 1.0 - ev[0] / ev[1] : 0.0; }

double planarity_compact(const Eigen::Vector3d& ev) { return ev[2] > 0 ? ev[1] / ev[2] : 0.0; }

double planarity_normal(const Eigen::Vector3d& nc, const Eigen::Vector3d& nr) {
  const double a = nc.norm(), b = nr.norm();
  if (a == 0 || b == 0) return 0.0;
  const double s = std::min(1.0, nc.cross(nr).norm() / (a * b));
  return 1.0 - s;
}

double planarity_index(const Eigen::Vector3d& ev, const Eigen::Vector3d& nc, const Eigen::Vector3d& nr,
                       const PlanarityWeights& w) {
  return w.flat * planarity_flat(ev) + w.compact * planarity_compact(ev) + w.normal * planarity_normal(nc, nr);
}

void Moments::add_triangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const double A = 0.5 * (b - a).cross(c - a).norm();
  const Eigen::Vector3d s = a + b + c;
  area += A;
  first += A * s / 3.0;
  second += A / 12.0 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
}

void Moments::plane(Eigen::Vector3d& eigenvalues, Eigen::Vector3d& normal) const {
  eigenvalues.setZero();
  normal.setZero();
  if (area <= 0) return;
  const Eigen::Vector3d mu = first / area;
  const Eigen::Matrix3d cov = second / area - mu * mu.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.compute(cov);
  eigenvalues = es.eigenvalues().cwiseMax(0.0);
  normal = es.eigenvectors().col(0);
}

}  // namespace texdefrag::merge
