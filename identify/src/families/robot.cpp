#include "kincal/identify/robot.hpp"

#include <sys/stat.h>

#include <fstream>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "io/json_locator.hpp"
#include "kincal/core/compensation.hpp"
#include "kincal/core/reference_machines.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

using nlohmann::json;

// ---------------------------------------------------------------- geometry

HybridGeometry<double> make_hybrid_geometry(const HybridDesign& d) {
  // Same derivation as make_hybrid_seed000 (core/reference_machines.hpp).
  HybridGeometry<double> g;
  g.base_joints = d.base_joints;
  g.platform_joints = d.platform_joints;
  g.platform_to_wrist = d.platform_to_wrist;
  g.wrist_link = d.wrist_link;
  g.tool_length = d.tool_length;
  g.workpiece_rotation = rot_y(pi<double>() - d.beta) * rot_z(pi<double>() / 2.0);  // seed 000 Eq. (8)
  g.home = HybridPassive<double>{};
  g.home.extension = d.reference_extension;
  const HybridFrames<double> ref = hybrid_frames(g, g.home, Vec3<double>(0.0, d.beta, 0.0));
  g.workpiece_origin = ref.P;
  g.tool_offset = ref.F6.transpose() * g.workpiece_rotation.transpose();
  g.min_joint = d.min_joint;
  g.max_joint = d.max_joint;
  g.min_extension = d.min_extension;
  g.max_extension = d.max_extension;
  g.joint_offset = d.joint_offset;
  return g;
}

HybridDesign hybrid_design_of(const HybridGeometry<double>& g) {
  HybridDesign d;
  d.base_joints = g.base_joints;
  d.platform_joints = g.platform_joints;
  d.platform_to_wrist = g.platform_to_wrist;
  d.wrist_link = g.wrist_link;
  d.tool_length = g.tool_length;
  // wR0·Rz(π/2)ᵀ = Rot(y, π − β)
  const Mat3<double> ry = g.workpiece_rotation * rot_z(pi<double>() / 2.0).transpose();
  d.beta = pi<double>() - std::atan2(ry(0, 2), ry(0, 0));
  d.reference_extension = g.home.extension;
  d.min_joint = g.min_joint;
  d.max_joint = g.max_joint;
  d.min_extension = g.min_extension;
  d.max_extension = g.max_extension;
  d.joint_offset = g.joint_offset;
  return d;
}

Pose<double> Robot::home_pose() const {
  if (is_stewart()) return stewart().home;
  const HybridGeometry<double>& g = hybrid();
  const Vec3<double> ref_angles(0.0, hybrid_design_of(g).beta, 0.0);
  return hybrid_tool_pose(g, hybrid_frames(g, g.home, ref_angles));
}

Vec6<double> Robot::correction_bound() const {
  if (max_correction) return *max_correction;
  const TableBounds<double> b = is_stewart() ? default_bounds(stewart()) : default_bounds(hybrid());
  Vec6<double> v;
  for (int i = 0; i < 6; ++i) v(i) = b.max_correction[i];
  return v;
}

void Robot::joint_limits(Vec6<double>& lo, Vec6<double>& hi) const {
  lo = is_stewart() ? stewart().min_length : hybrid().min_joint;
  hi = is_stewart() ? stewart().max_length : hybrid().max_joint;
}

Status Robot::inverse(const Pose<double>& pose, Vec6<double>& q) const {
  return is_stewart() ? stewart_ik(stewart(), pose, q) : hybrid_ik(hybrid(), pose, q);
}

// ---------------------------------------------------------------- built-ins

bool is_builtin_robot(const std::string& name) { return name == "stewart-seed001" || name == "hybrid-seed000"; }

Robot builtin_robot(const std::string& name) {
  Robot r;
  r.name = name;
  if (name == "stewart-seed001") {
    r.geometry = make_stewart_seed001<double>();
  } else if (name == "hybrid-seed000") {
    r.geometry = make_hybrid_seed000<double>();
    r.gauge_radius = HybridSeed000Dimensions::gauge_radius;
  } else {
    throw InputError("unknown built-in robot '" + name + "' (built-ins: stewart-seed001, hybrid-seed000)");
  }
  return r;
}

Robot load_robot(const std::string& name_or_path) {
  if (is_builtin_robot(name_or_path)) return builtin_robot(name_or_path);
  if (name_or_path.empty()) throw InputError("empty robot name");
  struct stat st {};
  if (::stat(name_or_path.c_str(), &st) != 0)
    throw InputError(name_or_path, 0, 0,
                     "neither a built-in robot (stewart-seed001, hybrid-seed000) nor a readable robot description file");
  return parse_robot(read_text_file(name_or_path), name_or_path);
}

// ---------------------------------------------------------------- parsing

namespace {

const char* type_name(const json& j) {
  switch (j.type()) {
    case json::value_t::null: return "null";
    case json::value_t::object: return "an object";
    case json::value_t::array: return "an array";
    case json::value_t::string: return "a string";
    case json::value_t::boolean: return "a boolean";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float: return "a number";
    default: return "an unsupported value";
  }
}

std::string display(const std::string& path) { return path.empty() ? "the document" : "'" + path.substr(1) + "'"; }

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : ", ") + s;
  return out;
}

// Schema checks with positions: every error names file, line and column.
class Reader {
 public:
  Reader(const std::string& text, const std::string& file) : text_(text), file_(file), loc_(detail::locate_json(text)) {}

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
  const json& object(const json& j, const std::string& path, const std::vector<std::string>& required,
                     const std::vector<std::string>& optional) const {
    if (!j.is_object()) fail(path, display(path) + " must be an object, not " + type_name(j));
    std::vector<std::string> unknown;
    std::size_t first_unknown = std::string::npos;
    for (auto it = j.begin(); it != j.end(); ++it) {
      const std::string& k = it.key();
      if (std::find(required.begin(), required.end(), k) == required.end() &&
          std::find(optional.begin(), optional.end(), k) == optional.end()) {
        unknown.push_back("'" + k + "'");
        first_unknown = std::min(first_unknown, loc_.key_offset(detail::child_path(path, k)));
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

  // Every number of a description is a length in mm, an angle in rad or a
  // ratio: none of a parallel machine reaches a kilometre. Larger is a typo
  // or a unit mistake (the audit's 1e9 mm stroke passed before).
  double number(const json& j, const std::string& path) const {
    if (!j.is_number()) fail(path, display(path) + " must be a number, not " + type_name(j));
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(path, display(path) + " must be finite");
    if (!(std::abs(v) <= 1e6)) fail(path, display(path) + " is beyond 1e6 (a kilometre in mm): a typo or a unit mistake");
    return v;
  }
  // A pose angle: radians of one turn at most (as in the CSV files).
  double angle(const json& j, const std::string& path) const {
    const double v = number(j, path);
    if (!(std::abs(v) <= 2 * pi<double>())) fail(path, display(path) + " is more than a turn (2 pi rad): angles are in radians");
    return v;
  }
  double non_negative(const json& j, const std::string& path) const {
    const double v = number(j, path);
    if (v < 0) fail(path, display(path) + " is a length and must not be negative");
    return v;
  }
  double positive(const json& j, const std::string& path) const {
    const double v = number(j, path);
    if (!(v > 0)) fail(path, display(path) + " must be positive");
    return v;
  }
  std::string string(const json& j, const std::string& path) const {
    if (!j.is_string()) fail(path, display(path) + " must be a string, not " + type_name(j));
    return j.get<std::string>();
  }
  void array_of(const json& j, const std::string& path, std::size_t n) const {
    if (!j.is_array()) fail(path, display(path) + " must be an array of " + std::to_string(n) + ", not " + type_name(j));
    if (j.size() != n)
      fail(path, display(path) + " must have " + std::to_string(n) + " entries, not " + std::to_string(j.size()));
  }
  template <int N> Eigen::Matrix<double, N, 1> vector(const json& j, const std::string& path) const {
    array_of(j, path, N);
    Eigen::Matrix<double, N, 1> v;
    for (int i = 0; i < N; ++i) v(i) = number(j[static_cast<std::size_t>(i)], detail::child_path(path, static_cast<std::size_t>(i)));
    return v;
  }
  // n points [x, y, z] as the columns of a 3×n matrix.
  template <int N> Eigen::Matrix<double, 3, N> points(const json& j, const std::string& path) const {
    array_of(j, path, N);
    Eigen::Matrix<double, 3, N> m;
    for (int i = 0; i < N; ++i) {
      const std::size_t si = static_cast<std::size_t>(i);
      m.col(i) = vector<3>(j[si], detail::child_path(path, si));
    }
    return m;
  }
  // 1–3 points [x, y, z] (the `targets` key).
  std::vector<Vec3<double>> target_points(const json& j, const std::string& path) const {
    if (!j.is_array() || j.empty() || j.size() > 3)
      fail(path, display(path) + " must be an array of 1 to 3 points [x, y, z]");
    std::vector<Vec3<double>> out;
    for (std::size_t i = 0; i < j.size(); ++i) out.push_back(vector<3>(j[i], detail::child_path(path, i)));
    return out;
  }
  // One positive number for every joint, or one per joint.
  Vec6<double> per_joint_positive(const json& j, const std::string& path) const {
    Vec6<double> v;
    if (j.is_number()) {
      v.setConstant(positive(j, path));
      return v;
    }
    if (!j.is_array()) fail(path, display(path) + " must be a number or an array of 6, not " + type_name(j));
    v = vector<6>(j, path);
    for (int i = 0; i < 6; ++i)
      if (!(v(i) > 0)) fail(detail::child_path(path, std::size_t(i)), display(path) + " entries must be positive");
    return v;
  }
  // {"min": [...], "max": [...]} with min ≤ max elementwise.
  template <int N>
  void range(const json& j, const std::string& path, Eigen::Matrix<double, N, 1>& lo, Eigen::Matrix<double, N, 1>& hi) const {
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
  detail::JsonLocations loc_;
};

const std::vector<std::string> kCommonRequired = {"format", "version", "family", "name", "units"};

Robot parse_stewart(const json& doc, const Reader& r) {
  r.object(doc, "",
           {"format", "version", "family", "name", "units", "base_joints", "platform_joints", "stroke", "home"},
           {"length_offset", "screw_lead", "max_correction", "targets"});
  Robot robot;
  StewartGeometry<double> g;
  g.base = r.points<6>(doc["base_joints"], "/base_joints");
  g.platform = r.points<6>(doc["platform_joints"], "/platform_joints");
  r.range<6>(doc["stroke"], "/stroke", g.min_length, g.max_length);
  for (int i = 0; i < 6; ++i)
    if (g.min_length(i) < 0) r.fail("/stroke/min/" + std::to_string(i), "'stroke/min' is a leg length and must not be negative");
  g.length_offset = doc.contains("length_offset") ? r.vector<6>(doc["length_offset"], "/length_offset") : Vec6<double>::Zero();
  const json& home = r.object(doc["home"], "/home", {"x", "y", "z", "rx", "ry", "rz"}, {});
  g.home = Pose<double>::from_xyz_rpy(r.number(home["x"], "/home/x"), r.number(home["y"], "/home/y"),
                                      r.number(home["z"], "/home/z"), r.angle(home["rx"], "/home/rx"),
                                      r.angle(home["ry"], "/home/ry"), r.angle(home["rz"], "/home/rz"));
  if (doc.contains("screw_lead")) robot.screw_lead = r.positive(doc["screw_lead"], "/screw_lead");
  if (doc.contains("max_correction")) robot.max_correction = r.per_joint_positive(doc["max_correction"], "/max_correction");
  if (doc.contains("targets")) robot.targets = r.target_points(doc["targets"], "/targets");
  robot.geometry = g;
  Vec6<double> q;
  // With the Jacobian: a geometry whose legs cannot hold the platform (six
  // base joints at one point, collinear platform joints, …) is singular at
  // every pose, and simulate would otherwise report measured == commanded.
  Mat6<double> J;
  const Status s = stewart_ik(g, g.home, q, &J);
  if (s == Status::Singular)
    r.fail("/base_joints", "the geometry is singular at its home pose: the legs cannot hold the platform (joints "
                           "at one point or on one line?)");
  if (s != Status::Ok) r.fail("/home", std::string("the home pose is not reachable: ") + to_string(s));
  return robot;
}

Robot parse_hybrid(const json& doc, const Reader& r) {
  r.object(doc, "",
           {"format", "version", "family", "name", "units", "base_joints", "platform_joints", "platform_to_wrist",
            "wrist_link", "tool_length", "beta", "reference_extension", "joint_limits", "extension_limits"},
           {"joint_offset", "gauge_radius", "screw_lead", "max_correction", "targets"});
  Robot robot;
  HybridDesign d;
  d.base_joints = r.points<3>(doc["base_joints"], "/base_joints");
  d.platform_joints = r.points<3>(doc["platform_joints"], "/platform_joints");
  d.platform_to_wrist = r.non_negative(doc["platform_to_wrist"], "/platform_to_wrist");
  d.wrist_link = r.non_negative(doc["wrist_link"], "/wrist_link");
  d.tool_length = r.positive(doc["tool_length"], "/tool_length");
  d.beta = r.number(doc["beta"], "/beta");
  if (!(std::abs(d.beta) < pi<double>() / 2)) r.fail("/beta", "'beta' must lie in (-pi/2, pi/2) rad");
  d.reference_extension = r.positive(doc["reference_extension"], "/reference_extension");
  r.range<6>(doc["joint_limits"], "/joint_limits", d.min_joint, d.max_joint);
  for (int i = 0; i < 3; ++i)
    if (d.min_joint(i) < 0)
      r.fail("/joint_limits/min/" + std::to_string(i), "'joint_limits/min' of a UPS limb is a length and must not be negative");
  const json& ext = r.object(doc["extension_limits"], "/extension_limits", {"min", "max"}, {});
  d.min_extension = r.non_negative(ext["min"], "/extension_limits/min");
  d.max_extension = r.number(ext["max"], "/extension_limits/max");
  if (!(d.min_extension < d.max_extension)) r.fail("/extension_limits", "'extension_limits': min must be below max");
  d.joint_offset = doc.contains("joint_offset") ? r.vector<6>(doc["joint_offset"], "/joint_offset") : Vec6<double>::Zero();
  robot.gauge_radius = doc.contains("gauge_radius") ? r.positive(doc["gauge_radius"], "/gauge_radius")
                                                    : HybridSeed000Dimensions::gauge_radius;
  if (doc.contains("screw_lead")) robot.screw_lead = r.positive(doc["screw_lead"], "/screw_lead");
  if (doc.contains("max_correction")) robot.max_correction = r.per_joint_positive(doc["max_correction"], "/max_correction");
  if (doc.contains("targets")) robot.targets = r.target_points(doc["targets"], "/targets");
  robot.geometry = make_hybrid_geometry(d);
  Vec6<double> q;
  // With the Jacobian: degenerate joint layouts (base or platform joints at
  // one point or on one line) are singular at the reference pose.
  Mat6<double> J;
  const Status s = hybrid_ik(robot.hybrid(), robot.home_pose(), q, &J);
  if (s == Status::Singular)
    r.fail("/base_joints", "the geometry is singular at its reference pose: the UPS limbs cannot hold the platform "
                           "(joints at one point or on one line?)");
  if (s != Status::Ok)
    r.fail("/reference_extension", std::string("the reference pose is not reachable: ") + to_string(s));
  return robot;
}

}  // namespace

Robot parse_robot(const std::string& text, const std::string& file) {
  const json doc = detail::parse_json_text(text, file);
  const Reader r(text, file);
  r.check_duplicates();
  if (!doc.is_object()) r.fail("", "a robot description must be a JSON object, not " + std::string(type_name(doc)));
  for (const auto& k : kCommonRequired)
    if (!doc.contains(k)) r.fail("", "missing key '" + k + "' in the document");
  if (r.string(doc["format"], "/format") != "kincal-robot")
    r.fail("/format", "'format' must be \"kincal-robot\"");
  if (!doc["version"].is_number_integer() || doc["version"].get<long long>() != 1)
    r.fail("/version", "unsupported robot description version (this tool reads version 1)");
  const std::string name = r.string(doc["name"], "/name");
  if (name.empty()) r.fail("/name", "'name' must not be empty");
  r.object(doc["units"], "/units", {"length", "angle"}, {});
  if (r.string(doc["units"]["length"], "/units/length") != "mm")
    r.fail("/units/length", "unsupported length unit (only \"mm\")");
  if (r.string(doc["units"]["angle"], "/units/angle") != "rad")
    r.fail("/units/angle", "unsupported angle unit (only \"rad\")");
  const std::string family = r.string(doc["family"], "/family");
  Robot robot;
  if (family == kStewartFamily)
    robot = parse_stewart(doc, r);
  else if (family == kHybridFamily)
    robot = parse_hybrid(doc, r);
  else
    r.fail("/family", "unknown family '" + family + "' (known: " + kStewartFamily + ", " + kHybridFamily + ")");
  robot.name = name;
  return robot;
}

// ---------------------------------------------------------------- writing

namespace {

template <int N> json points_json(const Eigen::Matrix<double, 3, N>& m) {
  json a = json::array();
  for (int i = 0; i < N; ++i) a.push_back({m(0, i) + 0.0, m(1, i) + 0.0, m(2, i) + 0.0});  // + 0.0: no "-0.0"
  return a;
}
template <int N> json vector_json(const Eigen::Matrix<double, N, 1>& v) {
  json a = json::array();
  for (int i = 0; i < N; ++i) a.push_back(v(i) + 0.0);
  return a;
}

// Pretty printer: objects one key per line, arrays of numbers on one line, so
// a description reads like a table and is easy to edit by hand.
void write_pretty(const nlohmann::ordered_json& j, int indent, std::string& out) {
  const std::string pad(static_cast<std::size_t>(indent + 2), ' ');
  if (j.is_object()) {
    out += "{\n";
    std::size_t k = 0;
    for (auto it = j.begin(); it != j.end(); ++it, ++k) {
      out += pad + nlohmann::ordered_json(it.key()).dump() + ": ";
      write_pretty(it.value(), indent + 2, out);
      out += (k + 1 < j.size() ? ",\n" : "\n");
    }
    out += std::string(static_cast<std::size_t>(indent), ' ') + "}";
  } else if (j.is_array() && std::any_of(j.begin(), j.end(), [](const auto& e) { return e.is_structured(); })) {
    out += "[\n";
    for (std::size_t k = 0; k < j.size(); ++k) {
      out += pad;
      write_pretty(j[k], indent + 2, out);
      out += (k + 1 < j.size() ? ",\n" : "\n");
    }
    out += std::string(static_cast<std::size_t>(indent), ' ') + "]";
  } else if (j.is_array()) {
    out += "[";
    for (std::size_t k = 0; k < j.size(); ++k) out += (k ? ", " : "") + j[k].dump();
    out += "]";
  } else {
    out += j.dump();
  }
}

}  // namespace

std::string robot_to_json(const Robot& robot) {
  // nlohmann keeps insertion order only with ordered_json; use it so the file
  // reads top-down like docs/formats.md.
  nlohmann::ordered_json j;
  j["format"] = "kincal-robot";
  j["version"] = 1;
  j["family"] = robot.family();
  j["name"] = robot.name;
  j["units"] = {{"length", "mm"}, {"angle", "rad"}};
  if (robot.is_stewart()) {
    const StewartGeometry<double>& g = robot.stewart();
    j["base_joints"] = points_json<6>(g.base);
    j["platform_joints"] = points_json<6>(g.platform);
    j["stroke"] = {{"min", vector_json<6>(g.min_length)}, {"max", vector_json<6>(g.max_length)}};
    j["length_offset"] = vector_json<6>(g.length_offset);
    const Vec6<double> h = g.home.to_xyz_rpy() + Vec6<double>::Zero();
    j["home"] = {{"x", h(0)}, {"y", h(1)}, {"z", h(2)}, {"rx", h(3)}, {"ry", h(4)}, {"rz", h(5)}};
  } else {
    const HybridDesign d = hybrid_design_of(robot.hybrid());
    j["base_joints"] = points_json<3>(d.base_joints);
    j["platform_joints"] = points_json<3>(d.platform_joints);
    j["platform_to_wrist"] = d.platform_to_wrist;
    j["wrist_link"] = d.wrist_link;
    j["tool_length"] = d.tool_length;
    j["beta"] = d.beta;
    j["reference_extension"] = d.reference_extension;
    j["joint_limits"] = {{"min", vector_json<6>(d.min_joint)}, {"max", vector_json<6>(d.max_joint)}};
    j["extension_limits"] = {{"min", d.min_extension}, {"max", d.max_extension}};
    j["joint_offset"] = vector_json<6>(d.joint_offset);
    j["gauge_radius"] = robot.gauge_radius;
  }
  j["screw_lead"] = robot.screw_lead;
  if (robot.max_correction) {
    const Vec6<double>& m = *robot.max_correction;
    if ((m.array() == m(0)).all())
      j["max_correction"] = m(0);
    else
      j["max_correction"] = vector_json<6>(m);
  }
  if (!robot.targets.empty()) {
    nlohmann::ordered_json t = nlohmann::ordered_json::array();
    for (const Vec3<double>& p : robot.targets) t.push_back({p.x(), p.y(), p.z()});
    j["targets"] = t;
  }
  std::string out;
  write_pretty(j, 0, out);
  return out + "\n";
}

std::string robot_summary(const Robot& robot) {
  std::ostringstream os;
  os << std::setprecision(10);
  os << "name:    " << robot.name << "\n"
     << "family:  " << robot.family() << " (" << Robot::joint_count() << " actuated joints)\n";
  const Vec6<double> home = robot.home_pose().to_xyz_rpy();
  if (robot.is_stewart()) {
    const StewartGeometry<double>& g = robot.stewart();
    os << "base joints B_i (mm):\n";
    for (int i = 0; i < 6; ++i) os << "  " << i + 1 << ": " << g.base.col(i).transpose() << "\n";
    os << "platform joints P_i (mm, platform frame):\n";
    for (int i = 0; i < 6; ++i) os << "  " << i + 1 << ": " << g.platform.col(i).transpose() << "\n";
    os << "stroke q (mm): [" << g.min_length.minCoeff() << ", " << g.max_length.maxCoeff() << "]\n";
  } else {
    const HybridDesign d = hybrid_design_of(robot.hybrid());
    os << "UPS base joints A1i (mm):\n";
    for (int i = 0; i < 3; ++i) os << "  " << i + 1 << ": " << d.base_joints.col(i).transpose() << "\n";
    os << "UPS platform joints a_i (mm, platform frame):\n";
    for (int i = 0; i < 3; ++i) os << "  " << i + 1 << ": " << d.platform_joints.col(i).transpose() << "\n";
    os << "|A64 Q| = " << d.platform_to_wrist << " mm, |Q P0| = " << d.wrist_link << " mm, |P0 P| = " << d.tool_length
       << " mm, beta = " << d.beta << " rad, reference extension = " << d.reference_extension << " mm\n"
       << "gauge radius |P0 Pj| = " << robot.gauge_radius << " mm\n";
  }
  os << "home pose (x y z rx ry rz): " << home.transpose() << "\n";
  Vec6<double> q;
  const Status s = robot.inverse(robot.home_pose(), q);
  if (s == Status::Ok)
    os << "joints at home:             " << q.transpose() << "\n";
  else
    os << "joints at home: " << to_string(s) << "\n";
  return os.str();
}

}  // namespace kincal::identify
