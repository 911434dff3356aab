// `kincal identify` (commands.hpp): the family's identification pipeline, the
// outlier screen, identifiability, and the narrative, MODEL.json and
// SUMMARY.json; `--effects` goes to identify_effects_command.cpp.
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
void print_residuals(const IdentifyArgs& a, const ki::PoseErrorReport& before, const ki::PoseErrorReport& after,
                     const std::string& nominal) {
  kincal_app::warn_unevaluated(a.data, after);
  const std::string at = after.target_points ? " at the targets" : "";
  std::cout << "\nresiduals" << at << " before calibration (" << nominal << "):\n";
  ki::print_pose_error_report(before, std::cout, false);
  std::cout << "\nresiduals" << at
            << " after calibration (measured - calibrated model; test rows were not used for fitting):\n";
  ki::print_pose_error_report(after, std::cout, false);
}

// SUMMARY.json's first fields (empty when no SUMMARY.json is asked for).
nlohmann::json summary_start(const IdentifyArgs& a, const ki::Robot& robot) {
  nlohmann::json j;
  if (a.json.empty()) return j;
  j["robot"] = robot.name;
  j["data"] = a.data;
  return j;
}

// seed 000's pipeline: coarse encoder offsets by iterated OLS (Eq. (15)), then
// the identifiable source errors by Liu (Eq. (11), d of Eq. (14)), OLS, ridge
// or PCR.
int run_identify_hybrid_gauge(const IdentifyArgs& a, const ki::Robot& robot, const ki::PoseTable& data) {
  std::string estimator = a.estimator.empty() ? "liu" : a.estimator;
  ki::EstimatorOptions eo = estimator_options(a, estimator);
  ki::HybridCalibrationOptions ho;
  // Liu by default, unless the data reject its shrinkage (then ridge, said
  // below); an estimator asked for by name is kept.
  if (!a.estimator.empty()) ho.liu_fallback = std::nullopt;
  ho.estimator = eo.kind;
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
  std::cout << "  fine: " << c.kept.size() << " of " << ki::HybridErrorModel::kParameterCount << " source errors identifiable (Sec. 4.1 reconstruction), rank "
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
  ki::CalibrationModel model = ki::hybrid_model(robot, used, a.data);
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
  print_residuals(a, before, after, "pose error from the gauge, measured - nominal model");
  kincal_app::warn_table_refusal(model, data);
  ki::OutputFiles outputs(identify_inputs(a));
  outputs.add(a.out, ki::model_to_json(model));
  nlohmann::json summary = summary_start(a, robot);
  if (!a.json.empty()) {
    nlohmann::json& j = summary;
    j["estimator"] = base_line.empty() ? estimator : model.estimator;
    j["estimator_settings"] = base_line.empty() ? ki::estimator_settings(est, eo) : model.settings;
    if (!base_line.empty()) {
      j["base"] = base_line;
      j["fine_stage"] = {{"estimator", estimator}, {"estimator_settings", ki::estimator_settings(est, eo)}};
    }
    j["rank"] = used.rank;
    j["parameters"] = ki::HybridErrorModel::kParameterCount;
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
  }
  return write_outputs(outputs, a, summary, screen, c.node_tests, before, after);
}

// Laser-tracker targets, either family (target_calibration.hpp): the
// family's errors with the targets' positions and, in the instrument's
// frame, its registration; the frame convention closes what target
// positions cannot fix. The same fit reads the full poses of a family whose
// own pipeline does not (the hybrid's is seed 000's gauge).
int run_identify_targets(const IdentifyArgs& a, const ki::Robot& robot, const ki::PoseTable& data) {
  const bool poses = ki::reads_full_poses(data);
  const std::string measured = poses ? "full poses" : "target measurements";
  if (!a.estimator.empty() && a.estimator != "ols")
    throw ki::InputError("--estimator " + a.estimator + ": " + measured + " of the " + robot.family() +
                         " family are identified by ols so far");
  const ki::TargetCalibrationOptions options;
  std::cout << "identify: " << a.data << ", robot " << robot.name << " (" << robot.error_model() << " from ";
  if (poses)
    std::cout << "full poses in the robot's base frame, rotations weighted at " << ki::kOrientationWeightMm << " mm)\n";
  else
    std::cout << data.target_columns() << " target(s) measured in the "
              << (a.instrument_frame ? "instrument's frame; registration identified" : "robot's base frame") << ")\n";
  const ki::TargetCalibration c = ki::calibrate_targets(robot, data, options);
  const int family_size = int(c.names.size());
  const int held = family_size + 3 * int(c.targets.size()) + (a.instrument_frame ? 6 : 0) - c.free_parameters;
  std::cout << "  cal nodes " << c.nodes << ", " << c.free_parameters << " free parameters (" << family_size
            << " errors, " << 3 * c.targets.size() << " target coordinates"
            << (a.instrument_frame ? ", 6 registration" : "") << ", less " << held << " fixed by the "
            << (poses ? "convention" : "frame convention") << ": " << c.convention << "), rank " << c.rank
            << ", condition number (column-scaled) " << c.condition_number << "\n";
  const auto held_errors = std::count(c.fitted.begin(), c.fitted.end(), false);
  if (held_errors > 0)
    std::cout << "  " << held_errors << " of the " << family_size
              << " errors held at 0 by the convention (MODEL.json: identifiable false; SUMMARY.json: dropped)\n";
  std::cout << (poses ? "  iteration   rms residual (um; rotations at the weight)\n"
                      : "  iteration   rms target residual (um)\n");
  for (const ki::TargetIteration& h : c.history) {
    char line[96];
    std::snprintf(line, sizeof line, "  %9d %26.4f\n", h.iteration, 1e3 * h.rms_position_mm);
    std::cout << line;
  }
  std::cout << "  worst-determined combinations (rotations at 1 m):\n";
  for (const ki::WeakCombination& w : c.weakest) {
    std::cout << "    sd " << 1e3 * w.standard_deviation_mm << " um:";
    for (std::size_t i = 0; i < w.terms.size() && i < 6; ++i)
      std::cout << (i ? " + " : " ") << w.terms[i].second << "*" << w.terms[i].first;
    std::cout << "\n";
  }
  const ki::TargetOutlierSearch search = ki::target_outlier_search(robot, data, c, options);
  const ki::OutlierScreen screen = ki::screen_of(search, c.outlier_p_threshold, a.keep_outliers);
  kincal_app::print_outliers(a.data, screen, c.nodes, a.keep_outliers);
  const ki::TargetCalibration& used = screen.excluded ? search.rest : c;
  const ki::CalibrationModel model = ki::target_model(robot, used, a.data);
  if (a.instrument_frame) {
    const kincal::Vec6<double> reg = used.registration.to_xyz_rpy();
    std::cout << "  registration (base frame in the instrument frame): x " << reg(0) << ", y " << reg(1) << ", z "
              << reg(2) << " mm, rx " << reg(3) << ", ry " << reg(4) << ", rz " << reg(5) << " rad\n";
  }
  for (std::size_t k = 0; k < used.targets.size(); ++k)
    std::cout << "  target t" << k + 1 << " on the " << robot.target_body() << ": "
              << used.targets[k].transpose() << " mm (sd "
              << 1e3 * used.target_standard_error[k].transpose() << " um)\n";
  kincal_app::warn_table_refusal(model, data);
  ki::OutputFiles outputs(identify_inputs(a));
  outputs.add(a.out, ki::model_to_json(model));
  const kincal::Pose<double> nominal_registration =
      a.instrument_frame ? ki::nominal_registration(robot, data) : kincal::Pose<double>{};
  const ki::PoseErrorReport before =
      ki::target_residuals(robot, Eigen::VectorXd::Zero(used.errors.size()), nominal_registration, robot.targets, data);
  const ki::PoseErrorReport after = ki::target_residuals(robot, used.errors, used.registration, used.targets, data);
  print_residuals(a, before, after,
                  a.instrument_frame ? "measured - nominal model laid onto them by a rigid fit" : "measured - nominal model");
  nlohmann::json summary = summary_start(a, robot);
  if (!a.json.empty()) {
    nlohmann::json& j = summary;
    j["estimator"] = "ols";
    j["measurement"] = poses ? nlohmann::json{{"full_pose", true}, {"orientation_weight_mm", ki::kOrientationWeightMm}}
                             : nlohmann::json{{"targets", data.target_columns()}, {"instrument_frame", a.instrument_frame}};
    j["rank"] = used.rank;
    j["parameters"] = used.free_parameters;
    // The family's errors the convention holds at 0 (the hybrid's column
    // selection; none on the 6-UPS, whose convention is a combination).
    nlohmann::json dropped = nlohmann::json::array();
    for (std::size_t i = 0; i < used.names.size(); ++i)
      if (!used.fitted[i]) dropped.push_back(used.names[i]);
    j["dropped"] = dropped;
    j["convention"] = used.convention;
    j["condition_number"] = used.condition_number;
    j["sigma_um"] = 1e3 * used.sigma_mm;
    j["iterations"] = used.history.size();
    nlohmann::json weak = nlohmann::json::array();
    for (const ki::WeakCombination& w : used.weakest) {
      nlohmann::json terms = nlohmann::json::object();
      for (const auto& [name, coefficient] : w.terms) terms[name] = coefficient;
      weak.push_back({{"sd_um", 1e3 * w.standard_deviation_mm}, {"terms", terms}});
    }
    j["weakest_combinations"] = weak;
    nlohmann::json inst = nlohmann::json::object();
    for (const ki::ModelParameter& p : model.instrument) {
      inst[p.name] = {{"value", p.value}, {"standard_error", p.standard_error}};
      if (p.name[0] == 't')  // the target's offset from the description's position
        inst[p.name]["offset"] = p.value - robot.targets[std::size_t(p.name[1] - '1')](p.name[2] - 'x');
    }
    j["instrument"] = inst;
  }
  return write_outputs(outputs, a, summary, screen, c.node_tests, before, after);
}

// The 6-UPS's own pipeline (seed 001's iterated least squares) and its
// narrative: the iterations, the outlier screen, the residuals.
int run_identify_stewart(const IdentifyArgs& a, const ki::Robot& robot) {
  const std::string estimator = a.estimator.empty() ? "ols" : a.estimator;
  if (estimator == "liu")
    throw ki::InputError("--estimator liu: the 6-UPS (seed 001) calibration offers ols, ridge and pcr; liu is seed "
                         "000's estimator for the hybrid's fine stage");
  if (!a.coarse_layers.empty()) throw ki::InputError("--coarse-layers applies to the hybrid's coarse stage (seed 000)");
  const ki::PoseTable data = kincal_app::read_measurements(robot, a.data, a.instrument_frame);
  // Targets are used when they are all the table has, or when asked for.
  if (ki::uses_target_model(robot, data)) return run_identify_targets(a, robot, data);
  ki::StewartCalibrationOptions so;
  so.estimator = estimator_options(a, estimator);
  const int parameters = ki::stewart_parameter_count(robot);
  std::cout << "identify: " << a.data << ", robot " << robot.name << " (" << parameters << "-parameter model of seed 001"
            << (robot.models_leg_offsets ? " with leg offsets dsq1..dsq6" : "") << ")\n";
  const ki::StewartCalibration c = ki::calibrate_stewart(robot, data, so);
  std::cout << "  cal nodes " << c.nodes << ", rank " << c.rank << " of " << parameters
            << ", condition number (column-scaled) "
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
  kincal_app::warn_table_refusal(model, data);
  ki::OutputFiles outputs(identify_inputs(a));
  outputs.add(a.out, ki::model_to_json(model));
  const ki::PoseErrorReport before = ki::stewart_residuals(robot, robot, data);
  const ki::PoseErrorReport after = ki::stewart_residuals(robot, ki::calibrated_robot(model), data);
  print_residuals(a, before, after, "measured - nominal model");
  nlohmann::json summary = summary_start(a, robot);
  if (!a.json.empty()) {
    nlohmann::json& j = summary;
    j["estimator"] = estimator;
    j["estimator_settings"] = ki::estimator_settings(used.fit, used.estimator);
    j["rank"] = used.rank;
    j["parameters"] = parameters;
    j["dropped"] = nlohmann::json::array();
    j["condition_number"] = used.condition_number;
    j["sigma_um"] = 1e3 * used.sigma_mm;
    j["iterations"] = used.history.size();
  }
  return write_outputs(outputs, a, summary, screen, c.node_tests, before, after);
}

// The hybrid's: target columns (or full poses alone) go to the target fit, the gauge to seed 000's
// coarse + fine pipeline.
int run_identify_hybrid(const IdentifyArgs& a, const ki::Robot& robot) {
  const ki::PoseTable data = kincal_app::read_measurements(robot, a.data, a.instrument_frame);
  if (ki::uses_target_model(robot, data)) return run_identify_targets(a, robot, data);
  return run_identify_hybrid_gauge(a, robot, data);
}

// Each family's own pipeline and narrative (its stages print differently):
// one line per family, keyed by the description's `family`
// (identify/src/families/families.cpp registers the families themselves).
struct Narrative {
  const char* family;
  int (*run)(const IdentifyArgs&, const ki::Robot&);
};
constexpr Narrative kNarratives[] = {
    {ki::kStewartFamily, run_identify_stewart},
    {ki::kHybridFamily, run_identify_hybrid},
};

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
  for (const Narrative& n : kNarratives)
    if (std::string(n.family) == robot.family()) return n.run(a, robot);
  // A family without a narrative of its own: tracker targets, by the target fit.
  const ki::PoseTable data = kincal_app::read_measurements(robot, a.data, a.instrument_frame);
  if (ki::uses_target_model(robot, data)) return run_identify_targets(a, robot, data);
  throw ki::InputError(std::string("identify: the ") + robot.family() +
                       " family's own measurement has no pipeline here yet; measure tracker targets (t1x,t1y,t1z)");
}

}  // namespace kincal_app
