// The Ceres variant of mergers.arap's local optimiser: the same ARAP energy as ArapSolver
// (arap_solver.h; Liu et al., SGP 2008, as the M-method of Maggiordomo et al. 2021 uses it), minimised
// as a nonlinear least-squares problem with Ceres (Levenberg-Marquardt, SPARSE_NORMAL_CHOLESKY, one
// thread) instead of local/global iterations. One residual block per triangle,
// r_t = sqrt(w_t / W) vec(F_t - R(F_t)) with R(F) the closest rotation, so the Ceres cost
// 1/2 sum ||r_t||^2 is half of arap_energy(). Jacobians are analytic (see arap_residual).
// Ceres headers stay inside ceres_arap_solver.cpp (they compile slowly).
#pragma once

#include "local_problem.h"

namespace texdefrag::merge {

/// Sparse Cholesky back end of Ceres' SPARSE_NORMAL_CHOLESKY.
enum class CeresSparseLibrary {
  SuiteSparse,  ///< CHOLMOD (Debian's Ceres is built with it)
  EigenSparse,  ///< Eigen's SimplicialLDLT
};

/// Ceres linear solver for the LM steps' normal equations.
enum class CeresLinearSolver {
  SparseNormalCholesky,  ///< SPARSE_NORMAL_CHOLESKY with sparse_library
  DenseNormalCholesky,   ///< DENSE_NORMAL_CHOLESKY (Eigen LLT): no symbolic analysis, O(n^3)
};

struct CeresArapSettings {
  int iterations = 10;      ///< Levenberg-Marquardt iterations (each one refactorises), >= 1
  double tolerance = 1e-6;  ///< stop when the energy drops by less than this fraction (function_tolerance), >= 0
  CeresLinearSolver linear_solver = CeresLinearSolver::SparseNormalCholesky;  ///< normal-equation solver
  CeresSparseLibrary sparse_library = CeresSparseLibrary::SuiteSparse;  ///< back end of the sparse one
};

/// ARAP LocalSolver on Ceres. Stateless between problems; single-threaded.
class CeresArapSolver final : public LocalSolver {
 public:
  explicit CeresArapSolver(CeresArapSettings s = {}) : s_(s) {}
  /// Runs up to s.iterations LM steps on the free positions of p (pinned ones never move).
  /// ok = false when inverted triangles remain or Ceres reports an unusable solution.
  SolveResult solve(LocalProblem& p) override;
  bool reentrant() const override { return true; }  ///< no state between calls

 private:
  CeresArapSettings s_;
};

/// One triangle's ARAP residual r = vec(F - R(F)) (row-major vec: F00, F01, F10, F11; R = closest
/// rotation, identity when F has no rotation part) and its Jacobian dr/dvec(F).
/// note: with E = (F00 + F11)/2, K = (F10 - F01)/2, n = hypot(E, K), R = [[E, -K], [K, E]] / n and
/// d vec(R)/d vec(F) = u u^T / n with u = (K, E, -E, K) / (sqrt(2) n), so dr/dF = I - u u^T / n
/// (symmetric, rank-1 update of the identity). At n = 0 the energy is not differentiable; the
/// identity is returned there (R held fixed).
/// @param F      deformation gradient
/// @param r      out: residual
/// @param dr_dF  out: Jacobian, row i = d r_i / d vec(F)
void arap_residual(const Mat2& F, Eigen::Vector4d& r, Eigen::Matrix4d& dr_dF);

}  // namespace texdefrag::merge
