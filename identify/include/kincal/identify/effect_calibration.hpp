// Identification with physical effects (`kincal identify --effects e1,e2`):
// the base model of the robot family and the effects' parameters together.
// The base model stays the family's own nonlinear calibration; the effects
// enter by alternation: fit the base on the data as the effect-free model
// should see it (joints as the machine really had them, thermal expansion
// taken out — detail::effect_corrected_table), refit the effects jointly with
// the base columns on the remaining residual (one linear step), repeat until
// the effect values settle. docs/effects.md.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/estimators.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal::identify {

struct EffectCalibrationOptions {
  // The base model in every pass: Ols, its least-squares minimum (the linear
  // effect step assumes a minimum); Ridge (hybrid only), the minimum of
  // RSS + k·‖χ − χ_coarse‖² over seed 000's identifiable source errors,
  // effects unpenalised. Ridge keeps the ill-conditioned directions near the
  // coarse machine, where seed 000's first-order error twist still describes
  // the machine (docs/diagnosis.md, measured per effect). nullopt: the
  // default, for the hybrid's gauge ridge with k by GCV at the solution
  // (ridge_k), else OLS. Other estimators throw InputError.
  std::optional<EstimatorKind> estimator;
  double ridge_k = 0;  // hybrid: the base penalty's k as given; 0 chooses it by GCV on base + effects at the solution
  int max_passes = 6;
  double tolerance = 1e-3;  // stop when the effect update is below this fraction of the values (scaled)
  // Backward elimination of effect parameters: while the least significant
  // free one fails its t test in the joint fit (Bonferroni: p × free < alpha),
  // it is held at 0 and the fit repeated. 0 keeps every parameter free.
  double alpha = 0.01;
};

// An effect parameter held at 0 by the elimination, with its test.
struct HeldParameter {
  std::string effect, parameter;
  std::size_t index = 0;       // in the effect's parameter_names
  double t = 0;                // estimate / standard error in the joint fit (0: not identifiable)
  double p_value = 1;          // two-sided, from t² ~ F(1, n − rank)
  std::size_t free_parameters = 0;  // free effect parameters when it was tested (Bonferroni factor)
  // The part of its column outside the base design's span, relative to the
  // column (1: orthogonal to the base). Below kBaseCopyShare the parameter
  // is a copy of base parameters (a clearance whose load never changes sign
  // is an encoder offset): held before any t test, which the model's own
  // small mismatches would otherwise pass (#32: 12 mm against 12 mm).
  double outside_base = 1;
};
inline constexpr double kBaseCopyShare = 1e-3;

struct EffectCalibrationReport {
  std::string base;  // how the base was fitted and, for the hybrid, why that estimator (printed by identify)
  int passes = 0;
  std::vector<double> rms_cal_um;  // cal residual RMS per pass (measurement coordinates)
  double rms_cal_um_final = 0, rms_test_um_final = 0;
  std::vector<HeldParameter> held;  // in the order they were held
  // The joint design [H G] on the cal rows at the solution and its residual
  // (row_node: node index), with each node's id and line: what the outlier
  // screen (identify/outliers.hpp) tests.
  LinearProblem final_problem;
  std::vector<NodeTest> nodes;
};

// Throws InputError for an unknown effect name, an effect whose inputs the
// data lacks (e.g. thermal without a temp column), or whatever the base
// calibration rejects.
CalibrationModel calibrate_with_effects(const Robot& robot, const PoseTable& data, const std::vector<std::string>& effects,
                                        const EffectCalibrationOptions& options = {},
                                        EffectCalibrationReport* report = nullptr);

}  // namespace kincal::identify
