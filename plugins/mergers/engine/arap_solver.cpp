// Local/global ARAP parameterisation (Liu, Zhang, Xu, Gotsman, Gortler, SGP 2008) restricted to a
// merge's free region, the optimiser of the M-method (Maggiordomo, Cignoni, Tarini, "Texture
// defragmentation for photo-reconstructed 3D models", Eurographics 2021).
#include "arap_solver.h"

#include <Eigen/SparseCholesky>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>

#include <algorithm>
#include <cmath>

namespace texdefrag::merge {

double arap_energy(const LocalProblem& p) {
  double e = 0, w = 0;
  for (size_t t = 0; t < p.tri.size(); ++t) {
    const Mat2 F = deformation_gradient(p, t);
    e += p.weight[t] * (F - closest_rotation(F)).squaredNorm();
    w += p.weight[t];
  }
  return w > 0 ? e / w : 0;
}

namespace {

/// Eigen's AMDOrdering for a matrix that is already structurally symmetric: SimplicialLDLT hands its
/// ordering the full symmetric matrix built from the lower triangle, whose pattern A + A^T (what
/// AMDOrdering forms first, a transpose and a sum) is its own, so the same permutation comes out.
struct SymmetricAmdOrdering {
  using PermutationType = Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int>;
  void operator()(const Eigen::SparseMatrix<double>& symmetric, PermutationType& perm) const {
    Eigen::SparseMatrix<double> work = symmetric;  // note: minimum_degree_ordering uses it as workspace
    Eigen::internal::minimum_degree_ordering(work, perm);
  }
};

/// The constant part of a problem's local/global iteration: per-triangle gradient operators and the
/// factorised global matrix K = sum_t w_t D_t^T D_t over the free coordinates.
struct ArapSystem {
  std::vector<Mat46> D;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, SymmetricAmdOrdering> ldlt;
};

/// What one pass over a problem's triangles at the current positions gives (evaluate()).
struct Evaluation {
  double energy = 0;  ///< arap_energy() at these positions
  int inverted = 0;   ///< count_inverted() at these positions
};

/// Per-thread scratch of the solver, kept between problems to spare allocations (the solver object
/// keeps no state, so solve() stays reentrant). Everything in it is overwritten before it is read.
struct Scratch {
  ArapSystem sys;
  std::vector<Eigen::Triplet<double>> trip;
  std::vector<Eigen::Vector4d> res;  ///< per triangle: vec(F - R(F)) (row-major) at the last evaluate()
  std::vector<double> smallest;      ///< per triangle: smaller signed singular value, when asked for
  Eigen::VectorXd g, step;
  std::vector<Vec2> base;
};

Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

/// Builds sys for p (K's lower triangle, then its factorisation); false when K is singular.
bool build_system(const LocalProblem& p, ArapSystem& sys, std::vector<Eigen::Triplet<double>>& trip) {
  const int n = p.num_free;
  sys.D.resize(p.tri.size());
  trip.clear();
  trip.reserve(p.tri.size() * 21);
  for (size_t t = 0; t < p.tri.size(); ++t) {
    sys.D[t] = gradient_operator(p.rest_inv[t]);
    const Eigen::Matrix<double, 6, 6> K = p.weight[t] * sys.D[t].transpose() * sys.D[t];
    for (int a = 0; a < 6; ++a) {
      const int va = p.tri[t][static_cast<size_t>(a / 2)];
      if (va >= n) continue;
      for (int b = 0; b < 6; ++b) {
        const int vb = p.tri[t][static_cast<size_t>(b / 2)];
        const int row = 2 * va + a % 2, col = 2 * vb + b % 2;
        // note: the factorisation (and its ordering) reads only K's lower triangle.
        if (vb >= n || row < col) continue;
        trip.emplace_back(row, col, K(a, b));
      }
    }
  }
  Eigen::SparseMatrix<double> K(2 * n, 2 * n);
  K.setFromTriplets(trip.begin(), trip.end());
  sys.ldlt.compute(K);
  return sys.ldlt.info() == Eigen::Success;
}

/// One pass over p's triangles at the current positions: the ARAP energy and inverted count (the
/// same operations, in the same order, as arap_energy() and count_inverted(), so the same bits), each
/// triangle's residual vec(F - R(F)) for the next local step into sc.res, and with `smallest` each
/// triangle's smaller signed singular value into sc.smallest.
Evaluation evaluate(const LocalProblem& p, Scratch& sc, bool smallest) {
  Evaluation ev;
  double e = 0, w = 0;
  sc.res.resize(p.tri.size());
  if (smallest) sc.smallest.resize(p.tri.size());
  for (size_t t = 0; t < p.tri.size(); ++t) {
    const Mat2 F = deformation_gradient(p, t);
    const Mat2 Rm = closest_rotation(F);
    e += p.weight[t] * (F - Rm).squaredNorm();
    w += p.weight[t];
    if (F.determinant() <= 0) ++ev.inverted;
    sc.res[t] << F(0, 0) - Rm(0, 0), F(0, 1) - Rm(0, 1), F(1, 0) - Rm(1, 0), F(1, 1) - Rm(1, 1);
    if (smallest) sc.smallest[t] = signed_singular_values_2x2(F)[1];
  }
  ev.energy = w > 0 ? e / w : 0;
  return ev;
}

/// One local/global step's displacement of the free coordinates into sc.step: local step = best
/// rotation per triangle (the residuals of the last evaluate()), global step = exact minimiser of the
/// resulting quadratic.
void local_global_step(const LocalProblem& p, const ArapSystem& sys, Scratch& sc) {
  const int n = p.num_free;
  sc.g.setZero(2 * n);
  for (size_t t = 0; t < p.tri.size(); ++t) {
    const Eigen::Vector4d& res = sc.res[t];
    const Eigen::Matrix<double, 6, 1> gl = p.weight[t] * sys.D[t].transpose() * res;
    for (int a = 0; a < 6; ++a) {
      const int va = p.tri[t][static_cast<size_t>(a / 2)];
      if (va < n) sc.g[2 * va + a % 2] += gl[a];
    }
  }
  sc.step = sys.ldlt.solve(-sc.g);
}

/// Moves p's free positions to base + t * step.
void place(LocalProblem& p, const std::vector<Vec2>& base, const Eigen::VectorXd& step, double t) {
  for (int i = 0; i < p.num_free; ++i)
    p.x[static_cast<size_t>(i)] = base[static_cast<size_t>(i)] + t * Vec2(step[2 * i], step[2 * i + 1]);
}

/// The flip-free cut of sc.step (run_steps' injective rule) from base = the current positions: places
/// p at the largest kept fraction and returns true, or leaves p at base and returns false.
bool place_injective(LocalProblem& p, Scratch& sc, double floor) {
  double t = std::min(1.0, 0.9 * max_injective_step(p, sc.step));
  sc.base.assign(p.x.begin(), p.x.begin() + p.num_free);
  const size_t checked = floor > 0 ? p.tri.size() : 0;
  for (int h = 0; h < 12; ++h, t *= 0.5) {
    place(p, sc.base, sc.step, t);
    bool kept = true;
    for (size_t k = 0; k < checked && kept; ++k)
      kept = sc.smallest[k] < floor || signed_singular_values_2x2(deformation_gradient(p, k))[1] >= floor;
    if (kept) return true;
  }
  place(p, sc.base, sc.step, 0);
  return false;
}

/// Up to `iterations` local/global steps from p (stopping when the energy drops by less than
/// `tolerance`). With `injective`, each step is cut to 0.9 of the largest step that turns no
/// triangle over (max_injective_step), then halved (at most 12 times, else the steps end) until no
/// triangle whose smaller singular value was >= `floor` goes below it. The ARAP energy still never
/// rises: it lies under the step's convex quadratic, which falls along the whole step. Returns the
/// steps run; `ev` ends as the final positions' evaluation.
int run_steps(LocalProblem& p, const ArapSystem& sys, Scratch& sc, int iterations, double tolerance, bool injective,
              double floor, Evaluation& ev) {
  const bool smallest = injective && floor > 0;
  int done_steps = 0;
  ev = evaluate(p, sc, smallest);
  for (int it = 0; it < iterations; ++it) {
    local_global_step(p, sys, sc);
    if (injective) {
      if (!place_injective(p, sc, floor)) {
        ev.inverted = count_inverted(p);  // note: p is back at base; counted again as before (NaN steps)
        break;
      }
    } else {
      sc.base.assign(p.x.begin(), p.x.begin() + p.num_free);
      place(p, sc.base, sc.step, 1);
    }
    ++done_steps;
    const double energy = ev.energy;
    ev = evaluate(p, sc, smallest);
    if (energy - ev.energy <= tolerance * std::max(energy, 1e-300)) break;
  }
  return done_steps;
}

}  // namespace

SolveResult ArapSolver::solve(LocalProblem& p) {
  SolveResult r;
  if (p.num_free == 0 || p.tri.empty()) {
    r.ok = count_inverted(p) == 0;
    if (!r.ok) r.failure = "inverted triangles with no free vertex";
    r.energy = arap_energy(p);
    return r;
  }
  Scratch& sc = scratch();
  if (!build_system(p, sc.sys, sc.trip)) {
    r.ok = false;
    r.failure = "singular ARAP system (free region without pinned vertex)";
    return r;
  }
  Evaluation ev;
  r.iterations = run_steps(p, sc.sys, sc, s_.iterations, s_.tolerance, false, 0, ev);
  r.energy = ev.energy;
  r.ok = ev.inverted == 0;
  if (!r.ok && s_.untangle && p.repair_usable) {
    // Injectivity repair: untangle, then lower the ARAP energy again without turning anything over.
    r.repaired = true;
    if (untangle(p, s_.untangling)) {
      r.iterations += run_steps(p, sc.sys, sc, s_.iterations, s_.tolerance, true, s_.singular_value_floor, ev);
      r.energy = ev.energy;
      r.ok = ev.inverted == 0;
    }
  }
  if (!r.ok) r.failure = "inverted triangles after ARAP";
  return r;
}

}  // namespace texdefrag::merge
