// The 6-UPS hexapod (seed 001): the family seam of family.hpp, one class per
// capability. The error model is seed 001's 42 parameters
// (stewart_error_model.hpp), its pipeline the iterated least squares
// (stewart_calibration.hpp) on full poses; tracker targets go to the target fit.
#pragma once

#include "families/family.hpp"

namespace kincal::identify {

class StewartFamilyDescription final : public FamilyDescription {
 public:
  const char* name() const override { return kStewartFamily; }
  bool describes(const Robot& robot) const override { return robot.is_stewart(); }
  Robot parse(const nlohmann::json& doc, const detail::DescriptionReader& reader) const override;
  void write(const Robot& robot, nlohmann::ordered_json& doc) const override;
  void summarize(const Robot& robot, std::ostream& os) const override;
};

class StewartFamilyKinematics final : public FamilyKinematics {
 public:
  bool revolute(int) const override { return false; }
  int screw_joints() const override { return 6; }
  const char* target_body() const override { return "platform"; }
  Pose<double> home_pose(const Robot& robot) const override { return robot.stewart().home; }
  void joint_limits(const Robot& robot, Vec6<double>& lo, Vec6<double>& hi) const override;
  Status inverse(const Robot& robot, const Pose<double>& pose, Vec6<double>& q, Mat6<double>* J = nullptr,
                 double* passive = nullptr) const override;
  bool forward_jacobian(const Robot& robot, const Pose<double>& pose, Vec6<double>& q, Mat6<double>& J) const override;
  double characteristic_length(const Robot& robot) const override { return robot.stewart().characteristic_length; }
  double reach(const Robot& robot) const override;
  std::unique_ptr<ActualMachine> actual_machine(const Robot& nominal, const Robot& actual) const override;
};

class StewartFamilyErrorModel final : public FamilyErrorModel {
 public:
  const char* name() const override { return "seed 001 42-parameter model"; }
  const std::vector<ParameterSpec>& parameter_specs(const Robot& robot) const override;
  std::unique_ptr<detail::FamilyErrors> errors(const Robot& open) const override;  // stewart_errors.cpp
  Eigen::Index outlier_min_nodes() const override { return 8; }
};

class StewartFamilyMeasurement final : public FamilyMeasurement {
 public:
  std::string missing_measurement(const Robot&, const PoseTable& data) const override {
    if (data.has_measured || data.has_targets) return {};
    return "needs the measured pose columns mx,my,mz,mrx,mry,mrz or target positions t1x.. to diagnose a 6-UPS";
  }
  const char* own_measurement() const override { return "the full pose"; }
  // examples/seed001/grid_poses.csv: three layers, each pose tilted within ±5°.
  HandGrid hand_grid() const override { return {3, true}; }
};

class StewartFamilyTable final : public FamilyTable {
 public:
  AnyCalibrationTable machine_table(const CalibrationModel& model) const override;
  TableBounds<double> default_bounds(const Robot& robot) const override;
  std::vector<TableGroup> machine_groups(const Robot& robot) const override;
  const char* joint_range_key() const override { return "stroke"; }
  std::string machine_limit_violation(const AnyCalibrationTable& table,
                                      const MachineLimits<double>& limits) const override;
};

// Seed 001's pipeline on full poses (stewart_identify.cpp, stewart_base_fit.cpp).
class StewartFamilyPipeline final : public FamilyPipeline {
 public:
  bool reads(const Robot&, const PoseTable& data) const override { return data.has_measured; }
  const char* base_fit() const override { return "seed 001's iterated least squares"; }
  detail::BaseModel fit_base(const Robot& robot, const PoseTable& fit_data,
                             const std::vector<std::optional<EffectNode>>& nodes,
                             std::optional<EstimatorKind> estimator, bool finish_least_squares,
                             double ridge_k) const override;  // stewart_base_fit.cpp
  void check_identify_options(const IdentifyOptions& options) const override;
  Identification identify_own(const Robot& robot, const PoseTable& data, const IdentifyOptions& options,
                              std::ostream& narrative) const override;
};

// The 6-UPS's capabilities held together (families.cpp's registry).
const Family& stewart_family();

}  // namespace kincal::identify
