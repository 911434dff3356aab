// The schema reader of robot descriptions (docs/formats.md "Robot
// description"): every check names file, line and column. parse_robot
// (robot.cpp) reads the common keys; each family reads its own
// (FamilyDescription::parse, families/<family>/).
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/json_locator.hpp"
#include "kincal/core/pose.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal::identify::detail {

inline const char* type_name(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null: return "null";
    case nlohmann::json::value_t::object: return "an object";
    case nlohmann::json::value_t::array: return "an array";
    case nlohmann::json::value_t::string: return "a string";
    case nlohmann::json::value_t::boolean: return "a boolean";
    case nlohmann::json::value_t::number_integer:
    case nlohmann::json::value_t::number_unsigned:
    case nlohmann::json::value_t::number_float: return "a number";
    default: return "an unsupported value";
  }
}

inline std::string display(const std::string& path) { return path.empty() ? "the document" : "'" + path.substr(1) + "'"; }

inline std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : ", ") + s;
  return out;
}

// Schema checks with positions: every error names file, line and column.
class DescriptionReader {
 public:
  DescriptionReader(const std::string& text, const std::string& file) : text_(text), file_(file), loc_(locate_json(text)) {}

  [[noreturn]] void fail_at(std::size_t offset, const std::string& message) const {
    const TextPosition p = position_of(text_, offset);
    throw InputError(file_, p.line, p.column, message);
  }
  [[noreturn]] void fail(const std::string& path, const std::string& message) const {
    fail_at(loc_.value_offset(path), message);
  }

  void check_duplicates() const {
    if (!loc_.duplicates.empty())
      fail_at(loc_.duplicates.front().offset, "duplicate key " + display(loc_.duplicates.front().path));
  }

  // Object with exactly the keys in `required` plus any of `optional`.
  const nlohmann::json& object(const nlohmann::json& j, const std::string& path, const std::vector<std::string>& required,
                     const std::vector<std::string>& optional) const {
    if (!j.is_object()) fail(path, display(path) + " must be an object, not " + type_name(j));
    std::vector<std::string> unknown;
    std::size_t first_unknown = std::string::npos;
    for (auto it = j.begin(); it != j.end(); ++it) {
      const std::string& k = it.key();
      if (std::find(required.begin(), required.end(), k) == required.end() &&
          std::find(optional.begin(), optional.end(), k) == optional.end()) {
        unknown.push_back("'" + k + "'");
        first_unknown = std::min(first_unknown, loc_.key_offset(child_path(path, k)));
      }
    }
    if (!unknown.empty()) {
      std::vector<std::string> allowed;
      for (const auto& k : required) allowed.push_back(k);
      for (const auto& k : optional) allowed.push_back(k);
      fail_at(first_unknown, std::string(unknown.size() == 1 ? "unknown key " : "unknown keys ") + join(unknown) +
                                 " in " + display(path) + " (allowed: " + join(allowed) + ")");
    }
    std::vector<std::string> missing;
    for (const auto& k : required)
      if (!j.contains(k)) missing.push_back("'" + k + "'");
    if (!missing.empty())
      fail(path, std::string(missing.size() == 1 ? "missing key " : "missing keys ") + join(missing) + " in " +
                     display(path));
    return j;
  }

  // The optional keys every family may have, after a family's own optional
  // keys (for object()'s list of allowed keys).
  static std::vector<std::string> with_common_optional(std::vector<std::string> keys) {
    for (const char* k : {"screw_lead", "max_correction", "max_geometry_error", "max_angle_error", "max_scale",
                          "max_thermal", "targets", "effects", "payload"})
      keys.emplace_back(k);
    return keys;
  }

  // The keys every family may have (screw_lead, max_correction, the caps of
  // the table check, targets).
  void common_optional(const nlohmann::json& doc, Robot& robot) const {
    if (doc.contains("screw_lead")) robot.screw_lead = positive(doc["screw_lead"], "/screw_lead");
    if (doc.contains("max_correction")) robot.max_correction = per_joint_positive(doc["max_correction"], "/max_correction");
    if (doc.contains("max_geometry_error")) robot.max_geometry_error = cap(doc["max_geometry_error"], "/max_geometry_error");
    if (doc.contains("max_angle_error")) robot.max_angle_error = cap(doc["max_angle_error"], "/max_angle_error");
    if (doc.contains("max_scale")) robot.max_scale = cap(doc["max_scale"], "/max_scale");
    if (doc.contains("max_thermal")) robot.max_thermal = cap(doc["max_thermal"], "/max_thermal");
    if (doc.contains("targets")) robot.targets = target_points(doc["targets"], "/targets");
    if (doc.contains("payload")) {
      const nlohmann::json& p = object(doc["payload"], "/payload", {}, {"weight", "com"});
      if (p.contains("weight")) robot.payload_weight = positive(p["weight"], "/payload/weight");
      if (p.contains("com")) robot.payload_com = vector<3>(p["com"], "/payload/com");
      robot.has_payload = true;
    }
    // `effects` needs the whole text (positions of the formulas' keys):
    // parse_robot reads it after the family (formula_effect.hpp).
  }

  // Every number of a description is a length in mm, an angle in rad or a
  // ratio: none of a parallel machine reaches a kilometre. Larger is a typo
  // or a unit mistake (the audit's 1e9 mm stroke passed before).
  double number(const nlohmann::json& j, const std::string& path) const {
    if (!j.is_number()) fail(path, display(path) + " must be a number, not " + type_name(j));
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(path, display(path) + " must be finite");
    if (!(std::abs(v) <= 1e6)) fail(path, display(path) + " is beyond 1e6 (a kilometre in mm): a typo or a unit mistake");
    return v;
  }
  // A pose angle: radians of one turn at most (as in the CSV files).
  double angle(const nlohmann::json& j, const std::string& path) const {
    const double v = number(j, path);
    if (!(std::abs(v) <= 2 * pi<double>())) fail(path, display(path) + " is more than a turn (2 pi rad): angles are in radians");
    return v;
  }
  double non_negative(const nlohmann::json& j, const std::string& path) const {
    const double v = number(j, path);
    if (v < 0) fail(path, display(path) + " is a length and must not be negative");
    return v;
  }
  // A cap of the table check (core/machine_limits.hpp): a magnitude, so not
  // negative; 0 allows no error of that kind at all.
  double cap(const nlohmann::json& j, const std::string& path) const {
    const double v = number(j, path);
    if (v < 0) fail(path, display(path) + " is the largest magnitude allowed and must not be negative");
    return v;
  }
  double positive(const nlohmann::json& j, const std::string& path) const {
    const double v = number(j, path);
    if (!(v > 0)) fail(path, display(path) + " must be positive");
    return v;
  }
  std::string string(const nlohmann::json& j, const std::string& path) const {
    if (!j.is_string()) fail(path, display(path) + " must be a string, not " + type_name(j));
    return j.get<std::string>();
  }
  void array_of(const nlohmann::json& j, const std::string& path, std::size_t n) const {
    if (!j.is_array()) fail(path, display(path) + " must be an array of " + std::to_string(n) + ", not " + type_name(j));
    if (j.size() != n)
      fail(path, display(path) + " must have " + std::to_string(n) + " entries, not " + std::to_string(j.size()));
  }
  template <int N> Eigen::Matrix<double, N, 1> vector(const nlohmann::json& j, const std::string& path) const {
    array_of(j, path, N);
    Eigen::Matrix<double, N, 1> v;
    for (int i = 0; i < N; ++i) v(i) = number(j[static_cast<std::size_t>(i)], child_path(path, static_cast<std::size_t>(i)));
    return v;
  }
  // n points [x, y, z] as the columns of a 3×n matrix.
  template <int N> Eigen::Matrix<double, 3, N> points(const nlohmann::json& j, const std::string& path) const {
    array_of(j, path, N);
    Eigen::Matrix<double, 3, N> m;
    for (int i = 0; i < N; ++i) {
      const std::size_t si = static_cast<std::size_t>(i);
      m.col(i) = vector<3>(j[si], child_path(path, si));
    }
    return m;
  }
  // 1–3 points [x, y, z] (the `targets` key).
  std::vector<Vec3<double>> target_points(const nlohmann::json& j, const std::string& path) const {
    if (!j.is_array() || j.empty() || j.size() > 3)
      fail(path, display(path) + " must be an array of 1 to 3 points [x, y, z]");
    std::vector<Vec3<double>> out;
    for (std::size_t i = 0; i < j.size(); ++i) out.push_back(vector<3>(j[i], child_path(path, i)));
    return out;
  }
  // One positive number for every joint, or one per joint.
  Vec6<double> per_joint_positive(const nlohmann::json& j, const std::string& path) const {
    Vec6<double> v;
    if (j.is_number()) {
      v.setConstant(positive(j, path));
      return v;
    }
    if (!j.is_array()) fail(path, display(path) + " must be a number or an array of 6, not " + type_name(j));
    v = vector<6>(j, path);
    for (int i = 0; i < 6; ++i)
      if (!(v(i) > 0)) fail(child_path(path, std::size_t(i)), display(path) + " entries must be positive");
    return v;
  }
  // {"min": [...], "max": [...]} with min ≤ max elementwise.
  template <int N>
  void range(const nlohmann::json& j, const std::string& path, Eigen::Matrix<double, N, 1>& lo, Eigen::Matrix<double, N, 1>& hi) const {
    object(j, path, {"min", "max"}, {});
    lo = vector<N>(j["min"], path + "/min");
    hi = vector<N>(j["max"], path + "/max");
    for (int i = 0; i < N; ++i)
      if (!(lo(i) < hi(i)))
        fail(path, display(path) + ": min must be below max (entry " + std::to_string(i + 1) + ": " +
                       std::to_string(lo(i)) + " ≥ " + std::to_string(hi(i)) + ")");
  }

 private:
  const std::string& text_;
  const std::string& file_;
  JsonLocations loc_;
};

// Writing: points as rows [x, y, z], vectors as one array (+ 0.0: no "-0.0").
template <int N> nlohmann::json points_json(const Eigen::Matrix<double, 3, N>& m) {
  nlohmann::json a = nlohmann::json::array();
  for (int i = 0; i < N; ++i) a.push_back({m(0, i) + 0.0, m(1, i) + 0.0, m(2, i) + 0.0});
  return a;
}
template <int N> nlohmann::json vector_json(const Eigen::Matrix<double, N, 1>& v) {
  nlohmann::json a = nlohmann::json::array();
  for (int i = 0; i < N; ++i) a.push_back(v(i) + 0.0);
  return a;
}

}  // namespace kincal::identify::detail
