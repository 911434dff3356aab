// One measurement model for every instrument kincal reads (issue #12 item 2),
// usable by both families:
//   - the full pose: 6 rows, the position, then the rotation (pose_error's
//     twist);
//   - 1–3 targets (SMRs) fixed on the platform (6-UPS) or the tool (hybrid),
//     at points t_k of its frame, seen from the instrument's frame
//     (registration T_IB; identity: the robot's base frame): 3 rows each,
//     y_k = T_IB·X·t_k (target_measurement.hpp);
//   - seed 000's three-target gauge: three targets on the tool at the gauge
//     radius (Eq. (9)), computed by the gauge's fixed-size kernel (gauge.hpp).
// Each predicts what it measures at a pose and maps a pose error twist
// (v at the pose's origin, ω; base axes, core/pose.hpp) to the change of
// that measurement, Δy = M·$, so a design is H = M·B (seed 000 Eq. (10))
// here for every instrument, the hybrid pipeline's per-node loops included
// (design_into: the gauge's rows from its fixed-size 9 × 6 kernel, written
// into the caller's stacked design without an allocation).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "kincal/core/hybrid.hpp"
#include "kincal/core/pose.hpp"

namespace kincal::identify {

// A measured rotation counts as the displacement it causes this far from its
// axis, so every row of a full pose is in mm and one noise level applies to
// all (the 6-UPS's fit, the full-pose target fit, the diagnosis, the plan).
inline constexpr double kOrientationWeightMm = 200.0;

class MeasurementModel {
 public:
  static MeasurementModel full_pose();
  static MeasurementModel targets(std::vector<Vec3<double>> points, const Pose<double>& registration = {});
  static MeasurementModel gauge(const HybridGeometry<double>& geometry, double radius);

  int rows() const;
  // Rows 3–5 are the rotation (the full pose); otherwise every row is a
  // position in mm.
  bool measures_orientation() const { return kind_ == Kind::FullPose; }
  // How it reads in a plan, e.g. "2 target positions (the robot's `targets`)".
  std::string describe() const;
  // The measured coordinates at `pose`: targets stacked (t1x t1y t1z t2x …),
  // or the pose as x, y, z, rx, ry, rz.
  Eigen::VectorXd predict(const Pose<double>& pose) const;
  // M (rows() × 6) at `pose`: Δy = M·$.
  Eigen::MatrixXd map(const Pose<double>& pose) const;
  // H = M·T for the twist columns T (6 × n) of some parameters at `pose`.
  Eigen::MatrixXd design(const Pose<double>& pose, const Eigen::Ref<const Eigen::MatrixXd>& T) const;
  // The same H written into the caller's rows() × n block (a node's rows of
  // a stacked design), with no temporary for the gauge and the full pose: the
  // gauge's fixed-size 9 × 6 map (seed 000 Eq. (9), gauge_map) times T, the
  // product the hybrid's per-node loops wrote by hand before (the same
  // Eigen product, so the same rounding).
  void design_into(const Pose<double>& pose, const Eigen::Ref<const Eigen::MatrixXd>& T,
                   Eigen::Ref<Eigen::MatrixXd> H) const;
  // The whitened design W·H = (W·M)·T, W = diag(row_weights) (1/σ of each
  // measured coordinate), into the caller's block: the planner's rows.
  void design_into(const Pose<double>& pose, const Eigen::Ref<const Eigen::MatrixXd>& T,
                   const Eigen::Ref<const Eigen::VectorXd>& row_weights, Eigen::Ref<Eigen::MatrixXd> H) const;
  // M alone into the caller's rows() × 6 block, where a twist is read back
  // from a measurement (the hybrid's residual twist) or M itself is kept.
  void map_into(const Pose<double>& pose, Eigen::Ref<Eigen::MatrixXd> M) const;

 private:
  enum class Kind { FullPose, Targets, Gauge };
  explicit MeasurementModel(Kind kind) : kind_(kind) {}
  Kind kind_;
  std::vector<Vec3<double>> points_;  // targets: on the platform / tool, mm
  Pose<double> registration_;         // targets: the base frame in the instrument frame
  HybridGeometry<double> geometry_{};  // gauge: the machine it sits on
  double radius_ = 0;                 // gauge: |P0 Pj|, mm
};

}  // namespace kincal::identify
