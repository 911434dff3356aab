// What the commands share (commands.hpp): option validators and lists,
// warnings, the measurement file with its checks, the outlier lines.
#include <CLI/CLI.hpp>
#include <charconv>
#include <cctype>
#include <algorithm>
#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/files.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/joint_limits.hpp"
#include "commands.hpp"

namespace ki = kincal::identify;

// Warnings are one line each, whatever strings from the input they quote.
void kincal_app::warn(const std::string& line) { std::cerr << ki::one_line(line) << "\n"; }

std::vector<std::string> kincal_app::robot_input(const std::string& robot) {
  return ki::is_builtin_robot(robot) ? std::vector<std::string>{} : std::vector<std::string>{robot};
}

bool kincal_app::strict_decimal(const std::string& v, double& out) {
  std::string_view s = v;
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty() || s.front() == '+' || (v.front() == '+' && s.front() == '-')) return false;
  for (const char c : s)
    if (!(std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == 'e' || c == 'E' || c == '-' || c == '+'))
      return false;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out, std::chars_format::general);
  return ec == std::errc() && ptr == s.data() + s.size() && std::isfinite(out);
}

std::string kincal_app::number_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

CLI::Validator kincal_app::decimal(double lo, double hi, bool open_low) {
  const std::string range = std::string(open_low ? "(" : "[") + kincal_app::number_text(lo) + ", " +
                            (std::isfinite(hi) ? kincal_app::number_text(hi) + "]" : std::string("inf)"));
  return CLI::Validator(
      [lo, hi, open_low, range](std::string& v) {
        double x = 0;
        if (!strict_decimal(v, x)) return "must be a decimal number, not '" + v + "'";
        if (x < lo || (open_low && x == lo) || x > hi) return "must be in " + range + ", not " + v;
        return std::string();
      },
      "NUMBER in " + range);
}

CLI::Validator kincal_app::whole_number(long long lo) {
  return CLI::Validator(
      [lo](std::string& v) {
        long long x = 0;
        std::string_view s = v;
        if (!s.empty() && s.front() == '+') s.remove_prefix(1);
        const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
        if (s.empty() || ec != std::errc() || ptr != s.data() + s.size())
          return "must be a decimal integer, not '" + v + "'";
        if (x < lo) return "must be at least " + std::to_string(lo) + ", not " + v;
        return std::string();
      },
      "INT >= " + std::to_string(lo));
}

std::vector<double> kincal_app::number_list(const std::string& text, const std::string& option) {
  std::vector<double> out;
  std::stringstream in(text);
  for (std::string field; std::getline(in, field, ',');) {
    double x = 0;
    if (!strict_decimal(field, x))
      throw ki::InputError(option + ": '" + field + "' is not a finite decimal number (in '" + text + "')");
    out.push_back(x);
  }
  return out;
}

std::vector<Eigen::Vector3d> kincal_app::target_list(const std::string& text, const std::string& option) {
  std::vector<Eigen::Vector3d> out;
  std::stringstream in(text);
  for (std::string point; std::getline(in, point, ';');) {
    const std::vector<double> v = number_list(point, option);
    if (v.size() != 3) throw ki::InputError(option + ": a target is x,y,z in mm, not '" + point + "'");
    out.emplace_back(v[0], v[1], v[2]);
  }
  if (out.empty() || out.size() > 3) throw ki::InputError(option + ": give one to three targets, 'x,y,z;x,y,z'");
  return out;
}

std::vector<std::string> kincal_app::effect_list(const ki::Robot& robot, const std::string& list) {
  std::vector<std::string> names;
  std::stringstream in(list);
  for (std::string name; std::getline(in, name, ',');) {
    if (name.empty()) continue;
    if (ki::find_effect(robot, name) == nullptr)
      throw ki::InputError("--effects: unknown effect '" + name + "' (known: " + ki::effect_names(robot) + ")");
    if (std::find(names.begin(), names.end(), name) != names.end())
      throw ki::InputError("--effects: '" + name + "' is named twice");
    names.push_back(name);
  }
  if (names.empty()) throw ki::InputError("--effects: no effect named in '" + list + "'");
  return names;
}

ki::PoseTable kincal_app::read_measurements(const ki::Robot& robot, const std::string& path, bool instrument_frame) {
  ki::PoseTableOptions options;
  options.joint_count = ki::Robot::joint_count();
  options.warn = warn;
  options.input_columns = robot.formula_inputs;
  ki::PoseTable data = ki::read_pose_table(path, options);
  if (instrument_frame) {
    if (!data.has_targets)
      throw ki::InputError(path, 1, 0, "--instrument-frame needs target columns t1x.. (laser-tracker targets)");
    data.in_instrument_frame = true;
  }
  for (const std::string& w : ki::joint_limit_warnings(robot, data)) warn(w);
  return data;
}

void kincal_app::warn_table_refusal(const ki::CalibrationModel& model, const ki::PoseTable& data) {
  const std::string w = ki::table_refusal_warning(model, data);
  if (!w.empty()) warn(data.file + ": warning: " + w);
}

void kincal_app::print_outliers(const std::string& file, const ki::OutlierScreen& screen, std::size_t nodes, bool keep) {
  ki::print_outlier_screen(std::cout, file, screen, nodes, keep);
}

