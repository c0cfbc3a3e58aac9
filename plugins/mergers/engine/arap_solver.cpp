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

/// The constant part of a problem's local/global iteration: per-triangle gradient rows G_t
/// (gradient_rows) and the factorised global matrix L = sum_t w_t G_t^T G_t over the free positions.
/// L is both diagonal blocks of the interleaved 2n x 2n K = sum_t w_t D_t^T D_t, whose x-y blocks are
/// zero (local_problem.h): one n x n factorisation serves x and y, at a quarter of K's nonzeros.
struct ArapSystem {
  std::vector<Mat23> G;
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
  std::vector<Mat2> res;          ///< per triangle: F - R(F) at the last evaluate()
  std::vector<double> smallest;   ///< per triangle: smaller signed singular value, when asked for
  Eigen::MatrixX2d g, solution;   ///< per free position: global step's gradient, its solution (x, y)
  Eigen::VectorXd step;           ///< the solution interleaved (x then y per position)
  std::vector<Vec2> base;
};

Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

/// Appends triangle t's lower-triangle entries of w_t G_t^T G_t between free positions to trip.
void append_triangle(const LocalProblem& p, size_t t, const Mat23& G, std::vector<Eigen::Triplet<double>>& trip) {
  const int n = p.num_free;
  const Eigen::Matrix3d K = p.weight[t] * G.transpose() * G;
  for (int a = 0; a < 3; ++a) {
    const int va = p.tri[t][static_cast<size_t>(a)];
    if (va >= n) continue;
    for (int b = 0; b < 3; ++b) {
      const int vb = p.tri[t][static_cast<size_t>(b)];
      // note: the factorisation (and its ordering) reads only L's lower triangle.
      if (vb >= n || va < vb) continue;
      trip.emplace_back(va, vb, K(a, b));
    }
  }
}

/// Builds sys for p (L's lower triangle, then its factorisation); false when L is singular.
bool build_system(const LocalProblem& p, ArapSystem& sys, std::vector<Eigen::Triplet<double>>& trip) {
  const int n = p.num_free;
  sys.G.resize(p.tri.size());
  trip.clear();
  trip.reserve(p.tri.size() * 6);
  for (size_t t = 0; t < p.tri.size(); ++t) {
    sys.G[t] = gradient_rows(p.rest_inv[t]);
    append_triangle(p, t, sys.G[t], trip);
  }
  Eigen::SparseMatrix<double> L(n, n);
  L.setFromTriplets(trip.begin(), trip.end());
  sys.ldlt.compute(L);
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
    sc.res[t] = F - Rm;
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
  sc.g.setZero(n, 2);
  for (size_t t = 0; t < p.tri.size(); ++t) {
    // note: row k of gl is corner k's (x, y) gradient: w G^T (F - R)^T, D^T vec(F - R) without D's zeros.
    const Eigen::Matrix<double, 3, 2> gl = p.weight[t] * sys.G[t].transpose() * sc.res[t].transpose();
    for (int k = 0; k < 3; ++k) {
      const int v = p.tri[t][static_cast<size_t>(k)];
      if (v < n) sc.g.row(v) += gl.row(k);
    }
  }
  sc.g = -sc.g;
  sc.solution = sys.ldlt.solve(sc.g);
  sc.step.resize(2 * n);
  for (int i = 0; i < n; ++i) {
    sc.step[2 * i] = sc.solution(i, 0);
    sc.step[2 * i + 1] = sc.solution(i, 1);
  }
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
    UntangleSettings us = s_.untangling;
    if (s_.singular_value_floor > 0) us.stop_floor = s_.singular_value_floor;
    if (untangle(p, us)) {
      r.iterations += run_steps(p, sc.sys, sc, s_.iterations, s_.tolerance, true, s_.singular_value_floor, ev);
      r.energy = ev.energy;
      r.ok = ev.inverted == 0;
    }
  }
  if (!r.ok) r.failure = "inverted triangles after ARAP";
  return r;
}

}  // namespace texdefrag::merge
