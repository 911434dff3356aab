// kincal — the command-line tool (GUIDE "Command-line contract"). Thin: parses
// arguments, delegates to identify/, and turns every failure into one line on
// stderr, `kincal: FILE:LINE:COL: message`, with a non-zero exit status.
//
// Exit status: 0 success; 1 bad input or a failed run; 2 usage errors and
// subcommands that are not implemented yet.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <iostream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "kincal/core/compensation.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/effect_calibration.hpp"
#include "kincal/identify/estimators.hpp"
#include "kincal/identify/files.hpp"
#include "kincal/identify/hybrid_calibration.hpp"
#include "kincal/identify/identifiability.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/joint_limits.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/robot.hpp"
#include "kincal/identify/pose_errors.hpp"
#include "kincal/identify/simulate.hpp"
#include "kincal/identify/stewart_calibration.hpp"
#include "kincal/identify/table_writer.hpp"
#include "kincal/identify/version.hpp"
#include "commands.hpp"

namespace ki = kincal::identify;

// Warnings are one line each, whatever strings from the input they quote.
void kincal_app::warn(const std::string& line) { std::cerr << ki::one_line(line) << "\n"; }

std::vector<std::string> kincal_app::robot_input(const std::string& robot) {
  return ki::is_builtin_robot(robot) ? std::vector<std::string>{} : std::vector<std::string>{robot};
}

namespace {
// The strict decimal syntax of decimal() / whole_number(): the whole string,
// one optional sign, no hex, finite.
bool strict_decimal(const std::string& v, double& out) {
  std::string_view s = v;
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty() || s.front() == '+' || (v.front() == '+' && s.front() == '-')) return false;
  for (const char c : s)
    if (!(std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == 'e' || c == 'E' || c == '-' || c == '+'))
      return false;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out, std::chars_format::general);
  return ec == std::errc() && ptr == s.data() + s.size() && std::isfinite(out);
}
}  // namespace

std::string kincal_app::number_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

CLI::Validator kincal_app::decimal(double lo, double hi, bool open_low) {
  const std::string range = std::string(open_low ? "(" : "[") + kincal_app::number_text(lo) + ", " +
                            (std::isfinite(hi) ? kincal_app::number_text(hi) + "]" : std::string("inf)"));
  return CLI::Validator(
      [lo, hi, open_low, range](std::string& v) {
        double x = 0;
        if (!strict_decimal(v, x)) return "must be a decimal number, not '" + v + "'";
        if (x < lo || (open_low && x == lo) || x > hi) return "must be in " + range + ", not " + v;
        return std::string();
      },
      "NUMBER in " + range);
}

CLI::Validator kincal_app::whole_number(long long lo) {
  return CLI::Validator(
      [lo](std::string& v) {
        long long x = 0;
        std::string_view s = v;
        if (!s.empty() && s.front() == '+') s.remove_prefix(1);
        const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
        if (s.empty() || ec != std::errc() || ptr != s.data() + s.size())
          return "must be a decimal integer, not '" + v + "'";
        if (x < lo) return "must be at least " + std::to_string(lo) + ", not " + v;
        return std::string();
      },
      "INT >= " + std::to_string(lo));
}

std::vector<double> kincal_app::number_list(const std::string& text, const std::string& option) {
  std::vector<double> out;
  std::stringstream in(text);
  for (std::string field; std::getline(in, field, ',');) {
    double x = 0;
    if (!strict_decimal(field, x))
      throw ki::InputError(option + ": '" + field + "' is not a finite decimal number (in '" + text + "')");
    out.push_back(x);
  }
  return out;
}

std::vector<Eigen::Vector3d> kincal_app::target_list(const std::string& text, const std::string& option) {
  std::vector<Eigen::Vector3d> out;
  std::stringstream in(text);
  for (std::string point; std::getline(in, point, ';');) {
    const std::vector<double> v = number_list(point, option);
    if (v.size() != 3) throw ki::InputError(option + ": a target is x,y,z in mm, not '" + point + "'");
    out.emplace_back(v[0], v[1], v[2]);
  }
  if (out.empty() || out.size() > 3) throw ki::InputError(option + ": give one to three targets, 'x,y,z;x,y,z'");
  return out;
}

std::vector<std::string> kincal_app::effect_list(const std::string& list) {
  std::vector<std::string> names;
  std::stringstream in(list);
  for (std::string name; std::getline(in, name, ',');) {
    if (name.empty()) continue;
    if (ki::find_effect(name) == nullptr)
      throw ki::InputError("--effects: unknown effect '" + name + "' (known: " + ki::effect_names() + ")");
    if (std::find(names.begin(), names.end(), name) != names.end())
      throw ki::InputError("--effects: '" + name + "' is named twice");
    names.push_back(name);
  }
  if (names.empty()) throw ki::InputError("--effects: no effect named in '" + list + "'");
  return names;
}

ki::PoseTable kincal_app::read_measurements(const ki::Robot& robot, const std::string& path, bool instrument_frame) {
  ki::PoseTableOptions options;
  options.joint_count = ki::Robot::joint_count();
  options.warn = warn;
  ki::PoseTable data = ki::read_pose_table(path, options);
  if (instrument_frame) {
    if (!data.has_targets)
      throw ki::InputError(path, 1, 0, "--instrument-frame needs target columns t1x.. (laser-tracker targets)");
    data.in_instrument_frame = true;
  }
  for (const std::string& w : ki::joint_limit_warnings(robot, data)) warn(w);
  return data;
}

void kincal_app::warn_correction_need(const ki::CalibrationModel& model, const ki::PoseTable& data) {
  const std::string w = ki::correction_need_warning(ki::correction_need(model, data));
  if (!w.empty()) warn(data.file + ": warning: " + w);
}

void kincal_app::warn_unevaluated(const std::string& file, const ki::PoseErrorReport& report) {
  for (const ki::UnevaluatedRow& r : report.unevaluated)
    warn(file + ":" + std::to_string(r.line) + ": warning: row '" + r.id + "': " + r.why +
         "; its residual is left out of the tables");
}

void kincal_app::print_outliers(const std::string& file, const ki::OutlierScreen& screen, std::size_t nodes, bool keep) {
  if (screen.flagged.empty()) {
    std::cout << "  outliers: none (deleted-node F test, p < " << screen.p_threshold << ")\n";
    return;
  }
  std::cout << "  nodes inconsistent with the others (set aside one at a time, most significant first):\n"
            << ki::describe_outliers(file, screen);
  if (screen.systematic)
    std::cout << "  still flagged after " << screen.flagged.size() << " of " << nodes
              << " nodes were set aside: the misfit is systematic (an unmodelled effect, or data without noise), "
                 "not a few bad nodes; no node is left out (kincal diagnose names the effect)\n";
  else if (screen.excluded)
    std::cout << "  the model is fitted without them (keep them with --keep-outliers)\n";
  else if (keep)
    std::cout << "  the model still uses every node (--keep-outliers)\n";
}

namespace {

constexpr int kExitError = 1;
constexpr int kExitUsage = 2;

using kincal_app::robot_input;
using kincal_app::warn;

struct SimulateArgs {
  std::string robot, poses, out, errors, targets, instrument_frame;
  std::vector<std::string> effects;
  double noise_mm = 0, noise_rad = 0;
  std::uint64_t seed = 1;
};


int run_simulate(const SimulateArgs& a) {
  std::vector<std::string> inputs = robot_input(a.robot);
  inputs.push_back(a.poses);
  inputs.push_back(a.errors);
  ki::check_outputs({a.out}, inputs);
  const ki::Robot nominal = ki::load_robot(a.robot);
  ki::ParameterSet errors;
  if (!a.errors.empty()) errors = ki::read_parameters(a.errors, nominal, warn);
  ki::EffectValues effects;
  for (const std::string& e : a.effects) {
    const ki::EffectSetting setting = ki::parse_effect_option(e);
    effects.set(nominal, setting.effect, setting.parameter, setting.value);
  }
  const ki::Robot actual = ki::apply_parameters(nominal, errors);

  ki::PoseTableOptions popt;
  popt.joint_count = ki::Robot::joint_count();
  popt.warn = warn;
  const ki::PoseTable poses = ki::read_pose_table(a.poses, popt);

  ki::SimulateOptions sopt;
  if (a.targets == "robot") {
    if (nominal.targets.empty())
      throw ki::InputError("--targets robot: the robot description has no `targets` (docs/formats.md)");
    sopt.targets = nominal.targets;
  } else if (!a.targets.empty()) {
    sopt.targets = kincal_app::target_list(a.targets, "--targets");
  }
  if (!a.instrument_frame.empty()) {
    const std::vector<double> v = kincal_app::number_list(a.instrument_frame, "--instrument-frame");
    if (v.size() != 6) throw ki::InputError("--instrument-frame: give x,y,z,rx,ry,rz (mm, rad)");
    sopt.instrument_frame = kincal::Pose<double>::from_xyz_rpy(Eigen::Map<const kincal::Vec6<double>>(v.data()));
  }
  sopt.noise_mm = a.noise_mm;
  sopt.noise_rad = a.noise_rad;
  sopt.seed = a.seed;
  sopt.effects = effects;
  ki::SimulateReport report;
  const ki::PoseTable out = ki::simulate(nominal, actual, poses, sopt, report, warn);
  if (report.simulated == 0 && !errors.values.empty()) {
    // The poses may be fine and the errors absurd: if the machine without
    // them reaches the poses, the fault is in PARAMS.csv, at its largest value.
    ki::SimulateReport without;
    ki::simulate(nominal, nominal, poses, sopt, without);
    if (without.simulated > 0) {
      const auto largest = std::max_element(errors.values.begin(), errors.values.end(), [](const auto& x, const auto& y) {
        return std::abs(x.value) < std::abs(y.value);
      });
      std::ostringstream value;
      value << largest->value;
      throw ki::InputError(errors.file, largest->line, 0,
                           "the machine these errors describe reaches none of the " + std::to_string(report.failed) +
                               " poses (the nominal machine reaches " + std::to_string(without.simulated) +
                               "); the largest error is " + largest->name + " = " + value.str());
    }
  }
  if (report.simulated == 0)
    throw ki::InputError(a.poses, 0, 0,
                         "no row could be simulated (" + std::to_string(report.failed) + " rows failed); nothing written");
  ki::write_pose_table_file(out, a.out, inputs);
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
  ki::write_output_file(out, ki::robot_to_json(robot), robot_input(name));
  return 0;
}

int run_errors(const std::string& data, const std::string& reference, bool per_row) {
  ki::PoseTableOptions options;
  options.warn = warn;
  const ki::PoseTable table = ki::read_pose_table(data, options);
  const ki::PoseErrorReport report =
      reference.empty() ? ki::pose_errors(table) : ki::pose_differences(table, ki::read_pose_table(reference, options));
  std::cout << (reference.empty() ? "pose error, measured - commanded: " + data
                                  : "pose difference, " + data + " - " + reference)
            << "\n";
  ki::print_pose_error_report(report, std::cout, per_row);
  return 0;
}

int run_compensate(const std::string& robot_name, const std::string& model_path, const std::string& poses_path,
                   const std::string& out_path) {
  std::vector<std::string> inputs = robot_input(robot_name);
  inputs.push_back(model_path);
  inputs.push_back(poses_path);
  ki::check_outputs({out_path}, inputs);
  const ki::Robot robot = ki::load_robot(robot_name);
  const ki::CalibrationModel model = ki::read_model_file(model_path);
  if (ki::robot_to_json(model.nominal) != ki::robot_to_json(robot)) {
    ki::Robot same_bound = robot;
    same_bound.max_correction = model.nominal.max_correction;
    if (ki::robot_to_json(model.nominal) == ki::robot_to_json(same_bound))
      throw ki::InputError(model_path, 0, 0,
                           "was identified with another 'max_correction' than " + robot_name +
                               " has; the model carries the bound into the table: identify again with " + robot_name);
    throw ki::InputError(model_path, 0, 0,
                         "was identified on robot '" + model.nominal.name + "', not on " + robot_name);
  }
  // The controller's own routine (core/compensation.hpp) on the table the
  // firmware gets from `kincal table`: 6-UPS IK of the calibrated geometry
  // (seed 001); hybrid: the pose corrected by the predicted error twist, then
  // the ideal IK with the identified encoder offsets (seed 000 Eq. (16));
  // then the joint-space effects and the bound / limit checks.
  ki::AnyCalibrationTable table;
  try {
    table = ki::calibration_table(model);
  } catch (const ki::InputError& e) {
    if (!e.file().empty()) throw;  // placed at the value at fault in MODEL.json
    throw ki::InputError(model_path, 0, 0, e.message());
  }
  ki::PoseTableOptions options;
  options.warn = warn;
  const ki::PoseTable poses = ki::read_pose_table(poses_path, options);
  ki::PoseTable out;
  out.file = out_path;
  out.has_q = true;
  out.has_layer = poses.has_layer;
  out.has_role = poses.has_role;
  // Covariates pass through, so the joints can be re-simulated on the machine
  // (temperature for thermal, time stamps) in the same file.
  out.has_temp = poses.has_temp;
  out.has_time = poses.has_time;
  // The controller's own routine on the table the firmware gets.
  ki::CompensatedStream stream;
  try {
    stream = ki::compensate_rows(table, model, poses);
  } catch (const ki::InputError& e) {
    throw ki::InputError(model_path, 0, 0, e.message());
  }
  if (!stream.home_ok)
    warn(model_path + ": warning: the home pose cannot be compensated; the stream starts from zero commands");
  std::size_t failed = 0;
  for (std::size_t k = 0; k < poses.rows.size(); ++k) {
    const ki::PoseRow& r = poses.rows[k];
    const ki::CompensatedRow& c = stream.rows[k];
    ki::PoseRow o;
    o.id = r.id;
    o.layer = r.layer;
    o.role = r.role;
    o.commanded = r.commanded;
    o.temp = r.temp;
    o.time = r.time;
    o.status = kincal::to_string(c.status);
    if (c.status == kincal::CompensationStatus::Ok) {
      o.q = Eigen::VectorXd(c.q);
    } else {
      ++failed;
      warn(poses_path + ":" + std::to_string(r.line) + ": warning: row '" + r.id + "': " +
           kincal::to_string(c.status) + "; written without joint commands");
    }
    out.rows.push_back(o);
  }
  out.has_status = failed > 0;
  if (failed == poses.rows.size()) throw ki::InputError(poses_path, 0, 0, "no pose could be compensated");
  ki::write_pose_table_file(out, out_path, inputs);
  return 0;
}

// The firmware's parameter table as a constexpr header (identify/table_writer.hpp).
int run_table(const std::string& model_path, const std::string& out_path) {
  ki::write_calibration_table_header(model_path, out_path);
  return 0;
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
  simulate->add_option("--effect", sim.effects,
                       "NAME:PARAM=VALUE, a physical effect of the actual machine (repeatable; e.g. scale:s1=1e-4, "
                       "thermal:c=1.2e-5; 'kincal effects' lists them)");
  simulate->add_option("--targets", sim.targets,
                       "measure laser-tracker targets instead of poses (6-UPS) or the gauge (hybrid): 'robot' (the "
                       "description's `targets`) or the true positions on the platform / tool 'x,y,z[;x,y,z[;x,y,z]]', "
                       "mm (columns t1x..)");
  simulate->add_option("--instrument-frame", sim.instrument_frame,
                       "with --targets: the robot base frame's pose in the instrument's frame, 'x,y,z,rx,ry,rz' (mm, "
                       "rad); the targets are written in the instrument frame");
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
                << "' (commands: simulate, robot, errors, identify, diagnose, compensate, table, effects, plan; run 'kincal --help')\n";
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
