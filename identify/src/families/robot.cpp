#include "kincal/identify/robot.hpp"

#include <sys/stat.h>

#include <fstream>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>
#include <utility>
#include <vector>

#include "kincal/identify/formula_candidate.hpp"
#include "families/description_reader.hpp"
#include "families/family.hpp"
#include "io/json_locator.hpp"
#include "kincal/core/compensation.hpp"
#include "kincal/core/formula_effects.hpp"
#include "kincal/core/reference_machines.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

using nlohmann::json;

// ---------------------------------------------------------------- the family's answers

const char* Robot::family() const { return family_of(*this).name(); }
Pose<double> Robot::home_pose() const { return family_of(*this).kinematics().home_pose(*this); }

Vec6<double> Robot::correction_bound() const {
  if (max_correction) return *max_correction;
  const TableBounds<double> b = family_of(*this).table().default_bounds(*this);
  Vec6<double> v;
  for (int i = 0; i < 6; ++i) v(i) = b.max_correction[i];
  return v;
}

void Robot::joint_limits(Vec6<double>& lo, Vec6<double>& hi) const { family_of(*this).kinematics().joint_limits(*this, lo, hi); }

Status Robot::inverse(const Pose<double>& pose, Vec6<double>& q) const {
  return family_of(*this).kinematics().inverse(*this, pose, q);
}

bool Robot::revolute(int joint) const { return family_of(*this).kinematics().revolute(joint); }
const char* Robot::target_body() const { return family_of(*this).kinematics().target_body(); }
const char* Robot::error_model() const { return family_of(*this).error_model().name(); }
Eigen::Index Robot::outlier_min_nodes() const { return family_of(*this).error_model().outlier_min_nodes(); }

std::vector<FamilyFormulaVariable> family_formula_variables(const Robot& robot) {
  return family_of(robot).kinematics().formula_joint_variables();
}
bool family_formula_values(const Robot& robot, const Pose<double>& pose, double* values) {
  return family_of(robot).kinematics().formula_joint_values(robot, pose, values);
}

// ---------------------------------------------------------------- built-ins

bool is_builtin_robot(const std::string& name) {
  return name == "stewart-seed001" || name == "hybrid-seed000" || name == "rus6-ref";
}

Robot builtin_robot(const std::string& name) {
  Robot r;
  r.name = name;
  if (name == "stewart-seed001") {
    r.family_data = StewartDescription{make_stewart_seed001<double>()};
  } else if (name == "hybrid-seed000") {
    HybridDescription h;
    h.geometry = make_hybrid_seed000<double>();
    h.gauge_radius = HybridSeed000Dimensions::gauge_radius;
    r.family_data = h;
  } else if (name == "rus6-ref") {
    r.family_data = Rus6Description{make_rus6_ref<double>()};
    r.screw_lead = Rus6RefDimensions::cyclic_period;
  } else {
    throw InputError("unknown built-in robot '" + name + "' (built-ins: stewart-seed001, hybrid-seed000, rus6-ref)");
  }
  return r;
}

Robot load_robot(const std::string& name_or_path) {
  if (is_builtin_robot(name_or_path)) return builtin_robot(name_or_path);
  if (name_or_path.empty()) throw InputError("empty robot name");
  struct stat st {};
  if (::stat(name_or_path.c_str(), &st) != 0)
    throw InputError(name_or_path, 0, 0,
                     "neither a built-in robot (stewart-seed001, hybrid-seed000, rus6-ref) nor a readable robot description file");
  return parse_robot(read_text_file(name_or_path), name_or_path);
}

// ---------------------------------------------------------------- parsing

namespace {

const std::vector<std::string> kCommonRequired = {"format", "version", "family", "name", "units"};

// The `effects` key: compiled (formula_effect.hpp, every error with the
// file, line and column), wrapped as candidates whose numbers follow one
// another in core's user slot, their inputs gathered into one list.
void read_formula_effects_into(Robot& robot, const json& doc, const std::string& text, const std::string& file) {
  if (!doc.contains("effects")) return;
  FormulaContext context;
  context.joint_count = Robot::joint_count();
  context.max_inputs = kFormulaInputs;
  for (const FamilyFormulaVariable& v : family_formula_variables(robot)) context.family_joint_variables.push_back(v.name);
  std::vector<FormulaEffect> effects = read_formula_effects(text, file, context);
  const detail::DescriptionReader r(text, file);
  int offset = 0;
  for (FormulaEffect& e : effects) {
    for (const std::string& in : e.spec().inputs)
      if (std::find(robot.formula_inputs.begin(), robot.formula_inputs.end(), in) == robot.formula_inputs.end())
        robot.formula_inputs.push_back(in);
    const int n = int(e.parameter_names().size());
    auto shared = std::make_shared<const FormulaEffect>(std::move(e));
    robot.formula_effects.push_back(std::make_shared<const FormulaCandidate>(shared, offset));
    offset += n;
  }
  if (offset > kUserEffectParameters)
    r.fail("/effects", "the formula effects have " + std::to_string(offset) + " parameters; the controller's table holds " +
                           std::to_string(kUserEffectParameters) + " (core's user slot)");
  robot.effects_json = doc["effects"].dump();
}

}  // namespace

Robot parse_robot(const std::string& text, const std::string& file) {
  const json doc = detail::parse_json_text(text, file);
  const detail::DescriptionReader r(text, file);
  r.check_duplicates();
  if (!doc.is_object()) r.fail("", "a robot description must be a JSON object, not " + std::string(detail::type_name(doc)));
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
  const Family* f = family_named(family);
  if (f == nullptr) r.fail("/family", "unknown family '" + family + "' (known: " + family_names() + ")");
  Robot robot = f->description().parse(doc, r);
  robot.name = name;
  read_formula_effects_into(robot, doc, text, file);
  // The controller's hybrid statics take a weight at the tool point only
  // (core/compensation.hpp prepare): an off-centre payload would be fitted
  // and compensated with different loads.
  if (robot.is_hybrid() && !robot.payload_com.isZero())
    r.fail("/payload/com", "the hybrid's payload acts at the tool point: 'com' must be [0, 0, 0] (not yet supported elsewhere)");
  return robot;
}

// ---------------------------------------------------------------- writing

namespace {

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
  family_of(robot).description().write(robot, j);
  j["screw_lead"] = robot.screw_lead;
  if (robot.max_correction) {
    const Vec6<double>& m = *robot.max_correction;
    if ((m.array() == m(0)).all())
      j["max_correction"] = m(0);
    else
      j["max_correction"] = detail::vector_json<6>(m);
  }
  // Only the caps a description set: one without them reads and writes as
  // before.
  for (const auto& [key, cap] : {std::pair{"max_geometry_error", &robot.max_geometry_error},
                                 std::pair{"max_angle_error", &robot.max_angle_error},
                                 std::pair{"max_scale", &robot.max_scale}, std::pair{"max_thermal", &robot.max_thermal}})
    if (*cap) j[key] = **cap;
  if (!robot.targets.empty()) {
    nlohmann::ordered_json t = nlohmann::ordered_json::array();
    for (const Vec3<double>& p : robot.targets) t.push_back({p.x(), p.y(), p.z()});
    j["targets"] = t;
  }
  if (robot.has_payload)
    j["payload"] = {{"weight", robot.payload_weight},
                    {"com", {robot.payload_com.x(), robot.payload_com.y(), robot.payload_com.z()}}};
  if (!robot.effects_json.empty()) j["effects"] = nlohmann::ordered_json::parse(robot.effects_json);
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
  family_of(robot).description().summarize(robot, os);
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
