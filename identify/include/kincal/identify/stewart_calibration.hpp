// Calibration of a 6-UPS machine by seed 001's method: the 42-parameter
// inverse-kinematics error model (Eqs. (6)–(12): per leg the base hinge B_i,
// the platform hinge P_i and the leg length l_i), identified by least squares
// from measured poses, iterated (steps 5–10 of Section 5) with the exact
// forward kinematics of the corrected machine until the parameters settle;
// compensation is the IK of the corrected geometry.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "kincal/core/stewart.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/estimators.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/outliers.hpp"
#include "kincal/identify/pose_errors.hpp"

namespace kincal::identify {

constexpr int kStewartParameterCount = 42;  // per leg: dXB, dYB, dZB, dl, dXP, dYP, dZP
// With the description key leg_offset_sq: then dsq1..dsq6 (core/stewart.hpp).
constexpr int kStewartLegOffsetParameterCount = kStewartParameterCount + 6;
int stewart_parameter_count(const Robot& robot);

using StewartErrorJacobian = Eigen::Matrix<double, 6, Eigen::Dynamic, 0, 6, kStewartLegOffsetParameterCount>;

// Linearised error model at a pose of geometry g: the pose error twist
// (v, ω) of the platform (core/pose.hpp convention) per unit parameter error,
// with the commanded leg lengths held. From seed 001 Eq. (9), J·dQ = B, with
// the platform twist in place of dQ: row block of leg i is
//   J⁻¹·e_i · [u_iᵀ, 1, −(Rᵀu_i)ᵀ]   for (dB_i, dl_i, dP_i).
// With leg offsets (`leg_offsets`: 48 columns, the six dsq_i last) the
// distance |L_i| = √(l_i² + s_i) moves by (l_i/|L_i|)·dl_i and ds_i/(2|L_i|):
// the dl column scaled by l_i/|L_i| (1 when s_i = 0), the dsq column J⁻¹·e_i/(2|L_i|).
StewartErrorJacobian stewart_error_jacobian(const StewartGeometry<double>& g, const Pose<double>& pose,
                                            bool leg_offsets = false);

// nominal + θ (θ in the order of the parameter table: dXB1 dYB1 dZB1 dl1 dXP1 dYP1 dZP1 …, then dsq1..dsq6 if given).
StewartGeometry<double> stewart_with_errors(const StewartGeometry<double>& nominal, const Eigen::VectorXd& theta);

struct StewartIteration {
  int iteration = 0;
  double max_dq_int = 0;       // max over cal nodes of dQ1 + dQ2 (seed 001 Eqs. (15)–(17)), mm + rad
  double rms_position_mm = 0;  // RMS position residual over cal nodes
  double step_norm = 0;        // |Δθ| of the step taken from this iteration, mm
  double step_fraction = 1;    // of the Gauss–Newton step: < 1 when it was damped (calibrate_stewart)
};

struct StewartCalibrationOptions {
  int max_iterations = 50;  // damped steps (far from the solution) may need more than seed 001's few
  double step_tolerance = 1e-9;  // stop when |Δθ| ≤ step_tolerance · (1 + |θ|)
  // Damped steps (calibrate_stewart): a step that leaves a node's FK without
  // a solution or multiplies the residual is halved. false: seed 001's full
  // step every time (for comparison; it fails from millimetre errors).
  bool damped = true;
  // The linear step (seed 001 step 5): ols (default), ridge (k by GCV unless
  // estimator.ridge says otherwise) or pcr (number of components by GCV unless
  // estimator.pcr says otherwise). Each iteration estimates the total error
  // θ from the linearisation at the current θ (see calibrate_stewart), so the
  // biased estimators shrink θ, not the step. Liu is the hybrid's (seed 000)
  // and is refused here.
  EstimatorOptions estimator;
};

struct StewartCalibration {
  Eigen::VectorXd theta;            // identified errors (42)
  Eigen::VectorXd standard_error;   // the estimator's standard errors at the solution (OLS: the usual ones)
  EstimatorOptions estimator;       // as asked
  Estimate fit;                     // the last linear step (x = θ; ridge_k, pcr_components as used)
  std::vector<StewartIteration> history;
  int rank = 0;
  double condition_number = 0;      // of the column-scaled design
  std::size_t nodes = 0;            // cal nodes used
  double sigma_mm = 0;              // residual σ (RSS / (n − m))^½ of the last fit
  std::vector<NodeTest> node_tests;   // per cal node, at the solution
  std::vector<std::string> outliers;  // ids of nodes inconsistent with the others (reported only)
  double outlier_p_threshold = 0;     // Bonferroni: α / testable nodes
  LinearProblem final_problem;        // the design at the solution and its residuals (row_node: node index)
  OutlierReport outlier_report;       // the node test behind node_tests, on final_problem
};

// Identifies θ from the table's `cal` rows (test rows are never used). Each row
// needs a measured pose; its joint commands are the row's q1..q6 or the
// nominal IK of its commanded pose. Throws InputError for too few nodes
// (fewer than 7, seed 001 Section 3), missing measurements, a rank-deficient
// design (naming the parameters and, from identifiability_hint, the poses that
// would separate them), or FK failures of the corrected machine.
StewartCalibration calibrate_stewart(const Robot& nominal, const PoseTable& data,
                                     const StewartCalibrationOptions& options = {});

// Which nodes are inconsistent with the others (identify/outliers.hpp: the
// sequential search on the design at the solution, at least 8 nodes kept).
// `removed` in the order found (each with its test statistic at that step);
// `rest` is the calibration refitted without them — or `all` itself when
// none was flagged or the misfit is systematic.
using StewartOutlierSearch = OutlierSearch<StewartCalibration>;
StewartOutlierSearch stewart_outlier_search(const Robot& nominal, const PoseTable& data,
                                            const StewartCalibration& all,
                                            const StewartCalibrationOptions& options = {});

// Residuals of a (calibrated) 6-UPS against measured data, all rows: the
// measured pose minus the FK of `robot` for the row's joint commands (q1..q6,
// or the nominal IK of the commanded pose). Grouped by role and layer.
PoseErrorReport stewart_residuals(const Robot& nominal, const Robot& robot, const PoseTable& data);

CalibrationModel stewart_model(const Robot& nominal, const StewartCalibration& calibration, const std::string& data_file);

// The calibration's own node test, reused by the outlier screen's first round
// (outliers.hpp).
inline const OutlierReport* outlier_report_of(const StewartCalibration& c) { return &c.outlier_report; }

}  // namespace kincal::identify
