#include "least_squares_step.hpp"

#include <Eigen/QR>
#include <cmath>

namespace kincal::identify::detail {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

VectorXd scaled_least_squares(const MatrixXd& X, const VectorXd& y) {
  // Column-scaled, rank-revealing: a column of zeros or one in the span of
  // the others gets the minimum-norm share (0).
  VectorXd scale(X.cols());
  for (Index j = 0; j < X.cols(); ++j) scale(j) = X.col(j).norm() > 0 ? X.col(j).norm() : 1.0;
  Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod;
  cod.setThreshold(1e-10);
  cod.compute(X * scale.cwiseInverse().asDiagonal());
  return scale.cwiseInverse().asDiagonal() * cod.solve(y);
}

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
