#include "effects/base_fit.hpp"

#include "kincal/identify/formula_candidate.hpp"
#include "kincal/identify/input_error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "estimate/least_squares_step.hpp"
#include "families/family.hpp"
#include "kincal/identify/decompositions.hpp"
#include "kincal/identify/joint_limits.hpp"
#include "kincal/identify/gauge.hpp"
#include "kincal/identify/hybrid_calibration.hpp"
#include "kincal/identify/hybrid_error_model.hpp"
#include "kincal/identify/simulate.hpp"
#include "kincal/identify/stewart_calibration.hpp"
#include "kincal/identify/target_calibration.hpp"

namespace kincal::identify::detail {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// Laser-tracker targets (target_calibration.hpp), either family, or the full
// poses of a family whose own fit does not read them: per node the residuals,
// their map M and the design rows in the convention's coordinates.
BaseModel target_base(const Robot& robot, const PoseTable& data, const std::vector<std::optional<EffectNode>>& en,
                      Statistics statistics) {
  TargetCalibrationOptions options;
  options.statistics = statistics == Statistics::Computed;
  const TargetCalibration cal = calibrate_targets(robot, data, options);
  BaseModel base;
  base.description = std::string(robot.error_model()) + " from " +
                     (cal.full_pose ? std::string("full poses") : std::to_string(data.target_columns()) + " target(s)") +
                     (data.in_instrument_frame ? " in the instrument's frame (registration identified)" : "") +
                     " (Gauss-Newton, " + std::to_string(cal.history.size()) + " evaluations)";
  base.parameters = cal.free_parameters;
  std::vector<std::size_t> at;
  std::vector<TargetRowInput> inputs;
  for (std::size_t k = 0; k < data.rows.size(); ++k) {
    const PoseRow& row = data.rows[k];
    if (!has_fit_measurement(row, cal.full_pose) || !usable_row(row) || !en[k]) continue;
    at.push_back(k);
    TargetRowInput input{joints_of(row, *en[k]), Pose<double>::from_xyz_rpy(row.commanded), {}, {}};
    if (cal.full_pose)
      input.measured_pose = Pose<double>::from_xyz_rpy(*row.measured);
    else
      input.measured = *row.targets;
    inputs.push_back(input);
  }
  std::vector<std::optional<TargetRowModel>> models = target_rows(robot, cal, inputs);
  for (std::size_t i = 0; i < at.size(); ++i) {
    if (!models[i]) continue;
    NodeData n;
    n.row = at[i];
    n.test = data.rows[at[i]].role == Role::Test;
    n.pose_rows = models[i]->pose_rows;
    n.r = std::move(models[i]->residual);
    n.M = std::move(models[i]->M);
    n.H = std::move(models[i]->H);
    n.effect = *en[at[i]];
    base.nodes.push_back(std::move(n));
  }
  base.model = target_model(robot, cal, data.file);
  return base;
}

}  // namespace

void stack(const BaseModel& base, bool test, MatrixXd& H, VectorXd& y) {
  Index rows = 0;
  for (const NodeData& n : base.nodes)
    if (n.test == test) rows += n.r.size();
  H.resize(rows, base.parameters);
  y.resize(rows);
  Index r = 0;
  for (const NodeData& n : base.nodes) {
    if (n.test != test) continue;
    H.middleRows(r, n.r.size()) = n.H;
    y.segment(r, n.r.size()) = n.r;
    r += n.r.size();
  }
}

void append_penalty_rows(const SteppedBaseFit& fit, MatrixXd& X, VectorXd& y) {
  const double penalty = fit.penalty();
  if (!(penalty > 0)) return;
  const Index p = fit.parameters(), n = X.rows();
  X.conservativeResize(n + p, Eigen::NoChange);
  X.bottomRows(p).setZero();
  X.bottomLeftCorner(p, p) = std::sqrt(penalty) * MatrixXd::Identity(p, p);
  y.conservativeResize(n + p);
  y.tail(p) = -std::sqrt(penalty) * fit.away();
}

void complete_at_solution(const SteppedBaseFit& fit, const PoseTable& data, bool ends_linearised,
                          bool has_joint_maps, BaseModel& base) {
  if (!ends_linearised)
    base = fit.evaluate(data, true);
  else if (!has_joint_maps)
    fit.add_joint_maps(data, base);
}

BaseModel descend_base(SteppedBaseFit& fit, const PoseTable& data, bool iterate) {
  BaseModel base;
  if (iterate) fit.start(data, false, true);
  // Gauss–Newton with Levenberg–Marquardt's damping when a step does not
  // lower the objective (damped_gauss_newton): 6 plain steps were enough
  // wherever seed 000's step started near the minimum; from the coarse
  // machine the damped steps need more.
  fit.keep();
  // A trial is judged by its objective alone; the design rows are formed
  // only at the iterates the descent linearises.
  const DescentCount count = damped_gauss_newton(
      iterate ? 40 : 0,
      [&] {
        std::size_t nodes = 0;
        const double objective = fit.trial_objective(data, nodes);
        return Evaluation{objective, nodes};
      },
      [&] { fit.keep(); }, [&] { fit.go_back(); },
      [&](MatrixXd& H, VectorXd& y) {
        base = fit.evaluate(data, false);
        stack(base, false, H, y);
        append_penalty_rows(fit, H, y);
      },
      [&](const VectorXd& delta) { fit.step(delta); });
  complete_at_solution(fit, data, count.ends_linearised, false, base);
  fit.finish(base, data.file, count.steps);
  return base;
}

BaseModel fit_base_for_effects(const Robot& robot, const PoseTable& data,
                               const std::vector<std::optional<EffectNode>>& nodes,
                               std::unique_ptr<SteppedBaseFit>& stepped) {
  const FamilyPipeline* pipeline = family_of(robot).pipeline_reading(robot, data);
  if (pipeline == nullptr || !pipeline->steps_base_with_effects()) {
    stepped.reset();
    return fit_base(robot, data, nodes, EstimatorKind::Ols, true, 0.0, Statistics::Skipped);
  }
  // What the family's fit_base (OLS, finished) constructs, kept.
  stepped = pipeline->stepped_base_fit(robot, data, nodes, EstimatorKind::Ols, 0.0);
  return descend_base(*stepped, data, true);
}

BaseModel fit_base(const Robot& robot, const PoseTable& fit_data, const std::vector<std::optional<EffectNode>>& nodes,
                   std::optional<EstimatorKind> estimator, bool finish_least_squares, double ridge_k,
                   Statistics statistics) {
  const FamilyPipeline* pipeline = family_of(robot).pipeline_reading(robot, fit_data);
  if (pipeline == nullptr) return target_base(robot, fit_data, nodes, statistics);
  return pipeline->fit_base(robot, fit_data, nodes, estimator, finish_least_squares, ridge_k);
}

PoseTable effect_corrected_table(const Robot& robot, const PoseTable& data,
                                 const std::vector<std::optional<EffectNode>>& nodes, const EffectParameters<double>& e) {
  PoseTable out = data;
  out.has_q = true;
  // Targets in the instrument's frame: the base-frame shift below is turned
  // into it by the registration (its rigid-fit estimate: only its rotation
  // matters, and to rounding of a micrometre-sized shift).
  Mat3<double> to_measurement = Mat3<double>::Identity();
  if (data.in_instrument_frame && data.has_targets && e.thermal != 0)
    to_measurement = nominal_registration(robot, data).R;
  for (std::size_t k = 0; k < out.rows.size(); ++k) {
    PoseRow& row = out.rows[k];
    if (!nodes[k]) continue;
    row.q = Eigen::VectorXd(effect_actual_joints(robot, e, *nodes[k]));
    // A pose-kind formula's twist taken off what was measured (the reverse
    // of simulate's: the tool landed twist away from its kinematics' pose);
    // targets move with the tool, about the commanded tool point.
    const Vec6<double> twist = formula_pose_twist(robot, e, *nodes[k], nodes[k]->q);
    if (!twist.isZero()) {
      if (data.in_instrument_frame && data.has_targets)
        throw InputError(data.file, row.line, 0,
                         "a pose-kind formula effect with targets in the instrument's frame is not supported yet");
      if (row.measured)
        row.measured = moved_by_twist(Pose<double>::from_xyz_rpy(*row.measured), -twist).to_xyz_rpy();
      if (row.targets) {
        const Pose<double> back = moved_by_twist(Pose<double>(), -twist);
        const Vec3<double> p = nodes[k]->pose.p;
        for (int t = 0; t < data.target_columns(); ++t) {
          const Vec3<double> moved = row.targets->col(t) - twist.head<3>() - p;
          row.targets->col(t) = p + back.R * moved;
        }
      }
    }
    if (!row.temp || e.thermal == 0) continue;
    // The thermal effect moves the reached pose (core thermal_reached: the
    // position scaled about the thermal origin, no rotation), so a measured
    // pose is scaled back and the gauge targets, fixed to the platform, are
    // translated back by the tool point's shift (the commanded position
    // stands in for the reached one: the shift's error is strain × a few mm,
    // below a nanometre). Scaling the targets about the origin would also
    // shrink the gauge triangle — a change the effect's columns do not have.
    const double scale = 1.0 / (1.0 + thermal_strain(e, *row.temp));
    if (row.measured) row.measured->head<3>() = e.thermal_origin + scale * (row.measured->head<3>() - e.thermal_origin);
    if (row.targets) {
      const Vec3<double> shift = to_measurement * ((scale - 1.0) * (nodes[k]->pose.p - e.thermal_origin));
      row.targets->leftCols(data.target_columns()).colwise() += shift;
    }
  }
  return out;
}

MatrixXd effect_columns(const Robot& robot, const Effect& effect, const BaseModel& base, bool test,
                        const EffectParameters<double>* at) {
  EffectParameters<double> frame = at != nullptr ? *at : effect_frame(robot);
  if (at == nullptr) effect.apply(robot, effect.start_values(robot), frame);  // (zero but for a formula's `start`)
  const Index k = Index(effect.parameter_names(robot).size());
  Index rows = 0;
  for (const NodeData& n : base.nodes)
    if (n.test == test) rows += n.r.size();
  MatrixXd G(rows, k), twist(6, k);
  Index r = 0;
  for (const NodeData& n : base.nodes) {
    if (n.test != test) continue;
    effect.twist_columns(robot, frame, n.effect, twist);
    G.middleRows(r, n.r.size()) = effect.acts_on_joints() ? MatrixXd(n.M * n.joint_map * twist) : MatrixXd(n.M * twist);
    r += n.r.size();
  }
  // A parameter whose input is (numerically) zero on this machine — e.g. the
  // static load of a joint whose axis is parallel to the weight — has no
  // column: zero it rather than let column scaling blow rounding up into a
  // huge estimate (the minimum-norm solution then leaves it at 0).
  double largest = 0;
  for (Index j = 0; j < k; ++j) largest = std::max(largest, G.col(j).norm());
  for (Index j = 0; j < k; ++j)
    if (!(G.col(j).norm() > 1e-9 * largest)) G.col(j).setZero();
  return G;
}

}  // namespace kincal::identify::detail
