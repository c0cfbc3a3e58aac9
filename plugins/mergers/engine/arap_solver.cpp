// Local/global ARAP parameterisation (Liu, Zhang, Xu, Gotsman, Gortler, SGP 2008) restricted to a
// merge's free region, the optimiser of the M-method (Maggiordomo, Cignoni, Tarini, "Texture
// defragmentation for photo-reconstructed 3D models", Eurographics 2021).
#include "arap_solver.h"

#include <Eigen/SparseCholesky>
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

/// The constant part of a problem's local/global iteration: per-triangle gradient operators and the
/// factorised global matrix K = sum_t w_t D_t^T D_t over the free coordinates.
struct ArapSystem {
  std::vector<Mat46> D;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
};

/// Builds sys for p; false when K is singular.
bool build_system(const LocalProblem& p, ArapSystem& sys) {
  const int n = p.num_free;
  sys.D.resize(p.tri.size());
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(p.tri.size() * 36);
  for (size_t t = 0; t < p.tri.size(); ++t) {
    sys.D[t] = gradient_operator(p.rest_inv[t]);
    const Eigen::Matrix<double, 6, 6> K = p.weight[t] * sys.D[t].transpose() * sys.D[t];
    for (int a = 0; a < 6; ++a) {
      const int va = p.tri[t][static_cast<size_t>(a / 2)];
      if (va >= n) continue;
      for (int b = 0; b < 6; ++b) {
        const int vb = p.tri[t][static_cast<size_t>(b / 2)];
        if (vb >= n) continue;
        trip.emplace_back(2 * va + a % 2, 2 * vb + b % 2, K(a, b));
      }
    }
  }
  Eigen::SparseMatrix<double> K(2 * n, 2 * n);
  K.setFromTriplets(trip.begin(), trip.end());
  sys.ldlt.compute(K);
  return sys.ldlt.info() == Eigen::Success;
}

/// One local/global step's displacement of the free coordinates: local step = best rotation per
/// triangle, global step = exact minimiser of the resulting quadratic.
Eigen::VectorXd local_global_step(const LocalProblem& p, const ArapSystem& sys) {
  const int n = p.num_free;
  Eigen::VectorXd g = Eigen::VectorXd::Zero(2 * n);
  for (size_t t = 0; t < p.tri.size(); ++t) {
    const Mat2 F = deformation_gradient(p, t);
    const Mat2 Rm = closest_rotation(F);
    Eigen::Vector4d res;
    res << F(0, 0) - Rm(0, 0), F(0, 1) - Rm(0, 1), F(1, 0) - Rm(1, 0), F(1, 1) - Rm(1, 1);
    const Eigen::Matrix<double, 6, 1> gl = p.weight[t] * sys.D[t].transpose() * res;
    for (int a = 0; a < 6; ++a) {
      const int va = p.tri[t][static_cast<size_t>(a / 2)];
      if (va < n) g[2 * va + a % 2] += gl[a];
    }
  }
  return sys.ldlt.solve(-g);
}

/// Smaller signed singular value of every triangle of p.
std::vector<double> smallest_singular_values(const LocalProblem& p) {
  std::vector<double> s(p.tri.size());
  for (size_t t = 0; t < p.tri.size(); ++t) s[t] = signed_singular_values_2x2(deformation_gradient(p, t))[1];
  return s;
}

/// Moves p's free positions to base + t * step.
void place(LocalProblem& p, const std::vector<Vec2>& base, const Eigen::VectorXd& step, double t) {
  for (int i = 0; i < p.num_free; ++i)
    p.x[static_cast<size_t>(i)] = base[static_cast<size_t>(i)] + t * Vec2(step[2 * i], step[2 * i + 1]);
}

/// Up to `iterations` local/global steps from p (stopping when the energy drops by less than
/// `tolerance`). With `injective`, each step is cut to 0.9 of the largest step that turns no
/// triangle over (max_injective_step), then halved (at most 12 times, else the steps end) until no
/// triangle whose smaller singular value was >= `floor` goes below it. The ARAP energy still never
/// rises: it lies under the step's convex quadratic, which falls along the whole step. Returns the
/// steps run; `energy` ends as the final energy.
int run_steps(LocalProblem& p, const ArapSystem& sys, int iterations, double tolerance, bool injective, double floor,
              double& energy) {
  int done_steps = 0;
  energy = arap_energy(p);
  for (int it = 0; it < iterations; ++it) {
    const Eigen::VectorXd step = local_global_step(p, sys);
    double t = 1;
    if (injective) {
      t = std::min(1.0, 0.9 * max_injective_step(p, step));
      const std::vector<double> before = floor > 0 ? smallest_singular_values(p) : std::vector<double>{};
      const std::vector<Vec2> base(p.x.begin(), p.x.begin() + p.num_free);
      bool kept = false;
      for (int h = 0; h < 12 && !kept; ++h, t *= 0.5) {
        place(p, base, step, t);
        kept = true;
        for (size_t k = 0; k < before.size() && kept; ++k)
          kept = before[k] < floor || signed_singular_values_2x2(deformation_gradient(p, k))[1] >= floor;
        if (kept) break;
      }
      if (!kept) {
        place(p, base, step, 0);
        break;
      }
    } else {
      place(p, std::vector<Vec2>(p.x.begin(), p.x.begin() + p.num_free), step, 1);
    }
    ++done_steps;
    const double e = arap_energy(p);
    const bool done = energy - e <= tolerance * std::max(energy, 1e-300);
    energy = e;
    if (done) break;
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
  ArapSystem sys;
  if (!build_system(p, sys)) {
    r.ok = false;
    r.failure = "singular ARAP system (free region without pinned vertex)";
    return r;
  }
  r.iterations = run_steps(p, sys, s_.iterations, s_.tolerance, false, 0, r.energy);
  r.ok = count_inverted(p) == 0;
  if (!r.ok && s_.untangle && p.repair_usable) {
    // Injectivity repair: untangle, then lower the ARAP energy again without turning anything over.
    r.repaired = true;
    if (untangle(p, s_.untangling)) {
      r.iterations += run_steps(p, sys, s_.iterations, s_.tolerance, true, s_.singular_value_floor, r.energy);
      r.ok = count_inverted(p) == 0;
    }
  }
  if (!r.ok) r.failure = "inverted triangles after ARAP";
  return r;
}

}  // namespace texdefrag::merge
