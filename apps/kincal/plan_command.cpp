// `kincal plan` (GUIDE "Command-line contract"; docs/plan.md): which poses to
// measure, chosen by identify/plan.hpp, written in motion order, with the
// numbers that show what the plan buys over a grid of the same size.
#include <cmath>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "commands.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/files.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/plan.hpp"
#include "kincal/identify/robot.hpp"

namespace ki = kincal::identify;

namespace kincal_app {

CLI::App* add_plan_command(CLI::App& app, PlanArgs& a) {
  CLI::App* p = app.add_subcommand(
      "plan", "choose the poses to measure (D-optimal), before the tracker is set up, and compare them with a grid");
  p->add_option("--robot", a.robot, "built-in robot name or robot description file")->required();
  p->add_option("--count", a.count, "calibration poses to choose")->required()->check(whole_number(1));
  p->add_option("--out", a.out, "POSES.csv to write (id, role, x..rz; dir1..dir6 with backlash), in motion order")
      ->required();
  p->add_option("--effects", a.effects,
                "effects to make identifiable and separable from the base too, e.g. compliance,scale ('kincal effects' "
                "lists them)");
  p->add_option("--measure", a.measure,
                "what the instrument measures: pose (6-UPS default) or targets (the robot's `targets`; hybrid "
                "default: seed 000's three-target gauge)")
      ->check(CLI::IsMember({"pose", "targets"}));
  p->add_option("--candidates", a.candidates,
                "poses the machine may be measured at (x..rz; e.g. those with the tracker in view); default: a "
                "sample of the workspace within the joint limits less the margin")
      ->check(CLI::ExistingFile);
  p->add_option("--samples", a.samples, "workspace poses sampled when no --candidates are given (default 5000)")
      ->check(whole_number(1));
  p->add_option("--test", a.test, "also choose this many held-out (test) poses spread over the workspace")
      ->check(whole_number(0));
  p->add_option("--json", a.json, "PLAN.json to write: the criterion and the planned, grid and random designs' numbers");
  p->add_option("--grid-out", a.grid_out, "also write the comparison grid's poses (CSV) here");
  p->add_option("--seed", a.seed, "seed of the workspace sample and the approach directions (default 1)")
      ->check(whole_number(0));
  p->add_option("--noise-um", a.noise_um, "sigma of a measured coordinate in um (default 5)")
      ->check(decimal(0, HUGE_VAL, true));
  p->add_option("--noise-urad", a.noise_urad,
                "sigma of a measured angle in urad, for --measure pose (default: the --noise-um over 200 mm)")
      ->check(decimal(0, HUGE_VAL, true));
  p->add_option("--margin", a.margin,
                "fraction of every joint range kept clear at both limits (default 0.05)")
      ->check(decimal(0, 0.49));
  p->add_flag("--quiet", a.quiet, "no progress lines on stderr");
  return p;
}

namespace {

std::string fixed(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

nlohmann::ordered_json assessment_json(const ki::DesignAssessment& a) {
  nlohmann::ordered_json j;
  j["poses"] = a.poses;
  j["parameters"] = a.parameters;
  j["rank"] = a.rank;
  j["condition_number"] = std::isfinite(a.condition_number) ? nlohmann::ordered_json(a.condition_number) : nullptr;
  j["log_det"] = a.log_det;
  j["undetermined_parameters"] = a.undetermined;
  j["predicted_test_position_um"] = a.predicted_test_um;
  nlohmann::ordered_json conf = nlohmann::ordered_json::object();
  for (const ki::PlanConfounding& c : a.confounding) conf[c.effect] = c.share;
  j["confounding"] = conf;
  nlohmann::ordered_json se = nlohmann::ordered_json::array();
  for (const ki::PlanParameter& p : a.parameter_errors)
    se.push_back({{"name", p.name}, {"unit", p.unit}, {"standard_error", p.standard_error}, {"prior", p.prior},
                  {"determined", p.determined}});
  j["standard_errors"] = se;
  return j;
}

// The largest standard error among the base's mm parameters, as "1.2 um (dl3)".
std::string worst_length(const ki::DesignAssessment& a) {
  const ki::PlanParameter* worst = nullptr;
  for (const ki::PlanParameter& p : a.parameter_errors)
    if (p.unit == "mm" && (worst == nullptr || p.standard_error > worst->standard_error)) worst = &p;
  return worst == nullptr ? "-" : fixed(1e3 * worst->standard_error, 1) + " um (" + worst->name + ")";
}

}  // namespace

int run_plan(const PlanArgs& a) {
  std::vector<std::string> inputs;
  if (!ki::is_builtin_robot(a.robot)) inputs.push_back(a.robot);
  if (!a.candidates.empty()) inputs.push_back(a.candidates);
  std::vector<std::string> outs{a.out};
  if (!a.json.empty()) outs.push_back(a.json);
  if (!a.grid_out.empty()) outs.push_back(a.grid_out);
  ki::check_outputs(outs, inputs);
  const ki::Robot robot = ki::load_robot(a.robot);

  ki::PlanOptions o;
  o.count = a.count;
  if (!a.effects.empty()) o.effects = effect_list(robot, a.effects);
  o.measure = a.measure.empty() ? ki::PlanMeasure::Default
                                : (a.measure == "pose" ? ki::PlanMeasure::Pose : ki::PlanMeasure::Targets);
  if (!a.candidates.empty()) {
    ki::PoseTableOptions po;
    po.warn = warn;
    po.input_columns = robot.formula_inputs;
    o.candidates = ki::read_pose_table(a.candidates, po);
    if (o.candidates.rows.empty()) throw ki::InputError(a.candidates, 0, 0, "no candidate poses");
  }
  o.sample_count = a.samples;
  o.test_count = a.test;
  o.seed = a.seed;
  o.noise_mm = a.noise_um * 1e-3;
  o.noise_rad = a.noise_urad * 1e-6;  // 0: noise_mm / 200 mm
  o.margin = a.margin;
  if (!a.quiet) o.progress = [](const std::string& s) { std::cerr << "plan: " << s << "\n"; };
  const ki::MeasurementPlan plan = ki::plan_measurements(robot, o);

  ki::OutputFiles outputs(inputs);
  outputs.add(a.out, ki::pose_table_text(plan.poses));
  if (!a.grid_out.empty()) outputs.add(a.grid_out, ki::pose_table_text(plan.grid));
  if (!a.json.empty()) {
    nlohmann::ordered_json j;
    j["robot"] = robot.name;
    j["measure"] = plan.measure;
    j["rows_per_pose"] = plan.rows_per_pose;
    j["noise_um"] = a.noise_um;
    j["criterion"] = "Bayesian D-optimality: log det(A'A + L) - log det L of the whitened identification Jacobian A "
                     "of the base model and the effects; L: each parameter moves the measured points by 1 mm RMS";
    j["effects"] = plan.effects;
    j["parameters"] = plan.parameter_names;
    j["candidates"] = plan.candidates;
    j["usable_candidates"] = plan.usable_candidates;
    j["exchange_passes"] = plan.exchange_passes;
    j["exchanges"] = plan.exchanges;
    j["evaluation_poses"] = plan.evaluation_poses;
    j["path_length_joint_ranges"] = plan.path_length;
    j["seconds"] = plan.seconds;
    j["planned"] = assessment_json(plan.planned);
    if (plan.grid_assessment.poses > 0) j["grid"] = assessment_json(plan.grid_assessment);
    j["random"] = assessment_json(plan.random_assessment);
    j["notes"] = plan.notes;
    outputs.add(a.json, j.dump(2) + "\n");
  }
  outputs.commit();

  const bool grid = plan.grid_assessment.poses > 0;
  std::cout << "plan: " << a.count << " poses for " << robot.name << ", measuring " << plan.measure << ", noise "
            << a.noise_um << " um\n"
            << "  criterion: D-optimal (Bayesian) on " << plan.parameter_names.size() << " parameters"
            << (plan.effects.empty() ? std::string() : " (base and " + std::to_string(plan.effects.size()) + " effects)")
            << "\n  candidates: " << plan.usable_candidates << " usable of " << plan.candidates
            << "; greedy + " << plan.exchange_passes << " exchange passes (" << plan.exchanges << " swaps), "
            << fixed(plan.seconds, 2) << " s\n";
  const auto row = [&](const std::string& label, auto value) {
    std::cout << "  " << std::left << std::setw(30) << label << std::right << std::setw(14) << value(plan.planned)
              << std::setw(14) << (grid ? value(plan.grid_assessment) : std::string("-")) << std::setw(14)
              << value(plan.random_assessment) << "\n";
  };
  std::cout << "  " << std::left << std::setw(30) << "" << std::right << std::setw(14) << "planned" << std::setw(14)
            << "grid" << std::setw(14) << "random" << "\n";
  row("rank", [](const ki::DesignAssessment& d) { return std::to_string(d.rank) + "/" + std::to_string(d.parameters); });
  row("condition number", [](const ki::DesignAssessment& d) {
    return std::isfinite(d.condition_number) ? fixed(d.condition_number, 1) : std::string("inf");
  });
  row("log det", [](const ki::DesignAssessment& d) { return fixed(d.log_det, 1); });
  row("undetermined parameters", [](const ki::DesignAssessment& d) { return std::to_string(d.undetermined); });
  for (std::size_t e = 0; e < plan.planned.confounding.size(); ++e)
    row("confounding " + plan.planned.confounding[e].effect, [e](const ki::DesignAssessment& d) {
      return e < d.confounding.size() ? fixed(100 * d.confounding[e].share, 1) + " %" : std::string("-");
    });
  row("predicted held-out error", [](const ki::DesignAssessment& d) { return fixed(d.predicted_test_um, 2) + " um"; });
  std::cout << "  largest length standard error: planned " << worst_length(plan.planned);
  if (grid) std::cout << ", grid " << worst_length(plan.grid_assessment);
  // Every parameter's predicted standard error, planned | grid, three to a
  // line; '*' marks one the data leave to the prior (not determined).
  std::cout << "\n  predicted standard errors, planned | grid (um for mm, urad for rad; * = not determined):";
  for (std::size_t i = 0; i < plan.planned.parameter_errors.size(); ++i) {
    const auto text = [](const ki::PlanParameter& q) {
      const double v = q.unit == "mm" ? 1e3 * q.standard_error : q.unit == "rad" ? 1e6 * q.standard_error
                                                                                  : q.standard_error;
      std::ostringstream s;
      s << std::setprecision(3) << v << (q.determined ? "" : "*");
      return s.str();
    };
    const ki::PlanParameter& q = plan.planned.parameter_errors[i];
    std::cout << (i % 3 == 0 ? "\n   " : "") << " " << std::left << std::setw(16) << q.name << std::right << std::setw(10)
              << text(q) << " |" << std::setw(10)
              << (grid ? text(plan.grid_assessment.parameter_errors[i]) : std::string("-"));
  }
  std::cout << "\n  (held-out error: RMS position error of the identified model from the noise, at "
            << plan.evaluation_poses << (a.test > 0 ? " test poses" : " workspace poses") << ")\n";
  for (const std::string& n : plan.notes) std::cout << "  note: " << n << "\n";
  std::cout << "wrote " << a.out << ": " << a.count << " cal" << (a.test > 0 ? " + " + std::to_string(a.test) + " test" : "")
            << " poses in motion order (path " << fixed(plan.path_length, 2) << " joint ranges)\n";
  return 0;
}

}  // namespace kincal_app
