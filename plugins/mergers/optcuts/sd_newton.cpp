// Projected Newton on the symmetric Dirichlet energy (Teran et al. 2005 projection; analytic 2D
// eigensystem of Smith, De Goes, Kim, TOG 2019), line search capped by the flip-free step of
// Smith & Schaefer 2015: the OptCuts geometry step (Li et al. 2018) used by Liu et al. 2024.
#include "sd_newton.h"

#include "arap_solver.h"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <Eigen/SVD>

#include <cmath>
#include <limits>

namespace texdefrag::merge {

double sd_energy(const Mat2& F) {
  if (F.determinant() <= 0) return std::numeric_limits<double>::infinity();
  const Eigen::Vector2d s = signed_singular_values_2x2(F);
  return s.x() * s.x() + s.y() * s.y() + 1 / (s.x() * s.x()) + 1 / (s.y() * s.y());
}

namespace {
Eigen::Vector4d vec_rm(const Mat2& M) { return {M(0, 0), M(0, 1), M(1, 0), M(1, 1)}; }
}  // namespace

void sd_gradient_hessian(const Mat2& F, Eigen::Vector4d& g, Eigen::Matrix4d& H) {
  Eigen::JacobiSVD<Mat2> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat2 U = svd.matrixU(), V = svd.matrixV();
  Eigen::Vector2d s = svd.singularValues();
  // Rotations only (det F > 0 so det U = det V).
  if (U.determinant() < 0) {
    U.col(1) *= -1;
    V.col(1) *= -1;
  }
  const double s1 = s.x(), s2 = s.y();
  const double d1 = 2 * s1 - 2 / (s1 * s1 * s1), d2 = 2 * s2 - 2 / (s2 * s2 * s2);
  Mat2 S;
  S << d1, 0, 0, d2;
  g = vec_rm(U * S * V.transpose());
  const double p3 = std::pow(s1 * s2, 3);
  const double l_scale1 = 2 + 6 / std::pow(s1, 4), l_scale2 = 2 + 6 / std::pow(s2, 4);
  const double l_twist = 2 - 2 * (s1 * s1 - s1 * s2 + s2 * s2) / p3;
  const double l_flip = 2 + 2 * (s1 * s1 + s1 * s2 + s2 * s2) / p3;
  Mat2 E;
  const double r = 1 / std::sqrt(2.0);
  E << 1, 0, 0, 0;
  const Eigen::Vector4d q1 = vec_rm(U * E * V.transpose());
  E << 0, 0, 0, 1;
  const Eigen::Vector4d q2 = vec_rm(U * E * V.transpose());
  E << 0, -r, r, 0;
  const Eigen::Vector4d qt = vec_rm(U * E * V.transpose());
  E << 0, r, r, 0;
  const Eigen::Vector4d qf = vec_rm(U * E * V.transpose());
  H = l_scale1 * q1 * q1.transpose() + l_scale2 * q2 * q2.transpose() + l_flip * qf * qf.transpose();
  if (l_twist > 0) H += l_twist * qt * qt.transpose();
}

double sd_total(const LocalProblem& p) {
  double e = 0;
  for (size_t t = 0; t < p.tri.size(); ++t) {
    const double v = sd_energy(deformation_gradient(p, t));
    if (!std::isfinite(v)) return std::numeric_limits<double>::infinity();
    e += p.weight[t] * v;
  }
  return e;
}

namespace {

/// Untangles an inverted start by a few ARAP steps (symmetric Dirichlet is infinite on inverted
/// triangles); false, with r's failure set, when triangles stay inverted.
bool untangle_start(LocalProblem& p, int iterations, SolveResult& r) {
  if (count_inverted(p) == 0) return true;
  // note: the weld can invert thin triangles at the seam; symmetric Dirichlet is infinite there,
  // so a few ARAP steps (which accept inverted input) look for an injective start first.
  ArapSettings as;
  as.iterations = iterations;
  ArapSolver(as).solve(p);
  if (count_inverted(p) == 0) return true;
  r.ok = false;
  r.failure = "could not untangle inverted triangles";
  return false;
}

/// The gradient g and the projected Hessian's entries (trip, with a tiny diagonal shift) of the
/// weighted energy over the n free vertices (coordinates 2 v, 2 v + 1); D holds each triangle's
/// gradient operator.
void assemble_newton(const LocalProblem& p, const std::vector<Mat46>& D, int n, Eigen::VectorXd& g,
                     std::vector<Eigen::Triplet<double>>& trip) {
  g.setZero();
  trip.clear();
  double diag = 0;
  for (size_t t = 0; t < p.tri.size(); ++t) {
    const Mat2 F = deformation_gradient(p, t);
    Eigen::Vector4d gF;
    Eigen::Matrix4d HF;
    sd_gradient_hessian(F, gF, HF);
    const Eigen::Matrix<double, 6, 1> gl = p.weight[t] * D[t].transpose() * gF;
    const Eigen::Matrix<double, 6, 6> Hl = p.weight[t] * D[t].transpose() * HF * D[t];
    for (int a = 0; a < 6; ++a) {
      const int va = p.tri[t][static_cast<size_t>(a / 2)];
      if (va >= n) continue;
      g[2 * va + a % 2] += gl[a];
      for (int b = 0; b < 6; ++b) {
        const int vb = p.tri[t][static_cast<size_t>(b / 2)];
        if (vb >= n) continue;
        trip.emplace_back(2 * va + a % 2, 2 * vb + b % 2, Hl(a, b));
      }
      diag += Hl(a, a);
    }
  }
  // note: a tiny diagonal shift keeps the system definite when the free region has no pinned
  // neighbour (its rigid motions are then a null space of the energy).
  const double shift = 1e-10 * diag / (2 * n);
  for (int i = 0; i < 2 * n; ++i) trip.emplace_back(i, i, shift);
}

/// Armijo backtracking along dir from the flip-free step cap (at most 40 halvings; the start is
/// restored when none is accepted). Updates E to the accepted energy; true when it decreased.
bool line_search(LocalProblem& p, const Eigen::VectorXd& dir, double slope, int n, std::vector<Vec2>& x0,
                 double& E) {
  double step = std::min(1.0, 0.9 * max_injective_step(p, dir));
  for (int i = 0; i < n; ++i) x0[static_cast<size_t>(i)] = p.x[static_cast<size_t>(i)];
  bool moved = false;
  for (int ls = 0; ls < 40; ++ls) {
    for (int i = 0; i < n; ++i)
      p.x[static_cast<size_t>(i)] = x0[static_cast<size_t>(i)] + step * Vec2(dir[2 * i], dir[2 * i + 1]);
    const double En = sd_total(p);
    if (En <= E + 1e-4 * step * slope) {
      moved = E - En > 0;
      E = En;
      break;
    }
    step *= 0.5;
    if (ls == 39)
      for (int i = 0; i < n; ++i) p.x[static_cast<size_t>(i)] = x0[static_cast<size_t>(i)];
  }
  return moved;
}

}  // namespace

SolveResult SdNewtonSolver::solve(LocalProblem& p) {
  SolveResult r;
  double wsum = 0;
  for (double w : p.weight) wsum += w;
  if (!untangle_start(p, s_.untangle_iterations, r)) return r;
  const int n = p.num_free;
  double E = sd_total(p);
  if (n == 0 || p.tri.empty()) {
    r.energy = wsum > 0 ? E / wsum : 0;
    return r;
  }
  std::vector<Mat46> D(p.tri.size());
  for (size_t t = 0; t < p.tri.size(); ++t) D[t] = gradient_operator(p.rest_inv[t]);
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  bool analysed = false;
  std::vector<Eigen::Triplet<double>> trip;
  Eigen::VectorXd g(2 * n);
  Eigen::SparseMatrix<double> H(2 * n, 2 * n);
  std::vector<Vec2> x0(static_cast<size_t>(n));
  for (int it = 0; it < s_.iterations; ++it) {
    assemble_newton(p, D, n, g, trip);
    H.setFromTriplets(trip.begin(), trip.end());
    if (!analysed) {
      ldlt.analyzePattern(H);
      analysed = true;
    }
    ldlt.factorize(H);
    if (ldlt.info() != Eigen::Success) break;
    const Eigen::VectorXd dir = ldlt.solve(-g);
    const double slope = g.dot(dir);  // < 0 for a descent direction
    ++r.iterations;
    if (!(slope < 0) || -slope < s_.tolerance * E) break;
    if (!line_search(p, dir, slope, n, x0, E)) break;
  }
  r.energy = wsum > 0 ? E / wsum : 0;
  r.ok = std::isfinite(E);
  if (!r.ok) r.failure = "inverted triangles after Newton";
  return r;
}

}  // namespace texdefrag::merge
