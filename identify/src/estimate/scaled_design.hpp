// The column-scaled design, its rank rule and what its singular value
// decomposition tells (private to identify/): the rank, the conditioning and
// the coefficients' covariance of a least-squares fit, for the statistics of
// the joint fit of base and effects (effect_calibration.cpp) and of the
// laser-tracker target fit (target_calibration.cpp).
#pragma once

#include <Eigen/Core>

#include "kincal/identify/decompositions.hpp"

namespace kincal::identify::detail {

// The one rank rule of identify/'s least-squares solves and of the
// statistics read from them: on the column-scaled design S = X·D⁻¹ (unit
// column norms, so mm, rad and an effect's units weigh alike), a direction
// counts when its singular value — or, in a rank-revealing QR, its pivot —
// exceeds kRankThreshold times the largest. Why 1e-10 and not rounding's
// max(n, p)·ε (rank_tolerance.hpp, the public identifiability report):
// a design's columns are not exact to ε — they come through iterated
// forward kinematics (converged to ~1e-9 mm), automatic or finite
// differences and the linearisation itself — so a direction below 1e-10 of
// the largest is the design's own error, not the machine; and its
// coefficient's standard error would exceed 1e10 times the noise's, which no
// data set of a machine determines. The solve (ScaledLeastSquares, the
// descent's step) and the rank, test degrees of freedom and covariance
// reported for it then agree on which directions were fitted.
inline constexpr double kRankThreshold = 1e-10;

// Column norms D (1 for a zero column): the scaling of every solve here.
Eigen::VectorXd column_scale(const Eigen::MatrixXd& X);

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
