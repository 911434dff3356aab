// The base model of a diagnosis or an identification with effects, as a
// linear problem at its solution (private to identify/): the family's own
// nonlinear calibration (seed 001's iterated LS for a 6-UPS; seed 000's coarse
// + fine stages for the hybrid), then per measured node the residual r in
// measurement space, the measurement map M (Δy = M·twist) and the base design
// rows H at the solution. Effects add columns M·(tool twist per parameter).
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "kincal/core/hybrid_error_twist.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/hybrid_calibration.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/robot.hpp"
#include "estimate/least_squares_step.hpp"

namespace kincal::identify::detail {

// A 6-UPS measures orientation too; a rotation counts as the displacement it
// causes 200 mm from its axis (as in stewart_calibration.cpp), so every
// residual coordinate is in mm and one noise level applies to all.
constexpr double kOrientationWeightMm = 200.0;

struct NodeData {
  std::size_t row = 0;
  bool test = false;
  // A 6-UPS's measured pose: rows 3–5 are orientations (in mm at
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
  // "ridge" fits (hybrid): the penalty k·‖χ − χ_coarse‖² minimised with the
  // RSS, and χ − χ_coarse over the design's columns (k = 0 otherwise).
  double ridge_k = 0;
  Eigen::VectorXd column_away;
};

// The hybrid's base fit as a state: seed 000's coarse + fine estimate on the
// start table (calibrate_hybrid, once), then evaluated on any table (the
// measurements corrected for effects at the current effect values) and
// stepped on seed 000's identifiable columns. fit_base finishes it by
// Gauss–Newton alone; the joint fit of base and effects
// (effect_calibration.cpp) steps it together with the effect parameters.
class HybridBaseFit {
 public:
  HybridBaseFit(const Robot& robot, const PoseTable& start, const std::vector<std::optional<EffectNode>>& nodes,
                const std::string& estimator, bool finish_least_squares, double ridge_k);
  Eigen::Index parameters() const { return p_; }
  double penalty() const { return penalty_; }  // k of "ridge", else 0
  void set_penalty(double k) { penalty_ = k; }
  Eigen::VectorXd values() const;              // χ on the identifiable columns
  Eigen::VectorXd away() const { return values() - reference_; }  // χ − χ_coarse
  void step(const Eigen::VectorXd& delta);     // χ += delta
  HybridCompensation state() const { return comp_; }
  void restore(const HybridCompensation& s) { comp_ = s; }
  // Seed 000's fine stage is one linear step from the coarse machine. Where
  // an unmodelled effect is almost in the span of the base's ill-conditioned
  // combinations, that step can land millimetres away where the first-order
  // model no longer holds (UPS-actuator scale s = ±5e-4: an encoder offset
  // moved 30 mm, every gauge target 5 mm off). Then the fit starts from the
  // coarse machine itself: of the two, the one that models more nodes of
  // `data`, then the lower objective. Returns true when it chose the coarse
  // machine.
  bool start_from_the_better(const PoseTable& data) { return start_from_the_best(data, {state()}); }
  // The same choice among `candidates` and the coarse machine (ties: the
  // earlier candidate).
  bool start_from_the_best(const PoseTable& data, const std::vector<HybridCompensation>& candidates);
  // The ridge's centre χ_coarse := seed 000's coarse stage run on `data`.
  void recentre(const PoseTable& data);
  // Seed 000's coarse + fine estimate this fit was constructed from.
  const HybridCompensation& seed_estimate() const { return seed_estimate_; }
  // Nodes (residual, M, H; the joint maps if asked) at the current χ on `data`.
  BaseModel evaluate(const PoseTable& data, bool with_joint_map) const;
  // RSS of the cal rows of `base` plus the ridge penalty k·‖χ − χ_coarse‖².
  double objective(const BaseModel& base) const;
  // Description, model (the current χ), ridge_k and column_away of `base`.
  void finish(BaseModel& base, const std::string& data_file, int steps) const;

 private:
  const Robot* robot_;
  const std::vector<std::optional<EffectNode>>* en_;
  HybridGeometry<double> g0_;
  bool ridge_, finish_;
  HybridFineEstimator fine_ = HybridFineEstimator::Ols;
  HybridCalibration cal_;
  HybridCompensation comp_, seed_estimate_;
  Eigen::Index p_ = 0;
  double penalty_ = 0;
  Eigen::VectorXd reference_;
  HybridErrorReference<double> twist_reference_{};
};

// `fit_data`: the table the base model is fitted on and compared with (the
// measurements, possibly corrected for effects); `nodes`: effect_nodes of the
// original table (same rows). `estimator`: "" for the family default.
// `finish_least_squares`: the hybrid's seed 000 estimate (one fine step from
// the coarse machine) is finished by Gauss–Newton steps to the OLS minimum —
// what a residual diagnosis needs; identification keeps seed 000's estimate
// (its Liu shrinkage is what keeps the ill-conditioned fit stable).
// `ridge_k`: with estimator "ridge" (hybrid), the penalty's k; 0 picks it by
// seed 000's fine-stage GCV.
BaseModel fit_base(const Robot& robot, const PoseTable& fit_data, const std::vector<std::optional<EffectNode>>& nodes,
                   const std::string& estimator = {}, bool finish_least_squares = false, double ridge_k = 0);

// The table as the effect-free model should see it: q1..q6 := the joints the
// machine really had (commands + Δq of the joint-space effects), measured
// poses / gauge targets scaled back about the base origin by 1/(1 + ε) of the
// thermal effect.
PoseTable effect_corrected_table(const Robot& robot, const PoseTable& data,
                                 const std::vector<std::optional<EffectNode>>& nodes, const EffectParameters<double>& e);

// Effect columns of the nodes of `base` whose role matches `test`, stacked
// like their residuals.
Eigen::MatrixXd effect_columns(const Robot& robot, const Effect& effect, const BaseModel& base, bool test);

}  // namespace kincal::identify::detail
