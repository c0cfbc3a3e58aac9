// Projected-Newton minimisation of the area-weighted symmetric Dirichlet energy on a merge's free
// region: the geometry step of OptCuts (Li, Kaufman, Kim, Sorkine-Hornung, "OptCuts: joint
// optimization of surface cuts and parameterization", SIGGRAPH Asia 2018) as Liu et al. 2024
// (section 2.2.3) use it after each weld.
#pragma once

#include "local_problem.h"

namespace texdefrag::merge {

struct SdNewtonSettings {
  int iterations = 10;        ///< Newton iterations, >= 1
  double tolerance = 1e-6;    ///< stop when the Newton decrement is below this fraction of the energy
  int untangle_iterations = 10;  ///< ARAP iterations used to remove inverted triangles first
};

/// Symmetric Dirichlet s1^2 + s2^2 + s1^-2 + s2^-2 of F; +inf when det F <= 0.
double sd_energy(const Mat2& F);

/// Gradient dPsi/dF (row-major vec) and the Hessian projected to positive semi-definite, from the
/// analytic eigensystem of Smith, De Goes, Kim, "Analytic eigensystems for isotropic distortion
/// energies", TOG 2019. Requires det F > 0.
/// @param F   deformation gradient
/// @param g   out: gradient, vec row-major (F00, F01, F10, F11)
/// @param H   out: projected 4x4 Hessian
void sd_gradient_hessian(const Mat2& F, Eigen::Vector4d& g, Eigen::Matrix4d& H);

/// Area-weighted sum of symmetric Dirichlet over p (not normalised); +inf if any triangle inverts.
double sd_total(const LocalProblem& p);

/// Projected Newton with a flip-preventing line search (the initial step is capped by
/// max_injective_step, then Armijo backtracking). Inverted starts are first untangled by ARAP.
class SdNewtonSolver final : public LocalSolver {
 public:
  explicit SdNewtonSolver(SdNewtonSettings s = {}) : s_(s) {}
  SolveResult solve(LocalProblem& p) override;
  bool reentrant() const override { return true; }  ///< no state between calls

 private:
  SdNewtonSettings s_;
};

}  // namespace texdefrag::merge
