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
std::string number_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}
}  // namespace

CLI::Validator kincal_app::decimal(double lo, double hi, bool open_low) {
  const std::string range = std::string(open_low ? "(" : "[") + number_text(lo) + ", " +
                            (std::isfinite(hi) ? number_text(hi) + "]" : std::string("inf)"));
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

ki::PoseTable kincal_app::read_measurements(const ki::Robot& robot, const std::string& path) {
  ki::PoseTableOptions options;
  options.joint_count = ki::Robot::joint_count();
  options.warn = warn;
  ki::PoseTable data = ki::read_pose_table(path, options);
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

using kincal_app::warn;

struct SimulateArgs {
  std::string robot, poses, out, errors;
  std::vector<std::string> effects;
  double noise_mm = 0, noise_rad = 0;
  std::uint64_t seed = 1;
};

// The files a command reads: an output must be none of them (files.hpp).
std::vector<std::string> robot_input(const std::string& robot) {
  return ki::is_builtin_robot(robot) ? std::vector<std::string>{} : std::vector<std::string>{robot};
}

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

struct IdentifyArgs {
  std::string robot, data, out, estimator, effects, json;  // estimator "": ols (6-UPS) / the default base (hybrid)
  bool keep_outliers = false;
  std::string ridge_k;                    // "" or "gcv" (default), "hkb", or a number >= 0
  Eigen::Index pcr_components = 0;        // 0: by GCV
  std::vector<long long> coarse_layers;   // hybrid: the coarse stage's layers (default: the cal rows)
  double effect_alpha = 0.01;             // --effects: significance for holding effect parameters at 0
};

// --estimator with --ridge-k / --pcr-components as library options.
ki::EstimatorOptions estimator_options(const IdentifyArgs& a, const std::string& estimator) {
  ki::EstimatorOptions o;
  o.kind = ki::parse_estimator(estimator);
  if (!a.ridge_k.empty() && o.kind != ki::EstimatorKind::Ridge)
    throw ki::InputError("--ridge-k applies to --estimator ridge (the estimator is " + estimator + ")");
  if (a.pcr_components > 0 && o.kind != ki::EstimatorKind::Pcr)
    throw ki::InputError("--pcr-components applies to --estimator pcr (the estimator is " + estimator + ")");
  if (a.ridge_k == "hkb") {
    o.ridge.rule = ki::RidgeRule::HoerlKennardBaldwin;
  } else if (!a.ridge_k.empty() && a.ridge_k != "gcv") {
    o.ridge.rule = ki::RidgeRule::Fixed;
    o.ridge.k = std::stod(a.ridge_k);  // validated by the option's check
  }
  if (a.pcr_components > 0) o.pcr.components = a.pcr_components;
  return o;
}

// "ridge, k = 4.3e-4 (GCV)", "pcr, 32 of 42 components (GCV)", "liu, d = 0.68 (Eq. (14))", "ols".
std::string describe_estimate(const ki::Estimate& e, const ki::EstimatorOptions& o) {
  std::ostringstream s;
  s << ki::to_string(o.kind);
  switch (o.kind) {
    case ki::EstimatorKind::Ridge:
      s << ", k = " << e.ridge_k
        << (o.ridge.rule == ki::RidgeRule::Gcv ? " (generalized cross-validation)"
                                               : o.ridge.rule == ki::RidgeRule::HoerlKennardBaldwin
                                                     ? " (Hoerl-Kennard-Baldwin)"
                                                     : " (given)");
      break;
    case ki::EstimatorKind::Pcr:
      s << ", " << e.pcr_components << " of " << e.x.size() << " principal components"
        << (o.pcr.components > 0 ? " (given)" : " (generalized cross-validation)");
      break;
    case ki::EstimatorKind::Liu: s << ", d = " << e.liu_d << " (Eq. (14))"; break;
    case ki::EstimatorKind::Ols: break;
  }
  return s.str();
}

nlohmann::json node_tests_json(const std::vector<ki::NodeTest>& tests) {
  nlohmann::json out = nlohmann::json::array();
  for (const ki::NodeTest& t : tests)
    out.push_back({{"id", t.id}, {"f", t.f}, {"p_value", t.p_value}, {"testable", t.testable}, {"outlying", t.outlying}});
  return out;
}

nlohmann::json stats_json(const ki::PoseErrorStats& s) {
  return {{"nodes", s.count},
          {"max_position_um", 1e3 * s.max_position_mm},
          {"mean_position_um", 1e3 * s.mean_position_mm},
          {"rms_position_um", 1e3 * s.rms_position_mm},
          {"max_orientation_urad", 1e6 * s.max_orientation_rad},
          {"mean_orientation_urad", 1e6 * s.mean_orientation_rad}};
}

// SUMMARY.json: the identification's own fields plus the residuals before and
// after calibration, overall and per role / layer.
std::string summary_text(nlohmann::json j, const ki::PoseErrorReport& before, const ki::PoseErrorReport& after) {
  auto groups = [](const ki::PoseErrorReport& r) {
    nlohmann::json out;
    out["all"] = stats_json(r.all);
    for (const auto& [name, st] : r.groups) out[name] = stats_json(st);
    return out;
  };
  j["residual_before"] = groups(before);
  j["residual"] = groups(after);
  return j.dump(2) + "\n";
}

// identify's outputs: MODEL.json and, if asked, SUMMARY.json, replaced
// together or not at all (files.hpp).
std::vector<std::string> identify_inputs(const IdentifyArgs& a) {
  std::vector<std::string> in = robot_input(a.robot);
  in.push_back(a.data);
  return in;
}

// seed 000's pipeline: coarse encoder offsets by iterated OLS (Eq. (15)), then
// the identifiable source errors by Liu (Eq. (11), d of Eq. (14)), OLS, ridge
// or PCR.
int run_identify_hybrid(const IdentifyArgs& a, const ki::Robot& robot, const ki::PoseTable& data) {
  std::string estimator = a.estimator.empty() ? "liu" : a.estimator;
  ki::EstimatorOptions eo = estimator_options(a, estimator);
  ki::HybridCalibrationOptions ho;
  // Liu by default, unless the data reject its shrinkage (then ridge, said
  // below); an estimator asked for by name is kept.
  if (!a.estimator.empty()) ho.liu_fallback = ki::HybridFineEstimator::None;
  ho.estimator = eo.kind == ki::EstimatorKind::Ols     ? ki::HybridFineEstimator::Ols
                 : eo.kind == ki::EstimatorKind::Ridge ? ki::HybridFineEstimator::Ridge
                 : eo.kind == ki::EstimatorKind::Pcr   ? ki::HybridFineEstimator::Pcr
                                                       : ki::HybridFineEstimator::Liu;
  ho.ridge = eo.ridge;
  ho.pcr = eo.pcr;
  ho.coarse_layers = a.coarse_layers;
  std::cout << "identify: " << a.data << ", robot " << robot.name << " (seed 000: coarse encoder offsets, then fine "
            << estimator << " on the identifiable source errors)\n";
  const ki::HybridCalibration c = ki::calibrate_hybrid(robot, data, ho);
  const bool liu_rejected = c.options.estimator != ho.estimator;
  if (liu_rejected) {
    estimator = ki::to_string(c.options.estimator);
    eo = estimator_options(a, estimator);
    std::cout << "  liu rejected by the data: its shrinkage adds F = " << c.liu_check_f << " (p = " << c.liu_check_p
              << ") to the OLS residual, so it removes the machine's errors, not noise; fine stage by " << estimator
              << " (--estimator liu keeps liu)\n";
  }
  ho = c.options;  // the outlier refits keep the estimator chosen here
  std::cout << "  cal nodes " << c.cal_nodes << "\n  coarse (Eq. (15)) on " << c.coarse_ids.size() << " nodes";
  if (!c.options.coarse_layers.empty()) {
    std::cout << " of layer(s)";
    for (long long l : c.options.coarse_layers) std::cout << " " << l;
    if (c.coarse_test_rows > 0)
      std::cout << " (" << c.coarse_test_rows << " of them test rows: held out from the fine stage, not from the "
                << "encoder offsets)";
  }
  std::cout << ": " << c.coarse_history.size() << " rounds, converged: " << (c.coarse_converged ? "yes" : "no")
            << "\n";
  for (std::size_t k = 0; k < c.coarse_history.size(); ++k)
    std::cout << "    round " << k + 1 << ": gauge residual rms " << 1e3 * c.coarse_history[k].rms_residual
              << " um, relative change " << c.coarse_history[k].relative_change << "\n";
  std::cout << "  fine: " << c.kept.size() << " of 150 source errors identifiable (Sec. 4.1 reconstruction), rank "
            << c.rank << ", condition number " << c.condition_number << "\n";
  if (c.linearisations.size() > 1) {
    // Large source errors: seed 000's one linear step did not predict the
    // model's residual at its estimate (hybrid_calibration.hpp).
    std::cout << "  fine: linearised " << c.linearisations.size() << " times (one step left the residual "
              << std::sqrt(c.linearisations.front().rss / std::max(c.linearisations.front().rss_predicted, 1e-300))
              << "x the linear prediction; large source errors)"
              << (c.fine_linearisation_valid ? "" : ", NOT converged: the result is where the iteration stopped")
              << "\n";
    for (std::size_t k = 0; k < c.linearisations.size(); ++k) {
      const ki::HybridFineLinearisation& l = c.linearisations[k];
      const double rows = 9.0 * double(c.cal_nodes);
      std::cout << "    linearisation " << k + 1 << ": "
                << (l.damping > 0 ? "damped least-squares step (lambda " + number_text(l.damping) + ")"
                                  : std::string(k == 0 ? "seed 000's step" : "the estimator's step"))
                << ", residual rms "
                << 1e3 * std::sqrt(l.rss / rows) << " um (predicted " << 1e3 * std::sqrt(l.rss_predicted / rows)
                << " um)\n";
    }
  }
  // What would make the others identifiable (pure-translation layers leave
  // whole families of source errors without effect on the gauge).
  const ki::IdentifiabilityHint hint = ki::hybrid_identifiability_hint(robot, c);
  if (!hint.text.empty()) std::cout << "  not identifiable from these poses; to separate them: " << hint.text << "\n";
  // Nodes inconsistent with the others (identify/outliers.hpp): the
  // sequential search on the fine design; left out unless --keep-outliers.
  const ki::HybridOutlierSearch search = ki::hybrid_outlier_search(robot, data, c, ho);
  const ki::OutlierScreen screen = ki::screen_of(search, c.outlier_p_threshold, a.keep_outliers);
  kincal_app::print_outliers(a.data, screen, c.cal_nodes, a.keep_outliers);
  const ki::HybridCalibration& used = screen.excluded ? search.rest : c;
  const ki::Estimate& est = *used.estimate(used.options.estimator);
  std::cout << "  estimator " << describe_estimate(est, eo) << "; fit residual rms "
            << 1e3 * std::sqrt(est.rss / double(std::max<Eigen::Index>(1, est.rows))) << " um per gauge coordinate\n";
  ki::CalibrationModel model = ki::hybrid_model(robot, used, std::nullopt, a.data);
  // The base by default (issue #14): seed 000's estimate finished by
  // Gauss–Newton on the nonlinear model, shrunk toward the coarse machine by
  // a ridge penalty whose k is chosen by GCV at the solution — the base of
  // `identify --effects` with no effect. Seed 000's single Liu step
  // compensated clean data of one design to 1.33–4.02 µm over three noise
  // seeds, this base to 1.28–1.65 µm (docs/diagnosis.md). An estimator asked
  // for by name is seed 000's fine stage with it, as is.
  std::string base_line;
  if (a.estimator.empty()) {
    ki::EffectCalibrationReport rep;
    model = ki::calibrate_with_effects(robot, screen.excluded ? ki::without_rows(data, screen.flagged) : data, {}, {},
                                       &rep);
    model.data_file = a.data;
    base_line = rep.base;
    std::cout << "  base: " << rep.base << "; cal residual rms " << rep.rms_cal_um_final
              << " um per gauge coordinate (seed 000's " << estimator << " step as is: --estimator " << estimator
              << ")\n";
  }
  const ki::HybridCompensation comp = ki::hybrid_compensation_from_model(model);
  const ki::PoseErrorReport before = ki::hybrid_residuals(robot, nullptr, data);
  const ki::PoseErrorReport after = ki::hybrid_residuals(robot, &comp, data);
  kincal_app::warn_unevaluated(a.data, after);
  std::cout << "\nresiduals before calibration (pose error from the gauge, measured - nominal model):\n";
  ki::print_pose_error_report(before, std::cout, false);
  std::cout << "\nresiduals after calibration (measured - calibrated model; test rows were not used for fitting):\n";
  ki::print_pose_error_report(after, std::cout, false);
  kincal_app::warn_correction_need(model, data);
  ki::OutputFiles outputs(identify_inputs(a));
  outputs.add(a.out, ki::model_to_json(model));
  if (!a.json.empty()) {
    nlohmann::json j;
    j["robot"] = robot.name;
    j["data"] = a.data;
    j["estimator"] = base_line.empty() ? estimator : model.estimator;
    j["estimator_settings"] = base_line.empty() ? ki::estimator_settings(est, eo) : model.settings;
    if (!base_line.empty()) {
      j["base"] = base_line;
      j["fine_stage"] = {{"estimator", estimator}, {"estimator_settings", ki::estimator_settings(est, eo)}};
    }
    j["rank"] = used.rank;
    j["parameters"] = 150;
    j["identifiable"] = used.kept_names;
    j["dropped"] = used.dropped_names;
    j["dropped_hint"] = hint.text;
    j["condition_number"] = used.condition_number;
    j["liu_d"] = used.liu.liu_d;
    j["liu_check"] = {{"f", c.liu_check_f}, {"p_value", c.liu_check_p}, {"rejected", liu_rejected}};
    j["fine_linearisations"] = used.linearisations.size();
    j["fine_linearisation_valid"] = used.fine_linearisation_valid;
    j["coarse_iterations"] = used.coarse_history.size();
    j["coarse_nodes"] = used.coarse_ids.size();
    j["coarse_layers"] = used.options.coarse_layers;
    j["sigma_um"] = 1e3 * std::sqrt(est.sigma2_unbiased);
    ki::add_outlier_fields(j, screen);
    j["node_tests"] = node_tests_json(c.node_tests);
    outputs.add(a.json, summary_text(j, before, after));
  }
  outputs.commit();
  std::cout << "\nmodel written to " << a.out << "\n";
  return 0;
}

int run_identify(const IdentifyArgs& a) {
  std::vector<std::string> outs{a.out};
  if (!a.json.empty()) outs.push_back(a.json);
  ki::check_outputs(outs, identify_inputs(a));
  const ki::Robot robot = ki::load_robot(a.robot);
  if (!a.effects.empty()) {
    // --ridge-k with --effects: "gcv" (default) or a number (hkb needs the
    // linear problem's full-rank OLS, which the passes do not form).
    if (a.ridge_k == "hkb") throw ki::InputError("--ridge-k hkb with --effects: give gcv or a number");
    if (!a.ridge_k.empty() && a.estimator != "ridge")
      throw ki::InputError("--ridge-k applies to --estimator ridge (the estimator is " +
                           (a.estimator.empty() ? std::string("ols") : a.estimator) + ")");
    const double k = a.ridge_k.empty() || a.ridge_k == "gcv" ? 0.0 : std::stod(a.ridge_k);  // checked by the option
    (void)kincal_app::effect_list(a.effects);  // known, each once (an effect named twice held its parameters at 0)
    return kincal_app::run_identify_with_effects(robot, a.data, a.out, a.effects, a.estimator, a.json, a.effect_alpha,
                                                 k, a.keep_outliers);
  }
  if (robot.is_hybrid()) return run_identify_hybrid(a, robot, kincal_app::read_measurements(robot, a.data));
  const std::string estimator = a.estimator.empty() ? "ols" : a.estimator;
  if (estimator == "liu")
    throw ki::InputError("--estimator liu: the 6-UPS (seed 001) calibration offers ols, ridge and pcr; liu is seed "
                         "000's estimator for the hybrid's fine stage");
  if (!a.coarse_layers.empty()) throw ki::InputError("--coarse-layers applies to the hybrid's coarse stage (seed 000)");
  ki::StewartCalibrationOptions so;
  so.estimator = estimator_options(a, estimator);
  const ki::PoseTable data = kincal_app::read_measurements(robot, a.data);
  std::cout << "identify: " << a.data << ", robot " << robot.name << " (42-parameter model of seed 001)\n";
  const ki::StewartCalibration c = ki::calibrate_stewart(robot, data, so);
  std::cout << "  cal nodes " << c.nodes << ", rank " << c.rank << " of 42, condition number (column-scaled) "
            << c.condition_number << "\n  estimator " << describe_estimate(c.fit, so.estimator)
            << "\n  iteration   max dQ_int (mm+rad)   rms |dp| (um)   |step| (mm)\n";
  for (const ki::StewartIteration& h : c.history) {
    char line[128];
    std::snprintf(line, sizeof line, "  %9d %21.3e %15.4f %13.3e\n", h.iteration, h.max_dq_int, 1e3 * h.rms_position_mm,
                  h.step_norm);
    std::cout << line;
  }
  // Nodes inconsistent with the others (identify/outliers.hpp); left out
  // unless --keep-outliers.
  const ki::StewartOutlierSearch search = ki::stewart_outlier_search(robot, data, c, so);
  const ki::OutlierScreen screen = ki::screen_of(search, c.outlier_p_threshold, a.keep_outliers);
  kincal_app::print_outliers(a.data, screen, c.nodes, a.keep_outliers);
  if (screen.excluded)
    std::cout << "  without them: " << search.rest.nodes << " nodes fit to "
              << 1e3 * search.rest.history.back().rms_position_mm << " um RMS (all nodes: "
              << 1e3 * c.history.back().rms_position_mm << " um)\n";
  const ki::StewartCalibration& used = screen.excluded ? search.rest : c;
  const ki::CalibrationModel model = ki::stewart_model(robot, used, a.data);
  kincal_app::warn_correction_need(model, data);
  ki::OutputFiles outputs(identify_inputs(a));
  outputs.add(a.out, ki::model_to_json(model));
  const ki::PoseErrorReport before = ki::stewart_residuals(robot, robot, data);
  const ki::PoseErrorReport after = ki::stewart_residuals(robot, ki::calibrated_robot(model), data);
  kincal_app::warn_unevaluated(a.data, after);
  std::cout << "\nresiduals before calibration (measured - nominal model):\n";
  ki::print_pose_error_report(before, std::cout, false);
  std::cout << "\nresiduals after calibration (measured - calibrated model; test rows were not used for fitting):\n";
  ki::print_pose_error_report(after, std::cout, false);
  if (!a.json.empty()) {
    nlohmann::json j;
    j["robot"] = robot.name;
    j["data"] = a.data;
    j["estimator"] = estimator;
    j["estimator_settings"] = ki::estimator_settings(used.fit, used.estimator);
    j["rank"] = used.rank;
    j["parameters"] = 42;
    j["dropped"] = nlohmann::json::array();
    j["condition_number"] = used.condition_number;
    j["sigma_um"] = 1e3 * used.sigma_mm;
    j["iterations"] = used.history.size();
    ki::add_outlier_fields(j, screen);
    j["node_tests"] = node_tests_json(c.node_tests);
    outputs.add(a.json, summary_text(j, before, after));
  }
  outputs.commit();
  std::cout << "\nmodel written to " << a.out << "\n";
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

  IdentifyArgs ident;
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
  if (*identify) return run_identify(ident);
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
