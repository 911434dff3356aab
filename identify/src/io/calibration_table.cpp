#include "kincal/identify/calibration_table.hpp"

#include "kincal/identify/formula_candidate.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "families/family.hpp"
#include "families/table_words.hpp"
#include "kincal/core/compensation.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal::identify {

namespace {

using detail::key_note;
std::string number(double v) { return detail::table_number(v); }

// Fills the effects and bounds, seals the table and checks it against the
// machine limits of the model's nominal robot: the status, and why in words.
template <class Machine>
CompensationStatus finish(CalibrationTable<Machine>& t, const CalibrationModel& model,
                          const CalibrationTableOptions& options, std::string* why) {
  t.effects = to_table(model.effects.to_core(model.nominal));
  const Vec6<double> bound = options.max_correction ? *options.max_correction : model.nominal.correction_bound();
  for (int i = 0; i < 6; ++i) t.bounds.max_correction[i] = bound(i);
  t = seal_table(t);
  const MachineLimits<double> limits = machine_limits(model.nominal, options);
  const CompensationStatus st = validate_table(t, limits);
  if (why != nullptr && st == CompensationStatus::TableLimits)
    *why = "the calibration table is outside the machine limits: " +
           limit_violation(model.nominal, AnyCalibrationTable(t), limits);
  else if (why != nullptr && st != CompensationStatus::Ok) {
    // Where a model can cause it, the family names the value (the encoder
    // offsets, one correction at every point).
    std::string value = family_of(model.nominal).table().machine_value_violation(AnyCalibrationTable(t));
    if (value.empty()) value = "a correction above its bound or a value out of range";
    *why = std::string("the calibration table fails its check (") + to_string(st) + "): " + value;
  }
  return st;
}

}  // namespace

MachineLimits<double> machine_limits(const Robot& robot, const CalibrationTableOptions& options) {
  const TableBounds<double> b = family_of(robot).table().default_bounds(robot);
  MachineLimits<double> l = limits_from_bounds(b);
  const Vec6<double> bound = options.max_correction ? *options.max_correction : robot.correction_bound();
  for (int i = 0; i < 6; ++i) l.max_correction[i] = bound(i);
  // Every cap from the description where it sets one (default: core's).
  l.max_geometry_error = robot.max_geometry_error.value_or(l.max_geometry_error);
  l.max_angle_error = robot.max_angle_error.value_or(l.max_angle_error);
  l.max_scale = robot.max_scale.value_or(l.max_scale);
  l.max_thermal = robot.max_thermal.value_or(l.max_thermal);
  return l;
}

std::string limit_violation(const Robot& robot, const AnyCalibrationTable& any, const MachineLimits<double>& l) {
  const Family& family = family_of(robot);
  const std::string why = std::visit(
      [&](const auto& t) -> std::string {
        if (validate_table(t, l) != CompensationStatus::TableLimits) return {};
        if (!limits_detail::sane(l))
          return "the machine limits are not sane (a cap negative or not finite, a joint range empty, a correction "
                 "bound not positive)";
        const char* range_key = family.table().joint_range_key();
        for (int i = 0; i < 6; ++i) {
          const std::string j = "[" + std::to_string(i) + "] ";
          if (!(t.bounds.min_joint[i] >= l.min_joint[i]))
            return "bounds.min_joint" + j + number(t.bounds.min_joint[i]) + " below the limit " +
                   number(l.min_joint[i]) + key_note(range_key);
          if (!(t.bounds.max_joint[i] <= l.max_joint[i]))
            return "bounds.max_joint" + j + number(t.bounds.max_joint[i]) + " above the limit " +
                   number(l.max_joint[i]) + key_note(range_key);
          if (!(t.bounds.max_correction[i] <= l.max_correction[i]))
            return "bounds.max_correction" + j + number(t.bounds.max_correction[i]) + " above the limit " +
                   number(l.max_correction[i]) + key_note("max_correction");
        }
        std::string effect;
        const auto& e = t.effects;
        const double* cap = t.bounds.max_correction;
        for (int i = 0; i < 6 && effect.empty(); ++i) {
          const std::string j = "[" + std::to_string(i) + "] = ";
          const std::string bound = " above the correction bound " + number(cap[i]) + key_note("max_correction");
          if (!(std::abs(e.scale[i]) <= l.max_scale)) effect = "effects.scale" + j + number(e.scale[i]) + " above max_scale " + number(l.max_scale) + key_note("max_scale");
          else if (!(std::abs(e.backlash[i]) <= cap[i])) effect = "effects.backlash" + j + number(e.backlash[i]) + bound;
          else if (!(std::abs(e.compliance[i]) <= cap[i])) effect = "effects.compliance" + j + number(e.compliance[i]) + bound;
          else if (!(std::abs(e.cyclic_sin[i]) <= cap[i])) effect = "effects.cyclic_sin" + j + number(e.cyclic_sin[i]) + bound;
          else if (!(std::abs(e.cyclic_cos[i]) <= cap[i])) effect = "effects.cyclic_cos" + j + number(e.cyclic_cos[i]) + bound;
        }
        if (!effect.empty()) return effect;
        if (!(std::abs(e.thermal) <= l.max_thermal))
          return "effects.thermal = " + number(e.thermal) + " above max_thermal " + number(l.max_thermal) +
                 key_note("max_thermal");
        // The machine's own numbers: the family says which and against what.
        return family.table().machine_limit_violation(any, l);
      },
      any);
  return why;
}

namespace {

// The family's table (machine and bounds: FamilyTable::machine_table), finished:
// effects and bounds filled, sealed and checked.
AnyCalibrationTable build_table(const CalibrationModel& model, const CalibrationTableOptions& options,
                                CompensationStatus& status, std::string* why) {
  AnyCalibrationTable t = family_of(model.nominal).table().machine_table(model);
  std::visit([&](auto& table) { status = finish(table, model, options, why); }, t);
  return t;
}

// Whether the model's table passes its check (no message built).
bool table_ok(const CalibrationModel& model, const CalibrationTableOptions& options) {
  CompensationStatus st = CompensationStatus::Ok;
  try {
    build_table(model, options, st, nullptr);
  } catch (const InputError&) {
    return false;
  }
  return st == CompensationStatus::Ok;
}

// A table that fails its check, reported where the user can mend it: the
// first value of the model (a parameter, then an effect parameter) whose
// table alone — every other value nominal — fails too, at its line and
// column in the MODEL.json it was read from (issue #10 item 11). A fault only
// the values together make names the file alone.
[[noreturn]] void throw_table_fault(const CalibrationModel& model, const CalibrationTableOptions& options,
                                    const std::string& why) {
  CalibrationModel alone = model;
  alone.parameters.clear();
  alone.effects = {};
  std::string culprit;
  double value = 0;
  for (const ModelParameter& p : model.parameters) {
    alone.parameters = {p};
    if (!table_ok(alone, options)) {
      culprit = p.name;
      value = p.value;
      break;
    }
  }
  alone.parameters.clear();
  for (const auto& [effect, values] : model.effects.values) {
    const Effect* e = find_effect(model.nominal, effect);
    if (!culprit.empty() || e == nullptr) break;
    const std::vector<std::string> names = e->parameter_names(model.nominal);
    for (std::size_t i = 0; i < names.size() && culprit.empty() && Eigen::Index(i) < values.size(); ++i) {
      alone.effects = {};
      alone.effects.set(model.nominal, effect, names[i], values(Eigen::Index(i)));
      if (!table_ok(alone, options)) {
        culprit = effect + ":" + names[i];
        value = values(Eigen::Index(i));
      }
    }
  }
  const auto at = model.value_positions.find(culprit);
  if (culprit.empty() || at == model.value_positions.end())
    throw InputError(model.source_file, 0, 0,
                     why + (culprit.empty() ? std::string(" (no single value causes it: the values together do)")
                                            : "; it comes from " + culprit + " = " + number(value)));
  throw InputError(model.source_file, at->second.line, at->second.column,
                   why + "; it comes from " + culprit + " = " + number(value));
}

}  // namespace

AnyCalibrationTable calibration_table(const CalibrationModel& model, const CalibrationTableOptions& options) {
  CompensationStatus st = CompensationStatus::Ok;
  std::string why;
  AnyCalibrationTable t = build_table(model, options, st, &why);
  if (st != CompensationStatus::Ok) throw_table_fault(model, options, why);
  return t;
}

namespace {
// The table of `model` as one family's type; `refusal` when the model is of
// another family.
template <class Table> Table table_of(const CalibrationModel& model, const CalibrationTableOptions& options,
                                      const char* family, const char* refusal) {
  if (std::string(family) != model.nominal.family()) throw InputError(refusal);
  return std::get<Table>(calibration_table(model, options));
}
}  // namespace

StewartCalibrationTable<double> stewart_calibration_table(const CalibrationModel& model,
                                                          const CalibrationTableOptions& options) {
  return table_of<StewartCalibrationTable<double>>(model, options, kStewartFamily,
                                                   "a 6-UPS calibration table needs a model of a 6-UPS robot");
}

HybridCalibrationTable<double> hybrid_calibration_table(const CalibrationModel& model,
                                                        const CalibrationTableOptions& options) {
  return table_of<HybridCalibrationTable<double>>(model, options, kHybridFamily,
                                                  "a hybrid calibration table needs a model of a hybrid robot");
}

CompensatedStream compensate_rows(const AnyCalibrationTable& table, const CalibrationModel& model,
                                  const PoseTable& poses, const CalibrationTableOptions& options) {
  CompensatedStream out;
  out.rows.reserve(poses.rows.size());
  // The limits the table was checked against (calibration_table): every cap
  // of the robot description, not only the table's own bounds.
  const MachineLimits<double> limits = machine_limits(model.nominal, options);
  const Robot& robot = model.nominal;
  // A formula the model carries reads columns the poses must have.
  for (const auto& f : robot.formula_effects) {
    if (!model.effects.values.count(f->name())) continue;
    const std::string missing = f->missing_inputs(poses);
    if (!missing.empty())
      throw InputError(poses.file, 0, 0, "the model's formula effect '" + f->name() + "' cannot be compensated: " + missing);
  }
  const auto run = [&](auto& compensator) {
        if (compensator.status() != CompensationStatus::Ok)
          throw InputError(std::string("calibration table: ") + to_string(compensator.status()));
        // A registered user joint effect's code (its numbers are in the table).
        compensator.set_user_effect(model.effects.to_core(model.nominal).user_error);
        // The stream starts with the machine at its home pose, approach
        // directions +1, as the firmware does (docs/compensation.md).
        Vec6<double> home = Vec6<double>::Zero();
        out.home_ok = compensator.home_command(home) == CompensationStatus::Ok;
        auto state = compensator.start(home);
        for (const PoseRow& r : poses.rows) {
          NcPoint<double> point;
          point.pose = Pose<double>::from_xyz_rpy(r.commanded);
          if (r.temp) {
            point.temperature = *r.temp;
            point.has_temperature = true;
          }
          Vec6<double> dir;
          if (r.dir && r.dir->size() >= 6) {
            dir = r.dir->head<6>().cast<double>();
            point.direction = &dir;
          }
          if (r.time) point.time = *r.time;
          double inputs[kFormulaInputs] = {};
          for (std::size_t i = 0; i < robot.formula_inputs.size(); ++i) {
            const auto it = r.inputs.find(robot.formula_inputs[i]);
            inputs[i] = it != r.inputs.end() ? it->second : std::numeric_limits<double>::quiet_NaN();
          }
          point.inputs = inputs;
          CompensatedRow row;
          row.status = compensator.compensate(state, point, row.q);
          if (row.status != CompensationStatus::Ok) row.q.setZero();
          out.rows.push_back(row);
        }
  };
  std::visit(
      [&](const auto& t) {
        using Machine = typename std::decay_t<decltype(t)>::MachineType;
        if (robot.formula_effects.empty()) {
          Compensator<Machine> compensator(t, limits);
          run(compensator);
        } else {
          Compensator<Machine, HostFormulaEffects> compensator(t, limits, HostFormulaEffects(robot));
          run(compensator);
        }
      },
      table);
  return out;
}

CorrectionNeed correction_need(const CalibrationModel& model, const PoseTable& poses) {
  CorrectionNeed need;
  need.bound = model.nominal.correction_bound();
  // The bound opened (the geometry caps still apply): how much the model
  // needs, not whether it fits.
  CalibrationTableOptions open;
  open.max_correction = Vec6<double>::Constant(1e6);
  try {
    const CompensatedStream s = compensate_rows(calibration_table(model, open), model, poses, open);
    for (std::size_t k = 0; k < poses.rows.size(); ++k) {
      if (s.rows[k].status != CompensationStatus::Ok) continue;
      Vec6<double> q_nominal;
      if (model.nominal.inverse(Pose<double>::from_xyz_rpy(poses.rows[k].commanded), q_nominal) != Status::Ok) continue;
      need.largest = need.largest.cwiseMax((s.rows[k].q - q_nominal).cwiseAbs());
      ++need.poses;
    }
  } catch (const InputError& e) {
    need.problem = e.message();
  }
  return need;
}

std::string correction_need_warning(const CorrectionNeed& need) {
  if (!need.problem.empty()) return "the identified model cannot be made into a calibration table: " + need.problem;
  if (!need.exceeds()) return {};
  std::string joints;
  for (int i = 0; i < 6; ++i)
    if (need.largest(i) > need.bound(i))
      joints += std::string(joints.empty() ? "" : ", ") + "q" + std::to_string(i + 1) + " " + number(need.largest(i)) +
                " > " + number(need.bound(i));
  return "the identified model needs corrections above the bound (largest |compensated - nominal| over " +
         std::to_string(need.poses) + " poses: " + joints +
         "); compensate and table will refuse those poses: raise the robot description's key 'max_correction' "
         "(one number or one per joint, mm or rad)";
}

std::string table_refusal_warning(const CalibrationModel& model, const PoseTable& poses) {
  // The check `compensate` and `table` apply, on the robot description's own
  // bounds: a refusal names the value, its bound and the key (limit_violation,
  // value_violation) and, through throw_table_fault, the model value it
  // comes from.
  const CorrectionNeed need = correction_need(model, poses);
  try {
    calibration_table(model);
  } catch (const InputError& e) {
    std::string w = "the model is written, but compensate and table will refuse it: " + e.message();
    // Refused for the correction bound alone: how much each joint needs is
    // what the user sets 'max_correction' to.
    if (need.problem.empty() && need.exceeds()) w += "; " + correction_need_warning(need);
    return w;
  }
  return correction_need_warning(need);
}

}  // namespace kincal::identify
