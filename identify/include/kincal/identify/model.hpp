// MODEL.json: an identified calibration model (GUIDE "Command-line contract",
// `kincal identify --out MODEL.json`). It carries the nominal robot it was
// identified on, the parameter errors with their standard errors, which of them
// were identifiable, and the estimator with its settings — everything
// `kincal compensate` and `kincal table` need, so a model file stands alone.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "kincal/identify/effects.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal::identify {

struct ModelParameter {
  std::string name;         // as in PARAMS.csv (e.g. dXB1)
  double value = 0;         // identified error, added to the nominal quantity
  double standard_error = 0;  // 0 when not available
  bool identifiable = true;   // false: held at 0 (not estimable from the data)
};

struct CalibrationModel {
  Robot nominal;
  std::vector<ModelParameter> parameters;
  std::string estimator;                     // "ols", "liu", ...
  std::map<std::string, double> settings;    // estimator settings (e.g. liu_d)
  std::string data_file;                     // the measurement file it came from
  // Identified physical effects (identify/effects.hpp), "effects" in the
  // JSON; `effects.to_core(nominal)` is what the controller corrects.
  EffectValues effects;
  // The laser tracker the model was identified with (stewart_target_calibration.hpp),
  // "instrument" in the JSON: reg_x .. reg_rz (the base frame's pose in the
  // instrument frame; `identifiable` false when it was given, not identified)
  // and t1x .. t3z (the targets' positions on the platform). Empty for a
  // model from full poses or the gauge.
  std::vector<ModelParameter> instrument;
  // Where each value stood in the MODEL.json it was read from (parse_model;
  // empty for a model made in memory), keyed by parameter name ("dXB1") or
  // "effect:parameter" ("scale:s2"): a fault found later, such as a table
  // that fails its machine-limit check (calibration_table.hpp), names the
  // file, line and column of the value that causes it.
  std::string source_file;
  std::map<std::string, TextPosition> value_positions;
};

// nominal + identified errors (the machine as the model believes it is).
Robot calibrated_robot(const CalibrationModel& model);

std::string model_to_json(const CalibrationModel& model);
// Written atomically (files.hpp); refused if `path` is one of `inputs`.
void write_model_file(const CalibrationModel& model, const std::string& path, const std::vector<std::string>& inputs = {});
// Throws InputError with file:line:column on malformed JSON, a missing key,
// an unknown parameter name for the robot, or a non-finite value.
CalibrationModel parse_model(const std::string& text, const std::string& file);
CalibrationModel read_model_file(const std::string& path);
// reg_x .. reg_rz and t1x .. t3z.
bool is_instrument_parameter(const std::string& name);

}  // namespace kincal::identify
