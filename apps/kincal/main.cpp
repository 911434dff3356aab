// kincal — the command-line tool (GUIDE "Command-line contract"). Thin: the
// command line alone. It parses arguments, delegates to the subcommands
// (commands.hpp, one file each), and turns every failure into one line on
// stderr, `kincal: FILE:LINE:COL: message`, with a non-zero exit status.
//
// Exit status: 0 success; 1 bad input or a failed run; 2 usage errors and
// subcommands that are not implemented yet.
#include <CLI/CLI.hpp>
#include <charconv>
#include <cstdint>
#include <exception>
#include <iostream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "kincal/identify/input_error.hpp"
#include "kincal/identify/version.hpp"
#include "commands.hpp"

namespace ki = kincal::identify;

namespace {

constexpr int kExitError = 1;
constexpr int kExitUsage = 2;

using namespace kincal_app;

int run(int argc, char** argv) {
  CLI::App app{"kincal: kinematic calibration of parallel and hybrid machines"};
  app.set_version_flag("--version", std::string("kincal ") + ki::kVersion);
  app.require_subcommand(1);

  SimulateArgs sim;
  CLI::App* simulate = app.add_subcommand("simulate", "simulate measurements of an erroneous machine");
  simulate->add_option("--robot", sim.robot, "built-in robot name or robot description file")->required();
  simulate->add_option("--poses", sim.poses, "commanded poses CSV")->required();
  simulate->add_option("--out", sim.out, "measurement CSV to write")->required();
  simulate->add_option("--errors", sim.errors, "parameter errors CSV (name,value)");
  simulate->add_option("--effect", sim.effects,
                       "NAME:PARAM=VALUE[,PARAM=VALUE...], a physical effect of the actual machine (repeatable; e.g. "
                       "scale:s1=1e-4,s2=-5e-5, thermal:c=1.2e-5; 'kincal effects' lists them)");
  simulate->add_option("--targets", sim.targets,
                       "measure laser-tracker targets instead of poses (6-UPS) or the gauge (hybrid): 'robot' (the "
                       "description's `targets`) or the true positions on the platform / tool 'x,y,z[;x,y,z[;x,y,z]]', "
                       "mm (columns t1x..)");
  simulate->add_option("--instrument-frame", sim.instrument_frame,
                       "with --targets: the robot base frame's pose in the instrument's frame, 'x,y,z,rx,ry,rz' (mm, "
                       "rad); the targets are written in the instrument frame");
  simulate->add_flag("--pose-only", sim.pose_only,
                     "write the measured poses alone (mx..mrz), without the hybrid's gauge targets: a 6-DOF instrument "
                     "(identify and diagnose then read the poses)");
  simulate->add_option("--noise-mm", sim.noise_mm, "sigma of Gaussian noise on positions, mm (default 0)")
      ->check(kincal_app::decimal(0, HUGE_VAL));
  simulate->add_option("--noise-rad", sim.noise_rad, "sigma of Gaussian noise on angles, rad (default 0)")
      ->check(kincal_app::decimal(0, HUGE_VAL));
  simulate->add_option("--seed", sim.seed, "noise seed (std::mt19937_64, default 1)")
      ->check(CLI::Validator(
          [](std::string& v) {
            std::uint64_t x = 0;
            const auto [ptr, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
            return !v.empty() && ec == std::errc() && ptr == v.data() + v.size()
                       ? std::string()
                       : std::string("must be an integer in [0, 2^64), not '" + v + "'");
          },
          "UINT"));

  std::string robot_name, robot_out;
  bool list_params = false;
  CLI::App* robot = app.add_subcommand("robot", "print a robot summary, or write its description file");
  robot->add_option("--robot", robot_name, "built-in robot name or robot description file")->required();
  robot->add_option("--out", robot_out, "write the robot description (JSON) here");
  robot->add_flag("--params", list_params, "list the parameter-error names of --errors for this robot");

  std::string errors_data, errors_reference;
  bool errors_rows = false;
  CLI::App* errors = app.add_subcommand(
      "errors", "pose errors of a measurement file (measured - commanded), or its difference from a reference file");
  errors->add_option("--data", errors_data, "measurement CSV")->required();
  errors->add_option("--reference", errors_reference, "compare measured poses with this file's, matched by id");
  errors->add_flag("--rows", errors_rows, "print every row, not only the summary");

  kincal_app::IdentifyArgs ident;
  CLI::App* identify = app.add_subcommand("identify", "identify model parameters from measurements");
  identify->add_option("--robot", ident.robot, "built-in robot name or robot description file")->required();
  identify->add_option("--data", ident.data, "measurement CSV")->required();
  identify->add_option("--out", ident.out, "MODEL.json to write")->required();
  identify->add_option("--estimator", ident.estimator, "6-UPS: ols (default), ridge, pcr. Hybrid: by default seed 000's estimate finished by Gauss-Newton with a ridge base, k by GCV at the solution; liu, ols, ridge, pcr: seed 000's fine stage with that estimator as it is. With --effects: the 6-UPS ols; the hybrid the default base, ols, or ridge with --ridge-k")
      ->check(CLI::IsMember({"ols", "ridge", "liu", "pcr"}));
  identify->add_option("--ridge-k", ident.ridge_k,
                       "ridge's k: gcv (generalized cross-validation, default), hkb (Hoerl-Kennard-Baldwin) or a "
                       "number >= 0")
      ->check(CLI::Validator(
          [](std::string& v) {
            if (v == "gcv" || v == "hkb") return std::string();
            double k = 0;
            return strict_decimal(v, k) && k >= 0 ? std::string()
                                                   : std::string("must be gcv, hkb or a number >= 0, not '" + v + "'");
          },
          "K"));
  identify->add_option("--pcr-components", ident.pcr_components,
                       "PCR: number of principal components kept (default: by generalized cross-validation)")
      ->check(kincal_app::whole_number(1));
  identify->add_option("--coarse-layers", ident.coarse_layers,
                       "hybrid: layers whose rows run the coarse stage, e.g. 2 (seed 000 Sec. 5: the middle layer); "
                       "default: the cal rows")
      ->delimiter(',')
      ->check(kincal_app::whole_number(std::numeric_limits<long long>::min()));
  identify->add_option("--effects", ident.effects, "effects to include, e.g. scale,thermal ('kincal effects' lists them)");
  identify->add_option("--effect-alpha", ident.effect_alpha,
                       "with --effects: an effect parameter not significant at this family-wise level (t test in the "
                       "joint fit, Bonferroni) is held at 0 and the fit repeated; 0 keeps every parameter (default 0.01)")
      ->check(kincal_app::decimal(0.0, 1.0));
  identify->add_option("--json", ident.json, "SUMMARY.json to write");
  identify->add_flag("--instrument-frame", ident.instrument_frame,
                     "target columns t1x.. (the robot's `targets`): measured in the instrument's own frame; its "
                     "registration is identified with the model (docs/identify.md)");
  identify->add_flag("--keep-outliers", ident.keep_outliers,
                     "fit every node, also those found inconsistent with the others (default: they are listed and "
                     "left out, unless the misfit is systematic)");

  std::string comp_robot, comp_model, comp_poses, comp_out;
  CLI::App* compensate = app.add_subcommand("compensate", "turn requested poses into compensated joint commands");
  compensate->add_option("--robot", comp_robot, "built-in robot name or robot description file")->required();
  compensate->add_option("--model", comp_model, "MODEL.json from kincal identify")->required();
  compensate->add_option("--poses", comp_poses, "requested poses CSV")->required();
  compensate->add_option("--out", comp_out, "JOINTS.csv to write (id, x..rz, q1..q6)")->required();

  kincal_app::DiagnoseArgs diag;
  CLI::App* diagnose = kincal_app::add_diagnose_command(app, diag);
  kincal_app::EffectsArgs effects_args;
  CLI::App* effects = kincal_app::add_effects_command(app, effects_args);
  kincal_app::PlanArgs plan_args;
  CLI::App* plan = kincal_app::add_plan_command(app, plan_args);

  kincal_app::ExportArgs export_args;
  CLI::App* export_linuxcnc = kincal_app::add_export_command(app, export_args);

  std::string table_model, table_out;
  CLI::App* table = app.add_subcommand(
      "table", "write a model's calibration table as a constexpr C++ header for the firmware (docs/firmware.md)");
  table->add_option("--model", table_model, "MODEL.json from kincal identify")->required();
  table->add_option("--out", table_out, "header to write (e.g. calibration_table.hpp)")->required();

  if (argc > 1 && argv[1][0] != '-') {
    const std::string first = argv[1];
    bool known = false;
    for (const CLI::App* sub : app.get_subcommands({})) known = known || sub->get_name() == first;
    if (!known) {
      std::cerr << "kincal: unknown command '" << first
                << "' (commands: simulate, robot, errors, identify, diagnose, compensate, table, effects, plan, export; run 'kincal --help')\n";
      return kExitUsage;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "kincal: " << ki::one_line(e.what()) << " (run 'kincal --help')\n";
    return kExitUsage;
  }

  if (*simulate) return run_simulate(sim);
  if (*robot) return run_robot(robot_name, robot_out, list_params);
  if (*errors) return run_errors(errors_data, errors_reference, errors_rows);
  if (*identify) return kincal_app::run_identify(ident);
  if (*diagnose) return kincal_app::run_diagnose(diag);
  if (*compensate) return run_compensate(comp_robot, comp_model, comp_poses, comp_out);
  if (*table) return run_table(table_model, table_out);
  if (*effects) return kincal_app::run_effects(effects_args);
  if (*plan) return kincal_app::run_plan(plan_args);
  if (*export_linuxcnc) return kincal_app::run_export(export_args);
  if (*export_linuxcnc->get_parent()) {
    std::cerr << "kincal: export: name the controller to export to: 'kincal export linuxcnc --model MODEL.json "
                 "--out DIR' (run 'kincal export linuxcnc --help')\n";
    return kExitUsage;
  }
  return kExitUsage;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const ki::InputError& e) {
    std::cerr << "kincal: " << e.what() << "\n";
  } catch (const std::exception& e) {
    std::cerr << "kincal: internal error: " << ki::one_line(e.what()) << "\n";
  } catch (...) {
    std::cerr << "kincal: internal error (unknown exception)\n";
  }
  return kExitError;
}
