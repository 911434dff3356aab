// kincal — the command-line tool (GUIDE "Command-line contract"). Thin: parses
// arguments, delegates to identify/, and turns every failure into one line on
// stderr, `kincal: FILE:LINE:COL: message`, with a non-zero exit status.
//
// Exit status: 0 success; 1 bad input or a failed run; 2 usage errors and
// subcommands that are not implemented yet.
#include <CLI/CLI.hpp>
#include <charconv>
#include <cstdint>
#include <exception>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/robot.hpp"
#include "kincal/identify/pose_errors.hpp"
#include "kincal/identify/simulate.hpp"
#include "kincal/identify/version.hpp"

namespace ki = kincal::identify;

namespace {

constexpr int kExitError = 1;
constexpr int kExitUsage = 2;

void warn(const std::string& line) { std::cerr << line << "\n"; }

struct SimulateArgs {
  std::string robot, poses, out, errors;
  std::vector<std::string> effects;
  double noise_mm = 0, noise_rad = 0;
  std::uint64_t seed = 1;
};

int run_simulate(const SimulateArgs& a) {
  const ki::Robot nominal = ki::load_robot(a.robot);
  ki::ParameterSet errors;
  if (!a.errors.empty()) errors = ki::read_parameters(a.errors, nominal, warn);
  std::vector<ki::EffectSetting> effects;
  for (const std::string& e : a.effects) effects.push_back(ki::parse_effect_option(e));
  ki::check_effects_available(effects);
  const ki::Robot actual = ki::apply_parameters(nominal, errors);

  ki::PoseTableOptions popt;
  popt.joint_count = ki::Robot::joint_count();
  popt.warn = warn;
  const ki::PoseTable poses = ki::read_pose_table(a.poses, popt);

  ki::SimulateOptions sopt;
  sopt.noise_mm = a.noise_mm;
  sopt.noise_rad = a.noise_rad;
  sopt.seed = a.seed;
  ki::SimulateReport report;
  const ki::PoseTable out = ki::simulate(nominal, actual, poses, sopt, report, warn);
  if (report.simulated == 0)
    throw ki::InputError(a.poses, 0, 0,
                         "no row could be simulated (" + std::to_string(report.failed) + " rows failed); nothing written");
  ki::write_pose_table_file(out, a.out);
  return 0;
}

int run_robot(const std::string& name, const std::string& out, bool list_params) {
  const ki::Robot robot = ki::load_robot(name);
  if (list_params) {
    for (const ki::ParameterSpec& s : ki::parameter_specs(robot))
      std::cout << s.name << "\t" << s.unit << "\t" << s.description << "\n";
    return 0;
  }
  if (out.empty()) {
    std::cout << ki::robot_summary(robot);
    return 0;
  }
  std::ofstream f(out, std::ios::binary);
  if (!f) throw ki::InputError(out, 0, 0, "cannot open for writing");
  f << ki::robot_to_json(robot);
  f.flush();
  if (!f) throw ki::InputError(out, 0, 0, "write error");
  return 0;
}

int run_errors(const std::string& data, const std::string& reference, bool per_row) {
  ki::PoseTableOptions options;
  options.warn = [](const std::string& w) { std::cerr << w << "\n"; };
  const ki::PoseTable table = ki::read_pose_table(data, options);
  const ki::PoseErrorReport report =
      reference.empty() ? ki::pose_errors(table) : ki::pose_differences(table, ki::read_pose_table(reference, options));
  std::cout << (reference.empty() ? "pose error, measured - commanded: " + data
                                  : "pose difference, " + data + " - " + reference)
            << "\n";
  ki::print_pose_error_report(report, std::cout, per_row);
  return 0;
}

int not_implemented(const std::string& command, const std::string& issue) {
  std::cerr << "kincal: " << command << ": not implemented yet (" << issue << ")\n";
  return kExitUsage;
}

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
  simulate->add_option("--effect", sim.effects, "NAME:PARAM=VALUE (effects library: later issue)");
  simulate->add_option("--noise-mm", sim.noise_mm, "sigma of Gaussian noise on positions, mm (default 0)");
  simulate->add_option("--noise-rad", sim.noise_rad, "sigma of Gaussian noise on angles, rad (default 0)");
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

  // Registered with their GUIDE options so scripts fail loudly and usefully.
  std::string s1, s2, s3, s4, s5, s6;
  CLI::App* identify = app.add_subcommand("identify", "identify model parameters (not implemented yet)");
  identify->add_option("--robot", s1)->required();
  identify->add_option("--data", s2)->required();
  identify->add_option("--out", s3)->required();
  identify->add_option("--estimator", s4)->check(CLI::IsMember({"ols", "ridge", "liu", "pcr"}));
  identify->add_option("--effects", s5);
  identify->add_option("--json", s6);
  CLI::App* diagnose = app.add_subcommand("diagnose", "diagnose residuals (not implemented yet)");
  diagnose->add_option("--robot", s1)->required();
  diagnose->add_option("--data", s2)->required();
  diagnose->add_option("--json", s3)->required();
  diagnose->add_option("--report", s4);
  CLI::App* compensate = app.add_subcommand("compensate", "compensate a pose stream (not implemented yet)");
  compensate->add_option("--robot", s1)->required();
  compensate->add_option("--model", s2)->required();
  compensate->add_option("--poses", s3)->required();
  compensate->add_option("--out", s4)->required();
  CLI::App* table = app.add_subcommand("table", "generate a calibration table header (not implemented yet)");
  table->add_option("--model", s1)->required();
  table->add_option("--out", s2)->required();

  if (argc > 1 && argv[1][0] != '-') {
    const std::string first = argv[1];
    bool known = false;
    for (const CLI::App* sub : app.get_subcommands({})) known = known || sub->get_name() == first;
    if (!known) {
      std::cerr << "kincal: unknown command '" << first
                << "' (commands: simulate, robot, errors, identify, diagnose, compensate, table; run 'kincal --help')\n";
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
    std::cerr << "kincal: " << e.what() << " (run 'kincal --help')\n";
    return kExitUsage;
  }

  if (*simulate) return run_simulate(sim);
  if (*robot) return run_robot(robot_name, robot_out, list_params);
  if (*errors) return run_errors(errors_data, errors_reference, errors_rows);
  if (*identify) return not_implemented("identify", "issue #3: identification pipelines and estimators");
  if (*diagnose) return not_implemented("diagnose", "issue #4: residual diagnosis and the physical-effect library");
  if (*compensate) return not_implemented("compensate", "issues #3 and #5: compensation of the NC pose stream");
  if (*table) return not_implemented("table", "issue #5: generated calibration tables for the firmware");
  return kExitUsage;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const ki::InputError& e) {
    std::cerr << "kincal: " << e.what() << "\n";
  } catch (const std::exception& e) {
    std::cerr << "kincal: internal error: " << e.what() << "\n";
  } catch (...) {
    std::cerr << "kincal: internal error (unknown exception)\n";
  }
  return kExitError;
}
