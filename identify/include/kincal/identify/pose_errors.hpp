// Pose errors of a measurement table: measured − commanded per row, as the
// pose error twist (Δp, Δθ) of core/pose.hpp, and their summary per role and
// layer in the form of seed 000 Table 5 (max and mean of the position and
// orientation error magnitudes). Also the difference between two tables'
// measured poses, matched by id (e.g. our simulation against a paper's).
#pragma once

#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "kincal/core/pose.hpp"
#include "kincal/identify/csv.hpp"

namespace kincal::identify {

struct PoseErrorRow {
  std::string id;
  std::string group;       // "layer N" or "" when the table has no layer column
  Role role = Role::Cal;
  Twist<double> error;     // (Δx, Δy, Δz) mm, (Δθx, Δθy, Δθz) rad, base frame
};

struct PoseErrorStats {
  std::size_t count = 0;
  double max_position_mm = 0, mean_position_mm = 0, rms_position_mm = 0;
  double max_orientation_rad = 0, mean_orientation_rad = 0;
};

// A measured row the model could not be evaluated at, and why ("nominal IK of
// the commanded pose failed (unreachable)"): the tool warns about each one at
// its line, where it used to count it silently with the rows that have no
// measurement.
struct UnevaluatedRow {
  std::string id;
  std::size_t line = 0;
  std::string why;
};

struct PoseErrorReport {
  std::vector<PoseErrorRow> rows;
  std::size_t skipped = 0;  // rows without a measurement (failed simulation)
  std::vector<UnevaluatedRow> unevaluated;
  PoseErrorStats all;
  std::map<std::string, PoseErrorStats> groups;  // "cal", "test", "layer N", "layer N test", ...
  // Rows are target points (laser-tracker targets, stewart_target_calibration.hpp):
  // positions only, no orientation was measured.
  bool target_points = false;
};

// measured − commanded. Throws InputError if the table has no measured pose
// columns (mx..mrz).
PoseErrorReport pose_errors(const PoseTable& table);

// a.measured − b.measured, rows matched by id. Throws InputError naming the
// file and id of any row present in one table and missing in the other.
PoseErrorReport pose_differences(const PoseTable& a, const PoseTable& b);

PoseErrorStats summarize(const std::vector<PoseErrorRow>& rows);

// A report from rows computed elsewhere (e.g. gauge residuals turned into pose
// error twists): overall and per role / layer statistics.
PoseErrorReport make_pose_error_report(std::vector<PoseErrorRow> rows, std::size_t skipped);

// Human-readable report: per-row table (optional) and the summary per group.
void print_pose_error_report(const PoseErrorReport& report, std::ostream& out, bool per_row);

}  // namespace kincal::identify
