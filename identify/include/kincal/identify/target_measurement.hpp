// The laser tracker as users have it (issue #12 item 2): one to three targets
// (SMRs) on the platform, their positions measured in the tracker's own
// frame. The instrument is described by
//   - the registration T_IB: the pose of the robot's base frame in the
//     instrument frame (p_I = R·p_B + t), and
//   - the targets' positions on the platform (platform frame, mm).
// A target k on the platform at pose X measures y_k = T_IB·X·t_k. To first
// order, a platform error twist $ (v at the platform origin, ω; base-frame
// axes, core/pose.hpp) moves it by R·(v + ω × X.R·t_k): the map M of
// H = M·B (seed 000 Eq. (10) with this M in place of the gauge's Eq. (9)).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "kincal/core/pose.hpp"

namespace kincal::identify {

using TargetPoints = Eigen::Matrix<double, 3, Eigen::Dynamic>;

// y_k = T_IB·X·t_k for every target (columns, in the targets' order).
TargetPoints predicted_targets(const Pose<double>& registration, const Pose<double>& platform,
                               const std::vector<Vec3<double>>& targets);

// M (3k × 6): the targets' displacement in the instrument frame per platform
// error twist (v, ω) in the base frame: rows of target k = R_IB·[I, −[X.R·t_k]×].
Eigen::MatrixXd target_map(const Pose<double>& registration, const Pose<double>& platform,
                           const std::vector<Vec3<double>>& targets);

// The instrument's own columns (3k × (6 + 3k)) for one pose, in the order
// registration twist (δv, δω: a small motion of the instrument frame's
// content, δy = δv + δω × y, instrument axes), then each target's offset in
// the platform frame (δy_k = R_IB·X.R·δt_k).
Eigen::MatrixXd instrument_columns(const Pose<double>& registration, const Pose<double>& platform,
                                   const std::vector<Vec3<double>>& targets);

// The registration moved by a twist in the instrument frame (the inverse of
// instrument_columns' first six columns to first order): R ← exp(δω)·R,
// t ← exp(δω)·t + δv.
Pose<double> moved_registration(const Pose<double>& registration, const Vec6<double>& twist);

// The rigid transform T minimising Σ|to_j − T·from_j|² (Kabsch / Horn: the SVD
// of the cross-covariance, the reflection excluded). Needs at least three
// points not on one line; fewer leave rotations free and T is one of the
// minimisers.
Pose<double> rigid_fit(const TargetPoints& from, const TargetPoints& to);

// The rows that keep a set of point errors d_j (3n, stacked) free of net rigid
// motion (6 × 3n): Σ d_j = 0 and Σ p_j × d_j = 0, i.e. d is orthogonal to
// every small rigid motion δv + δω × p_j of the points. The frame convention
// of target measurement (docs/identify.md "Laser tracker targets"): a rigid
// motion of all base joints is the registration's, of all platform joints
// the targets'.
Eigen::Matrix<double, 6, Eigen::Dynamic> rigid_motion_rows(const TargetPoints& points);

}  // namespace kincal::identify
