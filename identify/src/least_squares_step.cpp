#include "least_squares_step.hpp"

#include <Eigen/QR>
#include <cmath>

namespace kincal::identify::detail {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

ScaledLeastSquares::ScaledLeastSquares(const MatrixXd& X) : scale_(X.cols()) {
  for (Index j = 0; j < X.cols(); ++j) {
    const double n = X.col(j).norm();
    scale_(j) = n > 0 ? n : 1.0;
  }
  cod_.setThreshold(1e-10);
  cod_.compute(X * scale_.cwiseInverse().asDiagonal());
}

VectorXd ScaledLeastSquares::solve(const VectorXd& y) const { return scale_.cwiseInverse().asDiagonal() * cod_.solve(y); }

VectorXd scaled_least_squares(const MatrixXd& X, const VectorXd& y) { return ScaledLeastSquares(X).solve(y); }

VectorXd scaled_least_squares(const MatrixXd& X, const VectorXd& y, double damping) {
  if (!(damping > 0)) return scaled_least_squares(X, y);
  const Index n = X.rows(), p = X.cols();
  VectorXd scale(p);
  for (Index j = 0; j < p; ++j) scale(j) = X.col(j).norm() > 0 ? X.col(j).norm() : 1.0;
  MatrixXd A(n + p, p);
  A.topRows(n) = X * scale.cwiseInverse().asDiagonal();
  A.bottomRows(p) = std::sqrt(damping) * MatrixXd::Identity(p, p);
  VectorXd b = VectorXd::Zero(n + p);
  b.head(n) = y;
  return scale.cwiseInverse().asDiagonal() * Eigen::HouseholderQR<MatrixXd>(A).solve(b);
}

}  // namespace kincal::identify::detail
