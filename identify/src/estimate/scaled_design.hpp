// The column-scaled design, its rank rule and what its singular value
// decomposition tells (private to identify/): the rank, the conditioning and
// the coefficients' covariance of a least-squares fit, for the statistics of
// the joint fit of base and effects (effect_calibration.cpp) and of the
// laser-tracker target fit (target_calibration.cpp).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "kincal/identify/decompositions.hpp"
#include "kincal/identify/identifiability.hpp"
#include "kincal/identify/rank_tolerance.hpp"

namespace kincal::identify::detail {

// The one rank rule, kRankThreshold (rank_tolerance.hpp, with its reason),
// judged on the column-scaled design by each factorisation below, by
// ScaledLeastSquares and the descent's step (least_squares_step.hpp), and
// by the public identifiability report and estimators at their default
// rcond.

// The scaling of every solve here: D = column_scales(X) (identifiability.hpp;
// column norms, 1 for a zero column).

// A column-pivoted QR of S = X·D⁻¹ with the rank rule: for a solve that
// needs only the fitted part, a basis of the span or which columns are
// independent, where an SVD's directions are not needed. The pivots are
// judged as ScaledDesign's singular values are (|r_kk| > kRankThreshold ·
// |r_11|); the two agree on every design whose gap at the rank is wider
// than the pivots' slack (a factor ≤ √p of the singular values').
class ScaledPivotedQr {
 public:
  explicit ScaledPivotedQr(const Eigen::MatrixXd& X);
  Eigen::Index rank() const { return qr_.rank(); }
  // The least-squares coefficients of X (its own units); at a rank below
  // X's columns, the basic solution (the dependent columns' coefficients 0).
  Eigen::MatrixXd solve(const Eigen::MatrixXd& Y) const;
  // X·solve(Y): Y's part inside the span of X's columns.
  Eigen::MatrixXd fitted(const Eigen::MatrixXd& Y) const;
  // An orthonormal basis of that span (rows × rank): the Householder Q
  // applied to the first rank unit vectors, never the whole rows × rows Q.
  Eigen::MatrixXd column_space() const;
  // The columns a basis of the span is made of, in pivot order (rank of them).
  std::vector<Eigen::Index> independent_columns() const;

 private:
  Eigen::VectorXd scale_;
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr_;
};

// The SVD of S = X·D⁻¹, factored once. The rank by kRankThreshold; the
// right singular vectors V only when asked (at construction, or on first
// use: without them a BDCSVD costs about half).
class ScaledDesign {
 public:
  explicit ScaledDesign(const Eigen::MatrixXd& X, bool with_directions = false);
  const Eigen::VectorXd& scale() const { return scale_; }
  // min(n, p) singular values of S, descending.
  const Eigen::VectorXd& singular_values() const { return s_; }
  Eigen::Index rank() const { return rank_; }
  // s_max / s_min over all min(n, p) values (∞ when S is singular).
  double condition_number() const { return s_(0) / s_(s_.size() - 1); }
  // V (p × min(n, p)): S = U·Σ·Vᵀ.
  const Eigen::MatrixXd& V() const;
  // D⁻¹·V: the coefficients of X (its own units) along each singular
  // direction; the covariance of the least-squares coefficients is
  // σ²·(D⁻¹V)·Σ⁻²·(D⁻¹V)ᵀ at full rank.
  Eigen::MatrixXd directions() const;
  // Var(scaled coefficient j) / σ² over the determined directions,
  // Σ_{k < rank} V_jk² / s_k², and the part of unit coefficient j outside
  // them, Σ_{k ≥ rank} V_jk² (0 when the data determine it).
  double scaled_variance(Eigen::Index j) const;
  double outside_rank(Eigen::Index j) const;

 private:
  Eigen::VectorXd scale_;
  Eigen::MatrixXd S_;
  mutable Eigen::BDCSVD<Eigen::MatrixXd> svd_;
  Eigen::VectorXd s_;
  Eigen::Index rank_ = 0;
};

}  // namespace kincal::identify::detail
