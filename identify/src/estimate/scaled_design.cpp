#include "estimate/scaled_design.hpp"

namespace kincal::identify::detail {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

ScaledPivotedQr::ScaledPivotedQr(const MatrixXd& X) : scale_(column_scales(X)) {
  qr_.setThreshold(kRankThreshold);
  qr_.compute(X * scale_.cwiseInverse().asDiagonal());
}

MatrixXd ScaledPivotedQr::solve(const MatrixXd& Y) const { return scale_.cwiseInverse().asDiagonal() * qr_.solve(Y); }

MatrixXd ScaledPivotedQr::fitted(const MatrixXd& Y) const {
  MatrixXd QtY = qr_.householderQ().adjoint() * Y;
  QtY.bottomRows(QtY.rows() - qr_.rank()).setZero();
  return qr_.householderQ() * QtY;
}

MatrixXd ScaledPivotedQr::column_space() const {
  return qr_.householderQ() * MatrixXd::Identity(qr_.rows(), qr_.rank());
}

std::vector<Index> ScaledPivotedQr::independent_columns() const {
  std::vector<Index> out;
  for (Index k = 0; k < qr_.rank(); ++k) out.push_back(qr_.colsPermutation().indices()(k));
  return out;
}

ScaledDesign::ScaledDesign(const MatrixXd& X, bool with_directions)
    : scale_(column_scales(X)), S_(X * scale_.cwiseInverse().asDiagonal()) {
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
