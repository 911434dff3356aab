// The family seam (issue #12 item 1, split into capabilities in #33;
// docs/architecture.md "Adding a machine family"): what one machine family
// gives everything above identify/src/families. A family is one folder
// (families/stewart, families/hybrid, families/rus6) defining its six
// capabilities — description, kinematics, error model, measurement, table,
// and optionally its own pipeline — and one line in families.cpp's registry;
// the callers (robot descriptions, joint limits, effects, parameters, the
// target fit, simulate, plan, diagnosis, calibration tables, identify) ask
// the capability they need of their robot's family instead of switching on it.
//
// Private to identify/. Robot keeps its variant of core geometries (core's
// compile-time machines need the concrete type); family_of() is the one
// place that maps a Robot to its family.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "kincal/core/calibration_table.hpp"
#include "kincal/core/effects.hpp"
#include "kincal/core/pose.hpp"
#include "kincal/core/status.hpp"
#include "kincal/core/stewart.hpp"  // FkReport
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/estimators.hpp"
#include "kincal/identify/identify.hpp"
#include "kincal/identify/measurement_model.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal::identify {

namespace detail {
struct BaseModel;
class DescriptionReader;
class FamilyErrors;
class SteppedBaseFit;  // effects/base_fit.hpp
}  // namespace detail

// A passive joint the description bounds (the hybrid's UP extension c).
struct PassiveLimit {
  std::string name;  // as messages name it, e.g. "UP extension c"
  const char* unit;
  double lo, hi;
};

// How a user lays out a grid of poses by hand on this family (kincal plan's
// comparison): layers in z, each pose tilted at random within ±5° or not.
struct HandGrid {
  int layers = 1;
  bool tilted = false;
};

// One labelled run of a table's values (kincal table's generated header):
// `values` names each value on its own line where given, `note` follows the
// label.
struct TableGroup {
  std::string label;  // "machine.nominal.base"
  int count = 0;
  std::vector<std::string> values;
  std::string note;
};

// What a simulated row reaches on the actual machine (simulate.cpp).
struct ReachedPose {
  Status status = Status::Ok;
  const char* stage = "";  // what failed, for the warning
  Pose<double> pose;
};

// The actual (erroneous) machine of `kincal simulate`, built once per run.
class ActualMachine {
 public:
  virtual ~ActualMachine() = default;
  // The pose reached for a row's commands (q, else the nominal IK of the
  // commanded pose) with `joint_error(q)` added to them (an effect's Δq; may
  // be empty).
  virtual ReachedPose reach(const PoseRow& row,
                            const std::function<Vec6<double>(const Vec6<double>&)>& joint_error) const = 0;
};

// The actual machine of a family whose nominal IK gives the commands and
// whose FK of the erroneous geometry gives the pose (seed 001 §5.2; the
// 6-UPS and the 6-RUS): the row's commands (q, else the nominal IK of the
// commanded pose) with `joint_error` added drive FK(actual) from the
// commanded pose.
template <class Geometry, Status (*Ik)(const Geometry&, const Pose<double>&, Vec6<double>&),
          FkReport<double> (*Fk)(const Geometry&, const Vec6<double>&, const Pose<double>&, Pose<double>&)>
class CommandsThenFk final : public ActualMachine {
 public:
  CommandsThenFk(const Geometry& nominal, const Geometry& actual) : nominal_(nominal), actual_(actual) {}
  ReachedPose reach(const PoseRow& row,
                    const std::function<Vec6<double>(const Vec6<double>&)>& joint_error) const override {
    ReachedPose out;
    const Pose<double> commanded = Pose<double>::from_xyz_rpy(row.commanded);
    Vec6<double> q;
    if (row.q) {
      q = *row.q;
    } else {
      out.status = Ik(nominal_, commanded, q);
      out.stage = "inverse kinematics of the commanded pose";
      if (out.status != Status::Ok) return out;
    }
    if (joint_error) q += joint_error(q);
    out.status = Fk(actual_, q, commanded, out.pose).status;
    out.stage = "forward kinematics of the erroneous machine";
    return out;
  }

 private:
  Geometry nominal_, actual_;
};

// ---- A family's capabilities. A family is six small objects, one per job,
// that its folder defines and families.cpp's registry holds together; the
// callers reach the one they need (family_of(robot).kinematics().inverse(…)).
// Only the own pipeline is optional: a family without one is measured by
// full poses or tracker targets through the family-free target fit
// (target_calibration.hpp) alone.

// Its identity and description file (docs/formats.md "Robot description").
class FamilyDescription {
 public:
  virtual ~FamilyDescription() = default;
  // The description's `family` value, e.g. "stewart-6ups".
  virtual const char* name() const = 0;
  // Whether `robot` holds this family's geometry.
  virtual bool describes(const Robot& robot) const = 0;
  // Reads the family's keys of a description (the common ones are read by
  // parse_robot); throws InputError at the offending key.
  virtual Robot parse(const nlohmann::json& doc, const detail::DescriptionReader& reader) const = 0;
  // Writes the family's keys, in the order docs/formats.md lists them.
  virtual void write(const Robot& robot, nlohmann::ordered_json& doc) const = 0;
  // The geometry lines of `kincal robot`.
  virtual void summarize(const Robot& robot, std::ostream& os) const = 0;
};

// Its joints and nominal kinematics, in the robot's pose frame.
class FamilyKinematics {
 public:
  virtual ~FamilyKinematics() = default;
  // Revolute joints are in rad (µrad shown), prismatic ones in mm (µm shown).
  virtual bool revolute(int joint) const = 0;
  // Joints 1..n a screw drives (the `cyclic` effect's joints).
  virtual int screw_joints() const = 0;
  // The body the tracker targets sit on: "platform" or "tool".
  virtual const char* target_body() const = 0;
  virtual Pose<double> home_pose(const Robot& robot) const = 0;
  virtual void joint_limits(const Robot& robot, Vec6<double>& lo, Vec6<double>& hi) const = 0;
  // The passive joints the description bounds (none by default).
  virtual std::vector<PassiveLimit> passive_limits(const Robot&) const { return {}; }
  // Nominal IK; J (if given) = ∂q/∂twist; `passive` (if given) receives the
  // values of passive_limits()'s joints, in their order (at most 4). The robot's limits
  // apply as core applies them: model measured rows on without_limits().
  virtual Status inverse(const Robot& robot, const Pose<double>& pose, Vec6<double>& q, Mat6<double>* J = nullptr,
                         double* passive = nullptr) const = 0;
  // The tool twist per unit joint error at the nominal configuration of a
  // commanded pose (and its commands q); false when the IK fails or it is singular.
  virtual bool forward_jacobian(const Robot& robot, const Pose<double>& pose, Vec6<double>& q,
                                Mat6<double>& J) const = 0;
  // The length (mm) that makes an angle comparable to a displacement in the
  // IK Jacobian (the geometry's characteristic_length).
  virtual double characteristic_length(const Robot& robot) const = 0;
  // A size of the machine (mm) that bounds its reach: plan's search box.
  virtual double reach(const Robot& robot) const = 0;
  // The frame core's effects read poses in (effects.hpp's load direction and
  // thermal origin); the base frame needs nothing.
  virtual void set_effect_frame(const Robot&, EffectParameters<double>&) const {}
  // The actual machine of a simulation (nominal and actual are this family's).
  virtual std::unique_ptr<ActualMachine> actual_machine(const Robot& nominal, const Robot& actual) const = 0;
  // The numbers the family offers formula effects per joint (at most
  // core's kFormulaFamilyJointVariables), and their values at the nominal
  // configuration of a commanded pose (robot.hpp family_formula_values).
  virtual std::vector<FamilyFormulaVariable> formula_joint_variables() const { return {}; }
  virtual bool formula_joint_values(const Robot&, const Pose<double>&, double*) const { return true; }
};

// Its error model: the parameters a calibration identifies.
class FamilyErrorModel {
 public:
  virtual ~FamilyErrorModel() = default;
  // How the model reads in messages ("seed 001 42-parameter model").
  virtual const char* name() const = 0;
  // The family's names for simulate --errors and MODEL.json, in table order.
  virtual const std::vector<ParameterSpec>& parameter_specs(const Robot& robot) const = 0;
  // The same error under another name (the hybrid's encoder offsets have
  // two), else empty.
  virtual std::string alias_of(const std::string&) const { return {}; }
  // The family's error parameters as the target fit and the planner see
  // them (family_errors.hpp), for a robot with its limits opened.
  virtual std::unique_ptr<detail::FamilyErrors> errors(const Robot& open) const = 0;
  // The fewest nodes the deleted-node screen leaves (identify/outliers.hpp;
  // the own pipeline's and the target fit's screens, identify --effects's).
  virtual Eigen::Index outlier_min_nodes() const = 0;
};

// How it is measured, beside the tracker targets every family reads.
class FamilyMeasurement {
 public:
  virtual ~FamilyMeasurement() = default;
  // What the table lacks for the family's own measurement and for the
  // target fit alike, as the error message says it; empty when it has enough.
  virtual std::string missing_measurement(const Robot& robot, const PoseTable& data) const = 0;
  // The family's own measurement, as messages name it ("the hybrid's gauge").
  virtual const char* own_measurement() const = 0;
  // The family's own targets (the hybrid's gauge) on `robot`, if it has any:
  // simulate measures them on the actual machine, plan on the nominal one.
  virtual std::optional<MeasurementModel> own_targets(const Robot&) const { return std::nullopt; }
  // The grid a user would measure by hand (kincal plan --compare).
  virtual HandGrid hand_grid() const = 0;
};

// The machine part of the controller's table (calibration_table.hpp);
// calibration_table.cpp adds the effects and the bounds, seals and checks it.
class FamilyTable {
 public:
  virtual ~FamilyTable() = default;
  // The machine part and the default bounds of the model's table.
  virtual AnyCalibrationTable machine_table(const CalibrationModel& model) const = 0;
  virtual TableBounds<double> default_bounds(const Robot& robot) const = 0;
  // The machine part's values as labelled runs, in core's canonical order
  // (the Machine's visit).
  virtual std::vector<TableGroup> machine_groups(const Robot& robot) const = 0;
  // The table check's words (io/calibration_table.cpp): the description key
  // of the joints' range ("stroke", "joint_limits"); why the machine part of
  // `table` (this family's) is outside `limits`, naming the first value, its
  // cap and the key that raises it ("" when it is inside); why its values
  // fail validate_table where a model can cause it ("" otherwise: the check
  // then says it generically).
  virtual const char* joint_range_key() const = 0;
  virtual std::string machine_limit_violation(const AnyCalibrationTable& table,
                                              const MachineLimits<double>& limits) const = 0;
  virtual std::string machine_value_violation(const AnyCalibrationTable&) const { return {}; }
};

// Its own pipeline on its own measurement (6-UPS: seed 001's iterated least
// squares on full poses; hybrid: seed 000's coarse + fine stages on its
// gauge). Optional: Family::own_pipeline() is nullptr without one.
                                          class FamilyPipeline {
 public:
  virtual ~FamilyPipeline() = default;
  // Whether it, not the target fit, reads `data` (6-UPS: full poses;
  // hybrid: the gauge, when the robot names no targets).
  virtual bool reads(const Robot& robot, const PoseTable& data) const = 0;
  // How its base fit reads in messages ("seed 001's iterated least squares").
  virtual const char* base_fit() const = 0;
  // Its base fit, as a linear problem at its solution (effects/base_fit.hpp:
  // fit_base documents the arguments).
  virtual detail::BaseModel fit_base(const Robot& robot, const PoseTable& fit_data,
                                     const std::vector<std::optional<EffectNode>>& nodes,
                                     std::optional<EstimatorKind> estimator, bool finish_least_squares,
                                     double ridge_k) const = 0;
  // With effects (effect_calibration.cpp): the base fit as a state the joint
  // Gauss–Newton of base and effects steps (effects/base_fit.hpp), by OLS or
  // a ridge toward its centre (k as fit_base's ridge_k; ridge_k = 0 is the
  // family's own choice, later replaced by set_penalty). nullptr (the
  // default): fit_base converges alone and the effects alternate with it.
  virtual std::unique_ptr<detail::SteppedBaseFit> stepped_base_fit(const Robot&, const PoseTable&,
                                                                   const std::vector<std::optional<EffectNode>>&,
                                                                   EstimatorKind, double) const;  // families.cpp
  // Whether stepped_base_fit gives one.
  virtual bool steps_base_with_effects() const { return false; }
  // The options it refuses (InputError), before the data are read.
  virtual void check_identify_options(const IdentifyOptions&) const {}
  // Its measurement identified (identify.hpp), the narrative on `narrative`.
  virtual Identification identify_own(const Robot& robot, const PoseTable& data, const IdentifyOptions& options,
                                      std::ostream& narrative) const = 0;
};

// One machine family: its capabilities, held together. Each family's folder
// defines one (e.g. stewart_family()) and families.cpp lists it.
class Family {
 public:
  Family(const FamilyDescription& description, const FamilyKinematics& kinematics,
         const FamilyErrorModel& error_model, const FamilyMeasurement& measurement, const FamilyTable& table,
         const FamilyPipeline* own_pipeline)
      : description_(description),
        kinematics_(kinematics),
        error_model_(error_model),
        measurement_(measurement),
        table_(table),
        own_pipeline_(own_pipeline) {}

  const FamilyDescription& description() const { return description_; }
  const FamilyKinematics& kinematics() const { return kinematics_; }
  const FamilyErrorModel& error_model() const { return error_model_; }
  const FamilyMeasurement& measurement() const { return measurement_; }
  const FamilyTable& table() const { return table_; }
  // nullptr: full poses and tracker targets go to the target fit alone.
  const FamilyPipeline* own_pipeline() const { return own_pipeline_; }
  // Who reads `data`: the own pipeline, or nullptr for the family-free
  // target fit (uses_target_model). The own pipeline where it `reads` the
  // table, and also where the table has no measurement at all (its checks
  // say what is missing, in its words); never a table in the instrument's
  // frame (only the target fit estimates the registration).
  const FamilyPipeline* pipeline_reading(const Robot& robot, const PoseTable& data) const;  // families.cpp
  const char* name() const { return description_.name(); }

 private:
  const FamilyDescription& description_;
  const FamilyKinematics& kinematics_;
  const FamilyErrorModel& error_model_;
  const FamilyMeasurement& measurement_;
  const FamilyTable& table_;
  const FamilyPipeline* own_pipeline_;
};

// The one Family of the capability classes given (each default-constructed,
// once): what a family's folder returns from its <name>_family(). Pipeline
// void: the family has no own pipeline.
template <class Description, class Kinematics, class ErrorModel, class Measurement, class Table,
          class Pipeline = void>
const Family& family_of_capabilities() {
  static const Description description;
  static const Kinematics kinematics;
  static const ErrorModel error_model;
  static const Measurement measurement;
  static const Table table;
  if constexpr (std::is_void_v<Pipeline>) {
    static const Family family(description, kinematics, error_model, measurement, table, nullptr);
    return family;
  } else {
    static const Pipeline pipeline;
    static const Family family(description, kinematics, error_model, measurement, table, &pipeline);
    return family;
  }
}

// The family of a robot (every Robot has one; std::logic_error if its
// geometry has no registered family).
const Family& family_of(const Robot& robot);
// The family a description's `family` value names, or nullptr.
const Family* family_named(const std::string& name);
// The registered families' names, for messages ("stewart-6ups, hybrid-3ups-up-3r").
std::string family_names();

}  // namespace kincal::identify
