#include "effects/base_fit.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <limits>

#include "kincal/core/hybrid_error_twist.hpp"
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

bool usable(const PoseRow& r) { return r.status.empty() || r.status == "ok"; }

}  // namespace

namespace {

// The joints the model drives: the row's q1..q6 (the commands sent, or the
// effect-corrected joints of effect_corrected_table), else the nominal IK.
Vec6<double> joints_of(const PoseRow& row, const EffectNode& node) {
  return row.q ? Vec6<double>(row.q->head<6>()) : node.q;
}

// Laser-tracker targets (target_calibration.hpp), either family: per node the
// target residuals, their map M and the design rows in the convention's
// coordinates.
BaseModel target_base(const Robot& robot, const PoseTable& data, const std::vector<std::optional<EffectNode>>& en) {
  const TargetCalibration cal = calibrate_targets(robot, data);
  BaseModel base;
  base.description = std::string(robot.is_stewart() ? "seed 001 42-parameter model" : "seed 000 source-error model") +
                     " from " + std::to_string(data.target_columns()) + " target(s)" +
                     (data.in_instrument_frame ? " in the instrument's frame (registration identified)" : "") +
                     " (Gauss-Newton, " + std::to_string(cal.history.size()) + " evaluations)";
  base.parameters = cal.free_parameters;
  std::vector<std::size_t> at;
  std::vector<TargetRowInput> inputs;
  for (std::size_t k = 0; k < data.rows.size(); ++k) {
    const PoseRow& row = data.rows[k];
    if (!row.targets || !usable(row) || !en[k]) continue;
    at.push_back(k);
    inputs.push_back({joints_of(row, *en[k]), Pose<double>::from_xyz_rpy(row.commanded), *row.targets});
  }
  std::vector<std::optional<TargetRowModel>> models = target_rows(robot, cal, inputs);
  for (std::size_t i = 0; i < at.size(); ++i) {
    if (!models[i]) continue;
    NodeData n;
    n.row = at[i];
    n.test = data.rows[at[i]].role == Role::Test;
    n.r = std::move(models[i]->residual);
    n.M = std::move(models[i]->M);
    n.H = std::move(models[i]->H);
    n.effect = *en[at[i]];
    base.nodes.push_back(std::move(n));
  }
  base.model = target_model(robot, cal, data.file);
  return base;
}

BaseModel stewart_base(const Robot& robot, const PoseTable& data, const std::vector<std::optional<EffectNode>>& en,
                       const std::string& estimator) {
  (void)estimator;  // seed 001's model is fitted by OLS
  const StewartCalibration cal = calibrate_stewart(robot, data);
  const StewartGeometry<double> g = stewart_with_errors(without_limits(robot.stewart()), cal.theta);  // measured rows: no limits
  BaseModel base;
  base.description = "seed 001 42-parameter model (iterated LS, " + std::to_string(cal.history.size()) + " rounds)";
  base.parameters = kStewartParameterCount;
  Vec6<double> w;
  w << 1, 1, 1, kOrientationWeightMm, kOrientationWeightMm, kOrientationWeightMm;
  for (std::size_t k = 0; k < data.rows.size(); ++k) {
    const PoseRow& row = data.rows[k];
    if (!row.measured || !usable(row) || !en[k]) continue;
    const Pose<double> measured = Pose<double>::from_xyz_rpy(*row.measured);
    Pose<double> predicted;
    if (stewart_fk(g, joints_of(row, *en[k]), measured, predicted).status != Status::Ok) continue;
    NodeData n;
    n.row = k;
    n.test = row.role == Role::Test;
    n.pose_rows = true;
    n.r = w.asDiagonal() * pose_error(measured, predicted);
    n.M = w.asDiagonal();
    n.H = w.asDiagonal() * stewart_error_jacobian(g, predicted);
    n.effect = *en[k];
    base.nodes.push_back(std::move(n));
  }
  base.model = stewart_model(robot, cal, data.file);
  return base;
}

}  // namespace

HybridBaseFit::HybridBaseFit(const Robot& robot, const PoseTable& data,
                             const std::vector<std::optional<EffectNode>>& en, const std::string& estimator,
                             bool finish, double ridge_k)
    : robot_(&robot), en_(&en), g0_(without_limits(robot.hybrid())), ridge_(estimator == "ridge"), finish_(finish) {
  fine_ = ridge_                             ? HybridFineEstimator::Ridge
          : estimator == "ols" || finish     ? HybridFineEstimator::Ols
                                             : HybridFineEstimator::Liu;
  HybridCalibrationOptions opt;
  // Seed 000's single fine step by the fit's estimator: the fit finishes it
  // by its own (damped) Gauss–Newton steps, from the coarse machine instead
  // where the step lands farther (start_from_the_better). The fine stage's
  // re-linearisation would reach about the same point at ~0.5 G
  // instructions per construction (a diagnosis constructs several).
  opt.estimator = fine_;
  opt.max_linearisations = 1;
  opt.liu_fallback = HybridFineEstimator::None;
  opt.test_nodes = false;  // the base fit's own screen runs on its final model (outliers.hpp), not here
  cal_ = calibrate_hybrid(robot, data, opt);
  // Start from seed 000's coarse + fine estimate and finish the fit by
  // Gauss–Newton steps on the same identifiable columns: the fine stage is
  // one linear step from the coarse machine, which leaves the residual short
  // of its minimum (e.g. 6.3 vs 4.9 µm RMS on the diagnosis design) and not
  // orthogonal to the columns — the F tests and the effect fits need both.
  // "ridge": the minimum of RSS + k·‖χ − χ_coarse‖² (k by seed 000's
  // fine-stage GCV unless given), the penalised objective reached by
  // Gauss–Newton on the augmented rows √k·I.
  comp_ = cal_.compensation(fine_);
  if (comp_.structural.size() == 0) comp_.structural = VectorXd::Zero(HybridErrorModel::kParameterCount);
  seed_estimate_ = comp_;
  p_ = Index(cal_.kept.size());
  penalty_ = !ridge_ ? 0.0 : ridge_k > 0 ? ridge_k : cal_.ridge.ridge_k;
  reference_.resize(p_);  // the coarse machine: the fine stage's starting point
  for (Index j = 0; j < p_; ++j) {
    const Index idx = cal_.kept[std::size_t(j)];
    reference_(j) = idx < HybridErrorModel::kEncoderCount ? cal_.coarse_xi(idx) : 0.0;
  }
  // The structural twist $_t = B(p)·Δη alone, at any pose, by core's
  // evaluation (the compensator's: hybrid_error_twist.hpp, the same model
  // as B to rounding) — a few thousand operations where a full 6 × 150 B
  // costs a hundred times more; the joint map needs twelve of them per node.
  twist_reference_ = hybrid_error_reference(comp_.nominal, HybridErrorModelOptions().up_split);
}

bool HybridBaseFit::start_from_the_best(const PoseTable& data, const std::vector<HybridCompensation>& candidates) {
  std::vector<HybridCompensation> states = candidates;
  comp_ = seed_estimate_;
  step(reference_ - values());
  states.push_back(comp_);  // the coarse machine
  std::size_t best = 0, best_nodes = 0;
  double best_objective = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < states.size(); ++i) {
    comp_ = states[i];
    const BaseModel at = evaluate(data, false);
    const double objective_here = objective(at);
    if (at.nodes.size() > best_nodes || (at.nodes.size() == best_nodes && objective_here < best_objective)) {
      best = i;
      best_nodes = at.nodes.size();
      best_objective = objective_here;
    }
  }
  comp_ = states[best];
  return best + 1 == states.size();
}

void HybridBaseFit::recentre(const PoseTable& data) {
  HybridCalibrationOptions opt;
  opt.fine = false;
  opt.test_nodes = false;
  const HybridCalibration coarse = calibrate_hybrid(*robot_, data, opt);
  for (Index j = 0; j < p_; ++j) {
    const Index idx = cal_.kept[std::size_t(j)];
    if (idx < HybridErrorModel::kEncoderCount) reference_(j) = coarse.coarse_xi(idx);
  }
}

VectorXd HybridBaseFit::values() const {
  VectorXd v(p_);
  for (Index j = 0; j < p_; ++j) {
    const Index idx = cal_.kept[std::size_t(j)];
    v(j) = idx < HybridErrorModel::kEncoderCount ? comp_.encoder_offsets(idx) : comp_.structural(idx);
  }
  return v;
}

void HybridBaseFit::step(const VectorXd& delta) {
  for (Index j = 0; j < p_; ++j) {
    const Index idx = cal_.kept[std::size_t(j)];
    if (idx < HybridErrorModel::kEncoderCount)
      comp_.encoder_offsets(idx) += delta(j);
    else
      comp_.structural(idx) += delta(j);
  }
}

BaseModel HybridBaseFit::evaluate(const PoseTable& data, bool with_joint_map) const {
  // Δη has zeros at the encoder entries, so the twist is structural only.
  auto structural_twist = [&](const Pose<double>& pose, Twist<double>& t) {
    HybridFrames<double> f;
    HybridWrenches<double> w;
    Vec3<double> angles;
    return hybrid_frames_at_pose(comp_.nominal, pose, f, angles) == Status::Ok &&
           hybrid_wrenches(comp_.nominal, f, w) == Status::Ok &&
           hybrid_error_twist(comp_.nominal, twist_reference_, f, w, comp_.structural.data(), t) == Status::Ok;
  };
  BaseModel base;
  base.parameters = p_;
  MatrixXd B(6, HybridErrorModel::kParameterCount), B_kept(6, p_);
  const HybridGeometry<double> gc = without_limits(comp_.controller_geometry());
  const std::vector<std::optional<EffectNode>>& en = *en_;
  for (std::size_t k = 0; k < data.rows.size(); ++k) {
    const PoseRow& row = data.rows[k];
    if (!row.targets || !usable(row) || !en[k]) continue;
    const Pose<double> commanded = Pose<double>::from_xyz_rpy(row.commanded);
    HybridPassive<double> guess = g0_.home;
    Vec6<double> q_ik;
    if (hybrid_ik(g0_, commanded, q_ik, nullptr, &guess) != Status::Ok) continue;
    Pose<double> predicted;
    if (hybrid_fk(gc, joints_of(row, *en[k]), guess, predicted).status != Status::Ok) continue;
    // The structural twist at the pose the ideal machine reaches, joint
    // effects included (as the fine stage puts it and core's fixed point
    // p = apply_twist(target, −$_t(p)) inverts). Not at the commanded pose:
    // where the estimate's ill-conditioned combinations are large, the
    // twist changes fast with the point it is evaluated at, and a model and
    // a compensation that evaluate it at different points disagree by
    // micrometres (clean hybrid data: 15.6 µm compensated; 2.24 µm here).
    if (comp_.model->error_jacobian(predicted, B) != Status::Ok) continue;
    // with_joint_map: also ∂$_t/∂p per node by central differences of
    // B(p)·Δη (NodeData::joint_map), for the effect columns.
    Eigen::Matrix<double, 6, 6> joint_map = Eigen::Matrix<double, 6, 6>::Identity();
    if (with_joint_map) {
      bool ok = true;
      for (int i = 0; i < 6 && ok; ++i) {
        const double h = i < 3 ? 1e-3 : 1e-6;  // mm, rad: B·Δη is smooth on this scale
        Twist<double> d = Twist<double>::Zero();
        d(i) = h;
        Twist<double> plus, minus;
        ok = structural_twist(apply_twist(predicted, d), plus) &&
             structural_twist(apply_twist(predicted, Twist<double>(-d)), minus);
        if (ok) joint_map.col(i) += (plus - minus) / (2 * h);
      }
      if (!ok) joint_map.setIdentity();
    }
    predicted = apply_twist(predicted, Twist<double>(B * comp_.structural));
    const Eigen::Matrix<double, 3, 3> t = gauge_targets(g0_, robot_->gauge_radius, predicted);
    NodeData n;
    n.row = k;
    n.test = row.role == Role::Test;
    n.r.resize(9);
    for (int i = 0; i < 9; ++i) n.r(i) = row.targets->data()[i] - t.data()[i];
    const Eigen::Matrix<double, 9, 6> M = gauge_map(g0_, robot_->gauge_radius, predicted);
    n.M = M;
    for (Index j = 0; j < p_; ++j) B_kept.col(j) = B.col(cal_.kept[std::size_t(j)]);
    // One product of known inner size (9 × 6 by 6 × p), not a matrix–vector
    // product per kept column nor a general GEMM call.
    n.H.noalias() = M.lazyProduct(B_kept);
    n.effect = *en[k];
    n.joint_map = joint_map;
    base.nodes.push_back(std::move(n));
  }
  return base;
}

double HybridBaseFit::objective(const BaseModel& base) const {
  double o = penalty_ * (values() - reference_).squaredNorm();
  for (const NodeData& n : base.nodes) o += n.test ? 0.0 : n.r.squaredNorm();
  return o;
}

void HybridBaseFit::finish(BaseModel& base, const std::string& data_file, int steps) const {
  const bool ridge = ridge_ || penalty_ > 0;  // a joint fit may set a k (set_penalty)
  base.description = "seed 000 coarse + fine model, " + std::to_string(p_) + " identifiable of " +
                     std::to_string(HybridErrorModel::kParameterCount) + " source errors, " +
                     (ridge     ? "ridge (k = " + std::to_string(penalty_) + ") finished by " + std::to_string(steps) +
                                   " Gauss-Newton steps"
                      : finish_ ? "OLS finished by " + std::to_string(steps) + " Gauss-Newton steps"
                                : std::string(fine_ == HybridFineEstimator::Liu ? "Liu" : "OLS"));
  base.model = hybrid_model(*robot_, cal_, fine_, data_file);
  for (ModelParameter& mp : base.model.parameters) {
    const int idx = comp_.model->index_of(mp.name);
    if (idx < 0 || !mp.identifiable) continue;
    mp.value = idx < HybridErrorModel::kEncoderCount ? comp_.encoder_offsets(idx) : comp_.structural(idx);
  }
  base.model.settings["gauss_newton_steps"] = double(steps);
  if (ridge) {
    base.model.estimator = "ridge";
    base.model.settings["ridge_k"] = penalty_;
  }
  base.ridge_k = penalty_;
  base.column_away = values() - reference_;
}

namespace {

BaseModel hybrid_base(const Robot& robot, const PoseTable& data, const std::vector<std::optional<EffectNode>>& en,
                      const std::string& estimator, bool finish, double ridge_k) {
  HybridBaseFit fit(robot, data, en, estimator, finish, ridge_k);
  const Index p = fit.parameters();
  const double penalty = fit.penalty();
  BaseModel base;
  const bool iterate = finish || estimator == "ridge";
  if (iterate) fit.start_from_the_better(data);
  // Gauss–Newton with Levenberg–Marquardt's damping when a step does not
  // lower the objective (damped_gauss_newton): 6 plain steps were enough
  // wherever seed 000's step started near the minimum; from the coarse
  // machine the damped steps need more.
  HybridCompensation accepted = fit.state();
  const DescentCount count = damped_gauss_newton(
      iterate ? 40 : 0,
      [&] {
        base = fit.evaluate(data, false);
        return Evaluation{fit.objective(base), base.nodes.size()};
      },
      [&] { accepted = fit.state(); }, [&] { fit.restore(accepted); },
      [&](MatrixXd& H, VectorXd& y) {
        Index rows = 0;
        for (const NodeData& n : base.nodes) rows += n.test ? 0 : n.r.size();
        const Index penalty_rows = penalty > 0 ? p : 0;
        H.resize(rows + penalty_rows, p);
        y.resize(rows + penalty_rows);
        Index r = 0;
        for (const NodeData& n : base.nodes) {
          if (n.test) continue;
          H.middleRows(r, n.r.size()) = n.H;
          y.segment(r, n.r.size()) = n.r;
          r += n.r.size();
        }
        if (penalty > 0) {
          H.bottomRows(p) = std::sqrt(penalty) * MatrixXd::Identity(p, p);
          y.tail(p) = -std::sqrt(penalty) * fit.away();
        }
      },
      [&](const VectorXd& delta) { fit.step(delta); });
  const int steps = count.steps;
  base = fit.evaluate(data, true);  // at the solution, with the joint maps the effect columns need
  fit.finish(base, data.file, steps);
  return base;
}

}  // namespace

BaseModel fit_base(const Robot& robot, const PoseTable& fit_data, const std::vector<std::optional<EffectNode>>& nodes,
                   const std::string& estimator, bool finish_least_squares, double ridge_k) {
  if (uses_target_model(robot, fit_data)) return target_base(robot, fit_data, nodes);
  return robot.is_stewart() ? stewart_base(robot, fit_data, nodes, estimator)
                            : hybrid_base(robot, fit_data, nodes, estimator, finish_least_squares, ridge_k);
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
    row.q = Eigen::VectorXd(effect_actual_joints(e, *nodes[k]));
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

MatrixXd effect_columns(const Robot& robot, const Effect& effect, const BaseModel& base, bool test) {
  const EffectParameters<double> frame = effect_frame(robot);
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
