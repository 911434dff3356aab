// Seed 000's calibration pipeline for the hybrid robot (Section 4.3): coarse
// calibration of the six encoder offsets by iterated OLS (Eq. (15)), fine
// calibration of the identifiable source errors by the Liu estimator on the
// reconstructed identification Jacobian (Sections 4.1–4.2), pose error
// compensation by correcting the requested pose and running the ideal IK
// (Eq. (16)), the Monte Carlo robustness index η (Eqs. (17)–(18)), and the
// round trip through MODEL.json. docs/hybrid-calibration.md has the details
// and the measured numbers.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "kincal/core/hybrid.hpp"
#include "kincal/core/hybrid_exact.hpp"
#include "kincal/core/pose.hpp"
#include "kincal/core/status.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/estimators.hpp"
#include "kincal/identify/hybrid_error_model.hpp"
#include "kincal/identify/identifiability.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/outliers.hpp"
#include "kincal/identify/pose_errors.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal::identify {

struct HybridCalibrationOptions {
  // Eq. (15) stop rule, read as "relative change between two successive
  // estimates": ‖ξ̂^{k+1} − ξ̂^k‖ / ‖ξ̂^{k+1}‖ ≤ eps_xi (5 % as the paper).
  double eps_xi = 0.05;
  int max_coarse_iterations = 20;
  bool fine = true;  // false: coarse only
  LiuOptions liu;    // Eq. (14) d by default
  // Fit on the column-scaled design H·D⁻¹ (unit column norms) rather than on H
  // in mm and rad. Liu's filter (λ+d)/(λ+1) depends on the scaling.
  bool scale_columns = false;
  // reconstruct_by_column_selection's tolerance: a unit column counts as new
  // when its distance from the span so far exceeds it (<0: its ε-level
  // default). 1e-4 rather than a rounding-level value: columns that are new
  // only at 1e-6..1e-8 are identifiable in exact arithmetic but turn 5 µm of
  // gauge noise into millimetre-sized estimates (docs/hybrid-calibration.md).
  double selection_tolerance = 1e-4;
  // The fine estimator the calibration's model and compensation use (MODEL.json
  // "estimator"). All four are computed from one SVD of the fine design, so any
  // of them can still be compared (compensation(estimator)).
  EstimatorKind estimator = EstimatorKind::Liu;
  RidgeOptions ridge;                              // ridge's k: GCV by default
  PcrOptions pcr = PcrOptions{0, 0.0, 1e3, true};  // PCR's number of components: GCV by default
  // The coarse stage's nodes. Seed 000 Sec. 4.3: "the number of calibration
  // nodes required for coarse calibration is much fewer than is required in
  // the fine calibration", and Sec. 5 runs it on the 5 × 5 middle layer (the
  // fine stage's test layer). Non-empty: the rows with gauge targets in these
  // layers, whatever their role (a test layer used here stays held out from
  // the fine stage, not from the encoder offsets). Empty: the cal rows.
  std::vector<long long> coarse_layers;
  // Deleted-node F test of each cal node on the fine design (node_tests, outliers).
  bool test_nodes = true;
  // The fine stage is linearised again at its estimate while the model's
  // residual there exceeds the linearisation's prediction by more than this
  // fraction (in RSS): source errors of millimetres, where one step of seed
  // 000's linear fine stage stops far above the noise. 0.25: what the
  // linearisation misses is then at least half the noise (in RMS); seed
  // 000's own data sets stay at one step (their gap is ~5 %, and the
  // compensation, Eq. (16) at the requested pose, matches that step's
  // model). At most max_linearisations linearisations in all (1: seed 000's
  // single step).
  double relinearise_tolerance = 0.25;
  int max_linearisations = 20;
  // With estimator Liu: when the data reject Liu's shrinkage (the F test of
  // what it adds to the OLS residual at level liu_alpha; hybrid_calibration.cpp),
  // the fine stage uses this estimator instead and says so
  // (HybridCalibration::liu_check_*; options.estimator then names it).
  // nullopt: keep Liu whatever the data say (an explicit --estimator liu).
  std::optional<EstimatorKind> liu_fallback = EstimatorKind::Ridge;
  double liu_alpha = 0.01;
};

// One linearisation of the fine stage (the first is seed 000's step from the
// coarse machine).
struct HybridFineLinearisation {
  // 0: the estimator's step from the previous point; else the
  // Levenberg–Marquardt damping λ of the least-squares step taken because
  // the estimator's step did not lower the residual.
  double damping = 0;
  double rss_predicted = 0;  // the linearised problem's residual sum of squares at its estimate, mm²
  double rss = 0;            // the model's residual sum of squares at the point reached, mm²
};

struct HybridCoarseIteration {
  Vec6<double> delta_xi = Vec6<double>::Zero();  // Δξ̂^k of this round
  Vec6<double> xi = Vec6<double>::Zero();        // ξ̂^{k+1} after it
  double relative_change = 0;                    // ‖Δξ̂^k‖ / ‖ξ̂^{k+1}‖
  double rms_residual = 0;                       // RMS of the gauge residual before the round, mm
};

// The identified machine, as the controller compensates it: the nominal
// chains with the encoder offsets ξ̂ (seed 000 Eq. (15)) and the structural
// source errors Δχ̂ folded into their links — the erroneous machine itself
// (core/hybrid_exact.hpp; issue #31), not seed 000's first-order image of it
// (Eq. (16)'s $_t = B·Δη̂, which left 1.1 µm on a machine with 1 mm / 2 mrad
// errors). B stays the fit's Jacobian.
struct HybridCompensation {
  HybridGeometry<double> nominal;                       // the nominal machine (its own joint_offset included)
  Vec6<double> encoder_offsets = Vec6<double>::Zero();  // ξ̂: added to nominal.joint_offset
  Eigen::VectorXd structural;                           // Δχ̂ (156; encoder entries 0) or empty: none
  std::shared_ptr<const HybridErrorModel> model;        // B of the nominal machine
  // The ideal machine's geometry: nominal with joint_offset += encoder_offsets.
  HybridGeometry<double> controller_geometry() const;
  // The identified machine's chains (ξ̂ and Δχ̂ folded). InputError if the
  // values are not finite.
  HybridChains<double> chains() const;
};

// The identified machine's tool pose for commands q: core's exact FK of
// `chains` from `guess` (the passive it reached is written back on Ok).
Status predict_hybrid(const HybridGeometry<double>& nominal, const HybridChains<double>& chains,
                      const Vec6<double>& q, HybridPassive<double>& guess, Pose<double>& tool);

struct HybridCalibration {
  HybridGeometry<double> nominal;
  HybridCalibrationOptions options;  // as asked (options.estimator: the model's estimator)
  double gauge_radius = 0;
  std::size_t cal_nodes = 0;
  std::vector<std::string> cal_ids;  // the cal nodes in fit order (node k of fine_problem.row_node)

  // coarse (Eq. (15))
  std::vector<std::string> coarse_ids;  // its nodes (= cal_ids unless options.coarse_layers)
  std::size_t coarse_test_rows = 0;     // how many of them are `test` rows
  Vec6<double> coarse_xi = Vec6<double>::Zero();
  std::vector<HybridCoarseIteration> coarse_history;
  bool coarse_converged = false;

  // fine: Δχ increments relative to the coarse machine, over the kept columns
  bool fine_done = false;
  std::vector<Eigen::Index> kept, dropped;  // Δχ indices (encoders first)
  std::vector<std::string> kept_names, dropped_names;
  // Linearisations of the fine stage (one when seed 000's single step holds),
  // and whether the last one predicts the model's residual at the estimate.
  std::vector<HybridFineLinearisation> linearisations;
  bool fine_linearisation_valid = true;
  // The check of Liu's shrinkage (options.liu_fallback): F and its p-value;
  // options.estimator is the fallback when p < options.liu_alpha.
  double liu_check_f = 0, liu_check_p = 1;
  Eigen::Index rank = 0;
  double condition_number = 0;   // column-scaled reconstructed H
  // H (kept columns, divided by column_scale) and y (gauge residuals, plus
  // H·(χ − χ_coarse) of the last linearisation point when re-linearised)
  LinearProblem fine_problem;
  std::vector<Eigen::Matrix<double, 6, 1>> fine_poses;  // per cal node, the pose H was linearised at (x..rz)
  Eigen::VectorXd column_scale;  // D (ones unless scale_columns)
  Estimate liu, ols, ridge, pcr;     // all four from one SVD of fine_problem (x already divided by column_scale)
  Eigen::VectorXd chi_liu, chi_ols, chi_ridge, chi_pcr;  // 150 each, zeros where dropped

  // cal nodes inconsistent with the others: deleted-node F test (OLS on the
  // fine design, Bonferroni over the nodes, α = 0.01); reported, not excluded.
  std::vector<NodeTest> node_tests;
  std::vector<std::string> outliers;
  double outlier_p_threshold = 0;
  OutlierReport outlier_report;  // the node test behind node_tests, on fine_problem (empty without test_nodes)

  // The fine estimate of an estimator (null without a fine stage), and its
  // 150 Δχ̂ (zeros without a fine stage).
  const Estimate* estimate(EstimatorKind estimator) const;
  Eigen::VectorXd chi(EstimatorKind estimator) const;
  // Total encoder offsets ξ̂ + Δξ̂ (fine) and the structural part, for a fine
  // estimator; nullopt: the coarse stage alone (ξ̂, no structural part), the
  // compensation before any fine stage.
  HybridCompensation compensation(std::optional<EstimatorKind> fine) const;
  HybridCompensation compensation() const { return compensation(options.estimator); }
};

// Coarse + fine calibration on the `cal` rows of `data` that carry gauge
// targets (t1..t3) and no failure status (the coarse stage on
// options.coarse_layers' rows if given); commands are the row's q1..q6 or the
// nominal IK of the commanded pose. Throws InputError (non-hybrid robot, too
// few usable rows, IK/FK failure at a node, rank-deficient H_ξ).
HybridCalibration calibrate_hybrid(const Robot& nominal, const PoseTable& data,
                                   const HybridCalibrationOptions& options = {});

// Which cal nodes are inconsistent with the others (identify/outliers.hpp:
// the sequential search on the fine design, at least 7 nodes kept). `removed`
// in the order found, each with its statistic at that step; `rest` is the
// calibration (coarse + fine) refitted without them, or `all` itself when
// none was flagged or the search stopped with `systematic`: nodes still
// flagged after a tenth of the cal nodes was set aside, so the misfit is not
// a few bad nodes but the model (an unmodelled effect) or noise-free data
// (the F test assumes noise), and excluding nodes would hide it.
using HybridOutlierSearch = OutlierSearch<HybridCalibration>;
HybridOutlierSearch hybrid_outlier_search(const Robot& nominal, const PoseTable& data, const HybridCalibration& all,
                                          const HybridCalibrationOptions& options = {});

// The commands that put the identified machine's tool on `requested`: core's
// exact IK of its chains (hybrid_exact_ik), the same routine as the
// controller's Compensator. Returns its status; q is written only on Ok.
Status compensate_hybrid(const HybridCompensation& compensation, const Pose<double>& requested, Vec6<double>& q);
Status compensate_hybrid(const HybridCalibration& calibration, const Pose<double>& requested, Vec6<double>& q);

// What would make the source errors the fine stage drops identifiable:
// identifiability_hint on the fine design over all 150 errors at the cal
// nodes' poses, its null space taken to the reconstruction's tolerance
// (options.selection_tolerance as a singular value of the unit-column design),
// so the near-dependent columns the reconstruction drops are in it as well as
// the exact redundancies. Seed 000's pure-translation layers, for example,
// leave errors that only tilted poses separate. Empty when there is no fine
// stage.
IdentifiabilityHint hybrid_identifiability_hint(const Robot& nominal, const HybridCalibration& calibration,
                                                const HintOptions& options = {});

// ---- evaluation (seed 000 Table 5) ------------------------------------------

struct HybridLayerError {
  long long layer = 0;  // row's layer (0 when absent)
  std::size_t nodes = 0;
  std::size_t failed = 0;                            // IK / FK failures (not in the statistics)
  double max_position = 0, mean_position = 0;        // |Δp| of P, mm
  double max_orientation = 0, mean_orientation = 0;  // |Δθ|, deg
};

// Commands every row's pose (compensated when `compensation` is given, else
// the nominal IK of `nominal`), drives the erroneous `machine` (hybrid Robot
// with its HybridDescription::source_errors, or its ideal geometry if none)
// and compares the reached pose with the requested one. One entry per layer,
// ascending.
std::vector<HybridLayerError> evaluate_hybrid(const Robot& machine, const HybridGeometry<double>& nominal,
                                              const PoseTable& poses, const HybridCompensation* compensation);

// ---- Monte Carlo robustness index (Eqs. (17)–(18)) ----------------------------

struct HybridMonteCarlo {
  int runs = 0;
  double sigma_mm = 0;
  Eigen::VectorXd sd_ols, sd_liu;       // per kept parameter, standard deviation over the runs
  double sigma_ols = 0, sigma_liu = 0;  // √Σ variance (Eq. (18), D = variance)
  double eta = 0;                       // 1 − σ_L/σ_OLS, in percent
  double seconds = 0;                   // wall time of the runs (SVD excluded)
  double mean_d = 0;                    // mean Liu d over the runs
};

// Fresh Gaussian noise (σ on every gauge coordinate) added to y0 = H·Δχ̂_L on
// the calibration's fixed design, N OLS and Liu fits through one
// PreparedDesign (one SVD).
HybridMonteCarlo hybrid_monte_carlo(const HybridCalibration& calibration, int runs, double sigma_mm,
                                    std::uint64_t seed = 1);

// Residuals of the data against a compensation's model of the machine (or the
// nominal machine when `compensation` is null), every row with gauge targets:
// the machine as modelled (ideal FK with the encoder offsets, then the
// predicted error twist B·Δχ̂) gives predicted targets; the 9 target residuals
// are turned into the node's pose error twist by least squares through the
// gauge map of Eq. (9). Grouped by role and layer, so test rows are evaluated
// on a model that never saw them.
PoseErrorReport hybrid_residuals(const Robot& nominal, const HybridCompensation* compensation, const PoseTable& data);

// ---- MODEL.json -------------------------------------------------------------

// Parameters by HybridErrorModel names: dxi_* = total encoder offsets
// (coarse + fine), then the kept structural errors (fine), then the dropped
// ones (identifiable = false, value 0), of a fine estimator's compensation
// (compensation(fine); nullopt: the coarse stage alone). estimator:
// to_string(*fine), "coarse-ols" for the coarse stage alone; settings: the
// estimator's (estimator_settings: liu_d, ridge_k, pcr_components, ...) and
// eps_xi, coarse_iterations, coarse_nodes, rank, condition_number, cal_nodes.
CalibrationModel hybrid_model(const Robot& nominal, const HybridCalibration& calibration,
                              std::optional<EstimatorKind> fine, const std::string& data_file = {});
// The model of the calibration's own estimator (options.estimator).
CalibrationModel hybrid_model(const Robot& nominal, const HybridCalibration& calibration,
                              const std::string& data_file = {});
// Rebuilds the compensation from a model: dxi_* (and the older joint-offset
// names dq1..dq3, dtheta4..dtheta6) → encoder offsets, any other
// HybridErrorModel name → structural. Throws InputError on a non-hybrid robot
// or an unknown name.
HybridCompensation hybrid_compensation_from_model(const CalibrationModel& model);

// The calibration's own node test, reused by the outlier screen's first round
// (outliers.hpp); none when the nodes were not tested.
inline const OutlierReport* outlier_report_of(const HybridCalibration& c) {
  return c.outlier_report.nodes.empty() ? nullptr : &c.outlier_report;
}

}  // namespace kincal::identify
