// One identification of a robot from its measurements (identify.hpp): the
// dispatch between the target fit and the family's own pipeline, the target
// fit's narrative, and what the pipelines share.
#include "kincal/identify/identify.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "families/family.hpp"
#include "pipeline/pipeline_support.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/measurement_model.hpp"
#include "kincal/identify/target_calibration.hpp"

namespace kincal::identify {

void detail::add_table_warning(Identification& out, const CalibrationModel& model, const PoseTable& data) {
  const std::string w = table_refusal_warning(model, data);
  if (!w.empty()) out.warnings.push_back(data.file + ": warning: " + w);
}

void detail::add_unevaluated_warnings(Identification& out, const std::string& file, const PoseErrorReport& report) {
  for (const UnevaluatedRow& r : report.unevaluated)
    out.warnings.push_back(file + ":" + std::to_string(r.line) + ": warning: row '" + r.id + "': " + r.why +
                           "; its residual is left out of the tables");
}

std::string detail::number_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

EstimatorOptions estimator_options(const IdentifyOptions& options, const std::string& estimator) {
  EstimatorOptions o;
  o.kind = parse_estimator(estimator);
  if (!options.ridge_k.empty() && o.kind != EstimatorKind::Ridge)
    throw InputError("--ridge-k applies to --estimator ridge (the estimator is " + estimator + ")");
  if (options.pcr_components > 0 && o.kind != EstimatorKind::Pcr)
    throw InputError("--pcr-components applies to --estimator pcr (the estimator is " + estimator + ")");
  if (options.ridge_k == "hkb") {
    o.ridge.rule = RidgeRule::HoerlKennardBaldwin;
  } else if (!options.ridge_k.empty() && options.ridge_k != "gcv") {
    o.ridge.rule = RidgeRule::Fixed;
    o.ridge.k = std::stod(options.ridge_k);  // validated by the command line's option check
  }
  if (options.pcr_components > 0) o.pcr.components = options.pcr_components;
  return o;
}

std::string describe_estimate(const Estimate& e, const EstimatorOptions& o) {
  std::ostringstream s;
  s << to_string(o.kind);
  switch (o.kind) {
    case EstimatorKind::Ridge:
      s << ", k = " << e.ridge_k
        << (o.ridge.rule == RidgeRule::Gcv ? " (generalized cross-validation)"
                                           : o.ridge.rule == RidgeRule::HoerlKennardBaldwin ? " (Hoerl-Kennard-Baldwin)"
                                                                                            : " (given)");
      break;
    case EstimatorKind::Pcr:
      s << ", " << e.pcr_components << " of " << e.x.size() << " principal components"
        << (o.pcr.components > 0 ? " (given)" : " (generalized cross-validation)");
      break;
    case EstimatorKind::Liu: s << ", d = " << e.liu_d << " (Eq. (14))"; break;
    case EstimatorKind::Ols: break;
  }
  return s.str();
}


namespace {

// Laser-tracker targets, every family (target_calibration.hpp): the
// family's errors with the targets' positions and, in the instrument's
// frame, its registration; the frame convention closes what target
// positions cannot fix. The same fit reads the full poses of a family whose
// own pipeline does not (the hybrid's is seed 000's gauge).
Identification identify_targets(const Robot& robot, const PoseTable& data, const IdentifyOptions& options,
                                std::ostream& narrative) {
  Identification out;
  const bool poses = reads_full_poses(data);
  const std::string measured = poses ? "full poses" : "target measurements";
  if (!options.estimator.empty() && options.estimator != "ols")
    throw InputError("--estimator " + options.estimator + ": " + measured + " of the " + robot.family() +
                         " family are identified by ols so far");
  const TargetCalibrationOptions fit;
  narrative << "identify: " << options.data_file << ", robot " << robot.name << " (" << robot.error_model() << " from ";
  if (poses)
    narrative << "full poses in the robot's base frame, rotations weighted at " << kOrientationWeightMm << " mm)\n";
  else
    narrative << data.target_columns() << " target(s) measured in the "
              << (options.instrument_frame ? "instrument's frame; registration identified" : "robot's base frame") << ")\n";
  const TargetCalibration c = calibrate_targets(robot, data, fit);
  const int family_size = int(c.names.size());
  const int held = family_size + 3 * int(c.targets.size()) + (options.instrument_frame ? 6 : 0) - c.free_parameters;
  narrative << "  cal nodes " << c.nodes << ", " << c.free_parameters << " free parameters (" << family_size
            << " errors, " << 3 * c.targets.size() << " target coordinates"
            << (options.instrument_frame ? ", 6 registration" : "") << ", less " << held << " fixed by the "
            << (poses ? "convention" : "frame convention") << ": " << c.convention << "), rank " << c.rank
            << ", condition number (column-scaled) " << c.condition_number << "\n";
  const auto held_errors = std::count(c.fitted.begin(), c.fitted.end(), false);
  if (held_errors > 0)
    narrative << "  " << held_errors << " of the " << family_size
              << " errors held at 0 by the convention (MODEL.json: identifiable false; SUMMARY.json: dropped)\n";
  narrative << (poses ? "  iteration   rms residual (um; rotations at the weight)\n"
                      : "  iteration   rms target residual (um)\n");
  for (const TargetIteration& h : c.history) {
    char line[96];
    std::snprintf(line, sizeof line, "  %9d %26.4f\n", h.iteration, 1e3 * h.rms_position_mm);
    narrative << line;
  }
  narrative << "  worst-determined combinations (rotations at 1 m):\n";
  for (const WeakCombination& w : c.weakest) {
    narrative << "    sd " << 1e3 * w.standard_deviation_mm << " um:";
    for (std::size_t i = 0; i < w.terms.size() && i < 6; ++i)
      narrative << (i ? " + " : " ") << w.terms[i].second << "*" << w.terms[i].first;
    narrative << "\n";
  }
  const TargetOutlierSearch search = target_outlier_search(robot, data, c, fit);
  const OutlierScreen screen = screen_of(search, c.outlier_p_threshold, options.keep_outliers);
  print_outlier_screen(narrative, options.data_file, screen, c.nodes, options.keep_outliers);
  const TargetCalibration& used = screen.excluded ? search.rest : c;
  const CalibrationModel model = target_model(robot, used, options.data_file);
  if (options.instrument_frame) {
    const kincal::Vec6<double> reg = used.registration.to_xyz_rpy();
    narrative << "  registration (base frame in the instrument frame): x " << reg(0) << ", y " << reg(1) << ", z "
              << reg(2) << " mm, rx " << reg(3) << ", ry " << reg(4) << ", rz " << reg(5) << " rad\n";
  }
  for (std::size_t k = 0; k < used.targets.size(); ++k)
    narrative << "  target t" << k + 1 << " on the " << robot.target_body() << ": "
              << used.targets[k].transpose() << " mm (sd "
              << 1e3 * used.target_standard_error[k].transpose() << " um)\n";
  detail::add_table_warning(out, model, data);
  const Pose<double> registration0 = options.instrument_frame ? nominal_registration(robot, data) : Pose<double>{};
  out.before =
      target_residuals(robot, Eigen::VectorXd::Zero(used.errors.size()), registration0, robot.targets, data);
  out.after = target_residuals(robot, used.errors, used.registration, used.targets, data);
  detail::add_unevaluated_warnings(out, options.data_file, out.after);
  out.nominal = options.instrument_frame ? "measured - nominal model laid onto them by a rigid fit" : "measured - nominal model";
  if (options.summary) {
    nlohmann::json& j = out.summary;
    j["estimator"] = "ols";
    j["measurement"] = poses ? nlohmann::json{{"full_pose", true}, {"orientation_weight_mm", kOrientationWeightMm}}
                             : nlohmann::json{{"targets", data.target_columns()}, {"instrument_frame", options.instrument_frame}};
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
    for (const WeakCombination& w : used.weakest) {
      nlohmann::json terms = nlohmann::json::object();
      for (const auto& [name, coefficient] : w.terms) terms[name] = coefficient;
      weak.push_back({{"sd_um", 1e3 * w.standard_deviation_mm}, {"terms", terms}});
    }
    j["weakest_combinations"] = weak;
    nlohmann::json inst = nlohmann::json::object();
    for (const ModelParameter& p : model.instrument) {
      inst[p.name] = {{"value", p.value}, {"standard_error", p.standard_error}};
      if (p.name[0] == 't')  // the target's offset from the description's position
        inst[p.name]["offset"] = p.value - robot.targets[std::size_t(p.name[1] - '1')](p.name[2] - 'x');
    }
    j["instrument"] = inst;
  }
  out.model = model;
  out.screen = screen;
  out.node_tests = c.node_tests;
  return out;
}


}  // namespace

void check_identify_options(const Robot& robot, const IdentifyOptions& options) {
  if (const FamilyPipeline* pipeline = family_of(robot).own_pipeline()) pipeline->check_identify_options(options);
}

Identification identify(const Robot& robot, const PoseTable& data, const IdentifyOptions& options,
                        std::ostream& narrative) {
  check_identify_options(robot, options);
  // Targets are used when they are all the table has, or when asked for.
  if (uses_target_model(robot, data)) return identify_targets(robot, data, options, narrative);
  // The rest goes to the family's own pipeline, which says what its table
  // lacks; a family without one has nothing to read in it.
  const FamilyPipeline* pipeline = family_of(robot).pipeline_reading(robot, data);
  if (pipeline == nullptr)
    throw InputError(data.file, 0, 0,
                     std::string("identify: the table has neither measured poses (mx..mrz) nor tracker targets "
                                 "(t1x,t1y,t1z); a ") +
                         robot.family() + " robot is identified from one of them");
  return pipeline->identify_own(robot, data, options, narrative);
}

}  // namespace kincal::identify
