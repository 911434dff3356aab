#include "kincal/identify/simulate.hpp"

#include <cmath>
#include <memory>
#include <random>

#include "families/family.hpp"
#include "kincal/identify/formula_candidate.hpp"
#include "kincal/identify/measurement_model.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

Eigen::Matrix<double, 3, 3> gauge_targets(const HybridGeometry<double>& g, double radius, const Pose<double>& tool) {
  // Tool frame T = F6·C (hybrid.hpp), so the tool axis F6·z is Cᵀ·z in tool
  // coordinates; for machines built by make_hybrid_geometry it is −z.
  const Vec3<double> axis_tool = g.tool_offset.transpose().col(2);
  const Vec3<double> p0 = tool.p - g.tool_length * (tool.R * axis_tool);
  Eigen::Matrix<double, 3, 3> t;
  const double deg = pi<double>() / 180.0;
  const double phi[3] = {90.0 * deg, 210.0 * deg, 330.0 * deg};
  for (int j = 0; j < 3; ++j)
    t.col(j) = p0 + radius * (tool.R * Vec3<double>(std::cos(phi[j]), std::sin(phi[j]), 0.0));
  return t;
}

namespace {

// The machine's physical effects (null: none) with the row's node.
struct RowEffects {
  const Robot* robot = nullptr;  // its formula effects
  const EffectParameters<double>* parameters = nullptr;
  const EffectNode* node = nullptr;
};

// The pose the actual machine reaches for a row, with its effects: the
// joint-space ones in the commands, the thermal drift on the reached pose.
ReachedPose run_row(const ActualMachine& machine, const PoseRow& row, const RowEffects& effects) {
  std::function<Vec6<double>(const Vec6<double>&)> joint_error;
  if (effects.node != nullptr)
    joint_error = [&](const Vec6<double>& q) {
      return effect_joint_error(*effects.robot, *effects.parameters, *effects.node, q);
    };
  ReachedPose out = machine.reach(row, joint_error);
  if (out.status == Status::Ok && effects.node != nullptr && row.temp)
    out.pose = thermal_reached(*effects.parameters, out.pose, *row.temp);
  // A pose-kind formula's twist of the tool, evaluated at the commands
  // (core/formula_effects.hpp: the controller takes it off the pose).
  if (out.status == Status::Ok && effects.node != nullptr)
    out.pose = moved_by_twist(out.pose, formula_pose_twist(*effects.robot, *effects.parameters, *effects.node,
                                                           effects.node->q));
  return out;
}

}  // namespace

PoseTable simulate(const Robot& nominal, const Robot& actual, const PoseTable& poses, const SimulateOptions& options,
                   SimulateReport& report, const std::function<void(const std::string&)>& warn) {
  const Family& family = family_of(nominal);
  if (&family != &family_of(actual)) throw InputError("simulate: nominal and actual robot families differ");
  if (!(options.noise_mm >= 0) || !std::isfinite(options.noise_mm))
    throw InputError("--noise-mm must be a finite number >= 0");
  if (!(options.noise_rad >= 0) || !std::isfinite(options.noise_rad))
    throw InputError("--noise-rad must be a finite number >= 0");
  if (poses.joint_count != Robot::joint_count())
    throw InputError(poses.file, 0, 0, "the poses table has " + std::to_string(poses.joint_count) + " joints, the robot 6");

  std::mt19937_64 rng(options.seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  auto noise = [&](double sigma) { return sigma > 0 ? sigma * unit(rng) : 0.0; };

  // What the instrument measures: the tracker's targets, else the pose (and
  // the family's own targets, the hybrid's gauge, on the actual machine).
  std::optional<MeasurementModel> tracker;
  if (!options.targets.empty())
    tracker = MeasurementModel::targets(options.targets, options.instrument_frame.value_or(Pose<double>{}));
  const std::optional<MeasurementModel> own_targets =
      options.pose_only ? std::nullopt : family.measurement().own_targets(actual);
  if (options.targets.size() > 3) throw InputError("--targets: at most three targets (t1..t3)");
  if (options.instrument_frame && !tracker)
    throw InputError("--instrument-frame applies to target measurements (--targets)");
  if (options.pose_only && tracker) throw InputError("--pose-only measures poses; --targets measures targets: give one");
  PoseTable out = poses;
  out.has_measured = !tracker;
  out.target_count = tracker ? int(options.targets.size()) : own_targets ? own_targets->rows() / 3 : 0;
  out.has_targets = out.target_count > 0;
  out.has_status = false;
  out.ignored_columns.clear();
  report = SimulateReport{};
  const std::unique_ptr<ActualMachine> machine = family.kinematics().actual_machine(nominal, actual);
  const bool with_effects = !options.effects.empty();
  if (with_effects && options.effects.needs_temperature() && !poses.has_temp)
    throw InputError(poses.file, 1, 0, "the thermal effect needs a temp column (structure temperature, C)");
  const EffectParameters<double> effect_parameters = options.effects.to_core(nominal);
  for (const auto& [name, values] : options.effects.values) {
    const std::string missing = find_effect(nominal, name)->missing_inputs(poses);
    if (!missing.empty()) throw InputError(poses.file, 1, 0, "effect '" + name + "' cannot be simulated: " + missing);
  }
  const std::vector<std::optional<EffectNode>> effect_node =
      with_effects ? effect_nodes(nominal, poses) : std::vector<std::optional<EffectNode>>{};
  for (std::size_t index = 0; index < out.rows.size(); ++index) {
    PoseRow& row = out.rows[index];
    row.measured.reset();
    row.targets.reset();
    row.status = "ok";
    RowEffects effects;
    if (with_effects && effect_node[index]) effects = {&nominal, &effect_parameters, &*effect_node[index]};
    const ReachedPose r = run_row(*machine, row, effects);
    if (r.status != Status::Ok) {
      row.status = to_string(r.status);
      out.has_status = true;
      ++report.failed;
      if (warn)
        warn(format_location(poses.file, row.line, 0) + ": warning: row '" + row.id + "': " + r.stage +
             " failed (" + to_string(r.status) + "); written with empty measurements and status '" + row.status + "'");
      continue;
    }
    if (tracker) {
      // Each target where the tracker sees it: T_IB · X · t_k, plus noise.
      const Eigen::VectorXd y = tracker->predict(r.pose);
      Eigen::Matrix<double, 3, 3> t = Eigen::Matrix<double, 3, 3>::Zero();
      for (Eigen::Index k = 0; k < y.size(); ++k) t.data()[k] = y(k) + noise(options.noise_mm);
      row.targets = t;
      ++report.simulated;
      continue;
    }
    Vec6<double> m = r.pose.to_xyz_rpy();
    for (int k = 0; k < 3; ++k) m(k) += noise(options.noise_mm);
    for (int k = 3; k < 6; ++k) m(k) += noise(options.noise_rad);
    row.measured = m;
    if (own_targets) {  // the hybrid's gauge
      const Eigen::VectorXd y = own_targets->predict(r.pose);
      Eigen::Matrix<double, 3, 3> t;
      for (int k = 0; k < 9; ++k) t.data()[k] = y(k) + noise(options.noise_mm);
      row.targets = t;
    }
    ++report.simulated;
  }
  return out;
}

}  // namespace kincal::identify
