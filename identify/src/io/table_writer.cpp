#include "kincal/identify/table_writer.hpp"

#include "kincal/identify/formula_candidate.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "kincal/core/calibration_table.hpp"
#include "kincal/core/compensation.hpp"
#include "kincal/core/machine_limits.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/files.hpp"
#include "families/family.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/version.hpp"

namespace kincal::identify {

namespace {

// Named groups of the canonical value list, in the order for_each_value
// visits them (core/calibration_table.hpp): the machine's from its family
// (FamilyTable::machine_groups), then the effects and bounds every table has.
// Only labels for the reader: their count is checked against
// table_value_count below, so a change of the layout in core fails loudly
// here instead of mislabelling.
using Groups = std::vector<TableGroup>;

void add_effects_and_bounds(Groups& g) {
  for (const auto& [name, n] : std::vector<std::pair<std::string, int>>{
           {"effects.scale", 6}, {"effects.backlash", 6}, {"effects.compliance", 6}, {"effects.cyclic_sin", 6},
           {"effects.cyclic_cos", 6}, {"effects.thermal", 1}, {"effects.screw_lead", 1},
           {"effects.screw_joints", 1}, {"effects.load_direction", 3}, {"effects.thermal_origin", 3},
           {"effects.reference_temperature", 1}, {"effects.user", kUserEffectParameters},
           {"bounds.max_correction", 6}, {"bounds.min_joint", 6}, {"bounds.max_joint", 6}})
    g.push_back({name, n, {}, {}});
}

template <class Machine> Groups groups(const Robot& robot) {
  Groups g = family_of(robot).table().machine_groups(robot);
  add_effects_and_bounds(g);
  int total = 0;
  for (const TableGroup& e : g) total += e.count;
  if (total != static_cast<int>(table_value_count<Machine>()))
    throw InputError("kincal table: the table layout of core/calibration_table.hpp changed (" +
                     std::to_string(table_value_count<Machine>()) + " values, the writer knows " +
                     std::to_string(total) + "); update the family's machine_groups (identify/src/families/)");
  return g;
}

// 17 significant digits: the shortest width that round-trips every double
// (a float converts to double exactly, so its value round-trips too).
std::string number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  std::string s = buf;
  // A literal that reads as an integer is still a double in the array; keep
  // it visibly one.
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

std::string hex32(std::uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08Xu", static_cast<unsigned>(v));
  return buf;
}

// The machine limits (core/machine_limits.hpp) as a constexpr aggregate.
template <class Scalar>
void emit_limits(std::ostream& out, const MachineLimits<Scalar>& l, const std::string& scalar) {
  auto row = [&](const Scalar(&v)[6]) {
    std::string r = "{";
    for (int i = 0; i < 6; ++i) r += number(double(v[i])) + (i < 5 ? ", " : "}");
    return r;
  };
  out << "inline constexpr ::kincal::MachineLimits<" << scalar << "> kLimits_" << scalar << " = {\n"
      << "    " << row(l.min_joint) << ",  // min_joint\n"
      << "    " << row(l.max_joint) << ",  // max_joint\n"
      << "    " << row(l.max_correction) << ",  // max_correction\n"
      << "    " << number(double(l.max_geometry_error)) << ", " << number(double(l.max_scale)) << ", "
      << number(double(l.max_thermal)) << ", " << number(double(l.max_angle_error))
      << "};  // max_geometry_error, max_scale, max_thermal, max_angle_error\n\n";
}

// One table as a value array, a CRC constant and the constexpr table.
template <class Machine>
void emit_table(std::ostream& out, const CalibrationTable<Machine>& t, const std::string& name, const std::string& scalar,
                const Groups& g) {
  const std::size_t n = table_value_count<Machine>();
  std::vector<double> values(n);
  table_to_values(t, values.data());
  out << "inline constexpr double k" << name << "Values_" << scalar << "[" << n << "] = {\n";
  std::size_t k = 0;
  for (const TableGroup& group : g) {
    const int count = group.count;
    if (!group.values.empty()) {  // one value per line, each named
      out << "    // " << group.label << group.note << "\n";
      for (int i = 0; i < count; ++i, ++k)
        out << "    " << number(values[k]) << ",  // " << group.values[static_cast<std::size_t>(i)] << "\n";
      continue;
    }
    out << "    // " << group.label << "\n    ";
    for (int i = 0; i < count; ++i, ++k) out << number(values[k]) << (i + 1 < count ? ", " : ",\n");
  }
  out << "};\n";
  out << "inline constexpr std::uint32_t k" << name << "Crc_" << scalar << " = " << hex32(t.crc) << ";\n";
  out << "inline constexpr ::kincal::CalibrationTable<::kincal::" << Machine::type_name << "<"
      << scalar << ">> k" << name << "Table_" << scalar << " =\n    ::kincal::table_from_values<::kincal::"
      << Machine::type_name << "<" << scalar << ">>(k" << name << "Values_" << scalar << ", k" << name
      << "Crc_" << scalar << ");\n";
  out << "static_assert(::kincal::table_crc(k" << name << "Table_" << scalar << ") == k" << name << "Crc_" << scalar
      << ",\n              \"" << name << " table (" << scalar
      << "): CRC mismatch, the values were edited or corrupted; regenerate with kincal table\");\n";
  out << "static_assert(::kincal::validate_table(k" << name << "Table_" << scalar << ", kLimits_" << scalar
      << ") == ::kincal::CompensationStatus::Ok,\n              \"" << name << " table (" << scalar
      << "): fails validate_table (values, bounds, machine limits)\");\n\n";
}

// The nominal machine's table: the geometry without identified errors, the
// machine data of the effects (screw lead, weight direction, thermal origin,
// T0) without effect values, default bounds.
template <class Machine> CalibrationTable<Machine> nominal_of(const CalibrationTable<Machine>& calibrated) {
  using S = typename Machine::Scalar;
  EffectParameters<S> e = to_core(calibrated.effects);
  e.scale.setZero();
  e.backlash.setZero();
  e.compliance.setZero();
  e.cyclic_sin.setZero();
  e.cyclic_cos.setZero();
  e.thermal = S(0);
  e.user.setZero();
  return nominal_table_of(calibrated.machine, e);
}

// A string literal for the banner and the constants (quotes and backslashes escaped).
std::string literal(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n' || c == '\r') continue;
    out += c;
  }
  return out + "\"";
}

std::string comment_safe(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  for (std::size_t p; (p = s.find("*/")) != std::string::npos;) s.replace(p, 2, "* /");
  return s;
}

// The machine's formula effects (robot description key `effects`) as C++:
// one function per effect (FormulaEffect::cpp_function, templated on the
// scalar) and the policy Formulas<Scalar> that Compensator<Machine,
// Formulas> and port::Controller call directly (core/formula_effects.hpp):
// no function pointer, so the firmware's stack stays statically bounded. Every
// formula of the description, at the table's numbers (the user slot), as
// `kincal compensate` evaluates them (HostFormulaEffects).
void emit_formulas(std::ostream& out, const Robot& robot) {
  out << "// --- formula effects (the robot description's `effects`; core/formula_effects.hpp)\n";
  const auto& effects = robot.formula_effects;
  out << "// The named inputs the NC stream must carry, in the machine's input order.\n"
      << "inline constexpr int kFormulaInputCount = " << robot.formula_inputs.size() << ";\n"
      << "inline constexpr const char* kFormulaInputNames[::kincal::kFormulaInputs] = {";
  for (int i = 0; i < kFormulaInputs; ++i) {
    const std::size_t k = static_cast<std::size_t>(i);
    out << (i ? ", " : "") << (k < robot.formula_inputs.size() ? literal(robot.formula_inputs[k]) : "nullptr");
  }
  out << "};\n";
  if (effects.empty()) {
    out << "template <class Scalar> using Formulas = ::kincal::NoFormulaEffects;  // none\n\n";
    return;
  }
  out << "\n";
  for (const auto& c : effects) out << c->formula().cpp_function(c->formula().cpp_function_name()) << "\n";
  bool pose = false, reads_pose = false, reads_load = false, reads_stream = false, reads_family = false;
  for (const auto& c : effects) {
    const FormulaEffect& f = c->formula();
    pose = pose || f.kind() == FormulaKind::Pose;
    reads_family = reads_family || f.uses_family();
    reads_pose = reads_pose || f.uses_pose();
    reads_load = reads_load || f.uses_load();
    reads_stream = reads_stream || f.uses_time() || f.uses_inputs();
  }
  const auto flag = [](bool b) { return b ? "true" : "false"; };
  const auto members = [&](FormulaKind kind, const std::string& target) {
    for (const auto& c : effects) {
      const FormulaEffect& f = c->formula();
      if (f.kind() != kind) continue;
      out << "    {  // " << f.name() << ": numbers " << c->offset() << ".." << c->offset() + int(f.parameter_names().size()) - 1
          << " of the user slot\n"
          << "      Scalar v[" << f.output_count() << "];\n"
          << "      " << f.cpp_function_name() << "<Scalar>(params + " << c->offset() << ", vars, v);\n";
      for (int o = 0; o < f.output_count(); ++o) {
        const int index = kind == FormulaKind::Joint ? f.joints()[std::size_t(o)] - 1 : o;
        out << "      " << target << "[" << index << "] += v[" << o << "];\n";
      }
      out << "    }\n";
    }
  };
  out << "template <class Scalar> struct Formulas {\n"
      << "  static constexpr bool present = true;\n"
      << "  // What the formulas read (the rest is not computed: core/formula_effects.hpp).\n"
      << "  static constexpr bool pose_twist = " << flag(pose) << ", reads_pose = " << flag(reads_pose)
      << ", reads_load = " << flag(reads_load) << ", reads_stream = " << flag(reads_stream)
      << ", reads_family = " << flag(reads_family) << ";\n"
      << "  void add_joint_error(const Scalar* params, const Scalar* vars, Scalar* dq) const {\n"
      << "    (void)params; (void)vars; (void)dq;\n";
  members(FormulaKind::Joint, "dq");
  out << "  }\n"
      << "  void add_pose_twist(const Scalar* params, const Scalar* vars, Scalar* twist) const {\n"
      << "    (void)params; (void)vars; (void)twist;\n";
  members(FormulaKind::Pose, "twist");
  out << "  }\n"
      << "  bool has_pose() const { return " << flag(pose) << "; }\n"
      << "  int input_count() const { return kFormulaInputCount; }\n"
      << "  // The description's payload (N; mm, in the pose's body frame): the static joint loads `load`.\n"
      << "  Scalar payload_weight() const { return Scalar(" << number(robot.payload_weight) << "); }\n"
      << "  ::kincal::Vec3<Scalar> payload_com() const {\n"
      << "    return ::kincal::Vec3<Scalar>(Scalar(" << number(robot.payload_com.x()) << "), Scalar("
      << number(robot.payload_com.y()) << "), Scalar(" << number(robot.payload_com.z()) << "));\n"
      << "  }\n"
      << "};\n\n";
}

template <class Machine>
std::string header_for(const CalibrationModel& model, const CalibrationTable<Machine>& table,
                       const std::string& model_name) {
  using MachineF = typename Machine::template Rebind<float>;
  const CalibrationTable<Machine> nominal = nominal_of(table);
  const CalibrationTable<MachineF> table_f = table_cast<float>(table);
  const CalibrationTable<MachineF> nominal_f = table_cast<float>(nominal);
  // The machine limits from the nominal robot description (never from the
  // identified values): the firmware checks both tables against them.
  const MachineLimits<double> limits = machine_limits(model.nominal);
  MachineLimits<float> limits_f{};
  for (int i = 0; i < 6; ++i) {
    limits_f.min_joint[i] = float(limits.min_joint[i]);
    limits_f.max_joint[i] = float(limits.max_joint[i]);
    limits_f.max_correction[i] = float(limits.max_correction[i]);
  }
  limits_f.max_geometry_error = float(limits.max_geometry_error);
  limits_f.max_scale = float(limits.max_scale);
  limits_f.max_thermal = float(limits.max_thermal);
  limits_f.max_angle_error = float(limits.max_angle_error);
  for (const CompensationStatus st : {validate_table(table, limits), validate_table(nominal, limits),
                                      validate_table(table_f, limits_f), validate_table(nominal_f, limits_f)})
    if (st != CompensationStatus::Ok)
      throw InputError(model_name, 0, 0,
                       std::string("the generated table fails its check (") + to_string(st) + ")");
  const Groups names = groups<Machine>(model.nominal);
  const std::string fam = Machine::family_name;
  std::ostringstream out;
  out << "// Generated from " << comment_safe(model_name) << " by kincal " << kVersion
      << " (`kincal table`). Do not edit:\n"
      << "// regenerate it (the static_asserts below reject an edited value).\n"
      << "//\n"
      << "// robot: " << comment_safe(model.nominal.name) << " (" << comment_safe(model.nominal.family())
      << "), estimator: " << comment_safe(model.estimator) << ", data: " << comment_safe(model.data_file) << "\n"
      << "// Table format version " << kCalibrationTableVersion
      << " (core/calibration_table.hpp); values in its canonical order, 17 significant\n"
      << "// digits (exact round trip), lengths in mm, angles in rad. The calibration table is what\n"
      << "// `kincal compensate` runs on for this model; the nominal table is the firmware's fallback\n"
      << "// when the calibration table fails its start-up check (docs/firmware.md).\n"
      << "#pragma once\n\n"
      << "#include <cmath>\n"
      << "#include <cstdint>\n\n"
      << "#include \"kincal/core/calibration_table.hpp\"\n"
      << "#include \"kincal/core/formula_effects.hpp\"\n"
      << "#include \"kincal/core/machine_limits.hpp\"\n"
      << (std::string(Machine::header) != "kincal/core/calibration_table.hpp"
              ? "#include \"" + std::string(Machine::header) + "\"\n"
              : std::string())
      << "\n"
      << "static_assert(::kincal::kCalibrationTableVersion == " << kCalibrationTableVersion
      << ",\n              \"generated for calibration table format version " << kCalibrationTableVersion
      << "; regenerate with this kincal\");\n\n"
      << "namespace kincal::generated {\n\n"
      << "inline constexpr const char* kModelFile = " << literal(model_name) << ";\n"
      << "inline constexpr const char* kRobot = " << literal(model.nominal.name) << ";\n"
      << "inline constexpr const char* kGenerator = " << literal(std::string("kincal ") + kVersion) << ";\n"
      << "inline constexpr ::kincal::MachineFamily kFamily = ::kincal::MachineFamily::" << fam << ";\n"
      << "inline constexpr std::uint32_t kFormatVersion = " << kCalibrationTableVersion << ";\n"
      << "template <class Scalar> using Machine = ::kincal::" << Machine::type_name << "<Scalar>;\n\n"
      << "// The machine limits (core/machine_limits.hpp), from the nominal robot description,\n"
      << "// never from identified values: the controller checks the tables against them. A port\n"
      << "// may replace them with limits of its own (its drives' travel).\n";
  emit_limits(out, limits, "double");
  emit_limits(out, limits_f, "float");
  emit_table(out, table, "Calibration", "double", names);
  emit_table(out, nominal, "Nominal", "double", names);
  emit_table(out, table_f, "Calibration", "float", names);
  emit_table(out, nominal_f, "Nominal", "float", names);
  emit_formulas(out, model.nominal);
  out << "// By scalar: calibration_table<double>() etc.\n"
      << "template <class Scalar> struct Tables;\n"
      << "template <> struct Tables<double> {\n"
      << "  static constexpr const ::kincal::CalibrationTable<Machine<double>>& calibration() { return kCalibrationTable_double; }\n"
      << "  static constexpr const ::kincal::CalibrationTable<Machine<double>>& nominal() { return kNominalTable_double; }\n"
      << "  static constexpr const ::kincal::MachineLimits<double>& limits() { return kLimits_double; }\n"
      << "};\n"
      << "template <> struct Tables<float> {\n"
      << "  static constexpr const ::kincal::CalibrationTable<Machine<float>>& calibration() { return kCalibrationTable_float; }\n"
      << "  static constexpr const ::kincal::CalibrationTable<Machine<float>>& nominal() { return kNominalTable_float; }\n"
      << "  static constexpr const ::kincal::MachineLimits<float>& limits() { return kLimits_float; }\n"
      << "};\n\n"
      << "}  // namespace kincal::generated\n";
  return out.str();
}

}  // namespace

std::string calibration_table_header(const CalibrationModel& model, const std::string& model_name) {
  const AnyCalibrationTable t = calibration_table(model);
  return std::visit([&](const auto& table) { return header_for(model, table, model_name); }, t);
}

void write_calibration_table_header(const std::string& model_path, const std::string& out_path) {
  // The output is never read (it may be /dev/stdout or a FIFO): a build that
  // must not rebuild for an unchanged header writes to a scratch file and
  // copies it with `cmake -E copy_if_different` (examples/firmware/CMakeLists.txt).
  check_outputs({out_path}, {model_path});
  write_output_file(out_path, calibration_table_header(read_model_file(model_path), model_path), {model_path});
}

}  // namespace kincal::identify
