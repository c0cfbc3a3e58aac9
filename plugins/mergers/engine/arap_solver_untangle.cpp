// Untangling of a local problem's inverted triangles: the foldover-free energy of Garanzha,
// Kaporin, Kudryavtseva, Protais, Ray, Sokolov, "Foldover-free maps in 50 lines of code" (SIGGRAPH
// 2021), minimised over the free positions by L-BFGS with a decreasing regularisation eps.
#include "arap_solver.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>

namespace texdefrag::merge {

namespace {

/// Weight of the area term against the shape term. Garanzha et al. 2021 use 1/128; against input
/// UV triangles 0.5 leaves fewer near-collapsed triangles: on t078_L17's 80 refused solves 1/128
/// untangled 66 (40 of them with every smaller singular value >= 0.2), 0.5 untangled 79 (57).
constexpr double kTheta = 0.5;

/// chi(D, eps) = (D + s) / 2 > 0 with s = sqrt(eps^2 + D^2) given, evaluated without cancellation for D < 0.
double chi_of(double D, double eps, double s) { return D >= 0 ? 0.5 * (D + s) : 0.5 * eps * eps / (s - D); }

/// chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2 > 0.
double chi(double D, double eps) { return chi_of(D, eps, std::sqrt(eps * eps + D * D)); }

/// The free positions of p as one vector (x then y per position).
Eigen::VectorXd free_positions(const LocalProblem& p) {
  Eigen::VectorXd v(2 * p.num_free);
  for (int i = 0; i < p.num_free; ++i) {
    v[2 * i] = p.x[static_cast<size_t>(i)].x();
    v[2 * i + 1] = p.x[static_cast<size_t>(i)].y();
  }
  return v;
}

void set_free_positions(LocalProblem& p, const Eigen::VectorXd& v) {
  for (int i = 0; i < p.num_free; ++i) p.x[static_cast<size_t>(i)] = Vec2(v[2 * i], v[2 * i + 1]);
}

/// Per-triangle terms of the untangling energy at one point (f_eps and what its gradient needs).
struct TriangleTerms {
  Mat2 J;
  double det, s, c, f;
};

/// Scratch of one untangle() call: the per-triangle terms of the point last evaluated.
struct UntangleScratch {
  std::vector<TriangleTerms> terms;
  Eigen::VectorXd trial;  ///< free positions of a line-search trial
};

/// The untangling energy sum_t w_t f_eps(J_t) / sum_t w_t at p's positions, with
/// f_eps(J) = ((1 - theta) |J|^2 + theta (det^2 + 1)) / chi(det J, eps); keeps each triangle's terms
/// in sc for untangle_gradient() at the same point.
double untangle_energy(const LocalProblem& p, double eps, UntangleScratch& sc) {
  double e = 0, wsum = 0;
  sc.terms.resize(p.tri.size());
  for (size_t t = 0; t < p.tri.size(); ++t) {
    TriangleTerms& q = sc.terms[t];
    q.J = deformation_gradient(p, t);
    q.det = q.J.determinant();
    q.s = std::sqrt(eps * eps + q.det * q.det);
    q.c = chi_of(q.det, eps, q.s);
    const double N = (1 - kTheta) * q.J.squaredNorm() + kTheta * (q.det * q.det + 1);
    q.f = N / q.c;
    e += p.weight[t] * q.f;
    wsum += p.weight[t];
  }
  if (wsum <= 0) return 0;
  return e / wsum;
}

/// The gradient of untangle_energy() over the free coordinates into grad, from the terms its last
/// call kept (the point it evaluated).
void untangle_gradient(const LocalProblem& p, const std::vector<Mat23>& G, const UntangleScratch& sc,
                       Eigen::VectorXd& grad) {
  double wsum = 0;
  grad.setZero(2 * p.num_free);
  for (size_t t = 0; t < p.tri.size(); ++t) {
    const TriangleTerms& q = sc.terms[t];
    const Mat2& J = q.J;
    const double det = q.det, s = q.s, c = q.c, f = q.f;
    wsum += p.weight[t];
    Mat2 cof;  // d det / dJ
    cof << J(1, 1), -J(1, 0), -J(0, 1), J(0, 0);
    // note: dchi/dD = chi / sqrt(eps^2 + D^2).
    const Mat2 dfdJ = (2 * (1 - kTheta) * J + 2 * kTheta * det * cof - f * (c / s) * cof) / c;
    // note: row k of gl is corner k's (x, y) gradient, D^T vec(dfdJ) without D's zeros (gradient_rows).
    const Eigen::Matrix<double, 3, 2> gl = p.weight[t] * G[t].transpose() * dfdJ.transpose();
    for (int k = 0; k < 3; ++k) {
      const int v = p.tri[t][static_cast<size_t>(k)];
      if (v >= p.num_free) continue;
      grad[2 * v] += gl(k, 0);
      grad[2 * v + 1] += gl(k, 1);
    }
  }
  if (wsum <= 0) return;
  grad /= wsum;
}

/// The smallest det F of p's triangles and how many have det F <= 0 (count_inverted()), in one pass.
struct Tangle {
  double min_det = std::numeric_limits<double>::infinity();
  int inverted = 0;
};

Tangle tangle(const LocalProblem& p) {
  Tangle r;
  for (size_t t = 0; t < p.tri.size(); ++t) {
    const double d = deformation_gradient(p, t).determinant();
    r.min_det = std::min(r.min_det, d);
    if (d <= 0) ++r.inverted;
  }
  return r;
}

/// Whether every triangle of the point sc's terms were evaluated at is shape_kept() at `floor`
/// (determinants first: they are kept, and any det <= 0 answers without a singular value).
bool every_shape_kept(const UntangleScratch& sc, double floor) {
  for (const TriangleTerms& q : sc.terms)
    if (!(q.det > 0)) return false;
  for (const TriangleTerms& q : sc.terms)
    if (!shape_kept(q.J, floor)) return false;
  return true;
}

/// One L-BFGS memory pair: position change s, gradient change y, and s.y (the two-loop recursion reads
/// it twice per pair and step; y.s and s.y are the same bits: the products commute, the sum's order is
/// Eigen's either way).
struct LbfgsPair {
  Eigen::VectorXd s, y;
  double sy;
};

/// The two-loop recursion: -H g, H the inverse Hessian estimate of mem (oldest first; H = I when empty).
Eigen::VectorXd lbfgs_direction(const std::deque<LbfgsPair>& mem, const Eigen::VectorXd& g) {
  Eigen::VectorXd q = g;
  std::vector<double> alpha(mem.size());
  for (size_t i = mem.size(); i-- > 0;) {
    alpha[i] = mem[i].s.dot(q) / mem[i].sy;
    q -= alpha[i] * mem[i].y;
  }
  if (!mem.empty()) q *= mem.back().sy / mem.back().y.squaredNorm();
  for (size_t i = 0; i < mem.size(); ++i) {
    const double beta = mem[i].y.dot(q) / mem[i].sy;
    q += (alpha[i] - beta) * mem[i].s;
  }
  return -q;
}

/// L-BFGS (memory 7) with Armijo backtracking on untangle_energy at a fixed eps, from p's positions
/// whose energy `e` the last untangle_energy() call gave (its terms are in sc); at most `iterations`
/// steps, fewer with a stop_floor (UntangleSettings). Leaves p at the best point found and returns its
/// energy (sc's terms are then stale). The gradient is formed only at points the line search accepts
/// (the same numbers as forming it at every trial).
double minimise_lbfgs(LocalProblem& p, const std::vector<Mat23>& G, double eps, int iterations, double e,
                      std::optional<double> stop_floor, UntangleScratch& sc, int& steps) {
  constexpr int kMemory = 7;
  Eigen::VectorXd x = free_positions(p), g, gn;
  untangle_gradient(p, G, sc, g);
  std::deque<LbfgsPair> mem;  // newest last
  for (int it = 0; it < iterations; ++it) {
    Eigen::VectorXd d = lbfgs_direction(mem, g);
    double slope = g.dot(d);
    if (!(slope < 0)) {  // not a descent direction: restart from steepest descent
      mem.clear();
      d = -g;
      slope = -g.squaredNorm();
    }
    if (slope == 0) break;
    // The first step of a steepest-descent restart has no scale: move the fastest vertex ~1 texel.
    double step = mem.empty() ? 1.0 / std::max(d.lpNorm<Eigen::Infinity>(), 1e-12) : 1.0;
    double en = e;
    bool moved = false;
    for (int ls = 0; ls < 40; ++ls, step *= 0.5) {
      sc.trial = x + step * d;
      set_free_positions(p, sc.trial);
      en = untangle_energy(p, eps, sc);
      if (en <= e + 1e-4 * step * slope) {
        moved = true;
        break;
      }
    }
    if (!moved) {
      set_free_positions(p, x);
      break;
    }
    ++steps;
    // note: p and sc's terms are at the accepted point here.
    if (stop_floor && every_shape_kept(sc, *stop_floor)) return en;
    untangle_gradient(p, G, sc, gn);
    Eigen::VectorXd s = step * d, y = gn - g;
    x += s;
    const double rel = (e - en) / std::max(std::abs(e), 1e-300);
    e = en;
    g = gn;
    const double sy = s.dot(y);
    if (sy > 1e-12 * s.norm() * y.norm()) {
      mem.push_back({std::move(s), std::move(y), sy});
      if (static_cast<int>(mem.size()) > kMemory) mem.pop_front();
    }
    if (rel < 1e-9) break;
  }
  return e;
}

}  // namespace

/// Whether the rounds' inverted counts so far (oldest first) show a stall by `st`.
bool stalled(const std::vector<int>& inverted, const UntangleStall& st) {
  const size_t n = inverted.size(), lag = static_cast<size_t>(st.rounds);
  if (n <= lag) return false;
  const int now = inverted[n - 1], then = inverted[n - 1 - lag];
  return now >= st.min_inverted && now > st.share * then;
}

bool untangle(LocalProblem& p, const UntangleSettings& s, UntangleReport* report) {
  UntangleReport local;
  UntangleReport& rep = report ? *report : local;
  rep = UntangleReport();
  double dmin = tangle(p).min_det;
  if (dmin > 0) return true;

  if (p.num_free == 0) return false;
  // An inverted triangle with no free corner cannot be repaired.
  for (size_t t = 0; t < p.tri.size(); ++t) {
    const auto& c = p.tri[t];
    if (c[0] >= p.num_free && c[1] >= p.num_free && c[2] >= p.num_free &&
        deformation_gradient(p, t).determinant() <= 0)
      return false;
  }
  std::vector<Mat23> G(p.tri.size());
  for (size_t t = 0; t < p.tri.size(); ++t) G[t] = gradient_rows(p.rest_inv[t]);
  double eps = std::sqrt(1e-12 + 0.04 * dmin * dmin);
  const Eigen::VectorXd start = free_positions(p);
  UntangleScratch sc;
  std::vector<int> inverted;  // per round
  for (int outer = 0; outer < s.outer_iterations; ++outer) {
    const double e_prev = untangle_energy(p, eps, sc);
    ++rep.rounds;
    const double e = minimise_lbfgs(p, G, eps, s.inner_iterations, e_prev, s.stop_floor, sc, rep.lbfgs_steps);
    const Tangle now = tangle(p);
    dmin = now.min_det;
    if (dmin > 0) return true;
    inverted.push_back(now.inverted);
    if (s.stall && stalled(inverted, *s.stall)) break;
    // Garanzha et al. 2021, section 4: shrink eps with the progress made, keeping it above the
    // most inverted triangle's determinant.
    const double sigma = std::max(1 - e / e_prev, 0.1);
    const double mu = (1 - sigma) * chi(dmin, eps);
    eps = dmin < mu ? 2 * std::sqrt(mu * (mu - dmin)) : 1e-10;
  }
  set_free_positions(p, start);
  return false;
}

}  // namespace texdefrag::merge
