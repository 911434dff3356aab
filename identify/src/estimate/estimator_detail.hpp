// What the estimators' modules share (private to identify/): the checks of
// a linear problem, number formatting for their messages, the golden-section
// search of the Liu and ridge parameters, and the Liu parameter from a
// projected spectrum (liu.cpp), which PreparedDesign's Liu fit uses.
#pragma once

#include <cmath>
#include <string>

#include <Eigen/Core>

#include "kincal/identify/estimators.hpp"

namespace kincal::identify::detail {

std::string fmt(double v, const char* format = "%.4g");
std::string idx(Eigen::Index i);

// Checks of everything but y (InputError naming the row or column).
void validate_design(const LinearProblem& p);
void validate_y(const LinearProblem& p);

// Golden-section search of a unimodal f on [lo, hi].
template <class F>
double golden_min(F f, double lo, double hi) {
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double a = lo, b = hi;
  double c = b - g * (b - a), d = a + g * (b - a);
  double fc = f(c), fd = f(d);
  for (int it = 0; it < 200 && (b - a) > 1e-12 * (1.0 + std::abs(a) + std::abs(b)); ++it) {
    if (fc <= fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - g * (b - a);
      fc = f(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + g * (b - a);
      fd = f(d);
    }
  }
  return 0.5 * (a + b);
}

// The Liu parameter of `opt` from the projected data without forming
// vectors (a Monte Carlo run stays allocation-free): λ_j = s_j²,
// α̂_j = c_j / s_j (c = Uᵀy_w, α̂ = Vᵀx̂); seed 000 Eqs. (13), (14).
LiuParameter choose_d(const Eigen::VectorXd& s, const Eigen::VectorXd& c, double sigma2, const LiuOptions& opt);

}  // namespace kincal::identify::detail
