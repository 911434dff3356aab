#include "kincal/identify/parameters.hpp"

#include <algorithm>
#include <charconv>
#include <utility>
#include <cmath>
#include <map>

#include "families/family.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

namespace {

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : ", ") + s;
  return out;
}

const ParameterSpec* find_spec(const Robot& robot, const std::string& name) {
  for (const ParameterSpec& s : parameter_specs(robot))
    if (s.name == name) return &s;
  return nullptr;
}

}  // namespace

const std::vector<ParameterSpec>& parameter_specs(const Robot& robot) { return family_of(robot).error_model().parameter_specs(robot); }

std::vector<std::string> parameter_names(const Robot& robot) {
  std::vector<std::string> out;
  for (const ParameterSpec& s : parameter_specs(robot)) out.push_back(s.name);
  return out;
}

ParameterSet parse_parameters(std::string_view text, const std::string& file, const Robot& robot,
                              const std::function<void(const std::string&)>& warn) {
  const CsvDocument doc = parse_csv(text, file);
  const int name_col = doc.column("name"), value_col = doc.column("value");
  if (name_col < 0 || value_col < 0) {
    std::vector<std::string> missing;
    if (name_col < 0) missing.push_back("name");
    if (value_col < 0) missing.push_back("value");
    throw InputError(file, doc.header.line, 0, "missing required columns: " + join(missing) + " (expected header name,value)");
  }
  std::vector<std::string> ignored;
  for (const CsvField& f : doc.header.fields)
    if (f.text != "name" && f.text != "value") ignored.push_back("'" + f.text + "'");
  if (!ignored.empty() && warn)
    warn(format_location(file, doc.header.line, 0) + ": warning: unknown column" + (ignored.size() == 1 ? " " : "s ") +
         join(ignored) + " ignored");
  ParameterSet set;
  set.file = file;
  std::map<std::string, std::size_t> seen;
  for (const CsvRecord& r : doc.rows) {
    const CsvField& nf = r.fields[static_cast<std::size_t>(name_col)];
    if (find_spec(robot, nf.text) == nullptr)
      throw InputError(file, r.line, nf.column,
                       "unknown parameter '" + nf.text.substr(0, 40) + "' for family " + robot.family() +
                           " (valid: " + join(parameter_names(robot)) + ")");
    const auto [it, fresh] = seen.emplace(nf.text, r.line);
    if (!fresh)
      throw InputError(file, r.line, nf.column,
                       "parameter '" + nf.text + "' given twice (first at line " + std::to_string(it->second) + ")");
    const double v = parse_number(r.fields[static_cast<std::size_t>(value_col)], r.line, file, "value");
    set.values.push_back({nf.text, v, r.line});
  }
  return set;
}

ParameterSet read_parameters(const std::string& path, const Robot& robot,
                             const std::function<void(const std::string&)>& warn) {
  return parse_parameters(read_text_file(path), path, robot, warn);
}

Robot apply_parameters(const Robot& nominal, const ParameterSet& errors) {
  // In the family's table order whatever the file's: an error that does not
  // commute with another (the 6-RUS's shaft tilts, turned about the turned
  // axes) composes as the family's model composes it.
  const std::vector<ParameterSpec>& specs = parameter_specs(nominal);
  std::vector<std::pair<std::size_t, double>> ordered;
  for (const ParameterValue& p : errors.values) {
    const ParameterSpec* s = find_spec(nominal, p.name);
    if (s == nullptr)
      throw InputError(errors.file, p.line, 0, "unknown parameter '" + p.name + "' for family " + nominal.family());
    ordered.emplace_back(std::size_t(s - specs.data()), p.value);
  }
  std::stable_sort(ordered.begin(), ordered.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  Robot out = nominal;
  for (const auto& [index, value] : ordered) specs[index].add(out, value);
  return out;
}

EffectSetting parse_effect_option(const std::string& text) {
  const std::string where = "--effect '" + text.substr(0, 60) + "'";
  const std::size_t colon = text.find(':');
  const std::size_t eq = text.find('=', colon == std::string::npos ? 0 : colon);
  if (colon == std::string::npos || eq == std::string::npos || colon == 0 || eq == colon + 1 || eq + 1 == text.size())
    throw InputError(where + ": expected NAME:PARAM=VALUE");
  EffectSetting e;
  e.effect = text.substr(0, colon);
  e.parameter = text.substr(colon + 1, eq - colon - 1);
  const std::string v = text.substr(eq + 1);
  const char* b = v.data() + (v[0] == '+' ? 1 : 0);
  const auto [ptr, ec] = std::from_chars(b, v.data() + v.size(), e.value);
  if (ec != std::errc() || ptr != v.data() + v.size() || !std::isfinite(e.value))
    throw InputError(where + ": VALUE must be a finite number");
  return e;
}

std::vector<EffectSetting> parse_effect_options(const std::string& text) {
  const std::size_t colon = text.find(':');
  if (colon == std::string::npos) return {parse_effect_option(text)};  // its error message
  std::vector<EffectSetting> out;
  for (std::size_t b = colon + 1;;) {
    const std::size_t e = text.find(',', b);
    const std::string part = text.substr(b, e == std::string::npos ? std::string::npos : e - b);
    try {
      out.push_back(parse_effect_option(text.substr(0, colon + 1) + part));
    } catch (const InputError&) {  // one message for the whole option, naming the bad part
      throw InputError("--effect '" + text.substr(0, 60) + "': '" + part.substr(0, 40) +
                       "' is not PARAM=VALUE with a finite number");
    }
    if (e == std::string::npos) break;
    b = e + 1;
  }
  return out;
}

}  // namespace kincal::identify
