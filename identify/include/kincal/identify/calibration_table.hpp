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
#include <variant>

#include "kincal/core/calibration_table.hpp"
#include "kincal/core/pose.hpp"
#include "kincal/identify/model.hpp"

namespace kincal::identify {

struct CalibrationTableOptions {
  // Largest |command − nominal IK| per joint (mm, rad); default: core's
  // default_bounds (5 mm prismatic, 0.02 rad revolute).
  std::optional<Vec6<double>> max_correction;
};

using AnyCalibrationTable = std::variant<StewartCalibrationTable<double>, HybridCalibrationTable<double>>;

// Sealed (CRC set) tables that pass validate_table. Throw InputError for a
// model of the other family, a model the compensation cannot use (unknown
// parameter, non-finite value), or a table that fails validate_table (naming
// the status, e.g. an encoder offset above its correction bound).
StewartCalibrationTable<double> stewart_calibration_table(const CalibrationModel& model,
                                                          const CalibrationTableOptions& options = {});
HybridCalibrationTable<double> hybrid_calibration_table(const CalibrationModel& model,
                                                        const CalibrationTableOptions& options = {});
AnyCalibrationTable calibration_table(const CalibrationModel& model, const CalibrationTableOptions& options = {});

}  // namespace kincal::identify
