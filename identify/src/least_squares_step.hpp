// The least-squares step of every Gauss–Newton iteration on the host side
// (private to identify/): the base fits, the joint fit of base and effects,
// the hybrid fine stage's re-linearisation.
#pragma once

#include <Eigen/Core>

namespace kincal::identify::detail {

// The column-scaled least-squares step (rank-revealing COD; a zero or
// collinear column gets no share): the one solve of every Gauss–Newton step
// of the base and effect fits.
Eigen::VectorXd scaled_least_squares(const Eigen::MatrixXd& X, const Eigen::VectorXd& y);
// The same step with Levenberg–Marquardt's damping λ on the scaled columns
// (Marquardt's scaling: min ‖y − X·δ‖² + λ‖D·δ‖², D the column norms): a
// step that shrinks the poorly determined directions far more than the
// well-determined ones, where halving a Gauss–Newton step shrinks all alike.
// λ = 0 is the undamped step above.
Eigen::VectorXd scaled_least_squares(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, double damping);

// Levenberg–Marquardt's damping schedule around a Gauss–Newton iteration: 0
// (the plain step) while steps descend; after a step that does not, 1e-3 and
// then ×10 per refusal; ÷10 per accepted step, back to 0 below 1e-6.
struct Damping {
  double lambda = 0;
  static constexpr double kLargest = 1e8;  // beyond it no step descends: stop
  void accepted() { lambda = lambda / 10 < 1e-6 ? 0.0 : lambda / 10; }
  bool refused() {  // false: give up
    lambda = lambda == 0 ? 1e-3 : 10 * lambda;
    return lambda <= kLargest;
  }
};

}  // namespace kincal::identify::detail
