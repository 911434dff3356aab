// The 6-RUS hexapod (GUIDE "A third family"; core/rus6.hpp): the family seam
// of family.hpp, one class per capability. No own pipeline: full poses and
// tracker targets both go to the family-free target fit
// (target_calibration.hpp) on the error model of rus6_error_model.hpp (66
// parameters, 11 per leg); compensation is the closed-form IK of the
// calibrated geometry (core/rus6_machine.hpp).
#pragma once

#include "families/family.hpp"

namespace kincal::identify {

class Rus6FamilyDescription final : public FamilyDescription {
 public:
  const char* name() const override { return kRus6Family; }
  bool describes(const Robot& robot) const override { return robot.is_rus6(); }
  Robot parse(const nlohmann::json& doc, const detail::DescriptionReader& reader) const override;
  void write(const Robot& robot, nlohmann::ordered_json& doc) const override;
  void summarize(const Robot& robot, std::ostream& os) const override;
};

class Rus6FamilyKinematics final : public FamilyKinematics {
 public:
  bool revolute(int) const override { return true; }
  int screw_joints() const override { return 6; }  // every motor: `cyclic` per motor revolution
  const char* target_body() const override { return "platform"; }
  Pose<double> home_pose(const Robot& robot) const override { return robot.rus6().home; }
  void joint_limits(const Robot& robot, Vec6<double>& lo, Vec6<double>& hi) const override;
  Status inverse(const Robot& robot, const Pose<double>& pose, Vec6<double>& q, Mat6<double>* J = nullptr,
                 double* passive = nullptr) const override;
  bool forward_jacobian(const Robot& robot, const Pose<double>& pose, Vec6<double>& q, Mat6<double>& J) const override;
  double characteristic_length(const Robot& robot) const override { return robot.rus6().characteristic_length; }
  double reach(const Robot& robot) const override;
  std::unique_ptr<ActualMachine> actual_machine(const Robot& nominal, const Robot& actual) const override;
  std::vector<FamilyFormulaVariable> formula_joint_variables() const override;
  bool formula_joint_values(const Robot& robot, const Pose<double>& pose, double* values) const override;
};

class Rus6FamilyErrorModel final : public FamilyErrorModel {
 public:
  const char* name() const override { return "6-RUS 66-parameter model"; }
  const std::vector<ParameterSpec>& parameter_specs(const Robot& robot) const override;  // rus6_error_model.cpp
  std::unique_ptr<detail::FamilyErrors> errors(const Robot& open) const override;  // rus6_error_model.cpp
  // The target fit's deleted-node screen: 66 parameters over 6 rows per
  // full pose need 11 nodes; a few more keep the screen's F test testable.
  Eigen::Index outlier_min_nodes() const override { return 14; }
};

class Rus6FamilyMeasurement final : public FamilyMeasurement {
 public:
  std::string missing_measurement(const Robot&, const PoseTable& data) const override {
    if (data.has_measured || data.has_targets) return {};
    return "needs the measured pose columns mx,my,mz,mrx,mry,mrz or target positions t1x.. to diagnose a 6-RUS";
  }
  const char* own_measurement() const override { return "the full pose"; }
  HandGrid hand_grid() const override { return {3, true}; }
};

class Rus6FamilyTable final : public FamilyTable {
 public:
  AnyCalibrationTable machine_table(const CalibrationModel& model) const override;
  TableBounds<double> default_bounds(const Robot& robot) const override;
  std::vector<TableGroup> machine_groups(const Robot& robot) const override;
  const char* joint_range_key() const override { return "joint_limits"; }
  std::string machine_limit_violation(const AnyCalibrationTable& table,
                                      const MachineLimits<double>& limits) const override;
  std::string machine_value_violation(const AnyCalibrationTable& table) const override;
};

// The 6-RUS's capabilities held together, without an own pipeline
// (families.cpp's registry).
const Family& rus6_family();

}  // namespace kincal::identify
