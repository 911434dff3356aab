#include "kincal/identify/model.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <string_view>
#include <nlohmann/json.hpp>

#include "families/family.hpp"
#include "io/json_locator.hpp"
#include "kincal/identify/files.hpp"

#include "kincal/identify/input_error.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/version.hpp"

namespace kincal::identify {

namespace {

constexpr const char* kModelFormat = "kincal-model";
constexpr int kModelVersion = 1;

using nlohmann::json;

}  // namespace

Robot calibrated_robot(const CalibrationModel& model) {
  ParameterSet set;
  for (const ModelParameter& p : model.parameters) set.values.push_back({p.name, p.value, 0});
  return apply_parameters(model.nominal, set);
}

std::string model_to_json(const CalibrationModel& model) {
  json j;
  j["format"] = kModelFormat;
  j["version"] = kModelVersion;
  j["generator"] = std::string("kincal ") + kVersion;
  j["robot"] = json::parse(robot_to_json(model.nominal));
  j["data"] = model.data_file;
  j["estimator"] = {{"name", model.estimator}, {"settings", model.settings}};
  json params = json::array();
  for (const ModelParameter& p : model.parameters)
    params.push_back({{"name", p.name}, {"value", p.value}, {"standard_error", p.standard_error},
                      {"identifiable", p.identifiable}});
  j["parameters"] = params;
  // Physical effects (identify/effects.hpp): {"scale": {"s1": 1e-4, ...}, ...}.
  json effects = json::object();
  for (const auto& [name, values] : model.effects.values) {
    const Effect* e = find_effect(model.nominal, name);
    if (e == nullptr) continue;
    const std::vector<std::string> names = e->parameter_names(model.nominal);
    json v = json::object();
    for (std::size_t i = 0; i < names.size() && Eigen::Index(i) < values.size(); ++i) v[names[i]] = values(Eigen::Index(i));
    effects[name] = v;
  }
  if (!effects.empty()) j["effects"] = effects;
  // The laser tracker (stewart_target_calibration.hpp): registration and targets.
  if (!model.instrument.empty()) {
    json inst = json::array();
    for (const ModelParameter& p : model.instrument)
      inst.push_back({{"name", p.name}, {"value", p.value}, {"standard_error", p.standard_error},
                      {"identified", p.identifiable}});
    j["instrument"] = inst;
  }
  return j.dump(2) + "\n";
}

void write_model_file(const CalibrationModel& model, const std::string& path, const std::vector<std::string>& inputs) {
  write_output_file(path, model_to_json(model), inputs);
}

namespace {
class ModelReader;
}
static CalibrationModel parse_model_json(const json& j, const ModelReader& r, const std::string& file);

namespace {

// MODEL.json's schema checks with positions (issue #10 items 9, 11): every
// error names file, line and column; duplicate keys anywhere (the embedded
// robot included), a parameter given twice, or the hybrid's encoder offset
// under both of its names are errors, never silently summed or overridden.
class ModelReader {
 public:
  ModelReader(const std::string& text, const std::string& file)
      : text_(text), file_(file), loc_(detail::locate_json(text)) {}

  TextPosition position(const std::string& path) const { return position_of(text_, loc_.value_offset(path)); }
  [[noreturn]] void fail(const std::string& path, const std::string& message) const {
    const TextPosition p = position(path);
    throw InputError(file_, p.line, p.column, message);
  }
  void check_duplicates() const {
    if (loc_.duplicates.empty()) return;
    const TextPosition p = position_of(text_, loc_.duplicates.front().offset);
    throw InputError(file_, p.line, p.column, "duplicate key \"" + loc_.duplicates.front().path + "\"");
  }
  const json& require(const json& j, const std::string& path, const char* key) const {
    if (!j.is_object()) fail(path, (path.empty() ? std::string("a model file") : path) + " must be a JSON object");
    const auto it = j.find(key);
    if (it == j.end()) fail(path, std::string("missing key \"") + key + "\"");
    return *it;
  }
  std::string string(const json& j, const std::string& path) const {
    if (!j.is_string()) fail(path, path + " must be a string");
    return j.get<std::string>();
  }
  double finite_number(const json& j, const std::string& path, const std::string& what) const {
    if (!j.is_number()) fail(path, what + " must be a number");
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(path, what + " is not finite");
    return v;
  }

 private:
  const std::string& text_;
  const std::string& file_;
  detail::JsonLocations loc_;
};

}  // namespace

CalibrationModel parse_model(const std::string& text, const std::string& file) {
  const json j = detail::parse_json_text(text, file);
  const ModelReader r(text, file);
  r.check_duplicates();
  try {
    return parse_model_json(j, r, file);
  } catch (const json::exception& e) {  // a value of the wrong type
    throw InputError(file, 0, 0, std::string("malformed model: ") + e.what());
  }
}

static CalibrationModel parse_model_json(const json& j, const ModelReader& r, const std::string& file) {
  if (!j.is_object()) r.fail("", "a model file is a JSON object");
  if (r.require(j, "", "format") != kModelFormat)
    r.fail("/format", std::string("\"format\" must be \"") + kModelFormat + "\"");
  if (r.require(j, "", "version") != kModelVersion)
    r.fail("/version", "unsupported model version (this kincal reads version 1)");
  CalibrationModel m;
  try {
    m.nominal = parse_robot(r.require(j, "", "robot").dump(), file);
  } catch (const InputError& e) {
    r.fail("/robot", "robot: " + e.message());
  }
  const json& est = r.require(j, "", "estimator");
  m.estimator = r.string(r.require(est, "/estimator", "name"), "/estimator/name");
  if (const auto s = est.find("settings"); s != est.end()) {
    if (!s->is_object()) r.fail("/estimator/settings", "\"settings\" must be an object");
    for (const auto& [k, v] : s->items())
      m.settings[k] = r.finite_number(v, "/estimator/settings/" + k, "estimator setting " + k);
  }
  m.source_file = file;
  if (const auto d = j.find("data"); d != j.end() && d->is_string()) m.data_file = d->get<std::string>();
  const json& params = r.require(j, "", "parameters");
  if (!params.is_array()) r.fail("/parameters", "\"parameters\" must be an array");
  const std::vector<std::string> valid = parameter_names(m.nominal);
  std::map<std::string, std::size_t> seen;  // name → index
  for (std::size_t k = 0; k < params.size(); ++k) {
    const json& p = params[k];
    const std::string at = "/parameters/" + std::to_string(k);
    ModelParameter mp;
    mp.name = r.string(r.require(p, at, "name"), at + "/name");
    if (std::find(valid.begin(), valid.end(), mp.name) == valid.end())
      r.fail(at + "/name", "unknown parameter \"" + mp.name + "\" for a " + m.nominal.family() + " robot");
    if (const auto it = seen.find(mp.name); it != seen.end())
      r.fail(at, "parameter \"" + mp.name + "\" is given twice (also entry " + std::to_string(it->second + 1) + ")");
    if (const std::string alias = family_of(m.nominal).error_model().alias_of(mp.name); !alias.empty())
      if (const auto it = seen.find(alias); it != seen.end())
        r.fail(at, "parameter \"" + mp.name + "\" is the same encoder offset as \"" + it->first + "\" (entry " +
                       std::to_string(it->second + 1) + "); give it once");
    seen[mp.name] = k;
    mp.value = r.finite_number(r.require(p, at, "value"), at + "/value", "value of " + mp.name);
    m.value_positions[mp.name] = r.position(at + "/value");
    if (const auto se = p.find("standard_error"); se != p.end()) {
      mp.standard_error = r.finite_number(*se, at + "/standard_error", "standard_error of " + mp.name);
      if (mp.standard_error < 0) r.fail(at + "/standard_error", "standard_error of " + mp.name + " is negative");
    }
    if (const auto id = p.find("identifiable"); id != p.end() && id->is_boolean()) mp.identifiable = id->get<bool>();
    m.parameters.push_back(mp);
  }
  if (const auto effects = j.find("effects"); effects != j.end()) {
    if (!effects->is_object()) r.fail("/effects", "\"effects\" must be an object of effect name -> {parameter: value}");
    for (const auto& [name, params_of] : effects->items()) {
      const std::string at = "/effects/" + name;
      if (!params_of.is_object()) r.fail(at, "effect \"" + name + "\" must be an object of parameter -> value");
      for (const auto& [pname, value] : params_of.items()) {
        const double v = r.finite_number(value, at + "/" + pname, "effect " + name + ":" + pname);
        try {
          m.effects.set(m.nominal, name, pname, v);
        } catch (const InputError& e) {
          r.fail(at + "/" + pname, e.message());
        }
        m.value_positions[name + ":" + pname] = r.position(at + "/" + pname);
      }
    }
  }
  if (const auto inst = j.find("instrument"); inst != j.end()) {
    if (!inst->is_array()) r.fail("/instrument", "\"instrument\" must be an array of {name, value, standard_error}");
    for (std::size_t k = 0; k < inst->size(); ++k) {
      const json& p = (*inst)[k];
      const std::string at = "/instrument/" + std::to_string(k);
      ModelParameter mp;
      mp.name = r.string(r.require(p, at, "name"), at + "/name");
      if (!is_instrument_parameter(mp.name))
        r.fail(at + "/name", "unknown instrument parameter \"" + mp.name + "\" (reg_x .. reg_rz, t1x .. t3z)");
      mp.value = r.finite_number(r.require(p, at, "value"), at + "/value", "value of " + mp.name);
      if (const auto se = p.find("standard_error"); se != p.end())
        mp.standard_error = r.finite_number(*se, at + "/standard_error", "standard_error of " + mp.name);
      if (const auto id = p.find("identified"); id != p.end() && id->is_boolean()) mp.identifiable = id->get<bool>();
      m.instrument.push_back(mp);
    }
  }
  return m;
}

bool is_instrument_parameter(const std::string& name) {
  for (const char* c : {"reg_x", "reg_y", "reg_z", "reg_rx", "reg_ry", "reg_rz"})
    if (name == c) return true;
  return name.size() == 3 && name[0] == 't' && name[1] >= '1' && name[1] <= '3' &&
         std::string_view("xyz").find(name[2]) != std::string_view::npos;
}

CalibrationModel read_model_file(const std::string& path) { return parse_model(read_text_file(path), path); }

}  // namespace kincal::identify
