// Subcommands that live in their own files (one file per larger command, so
// main.cpp stays a table of contents). Each returns the process exit status
// and throws identify::InputError for bad input (main prints it as one line).
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>

namespace kincal_app {

struct DiagnoseArgs {
  std::string robot, data, json, report, effects;
  std::optional<double> noise_um;
  double alpha = 0.01;
  bool quiet = false;
};
CLI::App* add_diagnose_command(CLI::App& app, DiagnoseArgs& args);
int run_diagnose(const DiagnoseArgs& args);

}  // namespace kincal_app
