// The base model of a diagnosis or an identification with effects, as a
// linear problem at its solution (private to identify/): the family's own
// nonlinear calibration (seed 001's iterated LS for a 6-UPS; seed 000's coarse
// + fine stages for the hybrid), then per measured node the residual r in
// measurement space, the measurement map M (Δy = M·twist) and the base design
// rows H at the solution. Effects add columns M·(tool twist per parameter).
#pragma once

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/effect_calibration.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/estimators.hpp"
#include "kincal/identify/measurement_model.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal::identify::detail {

// A full pose measures orientation too: its rotation rows are weighted by
// kOrientationWeightMm (measurement_model.hpp).
using identify::kOrientationWeightMm;

struct NodeData {
  std::size_t row = 0;
  bool test = false;
  // A measured full pose: rows 3–5 are orientations (in mm at
  // kOrientationWeightMm). false: every row is a position (gauge, targets).
  bool pose_rows = false;
  Eigen::VectorXd r;  // base-model residual in measurement space, mm
  Eigen::MatrixXd M;  // measurement map: Δy = M·twist
  Eigen::MatrixXd H;  // base design rows at the solution
  EffectNode effect;  // effect inputs at the node (commands as sent)
  // The model's tool twist per tool twist of a joint-space effect: identity
  // for the 6-UPS; for the hybrid I + ∂$_t/∂p, because its structural twist
  // $_t = B(p)·Δη is evaluated at the pose p the joints reach and so moves
  // with them (large where the estimate's ill-conditioned combinations are).
  Eigen::Matrix<double, 6, 6> joint_map = Eigen::Matrix<double, 6, 6>::Identity();
};

struct BaseModel {
  std::string description;
  Eigen::Index parameters = 0;
  std::vector<NodeData> nodes;
  CalibrationModel model;  // the fitted base model (no effects)
  // Ridge fits (hybrid): the penalty k·‖χ − χ_coarse‖² minimised with the
  // RSS, and χ − χ_coarse over the design's columns (k = 0 otherwise).
  double ridge_k = 0;
  Eigen::VectorXd column_away;
};

// A row the model may use (simulate's status "ok" or none).
inline bool usable_row(const PoseRow& r) { return r.status.empty() || r.status == "ok"; }
// The joints the model drives: the row's q1..q6 (the commands sent, or the
// effect-corrected joints of effect_corrected_table), else the nominal IK.
inline Vec6<double> joints_of(const PoseRow& row, const EffectNode& node) {
  return row.q ? Vec6<double>(row.q->head<6>()) : node.q;
}

// A family's base fit as a state that Gauss–Newton steps together with the
// effect parameters (joint_fit, effect_calibration.cpp): where the base is
// nearly collinear with the effects (the hybrid's compliance is 99.9 %
// confounded with it), fitting the base to its minimum and then the effects
// in turn creeps along those directions; one step of both moves along them
// at once. FamilyPipeline::stepped_base_fit makes one; a family whose own fit
// converges alone (the 6-UPS, seed 001's iterated LS) offers none, and its
// effects alternate with fit_base.
class SteppedBaseFit {
 public:
  virtual ~SteppedBaseFit() = default;
  // The number of base parameters χ the steps move (the design's columns).
  virtual Eigen::Index parameters() const = 0;
  // k of the ridge penalty k·‖χ − χ_centre‖² (0: none) and its centre's
  // name in reports ("seed 000's coarse machine").
  virtual double penalty() const = 0;
  virtual void set_penalty(double k) = 0;
  virtual const char* centre() const = 0;
  // χ − χ_centre: a penalised step adds the rows √k·Δχ = −√k·away().
  virtual Eigen::VectorXd away() const = 0;
  // The centre recomputed on `data` (the measurements corrected for the
  // effects at their current values).
  virtual void recentre(const PoseTable& data) = 0;
  // χ += delta.
  virtual void step(const Eigen::VectorXd& delta) = 0;
  // Keep the current iterate / go back to the one kept (a damped
  // Gauss–Newton's accepted step and its undo).
  virtual void keep() = 0;
  virtual void go_back() = 0;
  // Start from the best, on `data`, of the family's own first estimate (if
  // `own_estimate`), the current iterate (if `current`) and the family's
  // fallback start: the one that models more nodes, then the lower objective.
  virtual void start(const PoseTable& data, bool own_estimate, bool current) = 0;
  // Nodes (residual, M, H; the joint maps if asked) at the current χ on `data`.
  virtual BaseModel evaluate(const PoseTable& data, bool with_joint_map) const = 0;
  // The joint maps of `base`, evaluate(data, false) at the current χ, filled
  // in: evaluate(data, true) without forming the design rows again (a descent
  // that ends on an iterate it linearised has them; #13).
  virtual void add_joint_maps(const PoseTable& data, BaseModel& base) const = 0;
  // RSS of the cal rows of evaluate(data, false) plus the penalty, and the
  // number of nodes it models, without forming the design rows: what a
  // trial iterate (a step, a start) is judged by before it is linearised
  // (#13: the design's error Jacobians were 90 % of an evaluation).
  virtual double trial_objective(const PoseTable& data, std::size_t& nodes) const = 0;
  // Description, model (the current χ), ridge_k and column_away of `base`.
  virtual void finish(BaseModel& base, const std::string& data_file, int steps) const = 0;
};

// Whether a base fit computes the statistics beyond its solution — the
// fitted model's standard errors (BaseModel::model) and the rest of the
// target fit's (TargetCalibrationOptions::statistics) — or skips them where
// only the linearisation at the solution is used: the diagnosis's fits,
// and the passes of the alternation before its last. The target fit's alone
// (a family's own pipeline computes its statistics anyway).
enum class Statistics { Computed, Skipped };

// The family's own pipeline (FamilyPipeline::fit_base), or the target fit for target
// data (either family).
// `fit_data`: the table the base model is fitted on and compared with (the
// measurements, possibly corrected for effects); `nodes`: effect_nodes of the
// original table (same rows). `estimator`: nullopt for the family default.
// `finish_least_squares`: the hybrid's seed 000 estimate (one fine step from
// the coarse machine) is finished by Gauss–Newton steps to the OLS minimum —
// what a residual diagnosis needs; identification keeps seed 000's estimate
// (its Liu shrinkage is what keeps the ill-conditioned fit stable).
// `ridge_k`: with estimator Ridge (hybrid), the penalty's k; 0 picks it by
// seed 000's fine-stage GCV.
BaseModel fit_base(const Robot& robot, const PoseTable& fit_data, const std::vector<std::optional<EffectNode>>& nodes,
                   std::optional<EstimatorKind> estimator = std::nullopt, bool finish_least_squares = false,
                   double ridge_k = 0, Statistics statistics = Statistics::Computed);

// Residuals and base design rows of the nodes of one role (test or cal),
// stacked in node order.
void stack(const BaseModel& base, bool test, Eigen::MatrixXd& H, Eigen::VectorXd& y);
// A ridge's rows √k·Δχ = −√k·(χ − χ_centre) appended under the design X (its
// first fit.parameters() columns are the base's) and y; none when k = 0.
void append_penalty_rows(const SteppedBaseFit& fit, Eigen::MatrixXd& X, Eigen::VectorXd& y);

// `base` made the base at the iterate a descent ended on, with the joint
// maps the effect columns need: `base` is the descent's last linearisation
// (formed with the joint maps or not: `has_joint_maps`) where the descent
// ended on that iterate (`ends_linearised`), and is evaluated afresh
// otherwise (the last evaluation may belong to a step that was undone).
void complete_at_solution(const SteppedBaseFit& fit, const PoseTable& data, bool ends_linearised,
                          bool has_joint_maps, BaseModel& base);

// Gauss–Newton (damped) of a stepped base fit alone to its minimum on
// `data`, from the better of its current iterate and its fallback start
// (`iterate`; else evaluated where it stands): the nodes at the solution with
// their joint maps, and the fit's description. A family's fit_base on its
// stepped fit (the hybrid's).
BaseModel descend_base(SteppedBaseFit& fit, const PoseTable& data, bool iterate);

// fit_base by OLS to the minimum (its statistics skipped), as a diagnosis
// fits it before it tests and accepts effects, and in `stepped` the family's stepped fit that made it
// (nullptr where the family alternates, or for target data). The joint fit of
// base and accepted effects on the same table starts from it
// (calibrate_with_effects' `from`) instead of constructing its own: the
// family's first stages on the same data run once (the hybrid: seed 000's
// coarse + fine, 72 M instructions; #13).
BaseModel fit_base_for_effects(const Robot& robot, const PoseTable& data,
                               const std::vector<std::optional<EffectNode>>& nodes,
                               std::unique_ptr<SteppedBaseFit>& stepped);

// The table as the effect-free model should see it: q1..q6 := the joints the
// machine really had (commands + Δq of the joint-space effects), measured
// poses / gauge targets scaled back about the base origin by 1/(1 + ε) of the
// thermal effect.
PoseTable effect_corrected_table(const Robot& robot, const PoseTable& data,
                                 const std::vector<std::optional<EffectNode>>& nodes, const EffectParameters<double>& e);

// calibrate_with_effects (effect_calibration.hpp), and in `base_out` (if
// given) the base model at its solution: the nodes on the table corrected for
// the fitted effects — what fit_base(effect_corrected_table(...)) would fit
// again (the diagnosis's re-linearisation). The alternation's last step is
// that fit itself; the joint Gauss–Newton's base (the hybrid) is at the
// minimum over base and effects, hence over the base with the effects held.
// `from` (if given): the stepped fit fit_base_for_effects made on the same
// `data`, used by the first round instead of a new one (its start() resets
// the iterate; OLS options only, the ones it was made with). `statistics`:
// of the final base fit (Skipped: the model's standard errors are NaN).
CalibrationModel calibrate_with_effects(const Robot& robot, const PoseTable& data, const std::vector<std::string>& effects,
                                        const EffectCalibrationOptions& options, EffectCalibrationReport* report,
                                        BaseModel* base_out, SteppedBaseFit* from = nullptr,
                                        Statistics statistics = Statistics::Computed);

// Effect columns of the nodes of `base` whose role matches `test`, stacked
// like their residuals, at the effect values `at` (nullptr: every value zero,
// a formula effect's at its start values — the columns of an effect
// nonlinear in its parameters depend on them).
Eigen::MatrixXd effect_columns(const Robot& robot, const Effect& effect, const BaseModel& base, bool test,
                               const EffectParameters<double>* at = nullptr);

}  // namespace kincal::identify::detail
