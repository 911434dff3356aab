// The hybrid's base fit as a state (seed 000's pipeline made a linear
// problem at its solution; effects/base_fit.hpp's BaseModel). Private to
// identify/: HybridFamilyPipeline::fit_base runs it to the least-squares minimum;
// the joint fit of base and effects (effect_calibration.cpp) steps it
// together with the effect parameters.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "effects/base_fit.hpp"
#include "kincal/core/hybrid_error_twist.hpp"
#include "kincal/identify/hybrid_calibration.hpp"
#include "kincal/identify/measurement_model.hpp"

namespace kincal::identify::detail {

// The hybrid's base fit as a state: seed 000's coarse + fine estimate on the
// start table (calibrate_hybrid, once), then evaluated on any table (the
// measurements corrected for effects at the current effect values) and
// stepped on seed 000's identifiable columns. fit_base finishes it by
// Gauss–Newton alone; the joint fit of base and effects
// (effect_calibration.cpp) steps it together with the effect parameters.
class HybridBaseFit final : public SteppedBaseFit {
 public:
  HybridBaseFit(const Robot& robot, const PoseTable& start, const std::vector<std::optional<EffectNode>>& nodes,
                std::optional<EstimatorKind> estimator, bool finish_least_squares, double ridge_k);
  Eigen::Index parameters() const override { return p_; }
  double penalty() const override { return penalty_; }  // k of ridge, else 0
  void set_penalty(double k) override { penalty_ = k; }
  const char* centre() const override { return "seed 000's coarse machine"; }
  Eigen::VectorXd values() const;  // χ on the identifiable columns
  Eigen::VectorXd away() const override { return values() - reference_; }  // χ − χ_coarse
  // The ridge's centre χ_coarse := seed 000's coarse stage run on `data`.
  void recentre(const PoseTable& data) override;
  void step(const Eigen::VectorXd& delta) override;  // χ += delta
  void keep() override { kept_ = comp_; }
  void go_back() override { comp_ = kept_; }
  // Seed 000's fine stage is one linear step from the coarse machine. Where
  // an unmodelled effect is almost in the span of the base's ill-conditioned
  // combinations, that step can land millimetres away where the first-order
  // model no longer holds (UPS-actuator scale s = ±5e-4: an encoder offset
  // moved 30 mm, every gauge target 5 mm off). Then the fit starts from the
  // coarse machine itself (the fallback start): of the candidates, the one
  // that models more nodes of `data`, then the lower objective (ties: seed
  // 000's estimate, then the current iterate, then the coarse machine).
  void start(const PoseTable& data, bool own_estimate, bool current) override;
  // Nodes (residual, M, H; the joint maps if asked) at the current χ on `data`.
  BaseModel evaluate(const PoseTable& data, bool with_joint_map) const override;
  void add_joint_maps(const PoseTable& data, BaseModel& base) const override;
  // RSS of the cal rows plus the ridge penalty k·‖χ − χ_coarse‖², the
  // rows predicted by the identified machine's exact FK.
  double trial_objective(const PoseTable& data, std::size_t& nodes) const override;
  // Description, model (the current χ), ridge_k and column_away of `base`.
  void finish(BaseModel& base, const std::string& data_file, int steps) const override;

 private:
  // Every value of `c` within the robot's limits (a table the controller accepts).
  bool within_limits(const HybridCompensation& c) const;
  // Row k's pose on the ideal machine with the current encoder offsets (the
  // pose the structural twist is evaluated at); false where IK or FK fails.
  bool ideal_pose(const PoseTable& data, std::size_t k, const HybridGeometry<double>& controller,
                  Pose<double>& pose) const;
  // Row k's pose on the identified machine (its exact chains, `chains`);
  // false where IK or FK fails.
  bool modelled_pose(const PoseTable& data, std::size_t k, const HybridChains<double>& chains,
                     Pose<double>& pose) const;
  // The structural twist B(p)·Δη at `pose` by core's evaluation.
  bool structural_twist(const Pose<double>& pose, Twist<double>& t) const;
  // I + ∂$_t/∂p at `pose` (NodeData::joint_map); identity where a twist fails.
  Eigen::Matrix<double, 6, 6> joint_map_at(const Pose<double>& pose) const;
  // Gauge residual measured − model at the ideal pose moved by the twist.
  Eigen::VectorXd gauge_residual(const PoseRow& row, const Pose<double>& modelled) const;
  const Robot* robot_;
  const std::vector<std::optional<EffectNode>>* en_;
  HybridGeometry<double> g0_;
  MeasurementModel gauge_;  // seed 000's gauge on g0_: every node's M and H = M·B
  bool ridge_, finish_;
  EstimatorKind fine_ = EstimatorKind::Ols;
  HybridCalibration cal_;
  HybridCompensation comp_, seed_estimate_, kept_;
  Eigen::Index p_ = 0;
  double penalty_ = 0;
  Eigen::VectorXd reference_;
  HybridErrorReference<double> twist_reference_{};
};

}  // namespace kincal::identify::detail
