// Comprehensive Planarity Index of a chart (Liu et al. 2024, equation 3), computed locally in the
// merge engine from a chart's area-weighted 3D covariance. Each term is its own function so the
// reading of the paper's (subscript-less) formula can be changed in one place.
#pragma once

#include <Eigen/Core>

namespace texdefrag::merge {

/// Flatness 1 - s1/s2 (1 when perfectly flat); 0 when s2 == 0.
/// @param ev  covariance eigenvalues s1 <= s2 <= s3 (>= 0)
double planarity_flat(const Eigen::Vector3d& ev);
/// Compactness s2/s3 (low for strips); 0 when s3 == 0.
double planarity_compact(const Eigen::Vector3d& ev);
/// 1 - sin(theta), theta the angle between the chart's and the region's normals (unit vectors);
/// orientation-free (sin uses |n_c x n_r|). 0 when either normal is zero.
double planarity_normal(const Eigen::Vector3d& chart_normal, const Eigen::Vector3d& region_normal);

/// Weights of the three terms (the paper's w1, w2, w3).
struct PlanarityWeights {
  double flat = 0.4, compact = 0.3, normal = 0.3;
};

/// I = w1*flat + w2*compact + w3*(1 - sin theta).
double planarity_index(const Eigen::Vector3d& ev, const Eigen::Vector3d& chart_normal,
                       const Eigen::Vector3d& region_normal, const PlanarityWeights& w = {});

/// Area-weighted second moments of a set of triangles; additive, so merged charts just sum them.
struct Moments {
  double area = 0;                                    ///< 3D area
  Eigen::Vector3d first = Eigen::Vector3d::Zero();    ///< sum A * centroid
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();   ///< sum of exact triangle second moments
  /// Adds triangle (a, b, c) (positions relative to a common origin).
  void add_triangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c);
  void add(const Moments& o) { area += o.area; first += o.first; second += o.second; }
  /// Covariance eigenvalues (ascending, clamped to >= 0) and the normal (eigenvector of the
  /// smallest). Zero outputs when area is 0.
  void plane(Eigen::Vector3d& eigenvalues, Eigen::Vector3d& normal) const;
};

}  // namespace texdefrag::merge
