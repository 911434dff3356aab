// The least-squares step of every Gauss–Newton iteration on the host side
// (private to identify/): the base fits, the joint fit of base and effects,
// the hybrid fine stage's re-linearisation.
#pragma once

#include <Eigen/Core>
#include <Eigen/QR>

namespace kincal::identify::detail {

// Least squares on the column-scaled design by a rank-revealing complete
// orthogonal decomposition (columns in mm and rad, or per unit of an effect
// input, differ by orders of magnitude; never the normal equations): a zero
// column or one in the span of the others gets the minimum-norm share (0).
// Relative rank threshold 1e-10. One factorisation, any number of solves.
class ScaledLeastSquares {
 public:
  explicit ScaledLeastSquares(const Eigen::MatrixXd& X);
  Eigen::VectorXd solve(const Eigen::VectorXd& y) const;
  Eigen::Index rank() const { return cod_.rank(); }

 private:
  Eigen::VectorXd scale_;
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod_;
};

// ScaledLeastSquares(X).solve(y): the one solve of every Gauss–Newton step
// of the base and effect fits, and of the diagnosis's nested fits.
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
