// `kincal identify --effects e1,e2` (identify/effect_calibration.hpp).
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "commands.hpp"
#include "kincal/identify/files.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/effect_calibration.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/estimators.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/model.hpp"

namespace ki = kincal::identify;

namespace kincal_app {

int run_identify_with_effects(const ki::Robot& robot, const std::string& data_path, const std::string& out,
                              const std::string& effects, const std::string& estimator, const std::string& json_path,
                              double effect_alpha, double ridge_k, bool keep_outliers, bool instrument_frame) {
  const std::vector<std::string> names = effect_list(robot, effects);
  const ki::PoseTable data = read_measurements(robot, data_path, instrument_frame);
  std::cout << "identify: " << data_path << ", robot " << robot.name << " with effects " << effects << "\n";
  ki::EffectCalibrationOptions opt;
  if (!estimator.empty()) opt.estimator = ki::parse_estimator(estimator);
  opt.ridge_k = ridge_k;
  opt.alpha = effect_alpha;
  // Blunders: the same screen as plain identify (identify/outliers.hpp), on
  // the joint design of base and effects; the flagged rows left out and the
  // whole fit repeated without them, unless --keep-outliers.
  struct Fit {
    ki::CalibrationModel model;
    ki::EffectCalibrationReport report;
  };
  const auto fit = [&](const ki::PoseTable& rows) {
    Fit f;
    f.model = ki::calibrate_with_effects(robot, rows, names, opt, &f.report);
    f.model.data_file = data_path;
    return f;
  };
  const Fit all = fit(data);
  ki::SequentialOutlierOptions so;
  so.min_nodes = robot.outlier_min_nodes();
  ki::ScreenedFit<Fit> screened = ki::screen_and_refit(
      data, all, [](const Fit& f) -> const ki::LinearProblem& { return f.report.final_problem; },
      [](const Fit& f) -> const std::vector<ki::NodeTest>& { return f.report.nodes; }, fit, so);
  ki::OutlierScreen& screen = screened.screen;
  screen.excluded = ki::leave_out(screen, keep_outliers);
  print_outliers(data_path, screen, all.report.nodes.size(), keep_outliers);
  const Fit& used = screen.excluded ? screened.rest : all;
  const ki::CalibrationModel& model = used.model;
  const ki::EffectCalibrationReport& report = used.report;
  if (screen.excluded)
    std::cout << "  without them: cal residual RMS " << report.rms_cal_um_final << " um (all nodes: "
              << all.report.rms_cal_um_final << " um)\n";
  warn_table_refusal(model, data);
  for (std::size_t i = 0; i < report.rms_cal_um.size(); ++i)
    std::cout << "  pass " << i + 1 << ": cal residual RMS " << report.rms_cal_um[i] << " um\n";
  for (const ki::HeldParameter& h : report.held) {
    const double start = ki::find_effect(robot, h.effect)->start_values(robot)(Eigen::Index(h.index));
    std::cout << "  held at ";
    if (start == 0)
      std::cout << "0";
    else
      std::cout << "its start " << start;
    std::cout << ": " << h.effect << " " << h.parameter;
    if (h.outside_base < ki::kBaseCopyShare)
      std::cout << " (a copy of the base model: " << h.outside_base
                << " of its column lies outside the base's span -- e.g. its input keeps one sign over the data, "
                   "so it is an offset the base already has)\n";
    else if (h.t == 0)
      std::cout << " (no column on this data: its input is zero or it is a combination of the others)\n";
    else
      std::cout << " (not significant beyond the base and the other parameters: t = " << h.t << ", p = " << h.p_value
                << " x " << h.free_parameters << " free > alpha " << opt.alpha << ")\n";
  }
  std::cout << "  base: " << report.base << "\n";
  std::cout << "  final: cal " << report.rms_cal_um_final << " um, test " << report.rms_test_um_final << " um\n";
  nlohmann::ordered_json values = nlohmann::ordered_json::object();
  for (const auto& [name, v] : model.effects.values) {
    const std::vector<std::string> pn = ki::find_effect(robot, name)->parameter_names(robot);
    std::cout << "  " << name << ":";
    for (std::size_t i = 0; i < pn.size(); ++i) {
      std::cout << " " << pn[i] << "=" << v(Eigen::Index(i));
      values[name][pn[i]] = v(Eigen::Index(i));
    }
    std::cout << "\n";
  }
  // MODEL.json and SUMMARY.json together or not at all (files.hpp); run_identify
  // has refused outputs that are inputs before any work.
  ki::OutputFiles outputs({data_path});
  outputs.add(out, ki::model_to_json(model));
  if (!json_path.empty()) {
    nlohmann::ordered_json j;
    j["robot"] = robot.name;
    j["data"] = data_path;
    j["estimator"] = model.estimator;
    j["base"] = report.base;
    j["effects"] = values;
    j["passes"] = report.passes;
    nlohmann::ordered_json held = nlohmann::ordered_json::array();
    for (const ki::HeldParameter& h : report.held)
      held.push_back({{"effect", h.effect}, {"parameter", h.parameter}, {"t", h.t}, {"p_value", h.p_value},
                      {"free_parameters", h.free_parameters}});
    j["held_at_zero"] = held;
    j["residual_rms_um"] = {{"cal", report.rms_cal_um_final}, {"test", report.rms_test_um_final}};
    ki::add_outlier_fields(j, screen);
    outputs.add(json_path, j.dump(2) + "\n");
  }
  outputs.commit();
  return 0;
}

}  // namespace kincal_app
