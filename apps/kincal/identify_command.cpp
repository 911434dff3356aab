// `kincal identify` (commands.hpp): reads the robot and the data, runs the
// library's identify() (identify.hpp: the family's pipeline or the target
// fit, the outlier screen, the narrative), prints the residuals and writes
// MODEL.json and SUMMARY.json; `--effects` goes to identify_effects_command.cpp.
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
#include "kincal/identify/hybrid_error_model.hpp"
#include "kincal/identify/identify.hpp"
#include "kincal/identify/identifiability.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/joint_limits.hpp"
#include "kincal/identify/measurement_model.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/robot.hpp"
#include "kincal/identify/pose_errors.hpp"
#include "kincal/identify/simulate.hpp"
#include "kincal/identify/stewart_calibration.hpp"
#include "kincal/identify/target_calibration.hpp"
#include "kincal/identify/table_writer.hpp"
#include "kincal/identify/version.hpp"
#include "commands.hpp"

namespace ki = kincal::identify;

namespace kincal_app {

namespace {

nlohmann::json node_tests_json(const std::vector<ki::NodeTest>& tests) {
  nlohmann::json out = nlohmann::json::array();
  for (const ki::NodeTest& t : tests)
    out.push_back({{"id", t.id}, {"f", t.f}, {"p_value", t.p_value}, {"testable", t.testable}, {"outlying", t.outlying}});
  return out;
}

// Target-point residuals (PoseErrorReport::target_points) have no orientation.
nlohmann::json stats_json(const ki::PoseErrorStats& s, bool target_points) {
  if (target_points)
    return {{"targets", s.count},
            {"max_position_um", 1e3 * s.max_position_mm},
            {"mean_position_um", 1e3 * s.mean_position_mm},
            {"rms_position_um", 1e3 * s.rms_position_mm}};
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
    out["all"] = stats_json(r.all, r.target_points);
    for (const auto& [name, st] : r.groups) out[name] = stats_json(st, r.target_points);
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

// SUMMARY.json's tail both families share (the outlier screen, the node
// tests, the residuals before and after) when it is asked for, then every
// output written at once.
int write_outputs(ki::OutputFiles& outputs, const IdentifyArgs& a, nlohmann::json& summary,
                  const ki::OutlierScreen& screen, const std::vector<ki::NodeTest>& node_tests,
                  const ki::PoseErrorReport& before, const ki::PoseErrorReport& after) {
  if (!a.json.empty()) {
    ki::add_outlier_fields(summary, screen);
    summary["node_tests"] = node_tests_json(node_tests);
    outputs.add(a.json, summary_text(summary, before, after));
  }
  outputs.commit();
  std::cout << "\nmodel written to " << a.out << "\n";
  return 0;
}

// The residual tables of every identification: before (`nominal`: how the
// nominal model is compared) and after; test rows were never fitted.
void print_residuals(const ki::PoseErrorReport& before, const ki::PoseErrorReport& after, const std::string& nominal) {
  const std::string at = after.target_points ? " at the targets" : "";
  std::cout << "\nresiduals" << at << " before calibration (" << nominal << "):\n";
  ki::print_pose_error_report(before, std::cout, false);
  std::cout << "\nresiduals" << at
            << " after calibration (measured - calibrated model; test rows were not used for fitting):\n";
  ki::print_pose_error_report(after, std::cout, false);
}

}  // namespace

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
    (void)kincal_app::effect_list(robot, a.effects);  // known, each once (an effect named twice held its parameters at 0)
    return kincal_app::run_identify_with_effects(robot, a.data, a.out, a.effects, a.estimator, a.json, a.effect_alpha,
                                                 k, a.keep_outliers, a.instrument_frame);
  }
  ki::IdentifyOptions o;
  o.data_file = a.data;
  o.estimator = a.estimator;
  o.ridge_k = a.ridge_k;
  o.pcr_components = a.pcr_components;
  o.coarse_layers = a.coarse_layers;
  o.keep_outliers = a.keep_outliers;
  o.instrument_frame = a.instrument_frame;
  o.summary = !a.json.empty();
  ki::check_identify_options(robot, o);
  const ki::PoseTable data = kincal_app::read_measurements(robot, a.data, a.instrument_frame);
  ki::Identification id = ki::identify(robot, data, o, std::cout);
  print_residuals(id.before, id.after, id.nominal);
  for (const std::string& w : id.warnings) warn(w);
  ki::OutputFiles outputs(identify_inputs(a));
  outputs.add(a.out, ki::model_to_json(id.model));
  if (!a.json.empty()) {
    id.summary["robot"] = robot.name;
    id.summary["data"] = a.data;
  }
  return write_outputs(outputs, a, id.summary, id.screen, id.node_tests, id.before, id.after);
}

}  // namespace kincal_app
