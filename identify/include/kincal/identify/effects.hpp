// Physical effects, identification half (GUIDE "An effect is the unit of
// physics"; the controller half and the definitions are in
// core/include/kincal/core/effects.hpp). An Effect names its parameters, says
// whether a data set carries the inputs it needs, gives its sensitivity
// columns (tool twist per unit parameter at a node, in the robot's pose
// frame), and stores identified values into core's EffectParameters. The five
// candidates of the GUIDE are registered by default. A joint-space effect is
// written once, in core: its columns here are the derivative of core's
// correction (JointSpaceEffect); a user effect is one templated function and
// one register_effect() call (UserJointEffect; docs/effects.md walks through one).
#pragma once

#include <Eigen/Core>
#include <unsupported/Eigen/AutoDiff>  // after Eigen/Core, which it needs
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "kincal/core/effects.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal::identify {

// What the sensitivity columns of one node depend on.
struct EffectNode {
  Vec6<double> q = Vec6<double>::Zero();                 // joint commands sent
  EffectInputs<double> inputs;                           // approach directions, static load
  std::optional<double> temperature, time;               // °C, s
  Mat6<double> joint_twist = Mat6<double>::Zero();       // tool twist per unit error of each joint
  Pose<double> pose;                                     // commanded tool pose (pose frame)
  // The robot's formula inputs (Robot::formula_inputs, that order) from the
  // row's columns; NaN where the data has none.
  std::vector<double> formula_inputs;
  // What the robot's family offers formulas per joint at `pose`
  // (family_formula_values: values[k·6 + j]; NaN where its IK fails), kept
  // by effect_nodes for a robot with formula effects: the fits evaluate the
  // formulas at the same node many times. Empty: formula_variables asks the
  // family.
  std::vector<double> family_values;
  std::string id;  // the row's id (messages)
};

class Effect {
 public:
  virtual ~Effect() = default;
  virtual std::string name() const = 0;
  virtual std::string description() const = 0;  // one line, for reports
  // Parameter names without the effect prefix, e.g. {"s1", ..., "s6"}.
  virtual std::vector<std::string> parameter_names(const Robot& robot) const = 0;
  // "" when the data carries what the effect needs; else why it cannot be
  // tested (e.g. "no temp column"), one phrase.
  virtual std::string missing_inputs(const PoseTable& data) const = 0;
  // The columns of the measurement CSV the effect reads, one phrase, for
  // `kincal effects` (docs/formats.md names them). Most effects need only the
  // commanded pose (and the joint commands derived from it).
  virtual std::string inputs() const { return "the commanded pose (x..rz)"; }
  // Whether the effect acts through the joints (the machine's joints differ
  // from the commands: scale, backlash, compliance, cyclic, a user joint
  // effect) rather than on the measured pose (thermal). The hybrid's
  // structural twist moves with the joints, not with the measurement.
  virtual bool acts_on_joints() const { return true; }
  // Where a fit starts (parameter_names order): zero for the built-in
  // effects, whose columns do not depend on the values; a formula effect's
  // `start` (its columns are its derivatives at the current values, which a
  // fit hands in through twist_columns' `frame`).
  virtual Eigen::VectorXd start_values(const Robot& robot) const {
    return Eigen::VectorXd::Zero(Eigen::Index(parameter_names(robot).size()));
  }
  // Tool twist per unit parameter at one node: 6 × parameter_names().size().
  virtual void twist_columns(const Robot& robot, const EffectParameters<double>& frame, const EffectNode& node,
                             Eigen::Ref<Eigen::MatrixXd> columns) const = 0;
  // Controller half: writes identified values (in parameter_names order) into
  // core's parameter set; `values` adds to what is there. A user joint effect
  // writes its numbers to out.user and its function to out.user_error (core
  // has one such slot; docs/effects.md).
  virtual void apply(const Robot& robot, const Eigen::VectorXd& values, EffectParameters<double>& out) const = 0;
};

// The scalar identify differentiates core's corrections with: a value and
// its derivative along one parameter (forward-mode automatic
// differentiation, Eigen's AutoDiffScalar; fixed size, no heap).
using EffectDual = Eigen::AutoDiffScalar<Eigen::Matrix<double, 1, 1>>;

// Where one effect parameter lives in core's EffectParameters.
struct EffectSlot {
  enum Field { Scale, Backlash, Compliance, CyclicSin, CyclicCos, User };
  Field field = Scale;
  int index = 0;  // the joint (0..5), or the user number (0..kUserEffectParameters − 1)
};

// A joint-space effect written once. Its definition is core's
// effect_joint_error (core/effects.hpp: what the simulator adds and the
// controller inverts); a subclass names its parameters and says where each
// lives in core's EffectParameters (slot). The identification columns are
// that function's derivative along each parameter, by automatic
// differentiation at EffectDual, times the joint's error twist:
//   column_k = joint_twist · ∂Δq/∂θ_k,
// so what is identified is, to rounding, what is compensated (test
// FamilySeam.EffectColumnsAreTheDerivativeOfCoresCorrectionOnTheFamilysPose).
class JointSpaceEffect : public Effect {
 public:
  void twist_columns(const Robot& robot, const EffectParameters<double>& frame, const EffectNode& node,
                     Eigen::Ref<Eigen::MatrixXd> columns) const final;
  // Adds each value to its slot (and sets core's user function, if any).
  void apply(const Robot& robot, const Eigen::VectorXd& values, EffectParameters<double>& out) const override;

 protected:
  // Where parameter k (parameter_names order) lives.
  virtual EffectSlot slot(const Robot& robot, int k) const = 0;
  // A user joint effect's function at the controller's scalar and at
  // EffectDual; null for the built-in effects.
  virtual UserJointError<double> user_function() const { return nullptr; }
  virtual UserJointError<EffectDual> user_function_dual() const { return nullptr; }
};

// A user joint effect (docs/effects.md): core's one user slot, its function
// written once as a template and handed in at two scalars, double (what the
// simulator, the identification's corrected data and the host compensator
// run) and EffectDual (its derivative, the identification columns). The
// parameters are u_1.. of the slot, in the order named (at most
// kUserEffectParameters). Throws std::invalid_argument for an empty name,
// no or too many parameters, or a null function.
class UserJointEffect final : public JointSpaceEffect {
 public:
  UserJointEffect(std::string name, std::string description, std::vector<std::string> parameters,
                  UserJointError<double> function, UserJointError<EffectDual> function_dual,
                  std::string inputs = "the joint commands q1..q6 (default: nominal IK of the commanded pose)");
  std::string name() const override { return name_; }
  std::string description() const override { return description_; }
  std::vector<std::string> parameter_names(const Robot&) const override { return parameters_; }
  std::string missing_inputs(const PoseTable&) const override { return {}; }
  std::string inputs() const override { return inputs_; }

 protected:
  EffectSlot slot(const Robot&, int k) const override { return {EffectSlot::User, k}; }
  UserJointError<double> user_function() const override { return function_; }
  UserJointError<EffectDual> user_function_dual() const override { return function_dual_; }

 private:
  std::string name_, description_;
  std::vector<std::string> parameters_;
  UserJointError<double> function_;
  UserJointError<EffectDual> function_dual_;
  std::string inputs_;
};

// The registered effects, the five GUIDE candidates first (scale, backlash,
// compliance, thermal, cyclic).
const std::vector<std::shared_ptr<const Effect>>& effect_registry();
// Adds (or replaces, by name) an effect. Not thread-safe: call at start-up.
void register_effect(std::shared_ptr<const Effect> effect);
// nullptr if unknown.
const Effect* find_effect(const std::string& name);
// Known names, comma separated (for error messages).
std::string effect_names();
// The candidates of one robot: the registry's, then the robot description's
// formula effects (`effects` key); lookups by name among them.
std::vector<const Effect*> effect_candidates(const Robot& robot);
const Effect* find_effect(const Robot& robot, const std::string& name);
std::string effect_names(const Robot& robot);

// Machine data of the corrections (core EffectParameters with all effect
// values zero): screw lead and screw-driven joints, the weight direction and
// the base origin in the pose frame.
EffectParameters<double> effect_frame(const Robot& robot);

// Per-row effect nodes for a table, in row order (rows whose nominal IK fails
// get std::nullopt): q from q1..q6 or the nominal IK, directions from
// dir1..dir6 or derived from the command sequence as the controller keeps
// them (the machine starts at its home pose, every direction +1; then the
// sign of the change from the previous row, kept when a joint does not move),
// the static load and joint_twist at the nominal configuration.
std::vector<std::optional<EffectNode>> effect_nodes(const Robot& robot, const PoseTable& table);

// Effect values from `--effect NAME:PARAM=VALUE` settings or a model: name →
// values in parameter_names order. Throws InputError for an unknown effect or
// parameter (naming the known ones).
struct EffectValues {
  std::map<std::string, Eigen::VectorXd> values;  // by effect name
  bool empty() const { return values.empty(); }
  void set(const Robot& robot, const std::string& effect, const std::string& parameter, double value);
  EffectParameters<double> to_core(const Robot& robot) const;
  // Whether any present effect needs the temperature input.
  bool needs_temperature() const;
};

// The tool pose the machine with these effects reaches for commands q of a
// node whose effect-free forward kinematics gives `reached_without`:
// joint-space effects change q (the caller re-runs its FK with
// q + effect_joint_error), thermal scales about the base origin. This returns
// the joints to drive the FK with.
// With `robot`, its formula effects' Δq too (their numbers in effects.user).
Vec6<double> effect_actual_joints(const EffectParameters<double>& effects, const EffectNode& node);
Vec6<double> effect_actual_joints(const Robot& robot, const EffectParameters<double>& effects, const EffectNode& node);
// Δq of every joint-space effect (core's and the robot's formulas) at joints q.
Vec6<double> effect_joint_error(const Robot& robot, const EffectParameters<double>& effects, const EffectNode& node,
                                const Vec6<double>& q);

}  // namespace kincal::identify
