// The hybrid 3-UPS/UP + 3R machine (seed 000): the family seam of
// family.hpp, one class per capability. The error model is seed 000's 150
// source errors (hybrid_error_model.hpp), its pipeline the coarse + fine
// estimate (hybrid_calibration.hpp), its own instrument the three-target gauge.
#pragma once

#include "families/family.hpp"

namespace kincal::identify {

class HybridFamilyDescription final : public FamilyDescription {
 public:
  const char* name() const override { return kHybridFamily; }
  bool describes(const Robot& robot) const override { return robot.is_hybrid(); }
  Robot parse(const nlohmann::json& doc, const detail::DescriptionReader& reader) const override;
  void write(const Robot& robot, nlohmann::ordered_json& doc) const override;
  void summarize(const Robot& robot, std::ostream& os) const override;
};

class HybridFamilyKinematics final : public FamilyKinematics {
 public:
  // The UPS limbs are prismatic and screw-driven; the wrist's three joints
  // are revolute (a screw lead means nothing there).
  bool revolute(int joint) const override { return joint >= 3; }
  int screw_joints() const override { return 3; }
  const char* target_body() const override { return "tool"; }
  Pose<double> home_pose(const Robot& robot) const override;
  void joint_limits(const Robot& robot, Vec6<double>& lo, Vec6<double>& hi) const override;
  std::vector<PassiveLimit> passive_limits(const Robot& robot) const override;
  Status inverse(const Robot& robot, const Pose<double>& pose, Vec6<double>& q, Mat6<double>* J = nullptr,
                 double* passive = nullptr) const override;
  bool forward_jacobian(const Robot& robot, const Pose<double>& pose, Vec6<double>& q, Mat6<double>& J) const override;
  double characteristic_length(const Robot& robot) const override { return robot.hybrid().characteristic_length; }
  double reach(const Robot& robot) const override;
  void set_effect_frame(const Robot& robot, EffectParameters<double>& e) const override;
  std::unique_ptr<ActualMachine> actual_machine(const Robot& nominal, const Robot& actual) const override;
};

class HybridFamilyErrorModel final : public FamilyErrorModel {
 public:
  const char* name() const override { return "seed 000 source-error model"; }
  const std::vector<ParameterSpec>& parameter_specs(const Robot& robot) const override;
  std::string alias_of(const std::string& name) const override;
  std::unique_ptr<detail::FamilyErrors> errors(const Robot& open) const override;  // hybrid_errors.cpp
  Eigen::Index outlier_min_nodes() const override { return 7; }
};

class HybridFamilyMeasurement final : public FamilyMeasurement {
 public:
  std::string missing_measurement(const Robot& robot, const PoseTable& data) const override;
  const char* own_measurement() const override { return "the hybrid's gauge"; }
  std::optional<MeasurementModel> own_targets(const Robot& robot) const override {
    return MeasurementModel::gauge(robot.hybrid(), robot.hybrid_description().gauge_radius);  // seed 000's gauge
  }
  // seed 000's layers: one layer of pure translations.
  HandGrid hand_grid() const override { return {1, false}; }
};

class HybridFamilyTable final : public FamilyTable {
 public:
  AnyCalibrationTable machine_table(const CalibrationModel& model) const override;
  TableBounds<double> default_bounds(const Robot& robot) const override;
  std::vector<TableGroup> machine_groups(const Robot& robot) const override;
  const char* joint_range_key() const override { return "joint_limits"; }
  std::string machine_limit_violation(const AnyCalibrationTable& table,
                                      const MachineLimits<double>& limits) const override;
  std::string machine_value_violation(const AnyCalibrationTable& table) const override;
};

// Seed 000's coarse + fine stages on the gauge (hybrid_identify.cpp,
// hybrid_base_fit.cpp).
class HybridFamilyPipeline final : public FamilyPipeline {
 public:
  // The gauge's columns, where the description names no targets of its own
  // (full poses alone go to the target fit's full-pose reading).
  bool reads(const Robot& robot, const PoseTable& data) const override {
    return robot.targets.empty() && data.has_targets;
  }
  const char* base_fit() const override { return "seed 000's coarse + fine stages"; }
  detail::BaseModel fit_base(const Robot& robot, const PoseTable& fit_data,
                             const std::vector<std::optional<EffectNode>>& nodes,
                             std::optional<EstimatorKind> estimator, bool finish_least_squares,
                             double ridge_k) const override;  // hybrid_base_fit.cpp
  bool steps_base_with_effects() const override { return true; }
  std::unique_ptr<detail::SteppedBaseFit> stepped_base_fit(const Robot& robot, const PoseTable& start,
                                                           const std::vector<std::optional<EffectNode>>& nodes,
                                                           EstimatorKind estimator,
                                                           double ridge_k) const override;  // hybrid_base_fit.cpp
  Identification identify_own(const Robot& robot, const PoseTable& data, const IdentifyOptions& options,
                              std::ostream& narrative) const override;
};

// The hybrid's capabilities held together (families.cpp's registry).
const Family& hybrid_family();

}  // namespace kincal::identify
