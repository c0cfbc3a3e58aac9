// The local UV optimisation problem a merge hands to an optimiser, and the per-triangle algebra
// both optimisers share.
//
// Each triangle's rest shape is its INPUT UV triangle in texels, so the optimum keeps the input texel
// density (Liu et al. 2024, section 2.2.3; Maggiordomo et al. 2021, section 4). The deformation
// gradient of triangle t is F = [x1-x0, x2-x0] * Dm^-1 (Dm = rest edge matrix); it is linear in the
// six corner coordinates: vec(F) = D * (x0, y0, x1, y1, x2, y2), vec row-major (F00, F01, F10, F11).
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>

#include <array>
#include <cmath>
#include <string>
#include <vector>

namespace texdefrag::merge {

using Vec2 = Eigen::Vector2d;
using Mat2 = Eigen::Matrix2d;
using Mat46 = Eigen::Matrix<double, 4, 6>;
using Mat23 = Eigen::Matrix<double, 2, 3>;

/// A local problem: positions of the wedges it touches, the free ones first.
struct LocalProblem {
  /// Positions (texels). x[0, num_free) are the unknowns; the rest are pinned (constant).
  std::vector<Vec2> x;
  /// Number of unknown positions (x's prefix). 0 is allowed (nothing to do).
  int num_free = 0;
  /// Per triangle: indices into x of its three corners, in face-corner order.
  std::vector<std::array<int, 3>> tri;
  /// Per triangle: inverse of the rest edge matrix Dm = [r1-r0, r2-r0] (input texels).
  std::vector<Mat2> rest_inv;
  /// Per triangle: weight = input UV area (texels^2), > 0.
  std::vector<double> weight;
  /// Whether the caller can use a solution that needed an injectivity repair (SolveResult::repaired);
  /// when false an optimiser skips the repair (the caller would refuse its result).
  bool repair_usable = true;
};

/// What an optimiser did.
struct SolveResult {
  bool ok = true;          ///< false when it could not reach a state without inverted triangles
  int iterations = 0;      ///< outer iterations run
  double energy = 0;       ///< final area-weighted mean energy of the optimiser's own measure
  std::string failure;     ///< why ok is false (one phrase), empty otherwise
  /// The optimiser's plain steps ended with inverted triangles and an injectivity repair ran (and
  /// removed them when ok is true).
  bool repaired = false;
};

/// A UV optimiser used by the merge engine (mergers.optcuts, mergers.arap).
class LocalSolver {
 public:
  virtual ~LocalSolver() = default;
  /// Moves the free positions of `p` (p.x[0, p.num_free)) to lower the solver's energy. Never
  /// touches pinned positions. Returns ok = false when the result still has inverted triangles
  /// (det F <= 0) that it could not remove; the caller then rejects the merge.
  virtual SolveResult solve(LocalProblem& p) = 0;
  /// Whether solve may run on several threads at once (on different problems): true for solvers that
  /// keep no state between calls. The merge engine runs its first pass's regions side by side only then.
  virtual bool reentrant() const { return false; }
};

/// The 2x3 matrix G with F.row(i)^T = G * (corner 0, 1, 2's coordinate i), the same for i = 0 (x) and
/// i = 1 (y), for a triangle with rest_inv: G = rest_inv^T * [[-1, 1, 0], [-1, 0, 1]]. D below is G
/// once per coordinate (F's row i depends on the corners' coordinate i only), so D^T D has no x-y
/// entries and both diagonal blocks are G^T G: the ARAP global step is one n x n system for x and y.
Mat23 gradient_rows(const Mat2& rest_inv);

/// The 4x6 matrix D with vec(F) = D * local corner coordinates, for a triangle with rest_inv
/// (D(2i + j, 2k + i) = gradient_rows(rest_inv)(j, k), zero elsewhere).
Mat46 gradient_operator(const Mat2& rest_inv);

/// Deformation gradient of triangle t of p at the current positions. (Inline, as the two below: the
/// solvers call them once per triangle and iteration.)
inline Mat2 deformation_gradient(const LocalProblem& p, size_t t) {
  const auto& c = p.tri[t];
  Mat2 B;
  B.col(0) = p.x[static_cast<size_t>(c[1])] - p.x[static_cast<size_t>(c[0])];
  B.col(1) = p.x[static_cast<size_t>(c[2])] - p.x[static_cast<size_t>(c[0])];
  return B * p.rest_inv[t];
}

/// Signed singular values of a 2x2 matrix in closed form (s1 >= |s2|, s2 < 0 when det < 0).
inline Eigen::Vector2d signed_singular_values_2x2(const Mat2& F) {
  // note: F = [[a, b], [c, d]]; with E=(a+d)/2, G=(a-d)/2, H=(c+b)/2, K=(c-b)/2 the signed singular
  // values are hypot(E, K) +/- hypot(G, H) (Blinn's 2x2 SVD); the minus one is negative iff det < 0.
  const double E = 0.5 * (F(0, 0) + F(1, 1)), G = 0.5 * (F(0, 0) - F(1, 1));
  const double H = 0.5 * (F(1, 0) + F(0, 1)), K = 0.5 * (F(1, 0) - F(0, 1));
  const double Q = std::hypot(E, K), R = std::hypot(G, H);
  return {Q + R, Q - R};
}

/// Whether a triangle with deformation gradient F is untangled and not compressed below `floor`:
/// det F > 0 and its smaller signed singular value >= floor (any floor; at floor <= 0 just det F > 0).
inline bool shape_kept(const Mat2& F, double floor) {
  return F.determinant() > 0 && signed_singular_values_2x2(F)[1] >= floor;
}

/// ARAP error (s1-1)^2 + (s2-1)^2 with signed singular values (core/distortion.h's measure).
double arap_error_2x2(const Mat2& F);

/// Closest rotation to F (polar decomposition, det +1 enforced).
inline Mat2 closest_rotation(const Mat2& F) {
  // The rotation maximising tr(R^T F): angle of the "similarity part" (E, K) of F.
  const double E = 0.5 * (F(0, 0) + F(1, 1)), K = 0.5 * (F(1, 0) - F(0, 1));
  const double n = std::hypot(E, K);
  Mat2 R;
  if (n == 0) {
    R.setIdentity();
    return R;
  }
  const double c = E / n, s = K / n;
  R << c, -s, s, c;
  return R;
}

/// Largest t in (0, +inf] such that no triangle of p whose edge determinant is positive at t = 0
/// reaches determinant 0 on [0, t) when the free positions move along `dir` (2*num_free values,
/// x then y per position). +inf when no triangle can collapse. Smith & Schaefer 2015, section 4.
double max_injective_step(const LocalProblem& p, const Eigen::VectorXd& dir);

/// Number of triangles of p with det F <= 0.
int count_inverted(const LocalProblem& p);

}  // namespace texdefrag::merge
