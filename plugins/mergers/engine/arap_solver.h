// Local/global ARAP (Liu et al., "A local/global approach to mesh parameterization", SGP 2008) on a
// merge's free region against the input UV triangles, as the M-method (Maggiordomo et al. 2021)
// optimises after each weld. The global step's matrix (area-weighted cotangent Laplacian of the
// input UV triangles, pinned wedges eliminated) is constant, so it is factorised once per problem
// (Eigen SimplicialLDLT) and every iteration is one back-substitution.
#pragma once

#include "local_problem.h"

namespace texdefrag::merge {

struct ArapSettings {
  int iterations = 10;          ///< local/global iterations, >= 1
  double tolerance = 1e-6;      ///< stop when the energy drops by less than this fraction
};

/// Local/global ARAP solver. Stateless between problems.
class ArapSolver final : public LocalSolver {
 public:
  explicit ArapSolver(ArapSettings s = {}) : s_(s) {}
  /// Runs up to s.iterations local/global steps. ok = false when inverted triangles remain.
  SolveResult solve(LocalProblem& p) override;
  bool reentrant() const override { return true; }  ///< no state between calls

 private:
  ArapSettings s_;
};

/// Area-weighted mean ARAP energy sum w ||F - R(F)||^2 / sum w of p at its current positions.
double arap_energy(const LocalProblem& p);

}  // namespace texdefrag::merge
