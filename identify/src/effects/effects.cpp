#include "kincal/identify/joint_limits.hpp"
#include "kincal/identify/effects.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "kincal/identify/formula_candidate.hpp"
#include "families/family.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

namespace {

std::vector<std::string> numbered(const std::string& prefix, int count) {
  std::vector<std::string> out;
  for (int i = 1; i <= count; ++i) out.push_back(prefix + std::to_string(i));
  return out;
}

// Joints a screw drives (FamilyKinematics::screw_joints): the six legs of a 6-UPS, the
// three UPS limbs of the hybrid.
int screw_joint_count(const Robot& robot) { return family_of(robot).kinematics().screw_joints(); }

// The built-in joint-space effects: names and slots; their shapes are core's
// effect_joint_error (JointSpaceEffect differentiates it).
class ScaleEffect final : public JointSpaceEffect {
 public:
  std::string name() const override { return "scale"; }
  std::string description() const override { return "encoder / leadscrew scale error per actuated joint, dq_i = s_i q_i"; }
  std::vector<std::string> parameter_names(const Robot&) const override { return numbered("s", 6); }
  std::string missing_inputs(const PoseTable&) const override { return {}; }
  std::string inputs() const override { return "joint commands q1..q6 (default: nominal IK of the commanded pose)"; }

 protected:
  EffectSlot slot(const Robot&, int k) const override { return {EffectSlot::Scale, k}; }
};

class BacklashEffect final : public JointSpaceEffect {
 public:
  std::string name() const override { return "backlash"; }
  std::string description() const override {
    return "lost motion per actuated joint, dq_i = b_i dir_i (approach direction)";
  }
  std::vector<std::string> parameter_names(const Robot&) const override { return numbered("b", 6); }
  std::string missing_inputs(const PoseTable& data) const override {
    // Without dir columns the directions come from the command sequence
    // (effect_nodes), which needs at least two rows.
    if (!data.has_dir && data.rows.size() < 2) return "no dir1..dir6 columns and too few rows to derive directions";
    return {};
  }
  std::string inputs() const override {
    return "approach directions dir1..dir6 (default: derived from the command sequence, rows in motion order)";
  }

 protected:
  EffectSlot slot(const Robot&, int k) const override { return {EffectSlot::Backlash, k}; }
};

class ComplianceEffect final : public JointSpaceEffect {
 public:
  std::string name() const override { return "compliance"; }
  std::string description() const override {
    return "axial deflection per actuator proportional to its static load from a payload weight (-z of the base)";
  }
  std::vector<std::string> parameter_names(const Robot&) const override { return numbered("k", 6); }
  std::string missing_inputs(const PoseTable&) const override { return {}; }
  std::string inputs() const override { return "the commanded pose (static load through the Jacobian)"; }

 protected:
  EffectSlot slot(const Robot&, int k) const override { return {EffectSlot::Compliance, k}; }
};

class CyclicEffect final : public JointSpaceEffect {
 public:
  std::string name() const override { return "cyclic"; }
  std::string description() const override {
    return "periodic screw error a_i sin(2 pi q_i / p) + b_i cos(2 pi q_i / p), p = screw lead (a rotary motor: "
           "its period at the joint, rad)";
  }
  std::vector<std::string> parameter_names(const Robot& robot) const override {
    std::vector<std::string> out = numbered("a", screw_joint_count(robot));
    for (const std::string& b : numbered("b", screw_joint_count(robot))) out.push_back(b);
    return out;
  }
  std::string missing_inputs(const PoseTable&) const override { return {}; }
  std::string inputs() const override {
    return "joint commands q1..qN of the screw-driven joints (default: nominal IK); the robot's screw_lead";
  }

 protected:
  // The sine terms of the screw-driven joints, then the cosine terms.
  EffectSlot slot(const Robot& robot, int k) const override {
    const int screws = screw_joint_count(robot);
    return {k < screws ? EffectSlot::CyclicSin : EffectSlot::CyclicCos, k % screws};
  }
};

class ThermalEffect final : public Effect {
 public:
  std::string name() const override { return "thermal"; }
  bool acts_on_joints() const override { return false; }
  std::string description() const override {
    return "uniform thermal expansion of structure and actuators, lengths x (1 + c (T - 20 C))";
  }
  std::vector<std::string> parameter_names(const Robot&) const override { return {"c"}; }
  std::string inputs() const override { return "temp (structure temperature, C), varying over the data set"; }
  std::string missing_inputs(const PoseTable& data) const override {
    if (!data.has_temp) return "the data has no temp column";
    double lo = 1e300, hi = -1e300;
    for (const PoseRow& r : data.rows)
      if (r.temp) lo = std::min(lo, *r.temp), hi = std::max(hi, *r.temp);
    if (!(hi - lo > 0.05))
      return "temp is constant (" + format_number(lo) +
             " C): a uniform expansion at one temperature cannot be told from the geometry";
    return {};
  }
  void twist_columns(const Robot&, const EffectParameters<double>& frame, const EffectNode& node,
                     Eigen::Ref<Eigen::MatrixXd> columns) const override {
    // d(reached)/dc = (T − T0)·(p − o), no rotation (core thermal_reached).
    columns.setZero();
    if (!node.temperature) return;
    columns.col(0).head<3>() = (*node.temperature - frame.reference_temperature) * (node.pose.p - frame.thermal_origin);
  }
  void apply(const Robot&, const Eigen::VectorXd& values, EffectParameters<double>& out) const override {
    out.thermal += values(0);
  }
};

std::vector<std::shared_ptr<const Effect>>& registry_storage() {
  static std::vector<std::shared_ptr<const Effect>> effects = {
      std::make_shared<ScaleEffect>(), std::make_shared<BacklashEffect>(), std::make_shared<ComplianceEffect>(),
      std::make_shared<ThermalEffect>(), std::make_shared<CyclicEffect>()};
  return effects;
}

}  // namespace

namespace {

// The value of `slot` in core's parameters, at any scalar.
template <class Scalar> Scalar& slot_in(EffectParameters<Scalar>& e, const EffectSlot& slot) {
  switch (slot.field) {
    case EffectSlot::Scale: return e.scale(slot.index);
    case EffectSlot::Backlash: return e.backlash(slot.index);
    case EffectSlot::Compliance: return e.compliance(slot.index);
    case EffectSlot::CyclicSin: return e.cyclic_sin(slot.index);
    case EffectSlot::CyclicCos: return e.cyclic_cos(slot.index);
    case EffectSlot::User: break;
  }
  return e.user(slot.index);
}

}  // namespace

void JointSpaceEffect::twist_columns(const Robot& robot, const EffectParameters<double>& frame, const EffectNode& node,
                                     Eigen::Ref<Eigen::MatrixXd> columns) const {
  // core's Δq(θ; q, inputs) at EffectDual, seeded along one parameter at a
  // time: ∂Δq/∂θ_k at the frame's values (every effect value 0 there; the
  // built-in effects are linear in θ, so anywhere).
  EffectParameters<EffectDual> at = frame.cast<EffectDual>();
  at.user_error = user_function_dual();
  const Vec6<EffectDual> q = node.q.cast<EffectDual>();
  EffectInputs<EffectDual> in;
  in.direction = node.inputs.direction.cast<EffectDual>();
  in.load = node.inputs.load.cast<EffectDual>();
  const int n = int(parameter_names(robot).size());
  for (int k = 0; k < n; ++k) {
    EffectParameters<EffectDual> seeded = at;
    slot_in(seeded, slot(robot, k)).derivatives()(0) = 1.0;
    const Vec6<EffectDual> dq = effect_joint_error(seeded, q, in);
    Vec6<double> d;
    for (int i = 0; i < 6; ++i) d(i) = dq(i).derivatives()(0);
    columns.col(k) = node.joint_twist * d;
  }
}

void JointSpaceEffect::apply(const Robot& robot, const Eigen::VectorXd& values, EffectParameters<double>& out) const {
  for (int k = 0; k < int(values.size()); ++k) slot_in(out, slot(robot, k)) += values(k);
  if (user_function() != nullptr) out.user_error = user_function();
}

UserJointEffect::UserJointEffect(std::string name, std::string description, std::vector<std::string> parameters,
                                 UserJointError<double> function, UserJointError<EffectDual> function_dual,
                                 std::string inputs)
    : name_(std::move(name)), description_(std::move(description)), parameters_(std::move(parameters)),
      function_(function), function_dual_(function_dual), inputs_(std::move(inputs)) {
  if (name_.empty()) throw std::invalid_argument("UserJointEffect: empty name");
  if (parameters_.empty() || parameters_.size() > std::size_t(kUserEffectParameters))
    throw std::invalid_argument("UserJointEffect '" + name_ + "': 1 to " + std::to_string(kUserEffectParameters) +
                                " parameters (core's user slot), got " + std::to_string(parameters_.size()));
  if (function_ == nullptr || function_dual_ == nullptr)
    throw std::invalid_argument("UserJointEffect '" + name_ + "': the function at double and at EffectDual are both needed");
}

const std::vector<std::shared_ptr<const Effect>>& effect_registry() { return registry_storage(); }

void register_effect(std::shared_ptr<const Effect> effect) {
  auto& effects = registry_storage();
  for (auto& e : effects)
    if (e->name() == effect->name()) {
      e = std::move(effect);
      return;
    }
  effects.push_back(std::move(effect));
}

const Effect* find_effect(const std::string& name) {
  for (const auto& e : effect_registry())
    if (e->name() == name) return e.get();
  return nullptr;
}

std::string effect_names() {
  std::string out;
  for (const auto& e : effect_registry()) out += (out.empty() ? "" : ", ") + e->name();
  return out;
}

std::vector<const Effect*> effect_candidates(const Robot& robot) {
  std::vector<const Effect*> out;
  for (const auto& e : effect_registry()) out.push_back(e.get());
  for (const auto& f : robot.formula_effects) out.push_back(f.get());
  return out;
}

const Effect* find_effect(const Robot& robot, const std::string& name) {
  for (const Effect* e : effect_candidates(robot))
    if (e->name() == name) return e;
  return nullptr;
}

std::string effect_names(const Robot& robot) {
  std::string out;
  for (const Effect* e : effect_candidates(robot)) out += (out.empty() ? "" : ", ") + e->name();
  return out;
}

EffectParameters<double> effect_frame(const Robot& robot) {
  EffectParameters<double> e;
  e.screw_lead = robot.screw_lead;
  e.screw_joints = std::uint8_t((1u << screw_joint_count(robot)) - 1u);
  family_of(robot).kinematics().set_effect_frame(robot, e);
  return e;
}

std::vector<std::optional<EffectNode>> effect_nodes(const Robot& robot, const PoseTable& table) {
  const EffectParameters<double> frame = effect_frame(robot);
  // Nodes of measured rows: the file's joint limits do not apply (joint_limits.hpp).
  const Robot open = without_limits(robot);
  const Family& family = family_of(open);
  std::vector<std::optional<EffectNode>> nodes(table.rows.size());
  const std::size_t family_value_count =
      robot.formula_effects.empty() ? 0 : family_formula_variables(robot).size() * 6;
  for (std::size_t k = 0; k < table.rows.size(); ++k) {
    const PoseRow& row = table.rows[k];
    EffectNode n;
    n.pose = Pose<double>::from_xyz_rpy(row.commanded);
    n.id = row.id;
    Vec6<double> q_ik;
    if (!family.kinematics().forward_jacobian(open, n.pose, q_ik, n.joint_twist)) continue;
    n.q = row.q ? Vec6<double>(row.q->head<6>()) : q_ik;
    n.inputs.load = static_load_forward(n.joint_twist, frame.load_direction);
    n.temperature = row.temp;
    n.time = row.time;
    if (row.dir) n.inputs.direction = row.dir->head<6>().cast<double>();
    for (const std::string& in : robot.formula_inputs) {
      const auto it = row.inputs.find(in);
      n.formula_inputs.push_back(it != row.inputs.end() ? it->second : std::numeric_limits<double>::quiet_NaN());
    }
    if (family_value_count > 0) {
      n.family_values.assign(family_value_count, std::numeric_limits<double>::quiet_NaN());
      family_formula_values(robot, n.pose, n.family_values.data());
    }
    nodes[k] = n;
  }
  if (!table.has_dir) {
    // Approach direction from the command sequence, as the controller keeps
    // it (core/compensation.hpp): the machine starts at its home pose with
    // every direction +1; then the sign of the change from the previous node,
    // kept while a joint stands still.
    Vec6<double> q_home;
    const bool home = robot.inverse(robot.home_pose(), q_home) == Status::Ok;
    for (int j = 0; j < 6; ++j) {
      double current = 1;
      std::optional<double> previous_q;
      if (home) previous_q = q_home(j);
      for (std::size_t k = 0; k < nodes.size(); ++k) {
        if (!nodes[k]) continue;
        const double qj = nodes[k]->q(j);
        if (previous_q && std::abs(qj - *previous_q) > 1e-12 * (1 + std::abs(qj))) current = qj > *previous_q ? 1 : -1;
        previous_q = qj;
        nodes[k]->inputs.direction(j) = current;
      }
    }
  }
  return nodes;
}

void EffectValues::set(const Robot& robot, const std::string& effect, const std::string& parameter, double value) {
  const Effect* e = find_effect(robot, effect);
  if (e == nullptr) throw InputError("unknown effect '" + effect + "' (known: " + effect_names(robot) + ")");
  const std::vector<std::string> names = e->parameter_names(robot);
  const auto it = std::find(names.begin(), names.end(), parameter);
  if (it == names.end()) {
    std::string known;
    for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
    throw InputError("effect '" + effect + "' has no parameter '" + parameter + "' for robot " + robot.name +
                     " (parameters: " + known + ")");
  }
  if (!std::isfinite(value)) throw InputError("effect " + effect + ":" + parameter + ": value must be finite");
  Eigen::VectorXd& v = values[effect];
  if (v.size() == 0) v = e->start_values(robot);
  v(it - names.begin()) = value;
}

EffectParameters<double> EffectValues::to_core(const Robot& robot) const {
  EffectParameters<double> out = effect_frame(robot);
  for (const auto& [name, v] : values) {
    const Effect* e = find_effect(robot, name);
    if (e == nullptr) throw InputError("unknown effect '" + name + "' (known: " + effect_names(robot) + ")");
    const UserJointError<double> before = out.user_error;
    e->apply(robot, v, out);
    // core has one user slot (EffectParameters::user, user_error).
    if (before != nullptr && out.user_error != before)
      throw InputError("effects: '" + name + "' and another effect both use the controller's one user joint effect "
                       "slot; identify them in separate models or combine them into one effect");
  }
  // The user slot holds the C++ user effect's numbers or the formulas'.
  if (out.user_error != nullptr && !robot.formula_effects.empty())
    for (const auto& f : robot.formula_effects)
      if (values.count(f->name()))
        throw InputError("effects: the C++ user effect and the formula effect '" + f->name() +
                         "' both need the controller's user slot; identify them in separate models");
  return out;
}

bool EffectValues::needs_temperature() const {
  const auto it = values.find("thermal");
  return it != values.end() && !it->second.isZero();
}

Vec6<double> effect_actual_joints(const EffectParameters<double>& effects, const EffectNode& node) {
  return node.q + effect_joint_error(effects, node.q, node.inputs);
}

Vec6<double> effect_joint_error(const Robot& robot, const EffectParameters<double>& effects, const EffectNode& node,
                                const Vec6<double>& q) {
  return effect_joint_error(effects, q, node.inputs) + formula_joint_error(robot, effects, node, q);
}

Vec6<double> effect_actual_joints(const Robot& robot, const EffectParameters<double>& effects, const EffectNode& node) {
  return node.q + effect_joint_error(robot, effects, node, node.q);
}

}  // namespace kincal::identify
