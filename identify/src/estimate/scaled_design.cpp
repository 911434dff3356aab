#include "estimate/scaled_design.hpp"

namespace kincal::identify::detail {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

VectorXd column_scale(const MatrixXd& X) {
  VectorXd scale(X.cols());
  for (Index j = 0; j < X.cols(); ++j) {
    const double n = X.col(j).norm();
    scale(j) = n > 0 ? n : 1.0;
  }
  return scale;
}

ScaledDesign::ScaledDesign(const MatrixXd& X, bool with_directions)
    : scale_(column_scale(X)), S_(X * scale_.cwiseInverse().asDiagonal()) {
  svd_.compute(S_, with_directions ? Eigen::ComputeThinV : 0);
  s_ = svd_.singularValues();
  while (rank_ < s_.size() && s_(rank_) > kRankThreshold * s_(0)) ++rank_;
}

const MatrixXd& ScaledDesign::V() const {
  // The singular values stay those of the first factorisation (s_).
  if (!svd_.computeV()) svd_.compute(S_, Eigen::ComputeThinV);
  return svd_.matrixV();
}

MatrixXd ScaledDesign::directions() const { return scale_.cwiseInverse().asDiagonal() * V(); }

// Both from row j of V as a contiguous vector (the sums' order is a
// vector's, whatever V's storage).
double ScaledDesign::scaled_variance(Index j) const {
  const VectorXd v = V().row(j).transpose();
  return (v.head(rank_).array().square() / s_.head(rank_).array().square()).sum();
}

double ScaledDesign::outside_rank(Index j) const {
  const VectorXd v = V().row(j).transpose();
  return v.tail(v.size() - rank_).squaredNorm();
}

}  // namespace kincal::identify::detail
