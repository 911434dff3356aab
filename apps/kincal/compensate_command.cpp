// `kincal compensate` (the controller's routine over a pose file) and
// `kincal table` (the firmware's parameter table).
#include <algorithm>
#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "kincal/core/compensation.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/files.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/table_writer.hpp"
#include "commands.hpp"

namespace ki = kincal::identify;

namespace kincal_app {

int run_compensate(const std::string& robot_name, const std::string& model_path, const std::string& poses_path,
                   const std::string& out_path) {
  std::vector<std::string> inputs = robot_input(robot_name);
  inputs.push_back(model_path);
  inputs.push_back(poses_path);
  ki::check_outputs({out_path}, inputs);
  const ki::Robot robot = ki::load_robot(robot_name);
  const ki::CalibrationModel model = ki::read_model_file(model_path);
  if (ki::robot_to_json(model.nominal) != ki::robot_to_json(robot)) {
    // Only the bounds differ: the model carries its robot's bounds into the
    // table, so name the keys rather than call it another robot.
    ki::Robot same_bounds = robot;
    std::string keys;
    auto bound = [&](const char* key, auto member) {
      if (same_bounds.*member != model.nominal.*member) keys += (keys.empty() ? "'" : ", '") + std::string(key) + "'";
      same_bounds.*member = model.nominal.*member;
    };
    bound("max_correction", &ki::Robot::max_correction);
    bound("max_geometry_error", &ki::Robot::max_geometry_error);
    bound("max_angle_error", &ki::Robot::max_angle_error);
    bound("max_scale", &ki::Robot::max_scale);
    bound("max_thermal", &ki::Robot::max_thermal);
    if (ki::robot_to_json(model.nominal) == ki::robot_to_json(same_bounds))
      throw ki::InputError(model_path, 0, 0,
                           "was identified with another " + keys + " than " + robot_name +
                               " has; the model carries the bounds into the table: identify again with " + robot_name);
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
  options.input_columns = model.nominal.formula_inputs;
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
  out.input_names = poses.input_names;
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
    o.inputs = r.inputs;
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

}  // namespace kincal_app
