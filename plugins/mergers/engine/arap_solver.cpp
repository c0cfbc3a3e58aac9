// Local/global ARAP parameterisation (Liu, Zhang, Xu, Gotsman, Gortler, SGP 2008) restricted to a
// merge's free region, the optimiser of the M-method (Maggiordomo, Cignoni, Tarini, "Texture
// defragmentation for photo-reconstructed 3D models", Eurographics 2021).
#include "arap_solver.h"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

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

SolveResult ArapSolver::solve(LocalProblem& p) {
  SolveResult r;
  const int n = p.num_free;
  if (n == 0 || p.tri.empty()) {
    r.ok = count_inverted(p) == 0;
    if (!r.ok) r.failure = "inverted triangles with no free vertex";
    r.energy = arap_energy(p);
    return r;
  }
  // Constant quadratic form K = sum_t w_t D_t^T D_t over free coordinates.
  std::vector<Mat46> D(p.tri.size());
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(p.tri.size() * 36);
  for (size_t t = 0; t < p.tri.size(); ++t) {
    D[t] = gradient_operator(p.rest_inv[t]);
    const Eigen::Matrix<double, 6, 6> K = p.weight[t] * D[t].transpose() * D[t];
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
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(K);
  if (ldlt.info() != Eigen::Success) {
    r.ok = false;
    r.failure = "singular ARAP system (free region without pinned vertex)";
    return r;
  }
  double prev = arap_energy(p);
  Eigen::VectorXd g(2 * n);
  for (int it = 0; it < s_.iterations; ++it) {
    // Local step: best rotation per triangle; global step: one exact solve of the quadratic.
    g.setZero();
    for (size_t t = 0; t < p.tri.size(); ++t) {
      const Mat2 F = deformation_gradient(p, t);
      const Mat2 Rm = closest_rotation(F);
      Eigen::Vector4d res;
      res << F(0, 0) - Rm(0, 0), F(0, 1) - Rm(0, 1), F(1, 0) - Rm(1, 0), F(1, 1) - Rm(1, 1);
      const Eigen::Matrix<double, 6, 1> gl = p.weight[t] * D[t].transpose() * res;
      for (int a = 0; a < 6; ++a) {
        const int va = p.tri[t][static_cast<size_t>(a / 2)];
        if (va < n) g[2 * va + a % 2] += gl[a];
      }
    }
    const Eigen::VectorXd step = ldlt.solve(-g);
    for (int i = 0; i < n; ++i) p.x[static_cast<size_t>(i)] += Vec2(step[2 * i], step[2 * i + 1]);
    ++r.iterations;
    const double e = arap_energy(p);
    const bool done = prev - e <= s_.tolerance * std::max(prev, 1e-300);
    prev = e;
    if (done) break;
  }
  r.energy = prev;
  r.ok = count_inverted(p) == 0;
  if (!r.ok) r.failure = "inverted triangles after ARAP";
  return r;
}

}  // namespace texdefrag::merge
