// The 6-UPS's own pipeline and its narrative (seed 001's iterated least
// squares on full poses: the iterations, the outlier screen, the residuals);
// identify.hpp dispatches to it.
#include <cmath>
#include <cstdio>

#include "families/stewart/stewart_family.hpp"
#include "pipeline/pipeline_support.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/stewart_calibration.hpp"

namespace kincal::identify {

void StewartFamilyPipeline::check_identify_options(const IdentifyOptions& options) const {
  if (options.estimator == "liu")
    throw InputError("--estimator liu: the 6-UPS (seed 001) calibration offers ols, ridge and pcr; liu is seed "
                     "000's estimator for the hybrid's fine stage");
  if (!options.coarse_layers.empty()) throw InputError("--coarse-layers applies to the hybrid's coarse stage (seed 000)");
}

Identification StewartFamilyPipeline::identify_own(const Robot& robot, const PoseTable& data, const IdentifyOptions& options,
                                                   std::ostream& narrative) const {
  Identification out;
  const std::string estimator = options.estimator.empty() ? "ols" : options.estimator;
  StewartCalibrationOptions so;
  so.estimator = estimator_options(options, estimator);
  const int parameters = stewart_parameter_count(robot);
  narrative << "identify: " << options.data_file << ", robot " << robot.name << " (" << parameters << "-parameter model of seed 001"
            << (robot.stewart_description().models_leg_offsets ? " with leg offsets dsq1..dsq6" : "") << ")\n";
  const StewartCalibration c = calibrate_stewart(robot, data, so);
  narrative << "  cal nodes " << c.nodes << ", rank " << c.rank << " of " << parameters
            << ", condition number (column-scaled) "
            << c.condition_number << "\n  estimator " << describe_estimate(c.fit, so.estimator)
            << "\n  iteration   max dQ_int (mm+rad)   rms |dp| (um)   |step| (mm)\n";
  for (const StewartIteration& h : c.history) {
    char line[128];
    std::snprintf(line, sizeof line, "  %9d %21.3e %15.4f %13.3e\n", h.iteration, h.max_dq_int, 1e3 * h.rms_position_mm,
                  h.step_norm);
    narrative << line;
  }
  // Nodes inconsistent with the others (identify/outliers.hpp); left out
  // unless --keep-outliers.
  const StewartOutlierSearch search = stewart_outlier_search(robot, data, c, so);
  const OutlierScreen screen = screen_of(search, c.outlier_p_threshold, options.keep_outliers);
  print_outlier_screen(narrative, options.data_file, screen, c.nodes, options.keep_outliers);
  if (screen.excluded)
    narrative << "  without them: " << search.rest.nodes << " nodes fit to "
              << 1e3 * search.rest.history.back().rms_position_mm << " um RMS (all nodes: "
              << 1e3 * c.history.back().rms_position_mm << " um)\n";
  const StewartCalibration& used = screen.excluded ? search.rest : c;
  const CalibrationModel model = stewart_model(robot, used, options.data_file);
  detail::add_table_warning(out, model, data);
  out.before = stewart_residuals(robot, robot, data);
  out.after = stewart_residuals(robot, calibrated_robot(model), data);
  detail::add_unevaluated_warnings(out, options.data_file, out.after);
  out.nominal = "measured - nominal model";
  if (options.summary) {
    nlohmann::json& j = out.summary;
    j["estimator"] = estimator;
    j["estimator_settings"] = estimator_settings(used.fit, used.estimator);
    j["rank"] = used.rank;
    j["parameters"] = parameters;
    j["dropped"] = nlohmann::json::array();
    j["condition_number"] = used.condition_number;
    j["sigma_um"] = 1e3 * used.sigma_mm;
    j["iterations"] = used.history.size();
  }
  out.model = model;
  out.screen = screen;
  out.node_tests = c.node_tests;
  return out;
}


}  // namespace kincal::identify
