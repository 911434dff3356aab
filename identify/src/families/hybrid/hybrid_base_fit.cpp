// The hybrid's base fit (hybrid_base_fit.hpp) and HybridFamilyPipeline::fit_base.
#include "families/hybrid/hybrid_base_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "estimate/least_squares_step.hpp"
#include "families/hybrid/hybrid_family.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/gauge.hpp"
#include "kincal/identify/hybrid_error_model.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/joint_limits.hpp"
#include "kincal/identify/simulate.hpp"

namespace kincal::identify {

namespace detail {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

HybridBaseFit::HybridBaseFit(const Robot& robot, const PoseTable& data,
                             const std::vector<std::optional<EffectNode>>& en,
                             std::optional<EstimatorKind> estimator, bool finish, double ridge_k)
    : robot_(&robot), en_(&en), g0_(without_limits(robot.hybrid())),
      gauge_(MeasurementModel::gauge(g0_, robot.hybrid_description().gauge_radius)),
      ridge_(estimator == EstimatorKind::Ridge), finish_(finish) {
  fine_ = ridge_                                      ? EstimatorKind::Ridge
          : estimator == EstimatorKind::Ols || finish ? EstimatorKind::Ols
                                                      : EstimatorKind::Liu;
  HybridCalibrationOptions opt;
  // Seed 000's single fine step by the fit's estimator: the fit finishes it
  // by its own (damped) Gauss–Newton steps, from the coarse machine instead
  // where the step lands farther (start). The fine stage's
  // re-linearisation would reach about the same point at ~0.5 G
  // instructions per construction (a diagnosis constructs several).
  opt.estimator = fine_;
  opt.max_linearisations = 1;
  opt.liu_fallback = std::nullopt;
  opt.test_nodes = false;  // the base fit's own screen runs on its final model (outliers.hpp), not here
  cal_ = calibrate_hybrid(robot, data, opt);
  // Start from seed 000's coarse + fine estimate and finish the fit by
  // Gauss–Newton steps on the same identifiable columns: the fine stage is
  // one linear step from the coarse machine, which leaves the residual short
  // of its minimum (e.g. 6.3 vs 4.9 µm RMS on the diagnosis design) and not
  // orthogonal to the columns — the F tests and the effect fits need both.
  // Ridge: the minimum of RSS + k·‖χ − χ_coarse‖² (k by seed 000's
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

// Whether every identified value lies within the machine's limits
// (machine_limits: the robot description's max_correction,
// max_geometry_error and max_angle_error), i.e. a table the controller accepts.
bool HybridBaseFit::within_limits(const HybridCompensation& c) const {
  const MachineLimits<double> l = machine_limits(*robot_);
  for (int i = 0; i < HybridErrorModel::kEncoderCount; ++i)
    if (!(std::abs(c.encoder_offsets(i)) <= l.max_correction[i])) return false;
  for (Index k = HybridErrorModel::kEncoderCount; k < c.structural.size(); ++k)
    if (!(std::abs(c.structural(k)) <=
          (HybridErrorLayout::angular(int(k)) ? l.max_angle_error : l.max_geometry_error)))
      return false;
  return true;
}

void HybridBaseFit::start(const PoseTable& data, bool own_estimate, bool current) {
  std::vector<HybridCompensation> states;
  if (own_estimate) states.push_back(seed_estimate_);
  if (current) states.push_back(comp_);
  comp_ = seed_estimate_;
  step(reference_ - values());
  states.push_back(comp_);  // the coarse machine
  // A start within the machine's limits first: where an effect lies nearly
  // in the span of the base's ill-conditioned combinations, the data fit as
  // well at a machine millimetres away (UPS-actuator scale ±5e-4: encoder
  // offset 24 mm, an S centre 26 mm off, 5.3 µm RMS at 5 µm noise) — a
  // model the controller refuses. The exact model fits it as well as the
  // true one; only the limits tell them apart. (Before the exact model the
  // first-order twist's error at such values made the far start fit worse.)
  std::size_t best = 0, best_nodes = 0;
  bool best_within = false;
  double best_objective = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < states.size(); ++i) {
    comp_ = states[i];
    const bool within = within_limits(comp_);
    std::size_t nodes_here = 0;
    const double objective_here = trial_objective(data, nodes_here);
    const bool better = within != best_within ? within
                        : nodes_here != best_nodes ? nodes_here > best_nodes
                                                   : objective_here < best_objective;
    if (i == 0 || better) {
      best = i;
      best_within = within;
      best_nodes = nodes_here;
      best_objective = objective_here;
    }
  }
  comp_ = states[best];
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

bool HybridBaseFit::ideal_pose(const PoseTable& data, std::size_t k, const HybridGeometry<double>& controller,
                               Pose<double>& pose) const {
  const PoseRow& row = data.rows[k];
  const std::optional<EffectNode>& en = (*en_)[k];
  if (!row.targets || !usable_row(row) || !en) return false;
  const Pose<double> commanded = Pose<double>::from_xyz_rpy(row.commanded);
  HybridPassive<double> guess = g0_.home;
  Vec6<double> q_ik;
  if (hybrid_ik(g0_, commanded, q_ik, nullptr, &guess) != Status::Ok) return false;
  return hybrid_fk(controller, joints_of(row, *en), guess, pose).status == Status::Ok;
}

bool HybridBaseFit::modelled_pose(const PoseTable& data, std::size_t k, const HybridChains<double>& chains,
                                  Pose<double>& pose) const {
  const PoseRow& row = data.rows[k];
  const std::optional<EffectNode>& en = (*en_)[k];
  if (!row.targets || !usable_row(row) || !en) return false;
  const Pose<double> commanded = Pose<double>::from_xyz_rpy(row.commanded);
  HybridPassive<double> guess = g0_.home;
  Vec6<double> q_ik;
  if (hybrid_ik(g0_, commanded, q_ik, nullptr, &guess) != Status::Ok) return false;
  return predict_hybrid(g0_, chains, joints_of(row, *en), guess, pose) == Status::Ok;
}

bool HybridBaseFit::structural_twist(const Pose<double>& pose, Twist<double>& t) const {
  // Δη has zeros at the encoder entries, so the twist is structural only.
  HybridFrames<double> f;
  HybridWrenches<double> w;
  Vec3<double> angles;
  return hybrid_frames_at_pose(comp_.nominal, pose, f, angles) == Status::Ok &&
         hybrid_wrenches(comp_.nominal, f, w) == Status::Ok &&
         hybrid_error_twist(comp_.nominal, twist_reference_, f, w, comp_.structural.data(), t) == Status::Ok;
}

VectorXd HybridBaseFit::gauge_residual(const PoseRow& row, const Pose<double>& modelled) const {
  const Eigen::Matrix<double, 3, 3> t = gauge_targets(g0_, robot_->hybrid_description().gauge_radius, modelled);
  VectorXd r(9);
  for (int i = 0; i < 9; ++i) r(i) = row.targets->data()[i] - t.data()[i];
  return r;
}

BaseModel HybridBaseFit::evaluate(const PoseTable& data, bool with_joint_map) const {
  BaseModel base;
  base.parameters = p_;
  MatrixXd B(6, HybridErrorModel::kParameterCount), B_kept(6, p_);
  const HybridGeometry<double> gc = without_limits(comp_.controller_geometry());
  const HybridChains<double> chains = comp_.chains();
  for (std::size_t k = 0; k < data.rows.size(); ++k) {
    // The identified machine's pose (its exact FK, joint effects included:
    // the pose the compensator's exact IK inverts); B, the fit's Jacobian,
    // at that pose.
    Pose<double> predicted, ideal;
    if (!modelled_pose(data, k, chains, predicted)) continue;
    if (comp_.model->error_jacobian(predicted, B) != Status::Ok) continue;
    // with_joint_map: also the joint map per node, for the effect columns
    // (first order: the twist's change over the ideal machine's pose).
    Eigen::Matrix<double, 6, 6> joint_map = Eigen::Matrix<double, 6, 6>::Identity();
    if (with_joint_map && ideal_pose(data, k, gc, ideal)) joint_map = joint_map_at(ideal);
    const PoseRow& row = data.rows[k];
    NodeData n;
    n.row = k;
    n.test = row.role == Role::Test;
    n.r = gauge_residual(row, predicted);
    Eigen::Matrix<double, 9, 6> M;
    gauge_.map_into(predicted, M);
    n.M = M;
    for (Index j = 0; j < p_; ++j) B_kept.col(j) = B.col(cal_.kept[std::size_t(j)]);
    // H = M·B_kept through the measurement model like every other design
    // (its product rounds a last bit differently from the coefficient-based
    // one this loop used before: the hybrid's printed results moved by
    // ~1e-12 relative when it changed, docs/architecture.md).
    n.H.resize(9, p_);
    gauge_.design_into(predicted, B_kept, n.H);
    n.effect = *(*en_)[k];
    n.joint_map = joint_map;
    base.nodes.push_back(std::move(n));
  }
  return base;
}

// ∂$_t/∂p by central differences of B(p)·Δη.
Eigen::Matrix<double, 6, 6> HybridBaseFit::joint_map_at(const Pose<double>& pose) const {
  Eigen::Matrix<double, 6, 6> joint_map = Eigen::Matrix<double, 6, 6>::Identity();
  for (int i = 0; i < 6; ++i) {
    const double h = i < 3 ? 1e-3 : 1e-6;  // mm, rad: B·Δη is smooth on this scale
    Twist<double> d = Twist<double>::Zero();
    d(i) = h;
    Twist<double> plus, minus;
    if (!structural_twist(apply_twist(pose, d), plus) || !structural_twist(apply_twist(pose, Twist<double>(-d)), minus))
      return Eigen::Matrix<double, 6, 6>::Identity();
    joint_map.col(i) += (plus - minus) / (2 * h);
  }
  return joint_map;
}

void HybridBaseFit::add_joint_maps(const PoseTable& data, BaseModel& base) const {
  const HybridGeometry<double> gc = without_limits(comp_.controller_geometry());
  for (NodeData& n : base.nodes) {
    Pose<double> predicted;
    n.joint_map = ideal_pose(data, n.row, gc, predicted) ? joint_map_at(predicted)
                                                         : Eigen::Matrix<double, 6, 6>::Identity();
  }
}

double HybridBaseFit::trial_objective(const PoseTable& data, std::size_t& nodes) const {
  double o = penalty_ * (values() - reference_).squaredNorm();
  nodes = 0;
  HybridChains<double> chains;
  try {
    chains = comp_.chains();
  } catch (const InputError&) {  // a trial step to non-finite values models nothing
    return o;
  }
  for (std::size_t k = 0; k < data.rows.size(); ++k) {
    Pose<double> predicted;
    if (!modelled_pose(data, k, chains, predicted)) continue;
    ++nodes;
    if (data.rows[k].role != Role::Test) o += gauge_residual(data.rows[k], predicted).squaredNorm();
  }
  return o;
}

void HybridBaseFit::finish(BaseModel& base, const std::string& data_file, int steps) const {
  const bool ridge = ridge_ || penalty_ > 0;  // a joint fit may set a k (set_penalty)
  base.description = "seed 000 coarse + fine model, " + std::to_string(p_) + " identifiable of " +
                     std::to_string(HybridErrorModel::kParameterCount) + " source errors, " +
                     (ridge     ? "ridge (k = " + std::to_string(penalty_) + ") finished by " + std::to_string(steps) +
                                   " Gauss-Newton steps"
                      : finish_ ? "OLS finished by " + std::to_string(steps) + " Gauss-Newton steps"
                                : std::string(fine_ == EstimatorKind::Liu ? "Liu" : "OLS"));
  base.model = hybrid_model(*robot_, cal_, fine_, data_file);
  for (ModelParameter& mp : base.model.parameters) {
    const int idx = comp_.model->index_of(mp.name);
    if (idx < 0 || !mp.identifiable) continue;
    mp.value = idx < HybridErrorModel::kEncoderCount ? comp_.encoder_offsets(idx) : comp_.structural(idx);
  }
  base.model.settings["gauss_newton_steps"] = double(steps);
  if (ridge) {
    base.model.estimator = to_string(EstimatorKind::Ridge);
    base.model.settings["ridge_k"] = penalty_;
  }
  base.ridge_k = penalty_;
  base.column_away = values() - reference_;
}

}  // namespace detail

std::unique_ptr<detail::SteppedBaseFit> HybridFamilyPipeline::stepped_base_fit(
    const Robot& robot, const PoseTable& start, const std::vector<std::optional<EffectNode>>& nodes,
    EstimatorKind estimator, double ridge_k) const {
  return std::make_unique<detail::HybridBaseFit>(robot, start, nodes, estimator, true, ridge_k);
}

detail::BaseModel HybridFamilyPipeline::fit_base(const Robot& robot, const PoseTable& data,
                                                 const std::vector<std::optional<EffectNode>>& en,
                                         std::optional<EstimatorKind> estimator, bool finish, double ridge_k) const {
  detail::HybridBaseFit fit(robot, data, en, estimator, finish, ridge_k);
  return detail::descend_base(fit, data, finish || estimator == EstimatorKind::Ridge);
}

}  // namespace kincal::identify
