#include "kincal/identify/parameters.hpp"

#include <charconv>
#include <cmath>
#include <map>

#include "kincal/core/reference_machines.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/hybrid_error_model.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

namespace {

const char* const kAxes[3] = {"X", "Y", "Z"};
const char* const kAxesLower[3] = {"x", "y", "z"};

// seed 001 Table 3: per leg dXBi, dYBi, dZBi, dli, dXPi, dYPi, dZPi (mm).
std::vector<ParameterSpec> stewart_table() {
  std::vector<ParameterSpec> t;
  for (int i = 0; i < 6; ++i) {
    const std::string leg = std::to_string(i + 1);
    for (int a = 0; a < 3; ++a)
      t.push_back({std::string("d") + kAxes[a] + "B" + leg, "mm",
                   std::string("base hinge B") + leg + " " + kAxesLower[a] + " (base frame)",
                   [i, a](Robot& r, double v) { r.stewart().base(a, i) += v; }});
    // The physical leg is the command plus dl (verified against seed 001 Table 4).
    t.push_back({"dl" + leg, "mm", "leg " + leg + " length offset (physical length = q + dl)",
                 [i](Robot& r, double v) { r.stewart().length_offset(i) += v; }});
    for (int a = 0; a < 3; ++a)
      t.push_back({std::string("d") + kAxes[a] + "P" + leg, "mm",
                   std::string("platform hinge P") + leg + " " + kAxesLower[a] + " (platform frame)",
                   [i, a](Robot& r, double v) { r.stewart().platform(a, i) += v; }});
  }
  return t;
}

// Hybrid, first subset of seed 000's source errors: encoder offsets Δξ, the
// UPS joint centres, and the three wrist lengths. The full 145-error set of
// seed 000 extends this table.
std::vector<ParameterSpec> hybrid_table() {
  std::vector<ParameterSpec> t;
  for (int i = 0; i < 3; ++i)
    t.push_back({"dq" + std::to_string(i + 1), "mm", "encoder offset of UPS limb " + std::to_string(i + 1),
                 [i](Robot& r, double v) { r.hybrid().joint_offset(i) += v; }});
  for (int i = 3; i < 6; ++i)
    t.push_back({"dtheta" + std::to_string(i + 1), "rad", "encoder offset of wrist joint " + std::to_string(i + 1),
                 [i](Robot& r, double v) { r.hybrid().joint_offset(i) += v; }});
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 3; ++a)
      t.push_back({std::string("d") + kAxes[a] + "A" + std::to_string(i + 1), "mm",
                   std::string("UPS base joint A1,") + std::to_string(i + 1) + " " + kAxesLower[a] + " (base frame)",
                   [i, a](Robot& r, double v) { r.hybrid().base_joints(a, i) += v; }});
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 3; ++a)
      t.push_back({std::string("d") + kAxes[a] + "a" + std::to_string(i + 1), "mm",
                   std::string("UPS platform joint a") + std::to_string(i + 1) + " " + kAxesLower[a] +
                       " (platform frame)",
                   [i, a](Robot& r, double v) { r.hybrid().platform_joints(a, i) += v; }});
  t.push_back({"d_platform_to_wrist", "mm", "|A64 Q|", [](Robot& r, double v) { r.hybrid().platform_to_wrist += v; }});
  t.push_back({"d_wrist_link", "mm", "|Q P0|", [](Robot& r, double v) { r.hybrid().wrist_link += v; }});
  t.push_back({"d_tool_length", "mm", "|P0 P|", [](Robot& r, double v) { r.hybrid().tool_length += v; }});
  // seed 000's complete set of joint/link source errors (Appendix A), acting on
  // the machine through the nonlinear chain model of hybrid_error_model.hpp.
  const HybridErrorModel model(make_hybrid_seed000<double>());
  for (const HybridErrorParameter& p : model.parameters()) {
    const int index = model.index_of(p.name);
    t.push_back({p.name, p.unit(), "seed 000 source error " + p.symbol, [index](Robot& r, double v) {
                   if (r.source_errors.size() == 0) r.source_errors = Eigen::VectorXd::Zero(HybridErrorModel::kParameterCount);
                   r.source_errors(index) += v;
                 }});
  }
  return t;
}

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

const std::vector<ParameterSpec>& parameter_specs(const Robot& robot) {
  static const std::vector<ParameterSpec> stewart = stewart_table();
  static const std::vector<ParameterSpec> hybrid = hybrid_table();
  return robot.is_stewart() ? stewart : hybrid;
}

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
  Robot out = nominal;
  for (const ParameterValue& p : errors.values) {
    const ParameterSpec* s = find_spec(nominal, p.name);
    if (s == nullptr)
      throw InputError(errors.file, p.line, 0, "unknown parameter '" + p.name + "' for family " + nominal.family());
    s->add(out, p.value);
  }
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

}  // namespace kincal::identify
