// Calibration from laser-tracker targets (issue #12 item 2): one to three
// targets on the platform (6-UPS) or the tool (hybrid), their positions
// measured per pose in the robot's base frame or, with
// PoseTable::in_instrument_frame, in the tracker's own frame.
//
// The same fit reads full poses (mx..mrz, the robot's base frame) for a
// family whose own pipeline does not (the hybrid, whose own is seed 000's
// gauge): the measurement model is then the full pose, 6 rows per node with
// the rotations weighted by kOrientationWeightMm like the 6-UPS's own fit
// (M = diag(I, 200 mm·I)), no registration and no targets.
//
// Unknowns: the family's error parameters (6-UPS: seed 001's 42 joint errors;
// hybrid: seed 000's 150 source errors), the targets' positions (3 per
// target) and, in the tracker's frame, its registration (6). Positions of
// targets fix the machine only up to what a registration and the targets'
// positions can absorb, so a stated convention closes it:
//   - 6-UPS (target_measurement.hpp rigid_motion_rows): the platform joints'
//     errors carry no net rigid motion (moving all of them and the targets
//     together changes no measurement); in the tracker's frame neither do
//     the base joints' (moving all of them is a change of registration);
//   - hybrid: seed 000 Section 4.1's column selection with the instrument's
//     columns placed first: a source error whose column the registration,
//     the targets or the errors before it already span is held at 0.
// The fit is Gauss–Newton on the nonlinear model (exact FK of the erroneous
// machine) in the coordinates of the convention's null space, damped as every
// host fit (least_squares_step.hpp), from the nominal machine and the rigid
// fit of measured against nominal targets.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "kincal/core/pose.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/estimators.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/outliers.hpp"
#include "kincal/identify/pose_errors.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal::identify {

struct TargetCalibrationOptions {
  int max_iterations = 60;
  // false: the solution alone (errors, registration, targets, convention,
  // the rank check) with NaN standard errors, and no weakest combinations,
  // node tests or final problem: for a caller that only linearises at the
  // solution (the diagnosis's base fits). Those statistics were 60 % of a
  // 6-RUS fit of 100 full poses (#33).
  bool statistics = true;
};

// A combination of parameters the data determine worst: the unit direction
// (rotations weighted by 1 m, so every term is in mm) and its standard
// deviation at the data's noise.
struct WeakCombination {
  double standard_deviation_mm = 0;
  std::vector<std::pair<std::string, double>> terms;  // largest first, |coefficient| ≥ 0.1
};

// One accepted iterate of the descent.
struct TargetIteration {
  int iteration = 0;
  double rms_position_mm = 0;  // RMS target residual per coordinate
  double step_norm = 0;        // |Δ errors| from the previous accepted iterate
};

struct TargetCalibration {
  std::vector<std::string> names;  // of errors: the family's parameter names
  Eigen::VectorXd errors;          // the family's error parameters, in the convention
  Eigen::VectorXd standard_error;  // of errors (0 where held)
  std::vector<bool> fitted;        // false: held at 0 by the convention (hybrid)
  std::string convention;          // as the identify line says it
  bool full_pose = false;          // read full poses (no targets, no registration)
  bool instrument_frame = false;
  Pose<double> registration;       // base frame in the instrument frame (identity unless instrument_frame)
  Vec6<double> registration_standard_error = Vec6<double>::Zero();  // of its twist (mm, rad; instrument axes)
  std::vector<Vec3<double>> targets;                // identified positions on the platform / tool, mm
  std::vector<Vec3<double>> target_standard_error;  // of each coordinate
  std::vector<TargetIteration> history;
  std::size_t nodes = 0;
  int free_parameters = 0;         // family + 3k (+ 6) minus the convention's rows
  int rank = 0;
  double condition_number = 0;     // of the column-scaled design in the convention's coordinates
  double sigma_mm = 0;             // per target coordinate (full pose: per weighted coordinate): (RSS / (n − p))^½
  std::vector<WeakCombination> weakest;  // the three worst-determined combinations, worst first
  std::vector<NodeTest> node_tests;
  std::vector<std::string> outliers;
  double outlier_p_threshold = 0;
  LinearProblem final_problem;     // the design at the solution (row_node: node index), residuals as y
  OutlierReport outlier_report;
  Eigen::MatrixXd convention_basis;  // N: x = N·φ (x: the family's errors, registration twist if free, 3 per target)
};

// Whether a table is identified by this fit:
//   - it has target columns and
//     - 6-UPS: no measured poses, or its targets are in the instrument's frame;
//     - hybrid: the robot description names `targets` (without them the
//       columns are seed 000's gauge), or they are in the instrument's frame;
//   - or it has measured poses alone and the family's own pipeline does not
//     read full poses (the hybrid).
bool uses_target_model(const Robot& robot, const PoseTable& data);
// Whether the fit reads the table's full poses rather than its targets.
bool reads_full_poses(const PoseTable& data);
// Whether a row has what the fit reads: a measured pose, or target positions.
inline bool has_fit_measurement(const PoseRow& row, bool full_pose) {
  return full_pose ? bool(row.measured) : bool(row.targets);
}

// Identifies from the table's cal rows with target positions (t1..tk), or
// with measured poses where the table has no targets. The robot description's
// `targets` are the nominal positions (their count must be the table's).
// Throws InputError for a robot without `targets`, a count mismatch, too few
// nodes, a design that does not determine the parameters (naming the weakest
// combination), or FK failures.
TargetCalibration calibrate_targets(const Robot& nominal, const PoseTable& data,
                                    const TargetCalibrationOptions& options = {});

// The registration that lays the nominal machine's targets (FK of the rows'
// commands) best onto the measured ones, over every usable cal row: the fit's
// start in the instrument frame, and the nominal model's for its residuals.
Pose<double> nominal_registration(const Robot& nominal, const PoseTable& data);

// The outlier screen of identify/outliers.hpp around it.
using TargetOutlierSearch = OutlierSearch<TargetCalibration>;
TargetOutlierSearch target_outlier_search(const Robot& nominal, const PoseTable& data, const TargetCalibration& all,
                                          const TargetCalibrationOptions& options = {});
inline const OutlierReport* outlier_report_of(const TargetCalibration& c) { return &c.outlier_report; }

// Residuals at the target points of every measured row: measured − the
// model's prediction (the machine with `errors` — the family's full vector,
// zero for the nominal one — at the row's commands, q1..q6 or the nominal IK
// of the commanded pose, then the registration and targets). One report row
// per target point (id "ROW:tK"), position only (PoseErrorReport::target_points).
// A table read by its full poses (reads_full_poses): one row per pose, the
// pose error measured − model (registration and targets unused).
PoseErrorReport target_residuals(const Robot& nominal, const Eigen::VectorXd& errors, const Pose<double>& registration,
                                 const std::vector<Vec3<double>>& targets, const PoseTable& data);

// Rows at a calibration's solution, for the diagnosis and the effect fits
// (identify/src/effects/base_fit.hpp): per row (commands q, commanded pose, measured
// targets) the model's pose, the target residual (3k), the measurement map M
// (3k × 6) and the design rows in the convention's coordinates
// (3k × free_parameters); nullopt where the model's FK fails.
struct TargetRowInput {
  Vec6<double> q;
  Pose<double> commanded;
  Eigen::Matrix<double, 3, 3> measured;  // targets (columns); unused for full poses
  Pose<double> measured_pose;            // full poses; unused for targets
};
struct TargetRowModel {
  Pose<double> pose;
  Eigen::VectorXd residual;  // full pose: rotations × kOrientationWeightMm, as M and H
  Eigen::MatrixXd M, H;
  bool pose_rows = false;    // rows 3–5 are the weighted rotation (full pose)
};
std::vector<std::optional<TargetRowModel>> target_rows(const Robot& nominal, const TargetCalibration& c,
                                                       const std::vector<TargetRowInput>& rows);

// MODEL.json: the family's errors (held ones not identifiable) and the
// instrument (registration and targets).
CalibrationModel target_model(const Robot& nominal, const TargetCalibration& c, const std::string& data_file);

}  // namespace kincal::identify
