// `kincal robot` (a summary, the description file, the parameter names) and
// `kincal errors` (measured − commanded, or two files' difference).
#include <algorithm>
#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "kincal/identify/files.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/pose_errors.hpp"
#include "kincal/identify/robot.hpp"
#include "commands.hpp"

namespace ki = kincal::identify;

namespace kincal_app {

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

}  // namespace kincal_app
