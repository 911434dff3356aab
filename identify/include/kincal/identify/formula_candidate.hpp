// A robot description's formula effects (key `effects`, GUIDE "Effects
// written as formulas"; issue #32) as candidates like the built-in five: an
// Effect whose columns are the formula's exact derivatives
// (identify/formula_effect.hpp) and whose numbers live in core's user slot
// (EffectParameters::user, from `offset`; core/formula_effects.hpp).
//
// A formula may be nonlinear in its parameters (a ramp's knee): its columns
// are the derivatives at the parameters' current values, which the
// identification's alternation hands in through `frame` (its user slot).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "kincal/identify/effects.hpp"
#include "kincal/identify/formula_effect.hpp"

namespace kincal::identify {

class FormulaCandidate final : public Effect {
 public:
  FormulaCandidate(std::shared_ptr<const FormulaEffect> formula, int offset);

  std::string name() const override { return formula_->name(); }
  std::string description() const override;
  std::vector<std::string> parameter_names(const Robot&) const override { return formula_->parameter_names(); }
  std::string missing_inputs(const PoseTable& data) const override;
  std::string inputs() const override;
  bool acts_on_joints() const override { return formula_->kind() == FormulaKind::Joint; }
  Eigen::VectorXd start_values(const Robot&) const override;
  void twist_columns(const Robot& robot, const EffectParameters<double>& frame, const EffectNode& node,
                     Eigen::Ref<Eigen::MatrixXd> columns) const override;
  void apply(const Robot& robot, const Eigen::VectorXd& values, EffectParameters<double>& out) const override;

  const FormulaEffect& formula() const { return *formula_; }
  // Where this effect's numbers start in EffectParameters::user.
  int offset() const { return offset_; }

 private:
  std::shared_ptr<const FormulaEffect> formula_;
  int offset_;
};

// The variables a formula reads at a node (FormulaLayout order, the robot's
// input list): joints `q` (the commands, or the iterate of a fixed point),
// the node's directions, temperature, time, commanded pose and named inputs,
// the static joint loads under the robot's payload, and the numbers the
// family offers per joint (family_formula_variables) at the commanded pose.
std::vector<double> formula_variables(const Robot& robot, const EffectNode& node, const Vec6<double>& q);

// Δq of the robot's joint-kind formula effects at joints `q` of a node, with
// their numbers in `effects.user` (zero without formula effects).
Vec6<double> formula_joint_error(const Robot& robot, const EffectParameters<double>& effects, const EffectNode& node,
                                 const Vec6<double>& q);

// The twist (dx dy dz drx dry drz; mm, rad, the pose frame) of the robot's
// pose-kind formula effects at a node with joints `q` (zero without any):
// the tool lands at p + d, exp(ω)·R where its kinematics put p, R.
Vec6<double> formula_pose_twist(const Robot& robot, const EffectParameters<double>& effects, const EffectNode& node,
                                const Vec6<double>& q);
// `pose` moved by a twist (or back, with −twist).
Pose<double> moved_by_twist(const Pose<double>& pose, const Vec6<double>& twist);

// The robot's formula effects as the policy of core's Compensator
// (core/formula_effects.hpp) on the host, at double: `kincal compensate`
// runs the controller's routine with the formulas compiled from the robot
// description (the firmware's are generated C++; `kincal table`). The robot
// must outlive it.
class HostFormulaEffects {
 public:
  static constexpr bool present = true;
  // Everything may be read: has_pose() and the formulas decide at run time.
  static constexpr bool pose_twist = true, reads_pose = true, reads_load = true, reads_stream = true,
                        reads_family = true;
  explicit HostFormulaEffects(const Robot& robot) : robot_(&robot) {}
  void add_joint_error(const double* params, const double* vars, double* dq) const;
  void add_pose_twist(const double* params, const double* vars, double* twist) const;
  bool has_pose() const;
  int input_count() const { return int(robot_->formula_inputs.size()); }
  double payload_weight() const { return robot_->payload_weight; }
  Vec3<double> payload_com() const { return robot_->payload_com; }

 private:
  const Robot* robot_;
};

}  // namespace kincal::identify
