#include "kincal/identify/linuxcnc_export.hpp"

#include <Eigen/Core>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <set>
#include <sstream>
#include <system_error>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "kincal/core/effects.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/pose_errors.hpp"
#include "kincal/identify/simulate.hpp"
#include "kincal/identify/version.hpp"

namespace kincal::identify {

namespace {

constexpr double kMmPerInch = 25.4;
// The joint-alone effects a compensation table carries exactly (up to its
// interpolation): each Δq_i depends on q_i and the direction of motion only.
// (A joint-kind formula effect of the joint's own command and direction
// belongs here too once formula effects exist, issue #32.)
const std::set<std::string> kCarriedByTables = {"scale", "backlash", "cyclic"};
// The table reaches this far past the stroke on each side (mm), so a command
// at the stroke's end is interpolated, not clamped to the last entry.
constexpr double kCompMarginMm = 1.0;
// A table aims at this fraction of the tolerance, where LinuxCNC's entries
// allow: the rest is room for LinuxCNC's own lookup, which takes the position
// of the servo cycle before a move ends (docs/linuxcnc.md).
constexpr double kCompGoal = 0.5;

std::string fixed(double v, int digits = 10) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

std::string general(double v, int digits = 4) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

// A continuous piecewise-linear function on uniform nodes.
struct PiecewiseLinear {
  double lo = 0, step = 1;
  Eigen::VectorXd values;
  double operator()(double x) const {
    const Eigen::Index n = values.size() - 1;
    double t = (x - lo) / step;
    Eigen::Index k = std::clamp<Eigen::Index>(Eigen::Index(std::floor(t)), 0, n - 1);
    t -= double(k);
    return values(k) * (1 - t) + values(k + 1) * t;
  }
};

// The continuous piecewise-linear function on `intervals` uniform intervals
// of [lo, hi] closest to f in the largest deviation, on 16 samples per
// interval: weighted least squares (hat-function normal equations,
// tridiagonal and SPD) whose weights Lawson's iteration multiplies by each
// sample's deviation, which drives the fit toward the minimax one. For a
// smooth f that error equioscillates about zero, half that of interpolating
// f at the nodes (measured on a screw's cyclic error: 0.0174·A against
// 0.032·A at 256 entries over 100 mm with a 5 mm lead; plain least squares
// 0.021·A), which is what lets LinuxCNC's 256 entries carry it.
PiecewiseLinear fit_piecewise_linear(const std::function<double(double)>& f, double lo, double hi, int intervals) {
  constexpr int kSamples = 16, kLawsonIterations = 30;
  const Eigen::Index n = intervals + 1, m = Eigen::Index(intervals) * kSamples;
  PiecewiseLinear p;
  p.lo = lo;
  p.step = (hi - lo) / intervals;
  Eigen::VectorXd y(m), t(m), w = Eigen::VectorXd::Ones(m);
  double best = std::numeric_limits<double>::infinity();
  for (Eigen::Index s = 0; s < m; ++s) {
    t(s) = (double(s % kSamples) + 0.5) / kSamples;
    y(s) = f(lo + (double(s / kSamples) + t(s)) * p.step);
  }
  for (int it = 0; it < kLawsonIterations; ++it) {
    Eigen::VectorXd diag = Eigen::VectorXd::Zero(n), off = Eigen::VectorXd::Zero(n - 1), b = Eigen::VectorXd::Zero(n);
    for (Eigen::Index s = 0; s < m; ++s) {
      const Eigen::Index k = s / kSamples;
      const double w0 = 1 - t(s), w1 = t(s);
      diag(k) += w(s) * w0 * w0;
      off(k) += w(s) * w0 * w1;
      diag(k + 1) += w(s) * w1 * w1;
      b(k) += w(s) * w0 * y(s);
      b(k + 1) += w(s) * w1 * y(s);
    }
    // A floor on the weights (below) keeps every interval determined; the
    // tiny ridge only guards the factorisation.
    diag.array() += 1e-14 * diag.maxCoeff();
    std::vector<Eigen::Triplet<double>> entries;
    for (Eigen::Index k = 0; k < n; ++k) entries.emplace_back(k, k, diag(k));
    for (Eigen::Index k = 0; k + 1 < n; ++k) entries.emplace_back(k + 1, k, off(k));
    Eigen::SparseMatrix<double> N(n, n);
    N.setFromTriplets(entries.begin(), entries.end());
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower> ldlt(N);
    const Eigen::VectorXd values = ldlt.solve(b);
    Eigen::VectorXd e(m);
    for (Eigen::Index s = 0; s < m; ++s) {
      const Eigen::Index k = s / kSamples;
      e(s) = std::abs(y(s) - (values(k) * (1 - t(s)) + values(k + 1) * t(s)));
    }
    const double worst = e.maxCoeff();
    if (!(worst >= 0)) break;  // not finite: keep the best so far
    if (worst < best) {
      best = worst;
      p.values = values;
    }
    if (worst == 0) break;
    // Lawson: each weight times its deviation, floored so that no interval
    // loses all its samples (then its values would be undetermined).
    w = w.cwiseProduct(e);
    w /= w.mean();
    w = w.cwiseMax(1e-6);
  }
  return p;
}

// Largest |f − p| on a grid 64 times finer than p's nodes (and the nodes).
double fit_error(const std::function<double(double)>& f, const PiecewiseLinear& p) {
  const Eigen::Index intervals = p.values.size() - 1;
  double worst = 0;
  for (Eigen::Index k = 0; k < intervals; ++k)
    for (int s = 0; s <= 64; ++s) {
      const double x = p.lo + (double(k) + s / 64.0) * p.step;
      worst = std::max(worst, std::abs(f(x) - p(x)));
    }
  return worst;
}

struct CompFit {
  PiecewiseLinear forward, reverse;
  double error = 0;
};

// The fewest uniform entries (doubling the intervals from 2) whose fit of both
// directions stays within `goal`; at most `max_entries` (then the error
// reached is what it is: the caller compares it with the tolerance).
CompFit fit_comp(const std::function<double(double)>& fwd, const std::function<double(double)>& rev, double lo,
                 double hi, double goal, int max_entries) {
  CompFit best;
  for (int intervals = 2;; intervals = std::min(2 * intervals, max_entries - 1)) {
    CompFit c;
    c.forward = fit_piecewise_linear(fwd, lo, hi, intervals);
    c.reverse = fit_piecewise_linear(rev, lo, hi, intervals);
    c.error = std::max(fit_error(fwd, c.forward), fit_error(rev, c.reverse));
    best = c;
    if (c.error <= goal || intervals >= max_entries - 1) return best;
  }
}

// The model with only the named effects (the rest removed).
CalibrationModel with_effects(const CalibrationModel& model, const std::function<bool(const std::string&)>& keep) {
  CalibrationModel out = model;
  out.effects.values.clear();
  for (const auto& [name, v] : model.effects.values)
    if (keep(name)) out.effects.values[name] = v;
  return out;
}

// The error the machine the model describes makes when commanded by
// `commanding`'s compensation, over the measured poses: the calibrated
// geometry with every identified effect, driven by those joints (simulate.hpp),
// measured − commanded.
LinuxCncPrediction predict(const CalibrationModel& model, const CalibrationModel& commanding, const PoseTable& data,
                           const std::string& what) {
  LinuxCncPrediction out;
  out.what = what;
  const CompensatedStream stream = compensate_rows(calibration_table(commanding), commanding, data);
  PoseTable driven = data;
  driven.rows.clear();
  driven.has_q = true;
  driven.has_measured = false;
  driven.has_targets = false;
  driven.target_count = 0;
  driven.has_status = false;
  for (std::size_t k = 0; k < data.rows.size(); ++k) {
    if (stream.rows[k].status != CompensationStatus::Ok) continue;
    PoseRow r = data.rows[k];
    r.q = Eigen::VectorXd(stream.rows[k].q);
    r.measured.reset();
    r.targets.reset();
    r.status.clear();
    driven.rows.push_back(r);
  }
  SimulateOptions sim;
  sim.effects = model.effects;
  SimulateReport report;
  const PoseTable reached = simulate(model.nominal, calibrated_robot(model), driven, sim, report);
  const PoseErrorReport errors = pose_errors(reached);
  double pos2 = 0, ang2 = 0;
  for (const PoseErrorRow& r : errors.rows) {
    pos2 += r.error.head<3>().squaredNorm();
    ang2 += r.error.tail<3>().squaredNorm();
    out.max_position_mm = std::max(out.max_position_mm, r.error.head<3>().norm());
  }
  out.poses = errors.rows.size();
  if (out.poses > 0) {
    out.rms_position_mm = std::sqrt(pos2 / double(out.poses));
    out.rms_orientation_rad = std::sqrt(ang2 / double(out.poses));
  }
  return out;
}

std::string units_name(bool inch) { return inch ? "inch" : "mm"; }

}  // namespace

void check_linuxcnc_family(const CalibrationModel& model) {
  if (!model.nominal.is_stewart())
    throw InputError(model.source_file.empty() ? std::string("MODEL.json") : model.source_file, 0, 0,
                     std::string("LinuxCNC has no kinematics for the family '") + model.nominal.family() +
                         "' (its genhexkins serves 6-UPS hexapods, family '" + kStewartFamily + "')");
}

LinuxCncExport linuxcnc_export(const CalibrationModel& model, const LinuxCncExportOptions& options) {
  const std::string file = model.source_file.empty() ? std::string("MODEL.json") : model.source_file;
  check_linuxcnc_family(model);
  if (options.max_comp_entries < 3 || !(options.comp_tolerance_mm > 0))
    throw InputError("linuxcnc export: a compensation table needs at least 3 entries and a positive tolerance");
  // The controller's own check of the model (bounds, limits): LinuxCNC must
  // not get a model kincal itself would refuse.
  try {
    (void)calibration_table(model);
  } catch (const InputError& e) {
    if (!e.file().empty()) throw;
    throw InputError(file, 0, 0, e.message());
  }
  const double unit = options.inch ? 1.0 / kMmPerInch : 1.0;  // mm → export units
  const Robot& nominal = model.nominal;
  const StewartGeometry<double> cal = calibrated_robot(model).stewart();
  // genhexkins's joint is the distance between a leg's joints; with a leg
  // line beside its U centre the actuator is at √(D² − s) instead
  // (core/stewart.hpp), which this export does not write yet.
  for (int i = 0; i < 6; ++i)
    if (cal.leg_offset_sq(i) != 0)
      throw InputError(file, 0, 0,
                       "leg " + std::to_string(i + 1) + " has a leg line offset (leg_offset_sq = " +
                           general(cal.leg_offset_sq(i)) +
                           " mm2), which LinuxCNC's genhexkins has no parameter for; this export does not carry it "
                           "yet (compensate with `kincal compensate` or the firmware table)");

  LinuxCncExport out;
  for (const auto& [name, v] : model.effects.values) {
    if (v.isZero()) continue;
    (kCarriedByTables.count(name) ? out.carried : out.not_carried).push_back(name);
  }

  // Home offsets: the configuration's (or the nominal strut length at home)
  // moved by the identified encoder offset.
  Vec6<double> home_nominal;
  if (options.home_offsets) {
    home_nominal = *options.home_offsets;
  } else {
    if (nominal.inverse(nominal.home_pose(), home_nominal) != Status::Ok)
      throw InputError(file, 0, 0, "the robot's home pose has no nominal inverse kinematics; give --home-offsets");
    home_nominal *= unit;
  }
  const Vec6<double> home_offset = home_nominal + cal.length_offset * unit;

  // Compensation tables over each joint's stroke in LinuxCNC's joint
  // coordinates (the physical strut length L = q + dl).
  const CalibrationModel carried_model =
      with_effects(model, [](const std::string& n) { return kCarriedByTables.count(n) > 0; });
  if (!out.carried.empty()) {
    EffectParameters<double> e = carried_model.effects.to_core(nominal);
    for (int j = 0; j < 6; ++j) {
      const double dl = cal.length_offset(j);
      auto correction = [&e, j, dl](double L, double dir) {
        Vec6<double> ideal = Vec6<double>::Constant(L - dl), q;
        EffectInputs<double> in;
        in.direction = Vec6<double>::Constant(dir);
        if (effect_correct_joints(e, ideal, in, q) != Status::Ok)
          throw InputError("linuxcnc export: the joint effects are not finite at L = " + general(L));
        return q(j) - ideal(j);
      };
      const double lo = cal.min_length(j) + dl - kCompMarginMm, hi = cal.max_length(j) + dl + kCompMarginMm;
      const CompFit fit = fit_comp([&](double L) { return correction(L, 1.0); },
                                   [&](double L) { return correction(L, -1.0); }, lo, hi,
                                   kCompGoal * options.comp_tolerance_mm, options.max_comp_entries);
      LinuxCncCompTable t;
      t.max_error_mm = fit.error;
      for (Eigen::Index k = 0; k < fit.forward.values.size(); ++k) {
        t.nominal.push_back((lo + double(k) * fit.forward.step) * unit);
        t.forward.push_back(fit.forward.values(k) * unit);
        t.reverse.push_back(fit.reverse.values(k) * unit);
      }
      if (fit.error > options.comp_tolerance_mm)
        out.warnings.push_back("joint " + std::to_string(j) + ": " + std::to_string(t.nominal.size()) +
                               " compensation entries (LinuxCNC's most) interpolate kincal's correction to within " +
                               general(fit.error * 1e3) + " um, above the " +
                               general(options.comp_tolerance_mm * 1e3) + " um asked");
      out.comp.push_back(t);
    }
  }

  // kincal-geometry.hal: every genhexkins pin the model sets.
  std::ostringstream hal;
  hal << "# Generated by kincal " << kVersion << " from " << file << " (robot '" << nominal.name << "', estimator "
      << model.estimator << "); do not edit: export again.\n"
      << "# genhexkins joint/leg N is kincal's leg N+1; base joints in the base (world) frame, platform joints in the\n"
      << "# platform frame, " << units_name(options.inch) << ". Load after genhexkins (docs/linuxcnc.md).\n";
  // genhexkins' screw-lead term adds a strut-length change for the screw's
  // rotation in its joints; kincal's strut length is |R·p + t − b| alone, and
  // what that term models was identified into the parameters: it must be off.
  hal << "setp genhexkins.screw-lead 0\n";
  for (int i = 0; i < 6; ++i)
    for (int a = 0; a < 3; ++a)
      hal << "setp genhexkins.base." << i << "." << "xyz"[a] << " " << fixed(cal.base(a, i) * unit) << "\n";
  for (int i = 0; i < 6; ++i)
    for (int a = 0; a < 3; ++a)
      hal << "setp genhexkins.platform." << i << "." << "xyz"[a] << " " << fixed(cal.platform(a, i) * unit) << "\n";
  out.files["kincal-geometry.hal"] = hal.str();

  // Compensation files (COMP_FILE_TYPE 1: nominal, forward offset, reverse offset).
  for (std::size_t j = 0; j < out.comp.size(); ++j) {
    std::ostringstream c;
    const LinuxCncCompTable& t = out.comp[j];
    for (std::size_t k = 0; k < t.nominal.size(); ++k)
      c << fixed(t.nominal[k]) << " " << fixed(t.forward[k], 12) << " " << fixed(t.reverse[k], 12) << "\n";
    out.files["joint-" + std::to_string(j) + ".comp"] = c.str();
  }

  // kincal.ini: the fragment to merge into the machine's INI.
  std::ostringstream ini;
  ini << "# Generated by kincal " << kVersion << " from " << file << ". Merge into the machine's INI file\n"
      << "# (docs/linuxcnc.md); lengths in " << units_name(options.inch) << ".\n\n"
      << "[KINS]\nKINEMATICS = genhexkins\nJOINTS = 6\n\n"
      << "[HAL]\n# after the HAL file that loads genhexkins:\nHALFILE = kincal-geometry.hal\n";
  for (int j = 0; j < 6; ++j) {
    ini << "\n[JOINT_" << j << "]\n"
        << "# kincal leg " << j + 1 << ": identified encoder offset dl" << j + 1 << " = "
        << fixed(cal.length_offset(j) * unit) << " " << units_name(options.inch) << "; HOME_OFFSET was "
        << fixed(home_nominal(j)) << "\n"
        << "HOME_OFFSET = " << fixed(home_offset(j)) << "\n"
        << "HOME = " << fixed(home_offset(j)) << "\n"
        << "MIN_LIMIT = " << fixed((cal.min_length(j) + cal.length_offset(j)) * unit) << "\n"
        << "MAX_LIMIT = " << fixed((cal.max_length(j) + cal.length_offset(j)) * unit) << "\n";
    if (!out.comp.empty())
      ini << "COMP_FILE = joint-" << j << ".comp\nCOMP_FILE_TYPE = 1\n"
          << "# the table carries the backlash: no BACKLASH here\nBACKLASH = 0\n";
  }
  out.files["kincal.ini"] = ini.str();

  // Predictions on the measured poses.
  if (options.data != nullptr) {
    const PoseTable& data = *options.data;
    CalibrationModel geometry_only = with_effects(model, [](const std::string&) { return false; });
    CalibrationModel uncalibrated = geometry_only;
    uncalibrated.parameters.clear();
    out.predictions.push_back(predict(model, model, data, "kincal's whole model (kincal compensate)"));
    out.predictions.push_back(predict(model, carried_model, data, "LinuxCNC with these files"));
    for (const std::string& name : out.not_carried)
      out.predictions.push_back(predict(model, with_effects(model, [&](const std::string& n) { return n != name; }),
                                        data, "everything but " + name));
    if (!out.carried.empty())
      out.predictions.push_back(predict(model, geometry_only, data, "the geometry alone (no compensation tables)"));
    out.predictions.push_back(predict(model, uncalibrated, data, "uncalibrated (nominal geometry)"));
  }

  // README.md in DIR.
  std::ostringstream md;
  md << "# LinuxCNC files for " << nominal.name << "\n\n"
     << "Generated by kincal " << kVersion << " (`kincal export linuxcnc`) from `" << file << "`, identified on `"
     << model.data_file << "`. Lengths in " << units_name(options.inch)
     << ". How kincal's frames map onto LinuxCNC's and how to merge these files: kincal's docs/linuxcnc.md.\n\n"
     << "| file | what |\n|---|---|\n"
     << "| `kincal-geometry.hal` | `setp` of the calibrated `genhexkins.base.N.*` and `genhexkins.platform.N.*` "
        "(kincal leg N+1 is LinuxCNC joint N) |\n"
     << "| `kincal.ini` | `[KINS]`, the `HALFILE` line, and per joint `HOME_OFFSET` moved by the identified encoder "
        "offset, the limits in joint (strut-length) coordinates"
     << (out.comp.empty() ? "" : ", `COMP_FILE`") << " |\n";
  if (!out.comp.empty())
    md << "| `joint-N.comp` | compensation table (`COMP_FILE_TYPE = 1`: nominal, forward offset, reverse offset) "
          "carrying " << [&] {
         std::string s;
         for (const std::string& n : out.carried) s += (s.empty() ? "" : ", ") + n;
         return s;
       }() << " |\n";
  md << "\n## Use\n\n"
     << "1. Copy `kincal-geometry.hal`" << (out.comp.empty() ? "" : " and `joint-N.comp`")
     << " into the machine's configuration directory.\n"
     << "2. Merge `kincal.ini` into the machine's INI: in each `[JOINT_n]` its keys replace the ones there; "
        "add its `HALFILE` line after the HAL file that loads genhexkins (`loadrt [KINS]KINEMATICS`), so its "
        "`setp` lines come last.\n"
     << "3. Home the machine as before: the home offsets carry the identified encoder offsets.\n"
     << "4. Keep genhexkins' `spindle-offset` and `tool-offset` at 0 (G49) when positions must be kincal's: "
        "genhexkins adds them to the z of every joint.\n";
  md << "\n## Carried\n\n- geometry: the 36 calibrated joint positions (exact: genhexkins evaluates the same strut "
        "lengths kincal does);\n- encoder offsets dl1..dl6 as `HOME_OFFSET` (exact).\n";
  if (!out.comp.empty()) {
    double worst = 0;
    std::size_t entries = 0;
    for (const LinuxCncCompTable& t : out.comp) {
      worst = std::max(worst, t.max_error_mm);
      entries = std::max(entries, t.nominal.size());
    }
    md << "- joint-alone effects by compensation tables: ";
    for (std::size_t k = 0; k < out.carried.size(); ++k) md << (k ? ", " : "") << out.carried[k];
    md << ". Up to " << entries << " entries per joint; LinuxCNC's linear interpolation stays within "
       << general(worst * 1e3, 3) << " um of kincal's correction over the stroke (+/- " << general(kCompMarginMm)
       << " mm).\n  LinuxCNC chooses the forward or reverse column by the sign of the joint's commanded velocity; "
          "kincal by the sign of the joint's change since the last point. They agree when each joint moves "
          "monotonically into a point (a final approach move); a leg can reverse along a long Cartesian line.\n"
          "  LinuxCNC 2.9 adds a step of the table (a backlash reversal) through a filter (`backlash-filt` "
          "toward `backlash-corr`); measured headless, it took a step at once only when it was at most the "
          "joint's MAX_ACCELERATION x servo period^2 / 4, larger ones when the joint moved on (docs/linuxcnc.md): "
          "compare the two pins at a point that matters.\n";
  }
  md << "\n## Not carried\n\n";
  if (out.not_carried.empty()) {
    md << "Nothing: the model has no effect LinuxCNC cannot carry.\n";
  } else {
    for (const std::string& n : out.not_carried) {
      md << "- `" << n << "`: ";
      if (n == "thermal")
        md << "a scaling of the pose by the temperature; LinuxCNC's kinematics has no temperature input.\n";
      else if (n == "compliance")
        md << "a joint deflection from the static load, which depends on the whole pose, not on the joint alone.\n";
      else
        md << "not an effect of one joint alone (or code kincal cannot write into a table).\n";
    }
  }
  md << "\n## Predicted error\n\n";
  if (out.predictions.empty()) {
    md << "No measured poses were given (`--data`): not predicted.\n";
  } else {
    md << "The machine as the model describes it (calibrated geometry and every identified effect), commanded in "
          "each way, on the "
       << out.predictions.front().poses << " poses (with their temperatures and directions) of `"
       << options.data->file << "`:\n\n"
       << "| commanded by | poses | RMS position (um) | max position (um) | RMS orientation (urad) |\n|---|---|---|---|---|\n";
    for (const LinuxCncPrediction& p : out.predictions)
      md << "| " << p.what << " | " << p.poses << " | " << fixed(p.rms_position_mm * 1e3, 3) << " | "
         << fixed(p.max_position_mm * 1e3, 3) << " | " << fixed(p.rms_orientation_rad * 1e6, 3) << " |\n";
  }
  if (!out.warnings.empty()) {
    md << "\n## Warnings\n\n";
    for (const std::string& w : out.warnings) md << "- " << w << "\n";
  }
  out.files["README.md"] = md.str();

  // export.json: the same numbers for scripts.
  nlohmann::json j;
  j["format"] = "kincal-linuxcnc-export";
  j["version"] = 1;
  j["generator"] = std::string("kincal ") + kVersion;
  j["model"] = file;
  j["units"] = units_name(options.inch);
  j["home_offset_before"] = std::vector<double>(home_nominal.data(), home_nominal.data() + 6);
  j["home_offset"] = std::vector<double>(home_offset.data(), home_offset.data() + 6);
  const Vec6<double> dl = cal.length_offset * unit;
  j["length_offset"] = std::vector<double>(dl.data(), dl.data() + 6);
  j["carried"] = out.carried;
  j["not_carried"] = out.not_carried;
  nlohmann::json comp = nlohmann::json::array();
  for (const LinuxCncCompTable& t : out.comp)
    comp.push_back({{"entries", t.nominal.size()}, {"max_error_um", t.max_error_mm * 1e3}});
  j["comp"] = comp;
  nlohmann::json pred = nlohmann::json::array();
  for (const LinuxCncPrediction& p : out.predictions)
    pred.push_back({{"what", p.what},
                    {"poses", p.poses},
                    {"rms_position_um", p.rms_position_mm * 1e3},
                    {"max_position_um", p.max_position_mm * 1e3},
                    {"rms_orientation_urad", p.rms_orientation_rad * 1e6}});
  j["predicted"] = pred;
  out.files["export.json"] = j.dump(2) + "\n";
  return out;
}

void check_export_directory(const std::string& dir, bool overwrite) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path target = fs::path(dir).lexically_normal();
  if (target.empty() || target.filename().empty() || target.filename() == "." || target.filename() == "..")
    throw InputError(dir, 0, 0, "not a directory name to write the export into");
  const bool exists = fs::exists(fs::symlink_status(target, ec));
  if (exists && !overwrite)
    throw InputError(dir, 0, 0, "exists; the export does not overwrite it unless asked (--force)");
  if (exists && !fs::is_directory(fs::symlink_status(target, ec)))
    throw InputError(dir, 0, 0, "exists and is not a directory");
  const fs::path parent = target.has_parent_path() ? target.parent_path() : fs::path(".");
  if (!fs::is_directory(parent, ec)) throw InputError(dir, 0, 0, "its parent directory does not exist");
}

void write_export_directory(const std::map<std::string, std::string>& files, const std::string& dir, bool overwrite) {
  namespace fs = std::filesystem;
  check_export_directory(dir, overwrite);
  std::error_code ec;
  const fs::path target = fs::path(dir).lexically_normal();
  const bool exists = fs::exists(fs::symlink_status(target, ec));
  const fs::path parent = target.has_parent_path() ? target.parent_path() : fs::path(".");
  const std::string tag = ".kincal-" + std::to_string(::getpid());
  const fs::path staging = parent / (target.filename().string() + tag + ".new");
  const fs::path old = parent / (target.filename().string() + tag + ".old");
  fs::remove_all(staging, ec);
  if (!fs::create_directory(staging, ec) || ec)
    throw InputError(dir, 0, 0, "cannot create " + staging.string() + ": " + ec.message());
  try {
    for (const auto& [name, text] : files) {
      std::ofstream f(staging / name, std::ios::binary);
      f << text;
      f.flush();
      if (!f) throw InputError((staging / name).string(), 0, 0, "cannot write");
    }
    if (exists) {
      fs::rename(target, old, ec);
      if (ec) throw InputError(dir, 0, 0, "cannot move the old export aside: " + ec.message());
    }
    fs::rename(staging, target, ec);
    if (ec) {
      std::error_code back;
      if (exists) fs::rename(old, target, back);
      throw InputError(dir, 0, 0, "cannot move the export into place: " + ec.message());
    }
  } catch (...) {
    fs::remove_all(staging, ec);
    throw;
  }
  if (exists) fs::remove_all(old, ec);
}

}  // namespace kincal::identify
