// `kincal simulate`: measurements of an erroneous machine (identify/simulate.hpp).
#include <algorithm>
#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "kincal/identify/effects.hpp"
#include "kincal/identify/files.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/simulate.hpp"
#include "commands.hpp"

namespace ki = kincal::identify;

namespace kincal_app {

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
    for (const ki::EffectSetting& setting : ki::parse_effect_options(e))
      effects.set(nominal, setting.effect, setting.parameter, setting.value);
  }
  const ki::Robot actual = ki::apply_parameters(nominal, errors);

  ki::PoseTableOptions popt;
  popt.joint_count = ki::Robot::joint_count();
  popt.warn = warn;
  popt.input_columns = nominal.formula_inputs;
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
  sopt.pose_only = a.pose_only;
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

}  // namespace kincal_app
