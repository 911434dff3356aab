#include "kincal/identify/model.hpp"

#include "kincal/identify/files.hpp"

#include <cmath>
#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>

#include "kincal/identify/input_error.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/version.hpp"

namespace kincal::identify {

namespace {

constexpr const char* kModelFormat = "kincal-model";
constexpr int kModelVersion = 1;

using nlohmann::json;

[[noreturn]] void fail(const std::string& file, const std::string& message) { throw InputError(file, 0, 0, message); }

const json& require(const json& j, const char* key, const std::string& file) {
  const auto it = j.find(key);
  if (it == j.end()) fail(file, std::string("missing key \"") + key + "\"");
  return *it;
}

double finite_number(const json& j, const std::string& what, const std::string& file) {
  if (!j.is_number()) fail(file, what + " must be a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) fail(file, what + " is not finite");
  return v;
}

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
    const Effect* e = find_effect(name);
    if (e == nullptr) continue;
    const std::vector<std::string> names = e->parameter_names(model.nominal);
    json v = json::object();
    for (std::size_t i = 0; i < names.size() && Eigen::Index(i) < values.size(); ++i) v[names[i]] = values(Eigen::Index(i));
    effects[name] = v;
  }
  if (!effects.empty()) j["effects"] = effects;
  return j.dump(2) + "\n";
}

void write_model_file(const CalibrationModel& model, const std::string& path, const std::vector<std::string>& inputs) {
  write_output_file(path, model_to_json(model), inputs);
}

static CalibrationModel parse_model_json(const json& j, const std::string& file);

CalibrationModel parse_model(const std::string& text, const std::string& file) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    const TextPosition at = position_of(text, e.byte == 0 ? 0 : e.byte - 1);
    throw InputError(file, at.line, at.column, "malformed JSON");
  } catch (const json::exception& e) {
    throw InputError(file, 0, 0, std::string("malformed JSON (") + e.what() + ")");
  }
  try {
    return parse_model_json(j, file);
  } catch (const json::exception& e) {  // a value of the wrong type
    throw InputError(file, 0, 0, std::string("malformed model: ") + e.what());
  }
}

static CalibrationModel parse_model_json(const json& j, const std::string& file) {
  if (!j.is_object()) fail(file, "a model file is a JSON object");
  if (require(j, "format", file) != kModelFormat) fail(file, std::string("\"format\" must be \"") + kModelFormat + "\"");
  if (require(j, "version", file) != kModelVersion) fail(file, "unsupported model version (this kincal reads version 1)");
  CalibrationModel m;
  m.nominal = parse_robot(require(j, "robot", file).dump(), file + " (robot)");
  const json& est = require(j, "estimator", file);
  m.estimator = require(est, "name", file).get<std::string>();
  if (const auto s = est.find("settings"); s != est.end())
    for (const auto& [k, v] : s->items()) m.settings[k] = finite_number(v, "estimator setting " + k, file);
  if (const auto d = j.find("data"); d != j.end() && d->is_string()) m.data_file = d->get<std::string>();
  const json& params = require(j, "parameters", file);
  if (!params.is_array()) fail(file, "\"parameters\" must be an array");
  const std::vector<std::string> valid = parameter_names(m.nominal);
  for (const json& p : params) {
    ModelParameter mp;
    mp.name = require(p, "name", file).get<std::string>();
    if (std::find(valid.begin(), valid.end(), mp.name) == valid.end())
      fail(file, "unknown parameter \"" + mp.name + "\" for a " + m.nominal.family() + " robot");
    mp.value = finite_number(require(p, "value", file), "value of " + mp.name, file);
    if (const auto se = p.find("standard_error"); se != p.end())
      mp.standard_error = finite_number(*se, "standard_error of " + mp.name, file);
    if (const auto id = p.find("identifiable"); id != p.end() && id->is_boolean()) mp.identifiable = id->get<bool>();
    m.parameters.push_back(mp);
  }
  if (const auto effects = j.find("effects"); effects != j.end()) {
    if (!effects->is_object()) fail(file, "\"effects\" must be an object of effect name -> {parameter: value}");
    for (const auto& [name, params_of] : effects->items()) {
      if (!params_of.is_object()) fail(file, "effect \"" + name + "\" must be an object of parameter -> value");
      for (const auto& [pname, value] : params_of.items()) {
        const double v = finite_number(value, "effect " + name + ":" + pname, file);
        try {
          m.effects.set(m.nominal, name, pname, v);
        } catch (const InputError& e) {
          fail(file, e.message());
        }
      }
    }
  }
  return m;
}

CalibrationModel read_model_file(const std::string& path) { return parse_model(read_text_file(path), path); }

}  // namespace kincal::identify
