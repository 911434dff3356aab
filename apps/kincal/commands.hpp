// Subcommands that live in their own files (one file per larger command, so
// main.cpp stays a table of contents). Each returns the process exit status
// and throws identify::InputError for bad input (main prints it as one line).
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>

#include "kincal/identify/robot.hpp"

namespace kincal_app {

struct DiagnoseArgs {
  std::string robot, data, json, report, effects;
  std::optional<double> noise_um;
  double alpha = 0.01;
  bool quiet = false;
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

// `kincal identify --effects e1,e2`: base model and effects together
// (identify/effect_calibration.hpp).
int run_identify_with_effects(const kincal::identify::Robot& robot, const std::string& data, const std::string& out,
                              const std::string& effects, const std::string& estimator, const std::string& json,
                              double effect_alpha, double ridge_k);

}  // namespace kincal_app
