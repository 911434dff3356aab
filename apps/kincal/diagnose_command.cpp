// `kincal diagnose` (GUIDE "Command-line contract"; docs/diagnosis.md).
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "commands.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/diagnosis.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/files.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/plan.hpp"
#include "kincal/identify/robot.hpp"

namespace ki = kincal::identify;

namespace kincal_app {

CLI::App* add_diagnose_command(CLI::App& app, DiagnoseArgs& a) {
  CLI::App* d = app.add_subcommand(
      "diagnose", "compare the model with measurements: where it fails and which physical effect is missing");
  d->add_option("--robot", a.robot, "built-in robot name or robot description file")->required();
  d->add_option("--data", a.data, "measurement CSV (cal rows are fitted, test rows held out)")->required();
  d->add_option("--json", a.json, "DIAG.json to write")->required();
  d->add_option("--report", a.report, "REPORT.html to write (self-contained, inline SVG)");
  d->add_option("--noise-um", a.noise_um,
                "sigma of a measured position coordinate in um (pose x, y, z; gauge targets); default: from repeated "
                "nodes, else estimated from neighbouring nodes")
      ->check(decimal(0, HUGE_VAL, true));
  d->add_option("--noise-urad", a.noise_urad,
                "sigma of a measured orientation coordinate in urad (6-UPS pose rx, ry, rz); default: from repeated "
                "nodes, else estimated from neighbouring nodes")
      ->check(decimal(0, HUGE_VAL, true));
  d->add_option("--effects", a.effects, "candidate effects to test, comma separated (default: all registered)");
  d->add_option("--alpha", a.alpha, "family-wise significance level (Holm), default 0.01")
      ->check(decimal(0, 1, true));
  d->add_flag("--keep-outliers", a.keep_outliers,
              "diagnose with every cal node, also those inconsistent with the others (default: they are listed and "
              "left out, unless the misfit is systematic)");
  d->add_flag("--quiet", a.quiet, "no progress lines on stderr");
  d->add_flag("--instrument-frame", a.instrument_frame,
              "target columns t1x.. (the robot's `targets`): measured in the instrument's own frame; its "
              "registration is identified with the base model (docs/identify.md)");
  return d;
}

namespace {

std::string um(double v) {
  std::ostringstream s;
  s.precision(3);
  s << v << " um";
  return s.str();
}

}  // namespace

int run_diagnose(const DiagnoseArgs& a) {
  // DIAG.json and REPORT.html are replaced together or not at all, and never
  // over an input (files.hpp).
  std::vector<std::string> inputs{a.data};
  if (!ki::is_builtin_robot(a.robot)) inputs.push_back(a.robot);
  std::vector<std::string> outs{a.json};
  if (!a.report.empty()) outs.push_back(a.report);
  ki::check_outputs(outs, inputs);
  const ki::Robot robot = ki::load_robot(a.robot);
  const ki::PoseTable data = read_measurements(robot, a.data, a.instrument_frame);

  ki::DiagnoseOptions opt;
  if (a.noise_um) {
    if (!(*a.noise_um > 0) || !std::isfinite(*a.noise_um)) throw ki::InputError("--noise-um must be a number > 0");
    opt.noise_um = a.noise_um;
  }
  opt.noise_urad = a.noise_urad;
  if (!(a.alpha > 0 && a.alpha < 1)) throw ki::InputError("--alpha must be in (0, 1)");
  opt.alpha = a.alpha;
  opt.progress = !a.quiet;
  opt.keep_outliers = a.keep_outliers;
  if (!a.effects.empty()) opt.candidates = effect_list(robot, a.effects);

  ki::Diagnosis d = ki::diagnose(robot, data, opt);
  ki::add_plan_hints(robot, d);  // what planned poses would do for an effect the data cannot tell from the base
  ki::OutputFiles outputs(inputs);
  outputs.add(a.json, ki::diagnosis_to_json(d));
  if (!a.report.empty()) outputs.add(a.report, ki::diagnosis_report_html(d));
  outputs.commit();

  std::cout << "diagnose: " << a.data << ", robot " << robot.name << " (" << d.base_model << ")\n";
  print_outliers(a.data, d.outliers, d.outliers.excluded ? d.rms.cal_nodes + d.outliers.flagged.size() : d.rms.cal_nodes,
                 a.keep_outliers);
  std::cout << "  noise " << um(d.noise_um) << " (" << d.noise_source << ")";
  if (!d.noise_urad_source.empty())  // orientations measured (full poses)
    std::cout << ", orientation " << d.noise_urad << " urad (" << d.noise_urad_source << ")";
  std::cout << "; base model RMS cal " << um(d.rms.cal)
            << ", test " << um(d.rms.test) << "\n";
  for (const ki::EffectTest& t : d.ranking) {
    std::cout << "  " << (t.accepted ? "+ " : "  ") << t.effect;
    if (!t.testable) {
      std::cout << ": not testable, " << t.why_not << "\n";
      continue;
    }
    std::cout << ": F = " << t.score << ", p(Holm) = " << t.p_adjusted << ", test RMS -> " << um(t.rms_after.test)
              << ", confounded " << std::fixed << std::setprecision(1) << t.confounded * 100 << std::defaultfloat
              << std::setprecision(6) << " %\n";
    if (t.plan_confounded >= 0) {
      std::ostringstream share;
      share << std::fixed << std::setprecision(1) << 100 * t.plan_confounded << " %";
      const std::string command =
          "kincal plan --effects " + t.plan_effects + " --count " + std::to_string(t.plan_count);
      if (t.plan_confounded < 0.9)
        std::cout << "    " << t.effect << " can hardly be told from the base on these poses; poses planned for it ("
                  << command << ") bring its confounding to " << share.str() << "\n";
      else
        std::cout << "    " << t.effect << " can hardly be told from the base on these poses, and a plan for it ("
                  << command << ") still leaves " << share.str() << ": the workspace hardly separates it\n";
    }
  }
  std::cout << "  verdict: " << d.verdict << "; final RMS cal " << um(d.final_rms.cal) << ", test "
            << um(d.final_rms.test) << "\n";
  for (const ki::Hotspot& h : d.hotspots) std::cout << "  hotspot (" << h.kind << "): " << h.where << " - " << h.detail << "\n";
  for (const std::string& n : d.notes) std::cout << "  note: " << n << "\n";
  return 0;
}

}  // namespace kincal_app
