// Per-triangle algebra shared by the local UV optimisers. The flip-preventing step bound follows
// Smith & Schaefer, "Bijective parameterization with free boundaries", SIGGRAPH 2015, section 4.
#include "local_problem.h"

#include <cmath>
#include <limits>

namespace texdefrag::merge {

Mat23 gradient_rows(const Mat2& rest_inv) {
  // G(j, k) = c_kj with c_0j = -(R_0j + R_1j), c_1j = R_0j, c_2j = R_1j (F_ij = sum_k c_kj x_k,i).
  Mat23 G;
  for (int j = 0; j < 2; ++j) {
    G(j, 0) = -(rest_inv(0, j) + rest_inv(1, j));
    G(j, 1) = rest_inv(0, j);
    G(j, 2) = rest_inv(1, j);
  }
  return G;
}

Mat46 gradient_operator(const Mat2& rest_inv) {
  const Mat23 G = gradient_rows(rest_inv);
  Mat46 D = Mat46::Zero();
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 3; ++k) D(i * 2 + j, 2 * k + i) = G(j, k);
  return D;
}

double arap_error_2x2(const Mat2& F) {
  const Eigen::Vector2d s = signed_singular_values_2x2(F);
  return (s.x() - 1) * (s.x() - 1) + (s.y() - 1) * (s.y() - 1);
}

namespace {
/// Smallest positive root of a t^2 + b t + c (c != 0), or +inf.
double smallest_positive_root(double a, double b, double c) {
  const double inf = std::numeric_limits<double>::infinity();
  const double scale = std::max({std::abs(a), std::abs(b), std::abs(c)});
  if (scale == 0) return inf;
  if (std::abs(a) <= 1e-14 * scale) {
    if (b == 0) return inf;
    const double t = -c / b;
    return t > 0 ? t : inf;
  }
  const double disc = b * b - 4 * a * c;
  if (disc < 0) return inf;
  // note: numerically stable pair of roots (no cancellation).
  const double q = -0.5 * (b + std::copysign(std::sqrt(disc), b));
  double t1 = q / a, t2 = q != 0 ? c / q : inf;
  double best = inf;
  if (t1 > 0) best = std::min(best, t1);
  if (t2 > 0) best = std::min(best, t2);
  return best;
}
}  // namespace

double max_injective_step(const LocalProblem& p, const Eigen::VectorXd& dir) {
  double best = std::numeric_limits<double>::infinity();
  auto d_of = [&](int i) -> Vec2 {
    if (i >= p.num_free) return Vec2::Zero();
    return {dir[2 * i], dir[2 * i + 1]};
  };
  for (size_t t = 0; t < p.tri.size(); ++t) {
    const auto& c = p.tri[t];
    const Vec2 e1 = p.x[static_cast<size_t>(c[1])] - p.x[static_cast<size_t>(c[0])];
    const Vec2 e2 = p.x[static_cast<size_t>(c[2])] - p.x[static_cast<size_t>(c[0])];
    const Vec2 d1 = d_of(c[1]) - d_of(c[0]);
    const Vec2 d2 = d_of(c[2]) - d_of(c[0]);
    const double a = d1.x() * d2.y() - d1.y() * d2.x();
    const double b = e1.x() * d2.y() + d1.x() * e2.y() - e1.y() * d2.x() - d1.y() * e2.x();
    const double c0 = e1.x() * e2.y() - e1.y() * e2.x();
    // Orientation of the rest triangle decides which sign of det(B) is "positive F".
    const double rest_sign = p.rest_inv[t].determinant() > 0 ? 1.0 : -1.0;
    if (c0 * rest_sign <= 0) continue;  // already inverted: not this bound's business
    best = std::min(best, smallest_positive_root(a, b, c0));
  }
  return best;
}

int count_inverted(const LocalProblem& p) {
  int n = 0;
  for (size_t t = 0; t < p.tri.size(); ++t)
    if (deformation_gradient(p, t).determinant() <= 0) ++n;
  return n;
}

}  // namespace texdefrag::merge
