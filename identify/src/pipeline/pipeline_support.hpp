// What the identification pipelines share (private to identify/): the
// warnings a pipeline leaves for the user's terminal, in the order it meets
// them (identify.hpp, Identification::warnings).
#pragma once

#include <string>

#include "kincal/identify/identify.hpp"

namespace kincal::identify::detail {

// The table `compensate` / `table` would refuse for `model` (its check
// against every bound of the robot description), if it would.
void add_table_warning(Identification& out, const CalibrationModel& model, const PoseTable& data);
// One line per row of `report` whose residual could not be evaluated.
void add_unevaluated_warnings(Identification& out, const std::string& file, const PoseErrorReport& report);
// A number as a stream prints it by default ("0.001", "1e-08").
std::string number_text(double v);

}  // namespace kincal::identify::detail
