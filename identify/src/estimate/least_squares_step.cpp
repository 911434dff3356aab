#include "estimate/least_squares_step.hpp"

#include <cmath>

#include "estimate/scaled_design.hpp"
#include "kincal/identify/decompositions.hpp"

namespace kincal::identify::detail {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

ScaledLeastSquares::ScaledLeastSquares(const MatrixXd& X) : scale_(column_scales(X)) {
  cod_.setThreshold(kRankThreshold);
  cod_.compute(X * scale_.cwiseInverse().asDiagonal());
}

VectorXd ScaledLeastSquares::solve(const VectorXd& y) const { return scale_.cwiseInverse().asDiagonal() * cod_.solve(y); }

MatrixXd ScaledLeastSquares::held_out_factor(const MatrixXd& Xt) const {
  const Index r = cod_.rank();
  // x_tᵀ·S⁺ without forming the n-wide pseudo-inverse (applying Q to an
  // n × n identity was most of the diagnosis's time on the 6-RUS): with
  // S·P = Q·[T 0; 0 0]·Z, x_tᵀ·S⁺ = (T⁻ᵀ·(Z·Pᵀ·x_t)₁..ᵣ)ᵀ·Q₁..ᵣᵀ, and Q keeps
  // the norm and the inner products.
  MatrixXd c = cod_.colsPermutation().transpose() * (Xt * scale_.cwiseInverse().asDiagonal()).transpose();
  if (r < c.rows()) c = cod_.matrixZ() * c;
  cod_.matrixT().topLeftCorner(r, r).triangularView<Eigen::Upper>().transpose().solveInPlace(c.topRows(r));
  return c.topRows(r);
}

// Σ_t ‖x_tᵀ·X⁺‖² / rows = ‖Xt·D⁻¹·S⁺‖²_F / rows, S = X·D⁻¹ (X⁺ = D⁻¹·S⁺ at
// the solve's rank).
double ScaledLeastSquares::mean_leverage(const MatrixXd& Xt) const {
  if (Xt.rows() == 0 || cod_.rank() == 0) return 0.0;
  return held_out_factor(Xt).squaredNorm() / double(Xt.rows());
}

double ScaledLeastSquares::prediction_chi2(const MatrixXd& Xt, const VectorXd& rt) const {
  if (Xt.rows() == 0) return 0.0;
  if (cod_.rank() == 0) return rt.squaredNorm();
  // (I + Bᵀ·B)⁻¹ = I − Bᵀ·(I + B·Bᵀ)⁻¹·B (Woodbury): one rank × rank solve.
  const MatrixXd B = held_out_factor(Xt);
  const VectorXd Br = B * rt;
  const MatrixXd inner = MatrixXd::Identity(B.rows(), B.rows()) + B * B.transpose();
  return rt.squaredNorm() - Br.dot(inner.llt().solve(Br));
}

AppendedColumnsLeastSquares::AppendedColumnsLeastSquares(const MatrixXd& X0) : X0_(X0), scale0_(column_scales(X0)) {
  qr0_.compute(X0 * scale0_.cwiseInverse().asDiagonal());
  const Index p0 = X0.cols();
  if (X0.rows() >= p0 && p0 > 0) {
    r0_.setThreshold(kRankThreshold);
    r0_.compute(MatrixXd(qr0_.matrixQR().topRows(p0).triangularView<Eigen::Upper>()));
    rank0_ = r0_.rank();
  }
}

double AppendedColumnsLeastSquares::share_of(const VectorXd& QtG_top, double g2) const {
  if (!(g2 > 0)) return 0.0;
  if (rank0_ < QtG_top.size())  // … and in range(R0)'s basis
    return (r0_.householderQ().adjoint() * QtG_top).head(rank0_).squaredNorm() / g2;
  return QtG_top.squaredNorm() / g2;
}

VectorXd AppendedColumnsLeastSquares::shares_in_span(const MatrixXd& G) const {
  const Index n = X0_.rows(), p0 = X0_.cols(), k = G.cols();
  VectorXd shares = VectorXd::Zero(k);
  if (p0 == 0) return shares;
  if (n < p0) {  // wider than tall: no triangular R0 to read the span off
    const ScaledLeastSquares ls(X0_);
    for (Index j = 0; j < k; ++j)
      if (G.col(j).squaredNorm() > 0)
        shares(j) = (X0_ * ls.solve(G.col(j))).squaredNorm() / G.col(j).squaredNorm();
    return shares;
  }
  const MatrixXd QtG = qr0_.householderQ().adjoint() * G;  // G in Q's directions, all columns at once
  for (Index j = 0; j < k; ++j) shares(j) = share_of(QtG.col(j).head(p0), G.col(j).squaredNorm());
  return shares;
}

VectorXd AppendedColumnsLeastSquares::solve(const MatrixXd& G, const VectorXd& y, Index& rank, VectorXd* shares) const {
  const Index n = X0_.rows(), p0 = X0_.cols(), k = G.cols();
  if (n < 2 * (p0 + k)) {
    if (shares != nullptr) *shares = shares_in_span(G);
    MatrixXd X(n, p0 + k);
    X << X0_, G;
    const ScaledLeastSquares ls(X);
    rank = ls.rank();
    return ls.solve(y);
  }
  const VectorXd scale_g = column_scales(G);
  // Qᵀ applied to the scaled G and to y in one pass (its block reflector
  // formed once).
  MatrixXd Gy(n, k + 1);
  Gy.leftCols(k) = G * scale_g.cwiseInverse().asDiagonal();
  Gy.col(k) = y;
  const MatrixXd QtGy = qr0_.householderQ().adjoint() * Gy;
  const auto QtG = QtGy.leftCols(k);
  const auto Qty = QtGy.col(k);
  if (shares != nullptr) {
    shares->resize(k);
    for (Index j = 0; j < k; ++j) (*shares)(j) = share_of(QtG.col(j).head(p0), Gy.col(j).squaredNorm());
  }
  MatrixXd C = MatrixXd::Zero(p0 + k, p0 + k);
  C.topLeftCorner(p0, p0) = qr0_.matrixQR().topRows(p0).triangularView<Eigen::Upper>();
  VectorXd rhs(p0 + k);
  rhs.head(p0) = Qty.head(p0);
  if (k > 0) {  // no columns appended: the current design's own fit
    const Eigen::HouseholderQR<MatrixXd> qr2(QtG.bottomRows(n - p0));
    const VectorXd Q2ty = qr2.householderQ().adjoint() * Qty.tail(n - p0);
    C.topRightCorner(p0, k) = QtG.topRows(p0);
    C.bottomRightCorner(k, k) = qr2.matrixQR().topRows(k).triangularView<Eigen::Upper>();
    rhs.tail(k) = Q2ty.head(k);
  }
  Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod;
  cod.setThreshold(kRankThreshold);
  cod.compute(C);
  rank = cod.rank();
  VectorXd delta = cod.solve(rhs);
  delta.head(p0).array() /= scale0_.array();
  delta.tail(k).array() /= scale_g.array();
  return delta;
}

VectorXd scaled_least_squares(const MatrixXd& X, const VectorXd& y) { return ScaledLeastSquares(X).solve(y); }

DescentStep::DescentStep(const MatrixXd& X, const VectorXd& y) : scale_(column_scales(X)), y_(y) {
  S_ = X * scale_.cwiseInverse().asDiagonal();
  const Index p = S_.cols();
  N_ = MatrixXd::Zero(p, p);
  N_.selfadjointView<Eigen::Lower>().rankUpdate(S_.transpose());
  Sty_ = S_.transpose() * y_;
  llt_.compute(N_);
  normal_ok_ = p > 0 && llt_.info() == Eigen::Success && llt_.rcond() > 1e-12;
}

VectorXd DescentStep::refined(const Eigen::LLT<MatrixXd>& llt, double damping) const {
  VectorXd z = llt.solve(Sty_);
  const VectorXd r = y_ - S_ * z;
  z += llt.solve(VectorXd(S_.transpose() * r - damping * z));
  return z;
}

VectorXd DescentStep::solve(double damping) const {
  if (!(damping > 0)) {
    if (normal_ok_) return scale_.cwiseInverse().asDiagonal() * refined(llt_, 0.0);
    return scaled_least_squares(S_, y_).cwiseQuotient(scale_);  // S's own columns are unit (or zero)
  }
  MatrixXd A = N_;
  A.diagonal().array() += damping;
  return scale_.cwiseInverse().asDiagonal() * refined(Eigen::LLT<MatrixXd>(A), damping);
}

VectorXd scaled_least_squares(const MatrixXd& X, const VectorXd& y, double damping) {
  if (!(damping > 0)) return scaled_least_squares(X, y);
  const Index n = X.rows(), p = X.cols();
  const VectorXd scale = column_scales(X);
  MatrixXd A(n + p, p);
  A.topRows(n) = X * scale.cwiseInverse().asDiagonal();
  A.bottomRows(p) = std::sqrt(damping) * MatrixXd::Identity(p, p);
  VectorXd b = VectorXd::Zero(n + p);
  b.head(n) = y;
  return scale.cwiseInverse().asDiagonal() * Eigen::HouseholderQR<MatrixXd>(A).solve(b);
}

}  // namespace kincal::identify::detail
