#include "kincal/identify/formula_candidate.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <limits>
#include <utility>

#include "kincal/core/formula_effects.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

FormulaCandidate::FormulaCandidate(std::shared_ptr<const FormulaEffect> formula, int offset)
    : formula_(std::move(formula)), offset_(offset) {}

std::string FormulaCandidate::description() const {
  const FormulaEffectSpec& s = formula_->spec();
  std::string out = s.description.empty() ? "formula effect" : s.description;
  if (s.kind == FormulaKind::Joint) {
    out += " (robot description; dq = " + s.formulas.front() + ")";
  } else {
    out += " (robot description; a twist of the tool)";
  }
  return out;
}

std::string FormulaCandidate::missing_inputs(const PoseTable& data) const {
  for (const std::string& c : formula_->required_columns()) {
    if (c == "temp" && !data.has_temp) return "the data has no temp column";
    if (c == "time" && !data.has_time) return "the data has no time column";
    if (c != "temp" && c != "time" &&
        std::find(data.input_names.begin(), data.input_names.end(), c) == data.input_names.end())
      return "the data has no '" + c + "' column";
  }
  if (formula_->uses_direction() && !data.has_dir && data.rows.size() < 2)
    return "no dir1..dir6 columns and too few rows to derive directions";
  return {};
}

std::string FormulaCandidate::inputs() const {
  std::string out = "the commanded pose";
  for (const std::string& c : formula_->required_columns()) out += ", " + c;
  if (formula_->uses_direction()) out += ", approach directions (dir1..dir6 or derived)";
  if (formula_->uses_load()) out += ", static loads under the robot's payload";
  return out;
}

Eigen::VectorXd FormulaCandidate::start_values(const Robot&) const {
  const std::vector<double> s = formula_->start_values();
  return Eigen::Map<const Eigen::VectorXd>(s.data(), Eigen::Index(s.size()));
}

void FormulaCandidate::twist_columns(const Robot& robot, const EffectParameters<double>& frame, const EffectNode& node,
                                     Eigen::Ref<Eigen::MatrixXd> columns) const {
  // The exact derivative along each parameter at the current numbers (the
  // frame's user slot; start values before the first fit).
  const std::vector<double> vars = formula_variables(robot, node, node.q);
  const Eigen::Index n = columns.cols();
  Eigen::VectorXd params = frame.user.segment(offset_, n);
  columns.setZero();
  const int outputs = formula_->output_count();
  // Values and derivatives checked: a formula that is not finite at a node
  // (sqrt of a negative, a division by zero) is an InputError naming the
  // node, the output and the numbers the formula read there.
  thread_local FormulaWorkspace ws;
  std::vector<double> values(static_cast<std::size_t>(outputs));
  std::vector<double> jacobian(static_cast<std::size_t>(outputs) * static_cast<std::size_t>(n));
  formula_->evaluate(vars.data(), params.data(), values.data(), jacobian.data(), "'" + node.id + "'", ws);
  for (int o = 0; o < outputs; ++o) {
    const Eigen::Map<const Eigen::VectorXd> grad(jacobian.data() + std::size_t(o) * std::size_t(n), n);
    if (formula_->kind() == FormulaKind::Joint) {
      const int joint = formula_->joints()[std::size_t(o)] - 1;
      columns += node.joint_twist.col(joint) * grad.transpose();
    } else {
      columns.row(o) += grad.transpose();
    }
  }
}

void FormulaCandidate::apply(const Robot&, const Eigen::VectorXd& values, EffectParameters<double>& out) const {
  out.user.segment(offset_, values.size()) += values;
}

namespace {

// The checked evaluation of every formula at a node where the sum was not
// finite: throws the InputError that names the effect, the node, the output
// and the numbers it read (FormulaEffect::evaluate).
[[noreturn]] void throw_not_finite(const Robot& robot, const EffectParameters<double>& effects, const EffectNode& node,
                                   const std::vector<double>& vars) {
  FormulaWorkspace ws;
  for (const auto& c : robot.formula_effects) {
    const FormulaEffect& f = c->formula();
    std::vector<double> values(static_cast<std::size_t>(f.output_count()));
    f.evaluate(vars.data(), effects.user.data() + c->offset(), values.data(), nullptr, "'" + node.id + "'", ws);
  }
  throw InputError("formula effects are not finite at node '" + node.id + "'");
}

}  // namespace

std::vector<double> formula_variables(const Robot& robot, const EffectNode& node, const Vec6<double>& q) {
  FormulaLayout lay;
  lay.joints = 6;
  lay.input_count = int(robot.formula_inputs.size());
  lay.input_capacity = kFormulaInputs;
  const std::vector<FamilyFormulaVariable> offered = family_formula_variables(robot);
  lay.family_joint_count = int(offered.size());
  std::vector<double> v(std::size_t(lay.size()), 0.0);
  for (int j = 1; j <= 6; ++j) {
    v[std::size_t(lay.q(j))] = q(j - 1);
    v[std::size_t(lay.dir(j))] = node.inputs.direction(j - 1);
  }
  // The static joint loads of the payload by virtual work, τ = J_fᵀ·(F, r × F)
  // with J_f the tool twist per joint (node.joint_twist, about the pose
  // point), F its weight along the frame's weight direction and r its centre
  // of mass from the pose point (the robot's `payload`; default a unit weight
  // at the pose point: compliance's load).
  const Vec3<double> F = robot.payload_weight * effect_frame(robot).load_direction;
  Vec6<double> wrench;
  wrench << F, (node.pose.R * robot.payload_com).cross(F);
  const Vec6<double> load = node.joint_twist.transpose() * wrench;
  for (int j = 1; j <= 6; ++j) v[std::size_t(lay.load(j))] = load(j - 1);
  v[std::size_t(lay.temp())] = node.temperature.value_or(20.0);
  v[std::size_t(lay.time())] = node.time.value_or(0.0);
  const Vec6<double> x = node.pose.to_xyz_rpy();
  for (int c = 0; c < 6; ++c) v[std::size_t(lay.pose(c))] = x(c);
  for (int i = 0; i < lay.input_count; ++i)
    v[std::size_t(lay.input(i))] =
        i < int(node.formula_inputs.size()) ? node.formula_inputs[std::size_t(i)] : std::numeric_limits<double>::quiet_NaN();
  if (!offered.empty()) {
    // Where the family cannot give them (its IK fails at the pose), NaN:
    // a formula that reads them is then refused at this node, by name.
    // The node's own copy where effect_nodes kept one (the same call).
    std::vector<double> values = node.family_values;
    if (values.size() != offered.size() * 6) {
      values.assign(offered.size() * 6, std::numeric_limits<double>::quiet_NaN());
      family_formula_values(robot, node.pose, values.data());
    }
    for (int k = 0; k < lay.family_joint_count; ++k)
      for (int j = 1; j <= 6; ++j) v[std::size_t(lay.family_joint(k, j))] = values[std::size_t(k * 6 + j - 1)];
  }
  return v;
}

Vec6<double> formula_joint_error(const Robot& robot, const EffectParameters<double>& effects, const EffectNode& node,
                                 const Vec6<double>& q) {
  Vec6<double> dq = Vec6<double>::Zero();
  if (robot.formula_effects.empty()) return dq;
  const std::vector<double> vars = formula_variables(robot, node, q);
  for (const auto& c : robot.formula_effects) {
    const FormulaEffect& f = c->formula();
    if (f.kind() != FormulaKind::Joint) continue;
    const double* params = effects.user.data() + c->offset();
    for (int o = 0; o < f.output_count(); ++o) dq(f.joints()[std::size_t(o)] - 1) += f.value(o, vars.data(), params);
  }
  if (!dq.allFinite()) throw_not_finite(robot, effects, node, vars);
  return dq;
}

Vec6<double> formula_pose_twist(const Robot& robot, const EffectParameters<double>& effects, const EffectNode& node,
                                const Vec6<double>& q) {
  Vec6<double> twist = Vec6<double>::Zero();
  bool any = false;
  for (const auto& c : robot.formula_effects) any = any || c->formula().kind() == FormulaKind::Pose;
  if (!any) return twist;
  const std::vector<double> vars = formula_variables(robot, node, q);
  HostFormulaEffects(robot).add_pose_twist(effects.user.data(), vars.data(), twist.data());
  if (!twist.allFinite()) throw_not_finite(robot, effects, node, vars);
  return twist;
}

Pose<double> moved_by_twist(const Pose<double>& pose, const Vec6<double>& twist) {
  Pose<double> out = pose;
  out.p += twist.head<3>();
  const Vec3<double> w = twist.tail<3>();
  if (w.norm() > 0) out.R = Eigen::AngleAxisd(w.norm(), w / w.norm()).toRotationMatrix() * pose.R;
  return out;
}

void HostFormulaEffects::add_joint_error(const double* params, const double* vars, double* dq) const {
  for (const auto& c : robot_->formula_effects) {
    const FormulaEffect& f = c->formula();
    if (f.kind() != FormulaKind::Joint) continue;
    for (int o = 0; o < f.output_count(); ++o) dq[f.joints()[std::size_t(o)] - 1] += f.value(o, vars, params + c->offset());
  }
}

void HostFormulaEffects::add_pose_twist(const double* params, const double* vars, double* twist) const {
  for (const auto& c : robot_->formula_effects) {
    const FormulaEffect& f = c->formula();
    if (f.kind() != FormulaKind::Pose) continue;
    for (int o = 0; o < 6; ++o) twist[o] += f.value(o, vars, params + c->offset());
  }
}

bool HostFormulaEffects::has_pose() const {
  for (const auto& c : robot_->formula_effects)
    if (c->formula().kind() == FormulaKind::Pose) return true;
  return false;
}

}  // namespace kincal::identify
