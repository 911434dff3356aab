#include "kincal/identify/measurement_model.hpp"

#include <cstdio>

#include "kincal/identify/gauge.hpp"
#include "kincal/identify/simulate.hpp"
#include "kincal/identify/target_measurement.hpp"

namespace kincal::identify {

MeasurementModel MeasurementModel::full_pose() { return MeasurementModel(Kind::FullPose); }

MeasurementModel MeasurementModel::targets(std::vector<Vec3<double>> points, const Pose<double>& registration) {
  MeasurementModel m(Kind::Targets);
  m.points_ = std::move(points);
  m.registration_ = registration;
  return m;
}

MeasurementModel MeasurementModel::gauge(const HybridGeometry<double>& geometry, double radius) {
  MeasurementModel m(Kind::Gauge);
  m.geometry_ = geometry;
  m.radius_ = radius;
  return m;
}

int MeasurementModel::rows() const {
  switch (kind_) {
    case Kind::FullPose: return 6;
    case Kind::Targets: return 3 * int(points_.size());
    case Kind::Gauge: return 9;
  }
  return 0;
}

std::string MeasurementModel::describe() const {
  switch (kind_) {
    case Kind::FullPose: return "the full pose (x, y, z, rx, ry, rz)";
    case Kind::Targets:
      return std::to_string(points_.size()) + " target position" + (points_.size() > 1 ? "s" : "") +
             " (the robot's `targets`)";
    case Kind::Gauge: {
      char radius[32];
      std::snprintf(radius, sizeof radius, "%.1f", radius_);
      return std::string("seed 000's three-target gauge (t1..t3, radius ") + radius + " mm)";
    }
  }
  return {};
}

Eigen::VectorXd MeasurementModel::predict(const Pose<double>& pose) const {
  switch (kind_) {
    case Kind::FullPose: return pose.to_xyz_rpy();
    case Kind::Targets: return predicted_targets(registration_, pose, points_).reshaped();
    case Kind::Gauge: return gauge_targets(geometry_, radius_, pose).reshaped();
  }
  return {};
}

Eigen::MatrixXd MeasurementModel::map(const Pose<double>& pose) const {
  switch (kind_) {
    case Kind::FullPose: return Eigen::MatrixXd::Identity(6, 6);
    case Kind::Targets: return target_map(registration_, pose, points_);
    case Kind::Gauge: return gauge_map(geometry_, radius_, pose);
  }
  return {};
}

Eigen::MatrixXd MeasurementModel::design(const Pose<double>& pose, const Eigen::Ref<const Eigen::MatrixXd>& T) const {
  switch (kind_) {
    case Kind::FullPose: return T;  // M = I
    // A fresh result: the product straight into it (design_into's Ref
    // arguments cost the target fit's small products ~30 % more).
    case Kind::Targets: return target_map(registration_, pose, points_) * T;
    case Kind::Gauge: {
      Eigen::MatrixXd H(9, T.cols());
      design_into(pose, T, H);
      return H;
    }
  }
  return {};
}

void MeasurementModel::design_into(const Pose<double>& pose, const Eigen::Ref<const Eigen::MatrixXd>& T,
                                   Eigen::Ref<Eigen::MatrixXd> H) const {
  switch (kind_) {
    case Kind::FullPose: H = T; return;  // M = I
    case Kind::Targets: H.noalias() = target_map(registration_, pose, points_) * T; return;
    // 9 × 6 (fixed) by 6 × n: no temporary; the map on the stack.
    case Kind::Gauge: H.noalias() = gauge_map(geometry_, radius_, pose) * T; return;
  }
}

void MeasurementModel::design_into(const Pose<double>& pose, const Eigen::Ref<const Eigen::MatrixXd>& T,
                                   const Eigen::Ref<const Eigen::VectorXd>& row_weights,
                                   Eigen::Ref<Eigen::MatrixXd> H) const {
  switch (kind_) {
    case Kind::FullPose: H.noalias() = row_weights.asDiagonal() * T; return;
    case Kind::Targets:
      H.noalias() = (row_weights.asDiagonal() * target_map(registration_, pose, points_)) * T;
      return;
    case Kind::Gauge: H.noalias() = (row_weights.asDiagonal() * gauge_map(geometry_, radius_, pose)) * T; return;
  }
}

void MeasurementModel::map_into(const Pose<double>& pose, Eigen::Ref<Eigen::MatrixXd> M) const {
  switch (kind_) {
    case Kind::FullPose: M.setIdentity(); return;
    case Kind::Targets: M = target_map(registration_, pose, points_); return;
    case Kind::Gauge: M = gauge_map(geometry_, radius_, pose); return;
  }
}

}  // namespace kincal::identify
