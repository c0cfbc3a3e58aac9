// Plane fitting and the Comprehensive Planarity Index of
//   Liu et al. 2024, "A Planar Feature-Preserving Texture Defragmentation Method for 3D Urban
//   Building Models", Remote Sensing 16(22):4154, section 2.1.2-2.1.3 (Equations 1-3).
//
// Point sets are triangle sets: the covariance is the area-weighted covariance of the continuous
// surface (each triangle integrated exactly), so it does not depend on how finely a plane is
// triangulated. Moments are additive, so a growing region is fitted by summing its patches' moments.
// note: the paper's Equation 3 lost its subscripts in extraction; our reading (METHOD.md section 1)
// is kept in the three term functions below so it can be changed in one place.
#pragma once

#include "texdefrag/core/mesh.h"

#include <Eigen/Core>

namespace texdefrag::detectors {

/// Additive second-order moments of a set of triangles, relative to a fixed reference point.
struct PlaneMoments {
  double area = 0;                                   ///< model units^2
  Vec3 first = Vec3::Zero();                         ///< integral of (p - ref) dA
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();  ///< integral of (p - ref)(p - ref)^T dA
  Vec3 normal_sum = Vec3::Zero();                    ///< sum of area-weighted face normals (orientation)
  int faces = 0;                                     ///< number of triangles added

  /// Adds the moments of another set (same reference point).
  void add(const PlaneMoments& o);
  /// Adds the triangle (a, b, c), positions already relative to the reference point.
  void add_triangle(const Vec3& a, const Vec3& b, const Vec3& c);
};

/// Moments of face f of `mesh` relative to `ref` (a point near the mesh, e.g. its bounding-box centre,
/// so large georeferenced coordinates do not cancel).
PlaneMoments face_moments(const TexturedMesh& mesh, size_t f, const Vec3& ref);

/// Result of a covariance plane fit.
struct PlaneFit {
  bool valid = false;                  ///< false when the set has zero area
  Vec3 centroid = Vec3::Zero();        ///< relative to the moments' reference point
  Vec3 normal = Vec3::Zero();          ///< unit eigenvector of s1, oriented with the face normals
  Vec3 eigenvalues = Vec3::Zero();     ///< covariance eigenvalues s1 <= s2 <= s3 (units^2), >= 0
};

/// Fits a plane (Equation 1: covariance, eigen-decomposition; the normal is the eigenvector of the
/// smallest eigenvalue, flipped to agree with the area-weighted face normals).
/// m: moments of a non-empty set; zero area gives an invalid fit.
PlaneFit fit_plane(const PlaneMoments& m);

/// Root-mean-square distance (model units) of the surface of the set `m` to the plane through
/// `point` with unit normal `normal` (both in the moments' reference frame): the square root of
/// integral(((p - point) . normal)^2 dA) / area, computed from the moments in O(1).
/// m: moments of the set (zero area gives 0); normal: unit vector.
double plane_rms_distance(const PlaneMoments& m, const Vec3& point, const Vec3& normal);

/// Angle between two directions in radians, in [0, pi] (oriented: opposite normals give pi).
/// a, b: any non-zero vectors; returns pi/2 when either is zero (no information).
double normal_angle(const Vec3& a, const Vec3& b);

/// Flatness term delta of the CPI: 1 - s1/s2 (1 for a perfect plane, 0 when the set is as thick as
/// it is wide); 0 when s2 = 0 (a segment or a point has no plane).
/// s1, s2: the two smallest covariance eigenvalues, 0 <= s1 <= s2.
double flatness_term(double s1, double s2);

/// Compactness term xi of the CPI: s2/s3 (1 for a disc-like set, near 0 for an elongated strip);
/// 0 when s3 = 0. s2, s3: the two largest covariance eigenvalues, 0 <= s2 <= s3.
double compactness_term(double s2, double s3);

/// Normal-consistency term of the CPI: 1 - sin(theta). theta: radians; angles past 90 degrees
/// (normals facing away) give 0 rather than rising again.
double normal_consistency_term(double theta);

/// CPI weights (paper: 0.4, 0.3, 0.3). Each in [0, 1]; they need not sum to 1.
struct CpiWeights {
  double flatness = 0.4;
  double compactness = 0.3;
  double normal = 0.3;
};

/// Comprehensive Planarity Index (Equation 3): w1*flatness + w2*compactness + w3*(1 - sin theta),
/// the first two from `fit`'s eigenvalues. fit: the plane fit being judged (invalid gives 0);
/// theta: angle (radians) between fit's normal and the region's normal.
double planarity_index(const PlaneFit& fit, double theta, const CpiWeights& w);

}  // namespace texdefrag::detectors
