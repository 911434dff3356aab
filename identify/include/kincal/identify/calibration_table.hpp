// The controller's parameter table (core/calibration_table.hpp) from an
// identified model (MODEL.json): what `kincal compensate` runs on the host and
// what `kincal table` writes into the firmware's generated header, so host and
// firmware compensate with one routine (core/compensation.hpp) on the same
// numbers.
//
//   6-UPS: nominal geometry and calibrated_robot(model)'s geometry (seed 001).
//   hybrid: hybrid_compensation_from_model(model): the total encoder offsets ξ̂
//     and the structural Δχ̂ of seed 000 Eq. (16), e = HybridErrorModelOptions's
//     up_split.
//   both: model.effects.to_core(nominal) and the bounds (core's default_bounds
//     unless given).
#pragma once

#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "kincal/core/calibration_table.hpp"
#include "kincal/core/machine_limits.hpp"
#include "kincal/core/pose.hpp"
#include "kincal/core/rus6_machine.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/model.hpp"

namespace kincal::identify {

struct CalibrationTableOptions {
  // Largest |command − nominal IK| per joint (mm, rad); default: the robot
  // description's `max_correction`, else core's default_bounds (5 mm
  // prismatic, 0.02 rad revolute).
  std::optional<Vec6<double>> max_correction;
};

// One alternative per family (its machine type's table): the registry line
// of this layer.
using AnyCalibrationTable =
    std::variant<StewartCalibrationTable<double>, HybridCalibrationTable<double>, Rus6CalibrationTable<double>>;

// The machine limits of a robot description (core/machine_limits.hpp): its
// stroke / joint limits as the drives' range, the correction bound (options,
// else the description's `max_correction`, else core's default_bounds) and
// the caps (the description's `max_geometry_error`, `max_angle_error`,
// `max_scale`, `max_thermal`, else core's DefaultLimitCaps). From the NOMINAL
// robot only, never from identified values: what the firmware checks a table
// against.
MachineLimits<double> machine_limits(const Robot& robot, const CalibrationTableOptions& options = {});

// Why a table is outside the limits, naming the first offending value, its
// bound and the robot description key that sets the bound
// ("machine.source_errors[37] = 0.15 rad above max_angle_error 0.1 (robot
// description key 'max_angle_error')"), or "" if validate_table(table,
// limits) is Ok or fails for another reason.
std::string limit_violation(const Robot& robot, const AnyCalibrationTable& table, const MachineLimits<double>& limits);

// Sealed (CRC set) tables that pass validate_table against machine_limits of
// the model's robot. Throw InputError for a
// model of the other family, a model the compensation cannot use (unknown
// parameter, non-finite value), or a table that fails validate_table (naming
// the status, e.g. an encoder offset above its correction bound).
StewartCalibrationTable<double> stewart_calibration_table(const CalibrationModel& model,
                                                          const CalibrationTableOptions& options = {});
HybridCalibrationTable<double> hybrid_calibration_table(const CalibrationModel& model,
                                                        const CalibrationTableOptions& options = {});
AnyCalibrationTable calibration_table(const CalibrationModel& model, const CalibrationTableOptions& options = {});

// The controller's routine run over a pose file as the firmware runs an NC
// stream: Compensator(table, machine_limits(model.nominal, options)) from the
// home command (approach directions +1),
// each row's pose with its temperature and approach directions where given.
// One status and command per row (q valid where the status is Ok).
struct CompensatedRow {
  CompensationStatus status = CompensationStatus::Ok;
  Vec6<double> q = Vec6<double>::Zero();
};
struct CompensatedStream {
  bool home_ok = false;  // false: the home pose could not be compensated; the stream started from zero commands
  std::vector<CompensatedRow> rows;
};
// Throws InputError if the table is refused by the Compensator (its status named).
CompensatedStream compensate_rows(const AnyCalibrationTable& table, const CalibrationModel& model,
                                  const PoseTable& poses, const CalibrationTableOptions& options = {});

// What an identified model asks of the correction bound (issue #11 item 3):
// per joint, the largest |compensated command − nominal IK| over the poses
// (rows the compensation cannot serve for another reason, such as the stroke,
// are left out), next to the bound the table would carry.
struct CorrectionNeed {
  Vec6<double> largest = Vec6<double>::Zero();
  Vec6<double> bound = Vec6<double>::Zero();
  std::size_t poses = 0;  // rows that entered `largest`
  std::string problem;    // the table could not be built even with the bound open (why)
  bool exceeds() const { return (largest.array() > bound.array()).any(); }
};
CorrectionNeed correction_need(const CalibrationModel& model, const PoseTable& poses);
// "" when the need is within the bound; else one line naming the joints, by
// how much, and the robot description key that raises the bound.
std::string correction_need_warning(const CorrectionNeed& need);

// "" when `compensate` and `table` accept the model on its robot description
// (model.nominal) and its corrections on `poses` fit the correction bound;
// else one line naming the value, the bound and the robot description key
// that raises it (issue #31): the table check's refusal (limit_violation:
// max_geometry_error, max_angle_error, max_scale, max_thermal,
// max_correction) first — followed by the correction need when the bound
// alone refuses it — else the correction need (correction_need_warning).
std::string table_refusal_warning(const CalibrationModel& model, const PoseTable& poses);

}  // namespace kincal::identify
