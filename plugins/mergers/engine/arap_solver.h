// Local/global ARAP (Liu et al., "A local/global approach to mesh parameterization", SGP 2008) on a
// merge's free region against the input UV triangles, as the M-method (Maggiordomo et al. 2021)
// optimises after each weld. The global step's matrix (area-weighted cotangent Laplacian of the
// input UV triangles, pinned wedges eliminated) is constant, so it is factorised once per problem
// (Eigen SimplicialLDLT) and every iteration is one back-substitution. x and y share it: the 2n x 2n
// system's x-y blocks are zero and its x and y blocks equal (gradient_rows), so it is n x n.
#pragma once

#include "local_problem.h"

#include <optional>

namespace texdefrag::merge {

/// When untangle() gives up early: after an eps round that leaves at least `min_inverted` triangles
/// inverted and more than `share` of the inverted count `rounds` rounds before. On the 1M-face
/// synthetic factory (best.json) no untangle that succeeded had 10 or more inverted triangles after its
/// fourth round, while failing ones kept hundreds for all 20 rounds (82% of the untangling's work).
struct UntangleStall {
  int rounds = 3;            ///< rounds compared, >= 1
  int min_inverted = 10;     ///< inverted triangles below which it never gives up, >= 1
  double share = 0.75;       ///< in (0, 1]: the count must fall below this share of the earlier one
};

/// Limits of untangle().
struct UntangleSettings {
  int outer_iterations = 20;  ///< eps updates (Garanzha et al. 2021's outer loop)
  int inner_iterations = 50;  ///< L-BFGS steps per eps
  /// Stop as soon as an L-BFGS step reaches a point where every triangle is shape_kept() at this floor
  /// (> 0), instead of minimising each eps to convergence. The merge's acceptance refuses a smaller
  /// singular value below its floor, and the flip-free steps after untangling keep a triangle above
  /// the floor once it is (ArapSettings::singular_value_floor), so polishing further only moves the
  /// ARAP steps' start. Unset: the paper's minimisation.
  std::optional<double> stop_floor;
  /// Give up on a stalled untangling before outer_iterations (UntangleStall); unset: never.
  std::optional<UntangleStall> stall = UntangleStall{};
};

/// What one untangle() call did.
struct UntangleReport {
  int rounds = 0;       ///< eps rounds run (0 when nothing was inverted or nothing could be done)
  int lbfgs_steps = 0;  ///< accepted L-BFGS steps over all rounds
};

struct ArapSettings {
  int iterations = 10;          ///< local/global iterations, >= 1
  double tolerance = 1e-6;      ///< stop when the energy drops by less than this fraction
  /// When the local/global steps end with inverted triangles: untangle() the free region, then run
  /// `iterations` local/global steps whose every step stops short of turning a triangle over
  /// (max_injective_step), so the result is flip-free. SolveResult::repaired tells it happened.
  bool untangle = false;
  /// Those flip-free steps also keep every triangle whose smaller singular value is at least this at
  /// least this (the merge's `min_singular_value`; 0 = no such limit). When > 0 the untangling also
  /// stops at the first point above it (UntangleSettings::stop_floor).
  double singular_value_floor = 0;
  UntangleSettings untangling;
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

/// Moves p's free positions until no triangle of p has det F <= 0, by minimising the foldover-free
/// energy of Garanzha et al., "Foldover-free maps in 50 lines of code" (SIGGRAPH 2021): per triangle
/// (|F|^2 + det F^2 + 1) / (2 chi(det F, eps)), chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2 (shape and area
/// terms weighted 1:1; the paper weights area 1/128),
/// area-weighted, by L-BFGS, with eps shrinking as the most inverted triangle recovers. Returns true
/// (positions moved, every det F > 0) or false (positions as given: an inverted triangle has no free
/// corner, the limits of `s` were reached or it stalled). Returns true at once when nothing is
/// inverted. `report`, when given, receives what it did.
bool untangle(LocalProblem& p, const UntangleSettings& s = {}, UntangleReport* report = nullptr);

/// Area-weighted mean ARAP energy sum w ||F - R(F)||^2 / sum w of p at its current positions.
double arap_energy(const LocalProblem& p);

}  // namespace texdefrag::merge
