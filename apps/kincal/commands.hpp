// The subcommands, one file each (`*_command.cpp`; cli_support.cpp holds what
// they share), so main.cpp is the command line alone: parse, delegate, print
// a failure. Each returns the process exit status
// and throws identify::InputError for bad input (main prints it as one line).
#pragma once

#include <CLI/CLI.hpp>
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/pose_errors.hpp"
#include "kincal/identify/outliers.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal_app {

// Option values as a user means them (issue #10 item 10): a decimal number
// (optional sign, digits, point, exponent — no hex, no "", no NaN/Inf) in
// [lo, hi] (lo excluded if `open_low`), or a decimal integer ≥ lo.
CLI::Validator decimal(double lo, double hi, bool open_low = false);
// The strict decimal syntax of decimal() / whole_number(): the whole string,
// one optional sign, no hex, finite.
bool strict_decimal(const std::string& text, double& out);
CLI::Validator whole_number(long long lo);
// An effect list (`--effects a,b`): known effects, each once.
std::vector<std::string> effect_list(const kincal::identify::Robot& robot, const std::string& list);

// One warning on stderr, on one line whatever strings from the input it quotes.
void warn(const std::string& line);

// The files a command reads (a robot description unless built in): an output
// must be none of them (files.hpp).
std::vector<std::string> robot_input(const std::string& robot);
// "a,b,c": finite decimal numbers (InputError naming `option` otherwise).
std::vector<double> number_list(const std::string& text, const std::string& option);
// "x,y,z[;x,y,z[;x,y,z]]": one to three points, mm.
std::vector<Eigen::Vector3d> target_list(const std::string& text, const std::string& option);
// A number as `std::ostream <<` writes it (messages).
std::string number_text(double v);

// `kincal simulate` (simulate_command.cpp): measurements of an erroneous
// machine (identify/simulate.hpp).
struct SimulateArgs {
  std::string robot, poses, out, errors, targets, instrument_frame;
  std::vector<std::string> effects;
  double noise_mm = 0, noise_rad = 0;
  std::uint64_t seed = 1;
  bool pose_only = false;
};
int run_simulate(const SimulateArgs& args);

// `kincal robot` and `kincal errors` (robot_command.cpp).
int run_robot(const std::string& name, const std::string& out, bool list_params);
int run_errors(const std::string& data, const std::string& reference, bool per_row);

// `kincal compensate` and `kincal table` (compensate_command.cpp).
int run_compensate(const std::string& robot_name, const std::string& model_path, const std::string& poses_path,
                   const std::string& out_path);
int run_table(const std::string& model_path, const std::string& out_path);

// `kincal identify` (identify_command.cpp): the base model by the family's
// pipeline (6-UPS: seed 001's iterated LS; hybrid: seed 000's coarse + fine
// stages finished by the joint fit), the outlier screen, identifiability,
// MODEL.json and SUMMARY.json; with --effects, run_identify_with_effects.
struct IdentifyArgs {
  std::string robot, data, out, estimator, effects, json;  // estimator "": ols (6-UPS) / the default base (hybrid)
  bool keep_outliers = false;
  bool instrument_frame = false;          // 6-UPS targets: measured in the instrument's frame
  std::string ridge_k;                    // "" or "gcv" (default), "hkb", or a number >= 0
  Eigen::Index pcr_components = 0;        // 0: by GCV
  std::vector<long long> coarse_layers;   // hybrid: the coarse stage's layers (default: the cal rows)
  double effect_alpha = 0.01;             // --effects: significance for holding effect parameters at 0
};
int run_identify(const IdentifyArgs& args);

// A measurement file for identify / diagnose, with its warnings, and one
// warning per row and joint outside the robot file's limits (the rows are
// used: identify/joint_limits.hpp).
// `instrument_frame` (--instrument-frame): the table's targets are in the
// instrument's frame (PoseTable::in_instrument_frame); refused for a table
// without targets and for the hybrid.
kincal::identify::PoseTable read_measurements(const kincal::identify::Robot& robot, const std::string& path,
                                              bool instrument_frame = false);

// Warns (one line) when `compensate` or `table` would refuse the identified
// model (issue #31: the table check against every bound of the robot
// description) or it needs corrections above the robot's correction bound on
// the measured poses (issue #11 item 3), naming the value, the bound and the
// robot description key that raises it. The model is written all the same.
void warn_table_refusal(const kincal::identify::CalibrationModel& model, const kincal::identify::PoseTable& data);

// The outlier screen (identify/outliers.hpp) as every command reports it:
// the flagged nodes with file line and statistic, and what was done with
// them (the JSON fields: identify::add_outlier_fields).
void print_outliers(const std::string& file, const kincal::identify::OutlierScreen& screen, std::size_t nodes,
                    bool keep);

struct DiagnoseArgs {
  std::string robot, data, json, report, effects;
  std::optional<double> noise_um, noise_urad;
  double alpha = 0.01;
  bool quiet = false, keep_outliers = false, instrument_frame = false;
};
CLI::App* add_diagnose_command(CLI::App& app, DiagnoseArgs& args);
int run_diagnose(const DiagnoseArgs& args);

// `kincal effects`: the registered effects, their parameters and inputs.
struct EffectsArgs {
  std::string robot;
  bool json = false;
};
CLI::App* add_effects_command(CLI::App& app, EffectsArgs& args);
int run_effects(const EffectsArgs& args);

// `kincal plan`: which poses to measure (identify/plan.hpp).
struct PlanArgs {
  std::string robot, out, effects, measure, candidates, json, grid_out;
  std::size_t count = 0, samples = 5000, test = 0;
  std::uint64_t seed = 1;
  double noise_um = 5.0, noise_urad = 0, margin = 0.05;
  bool quiet = false;
};
CLI::App* add_plan_command(CLI::App& app, PlanArgs& args);
int run_plan(const PlanArgs& args);

// `kincal identify --effects e1,e2`: base model and effects together
// (identify/effect_calibration.hpp).
int run_identify_with_effects(const kincal::identify::Robot& robot, const std::string& data, const std::string& out,
                              const std::string& effects, const std::string& estimator, const std::string& json,
                              double effect_alpha, double ridge_k, bool keep_outliers, bool instrument_frame);

// `kincal export linuxcnc` (export_command.cpp): the files a LinuxCNC
// hexapod needs (identify/linuxcnc_export.hpp).
struct ExportArgs {
  std::string model, out, data, units = "mm", home_offsets;
  double tolerance_um = 0.1;
  bool force = false;
};
CLI::App* add_export_command(CLI::App& app, ExportArgs& args);
int run_export(const ExportArgs& args);

}  // namespace kincal_app
