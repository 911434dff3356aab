// The Liu estimator's parameter d, seed 000 Eqs. (13) and (14) (estimators.hpp,
// "Liu"; docs/estimators.md).
#include "kincal/identify/estimators.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "estimate/estimator_detail.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using namespace detail;  // the shared checks and search (estimator_detail.hpp)

// ---- Liu parameter (seed 000 Eqs. (13), (14)) ------------------------------

namespace {

// Eq. (13)'s MSE of the Liu estimate and Eq. (14)'s d over the spectrum
// (λ_j, α̂_j), j < n, read through at(j) -> {λ_j, α̂_j}: the one kernel of
// the vector forms below and of the projected data's (choose_d).
template <class At>
double liu_mse_over(Index n, At at, double sigma2, double d) {
  double var = 0, bias = 0;
  for (Index j = 0; j < n; ++j) {
    const auto [l, a] = at(j);
    const double l1 = (l + 1) * (l + 1);
    var += (l + d) * (l + d) / (l * l1);
    bias += a * a / l1;
  }
  return sigma2 * var + (d - 1) * (d - 1) * bias;
}

template <class At>
double liu_d_over(Index n, At at, double sigma2) {
  double num = 0, den = 0;
  for (Index j = 0; j < n; ++j) {
    const auto [l, a] = at(j);
    const double l1 = (l + 1) * (l + 1), a2 = a * a;
    num += (a2 - sigma2) / l1;
    den += (sigma2 + l * a2) / (l * l1);
  }
  // den = 0 only with σ̂² = 0 and α̂ = 0: nothing to shrink, d = 1 (OLS).
  return den > 0 ? num / den : 1.0;
}

}  // namespace

double liu_mse_eq13(const Eigen::VectorXd& lambda, const Eigen::VectorXd& alpha_hat, double sigma2, double d) {
  return liu_mse_over(lambda.size(), [&](Index j) { return std::pair{lambda(j), alpha_hat(j)}; }, sigma2, d);
}

double liu_d_eq14(const Eigen::VectorXd& lambda, const Eigen::VectorXd& alpha_hat, double sigma2) {
  return liu_d_over(lambda.size(), [&](Index j) { return std::pair{lambda(j), alpha_hat(j)}; }, sigma2);
}

double liu_d_minimise_mse(const Eigen::VectorXd& lambda, const Eigen::VectorXd& alpha_hat, double sigma2, double lo,
                          double hi) {
  return golden_min([&](double d) { return liu_mse_eq13(lambda, alpha_hat, sigma2, d); }, lo, hi);
}

LiuParameter detail::choose_d(const VectorXd& s, const VectorXd& c, double sigma2, const LiuOptions& opt) {
  LiuParameter p;
  if (opt.rule == LiuRule::Fixed) {
    if (!std::isfinite(opt.d)) throw InputError("Liu: fixed d is not finite");
    p.d = p.d_unclamped = opt.d;
    return p;
  }
  // λ_j = s_j², α̂_j = c_j / s_j.
  const auto projected = [&](Index j) { return std::pair{s(j) * s(j), c(j) / s(j)}; };
  p.d_unclamped = liu_d_over(c.size(), projected, sigma2);
  if (opt.rule == LiuRule::Eq14) {
    p.d = std::clamp(p.d_unclamped, 0.0, 1.0);
    p.clamped = p.d != p.d_unclamped;
  } else {
    // The MSE is a convex quadratic in d, so its minimum on [0, 1] is the
    // clamped Eq. (14) value; the unclamped one is reported for comparison.
    p.d = golden_min([&](double d) { return liu_mse_over(c.size(), projected, sigma2, d); }, 0.0, 1.0);
    p.clamped = p.d_unclamped < 0.0 || p.d_unclamped > 1.0;
  }
  return p;
}

}  // namespace kincal::identify
