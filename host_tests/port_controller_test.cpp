// The controller loop on the emulator backend (port/include/kincal/port/controller.hpp,
// port/emulator): every failure the GUIDE's reliability bar names — NaN/Inf in
// the stream, unreachable and singular poses, out-of-limit commands, oversized
// corrections, a corrupted table, a failed register write or read-back, stream
// overrun and underrun — gives its status, holds a safe output, is counted,
// and loses no point: the sequence numbers of the commands are exactly those
// of the points, in order.
#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <limits>
#include <optional>
#include <vector>

#include "kincal/core/compensation.hpp"
#include "kincal/core/reference_machines.hpp"
#include "kincal/port/controller.hpp"
#include "kincal/port/emulator/encoder_registers.hpp"
#include "kincal/port/emulator/nc_stream.hpp"
#include "portable/core_checks.hpp"

namespace {

using namespace kincal;
using namespace kincal::port;
using CS = CompensationStatus;
using HybridM = HybridMachine<double>;
using StewartM = StewartMachine<double>;

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---- tables (they must outlive the controllers: the compensator reads Δχ̂ in place)

const HybridCalibrationTabled& hybrid_nominal() {
  static const HybridCalibrationTabled t = nominal_table(make_hybrid_seed000<double>());
  return t;
}

// A calibrated hybrid: encoder offsets of the size seed 000's coarse stage
// finds, and structural errors of tens of micrometres.
const HybridCalibrationTabled& hybrid_calibrated() {
  static const HybridCalibrationTabled t = [] {
    HybridCalibrationTabled c = hybrid_nominal();
    const double xi[6] = {0.31, -0.22, 0.14, 4e-4, -3e-4, 2.5e-4};
    for (int i = 0; i < 6; ++i) c.machine.encoder_offsets[i] = xi[i];
    for (int k = 6; k < HybridErrorLayout::tool(); k += 7) c.machine.source_errors[k] = (k % 3 == 0 ? 0.03 : -2e-5);
    return seal_table(c);
  }();
  return t;
}

StewartGeometry<double> wide_stewart() {
  // Stroke widened so that only the singularity can stop the IK at the
  // torsional singularity (core_checks.hpp does the same).
  StewartGeometry<double> g = make_stewart_seed001<double>();
  g.min_length.setConstant(1.0);
  g.max_length.setConstant(1000.0);
  return g;
}

const StewartCalibrationTabled& stewart_nominal() {
  static const StewartCalibrationTabled t = nominal_table(wide_stewart());
  return t;
}

const StewartCalibrationTabled& stewart_calibrated() {
  static const StewartCalibrationTabled t = [] {
    StewartCalibrationTabled c = stewart_nominal();
    for (int i = 0; i < 6; ++i) c.machine.calibrated.length_offset[i] = 0.05 * (i + 1) - 0.17;
    c.machine.calibrated.base[4] += 0.02;
    c.machine.calibrated.platform[7] -= 0.015;
    return seal_table(c);
  }();
  return t;
}

// ---- points

NcInput<double> point(std::uint32_t seq, double x, double y, double z, double rx = 0, double ry = 0, double rz = 0) {
  NcInput<double> p;
  p.sequence = seq;
  p.pose << x, y, z, rx, ry, rz;
  return p;
}

// n points on a line through the hybrid's task cuboid, numbered from 1.
std::vector<NcInput<double>> hybrid_path(int n) {
  std::vector<NcInput<double>> v;
  for (int k = 0; k < n; ++k) {
    const double s = n > 1 ? double(k) / (n - 1) : 0.0;
    v.push_back(point(static_cast<std::uint32_t>(k + 1), -200 + 400 * s, 150 - 300 * s, -50 + 100 * s, 0.02 * s, -0.01, 0.0));
  }
  return v;
}

std::vector<NcInput<double>> stewart_path(int n) {
  std::vector<NcInput<double>> v;
  for (int k = 0; k < n; ++k) {
    const double s = n > 1 ? double(k) / (n - 1) : 0.0;
    v.push_back(point(static_cast<std::uint32_t>(k + 1), -20 + 40 * s, 10 - 20 * s, 195 + 10 * s, 0.02 * s, -0.01, 0.03 * s));
  }
  return v;
}

// ---- the rig: emulated registers and stream, a controller, a producer and a
// consumer that the test makes early or late.

template <class Machine, std::size_t In = 4, std::size_t Out = 4, class Formulas = NoFormulaEffects> struct Rig {
  using Table = CalibrationTable<Machine>;
  using Stream = emulator::NcStream<double, In, Out>;
  using Ctl = Controller<Machine, emulator::EncoderRegisters, Stream, Formulas>;

  emulator::EncoderRegisters regs;
  Stream stream;
  ControllerConfig<double> config;
  const Table* calibration;
  const Table* nominal;
  // The machine limits compiled in apart from the tables: here the nominal
  // table's bounds (its stroke, the default correction bound).
  MachineLimits<double> limits;
  std::vector<JointCommand<double>> out;
  std::vector<Cycle> cycles;

  Rig(const Table& cal, const Table& nom) : calibration(&cal), nominal(&nom), limits(limits_from_bounds(nom.bounds)) {
    config.scaling = EncoderOffsetScaling<double>::of<Machine>();
  }

  // Runs the points through: each period the producer pushes `per_period`
  // points (every `producer_every`-th period; a refused point is retried
  // the next time), the controller steps once, and the consumer takes every
  // command (every `consumer_every`-th period). Ends when the stream is
  // over and everything is out.
  Ctl& run(std::vector<NcInput<double>> points, int producer_every = 1, int per_period = 1, int consumer_every = 1) {
    Ctl& ctl = ctl_storage.emplace(regs, stream, *calibration, *nominal, limits, config);
    ctl.start();
    std::size_t next = 0;
    for (int period = 0; period < 100000; ++period) {
      if (period % producer_every == 0) {
        for (int k = 0; k < per_period && next < points.size(); ++k) {
          if (stream.push(points[next]) != PortStatus::Ok) break;  // full: keep it, retry later
          ++next;
        }
        if (next == points.size()) stream.end();
      }
      const Cycle c = ctl.step();
      cycles.push_back(c);
      if (period % consumer_every == 0) {
        JointCommand<double> cmd;
        while (stream.pop(cmd)) out.push_back(cmd);
      }
      if (c == Cycle::End || c == Cycle::Error) break;
    }
    JointCommand<double> cmd;
    while (stream.pop(cmd)) out.push_back(cmd);
    return ctl;
  }

  // The commands minus the drive's register offset: what the drives servo to.
  Vec6<double> raw(const JointCommand<double>& c) const {
    Vec6<double> q = c.q;
    for (int k = 0; k < 6; ++k) q(k) -= config.scaling.to_joint(k, regs.value(k));
    return q;
  }

  std::optional<Ctl> ctl_storage;
};

// Every point answered once, in order, and nothing non-finite sent.
void expect_no_point_lost(const std::vector<JointCommand<double>>& out, const std::vector<NcInput<double>>& in) {
  ASSERT_EQ(out.size(), in.size());
  for (std::size_t k = 0; k < in.size(); ++k) {
    EXPECT_EQ(out[k].sequence, in[k].sequence) << "command " << k;
    EXPECT_TRUE(all_finite(out[k].q)) << "command " << k << " is not finite";
  }
}

// The reference: the same table's compensator driven directly.
template <class Machine>
std::vector<Vec6<double>> direct(const CalibrationTable<Machine>& t, const std::vector<NcInput<double>>& in,
                                 std::vector<CS>* statuses = nullptr, UserJointError<double> user_effect = nullptr) {
  Compensator<Machine> comp(t, trust_table_bounds);
  comp.set_user_effect(user_effect);
  Vec6<double> home;
  EXPECT_EQ(comp.home_command(home), CS::Ok);
  CompensatorState<double> s = comp.start(home);
  std::vector<Vec6<double>> q;
  for (const NcInput<double>& p : in) {
    kincal::NcPoint<double> cp;
    cp.pose = Pose<double>::from_xyz_rpy(p.pose);
    cp.temperature = p.temperature;
    cp.has_temperature = p.has_temperature;
    Vec6<double> c;
    const CS st = comp.compensate(s, cp, c);
    if (statuses != nullptr) statuses->push_back(st);
    q.push_back(c);
  }
  return q;
}

// ---- the normal case -------------------------------------------------------

TEST(PortController, HybridStreamEqualsTheCompensatorAndWritesTheEncoderOffsets) {
  Rig<HybridM> rig(hybrid_calibrated(), hybrid_nominal());
  const auto in = hybrid_path(25);
  auto& ctl = rig.run(in);
  expect_no_point_lost(rig.out, in);
  EXPECT_TRUE(ctl.report().ready());
  EXPECT_FALSE(ctl.report().nominal);
  // The offsets are in the registers, in counts of 1 nm / 10 nrad.
  for (int ch = 0; ch < 6; ++ch) {
    const double xi = hybrid_calibrated().machine.encoder_offsets[ch];
    EXPECT_EQ(rig.regs.value(ch), static_cast<std::int32_t>(std::lround(xi / rig.config.scaling.resolution[ch])));
  }
  const auto want = direct(hybrid_calibrated(), in);
  for (std::size_t k = 0; k < in.size(); ++k) {
    EXPECT_EQ(rig.out[k].status, CS::Ok);
    EXPECT_EQ(rig.out[k].flags, 0);
    // The drive frame is shifted by the register; the drive's raw setpoint is
    // the compensator's command.
    EXPECT_LT((rig.raw(rig.out[k]) - want[k]).cwiseAbs().maxCoeff(), 1e-12) << k;
  }
  EXPECT_EQ(ctl.counters().points, 25u);
  EXPECT_EQ(ctl.counters().compensated, 25u);
  EXPECT_EQ(ctl.counters().held, 0u);
  EXPECT_EQ(ctl.state().count(CS::Ok), 25u);
  EXPECT_EQ(ctl.state().failures(), 0u);
}

TEST(PortController, StewartStreamEqualsTheCompensatorAndWritesTheLegOffsets) {
  Rig<StewartM> rig(stewart_calibrated(), stewart_nominal());
  const auto in = stewart_path(12);
  auto& ctl = rig.run(in);
  expect_no_point_lost(rig.out, in);
  for (int ch = 0; ch < 6; ++ch)
    EXPECT_EQ(rig.regs.value(ch), static_cast<std::int32_t>(std::lround((0.05 * (ch + 1) - 0.17) / 1e-6)));
  const auto want = direct(stewart_calibrated(), in);
  for (std::size_t k = 0; k < in.size(); ++k) {
    EXPECT_EQ(rig.out[k].status, CS::Ok);
    EXPECT_LT((rig.raw(rig.out[k]) - want[k]).cwiseAbs().maxCoeff(), 1e-12) << k;
  }
  EXPECT_EQ(ctl.counters().compensated, 12u);
}

// A user joint effect (core/effects.hpp): its numbers in the table, its code
// through ControllerConfig::user_effect. Here Δq_i = u_i · (q_i − 230 mm)².
double quadratic_user_effect(const double* u, int joint, const Vec6<double>& q, const kincal::EffectInputs<double>&) {
  const double d = q(joint) - 230.0;
  return u[joint] * d * d;
}

TEST(PortController, AUserEffectComesWithTheTableAndItsCodeWithTheConfig) {
  static const StewartCalibrationTabled with_user = [] {
    StewartCalibrationTabled c = stewart_calibrated();
    for (int i = 0; i < 6; ++i) c.effects.user[i] = 2e-5 * (i % 2 == 0 ? 1 : -1);
    return seal_table(c);
  }();
  const auto in = stewart_path(12);
  Rig<StewartM> rig(with_user, stewart_nominal());
  rig.config.user_effect = &quadratic_user_effect;
  rig.run(in);
  expect_no_point_lost(rig.out, in);
  const auto want = direct(with_user, in, nullptr, &quadratic_user_effect);
  const auto without = direct(with_user, in);
  double effect = 0;
  for (std::size_t k = 0; k < in.size(); ++k) {
    EXPECT_EQ(rig.out[k].status, CS::Ok);
    EXPECT_LT((rig.raw(rig.out[k]) - want[k]).cwiseAbs().maxCoeff(), 1e-12) << k;
    effect = std::max(effect, (want[k] - without[k]).cwiseAbs().maxCoeff());
  }
  // The plug-in changed the commands (by the effect's size, micrometres).
  EXPECT_GT(effect, 1e-4);
  EXPECT_LT(effect, 0.1);
}

// A formula-effect policy as `kincal table` generates one (core/
// formula_effects.hpp), written by hand: leg 3 drifts with the time stamp
// and with the point's first named input, leg 5 with the temperature. The
// controller hands the stream's time and inputs to the compensator.
struct DriftFormulas {
  static constexpr bool present = true;
  static constexpr bool pose_twist = false, reads_pose = false, reads_load = false, reads_stream = true,
                        reads_family = false;
  void add_joint_error(const double* params, const double* vars, double* dq) const {
    dq[2] += params[0] * vars[FormulaSlot::time] + params[1] * vars[FormulaSlot::input];
    dq[4] += params[2] * (vars[FormulaSlot::temp] - 20) * vars[FormulaSlot::q + 4];
  }
  void add_pose_twist(const double*, const double*, double*) const {}
  bool has_pose() const { return false; }
  int input_count() const { return 1; }
  double payload_weight() const { return 1.0; }
  Vec3<double> payload_com() const { return Vec3<double>::Zero(); }
};

TEST(PortController, FormulaEffectsReadTheStreamsTimeAndInputs) {
  static const StewartCalibrationTabled with_formulas = [] {
    StewartCalibrationTabled c = stewart_calibrated();
    c.effects.user[0] = 2e-4;   // mm/s
    c.effects.user[1] = -3e-3;  // mm per input unit
    c.effects.user[2] = 1.2e-5; // 1/°C
    return seal_table(c);
  }();
  std::vector<NcInput<double>> in = stewart_path(10);
  for (std::size_t k = 0; k < in.size(); ++k) {
    in[k].time = 0.5 * double(k);
    in[k].inputs[0] = 2.0 - 0.3 * double(k);
    in[k].temperature = 21 + 0.4 * double(k);
    in[k].has_temperature = true;
  }
  in[6].inputs[0] = kNan;  // a sensor that failed: held with a status, never sent
  Rig<StewartM, 4, 4, DriftFormulas> rig(with_formulas, stewart_nominal());
  rig.config.has_initial_command = true;  // the home pose has no input: where the machine stands
  ASSERT_EQ(Compensator<StewartM>(stewart_nominal(), trust_table_bounds).home_command(rig.config.initial_command), CS::Ok);
  rig.run(in);
  expect_no_point_lost(rig.out, in);

  // The same stream through the compensator directly.
  const Compensator<StewartM, DriftFormulas> direct_formulas(with_formulas, rig.limits);
  auto state = direct_formulas.start(rig.config.initial_command);
  double moved = 0;
  for (std::size_t k = 0; k < in.size(); ++k) {
    NcPoint<double> p;
    p.pose = Pose<double>::from_xyz_rpy(in[k].pose);
    p.temperature = in[k].temperature;
    p.has_temperature = true;
    p.time = in[k].time;
    p.inputs = in[k].inputs;
    Vec6<double> q;
    const CS st = direct_formulas.compensate(state, p, q);
    EXPECT_EQ(rig.out[k].status, st) << k;
    if (k == 6) {
      EXPECT_EQ(st, CS::InvalidInput);
      EXPECT_TRUE(rig.out[k].flags & kCommandHeld);
      continue;
    }
    ASSERT_EQ(st, CS::Ok) << k;
    EXPECT_LT((rig.raw(rig.out[k]) - q).cwiseAbs().maxCoeff(), 1e-12) << k;
    Vec6<double> plain;
    auto s2 = Compensator<StewartM>(stewart_calibrated(), rig.limits).start(q);
    ASSERT_EQ(Compensator<StewartM>(stewart_calibrated(), rig.limits).compensate(s2, p, plain), CS::Ok);
    moved = std::max(moved, std::abs(q(2) - plain(2)));
  }
  EXPECT_GT(moved, 1e-3);  // the formulas moved leg 3 (time and input terms)
}

// A user effect that returns NaN: no NaN leaves core; every point is held
// with a status and counted.
TEST(PortController, AUserEffectReturningNanIsHeldNotSent) {
  static const StewartCalibrationTabled with_user = [] {
    StewartCalibrationTabled c = stewart_calibrated();
    c.effects.user[0] = 1.0;
    return seal_table(c);
  }();
  const auto in = stewart_path(6);
  Rig<StewartM> rig(with_user, stewart_nominal());
  rig.config.user_effect = [](const double*, int, const Vec6<double>&, const kincal::EffectInputs<double>&) {
    return std::nan("");
  };
  // The home pose cannot be compensated either (the user code fails there
  // too), so only a configured initial command — where the machine stands,
  // inside the limits — gives the controller something safe to hold.
  rig.config.has_initial_command = true;
  ASSERT_EQ(Compensator<StewartM>(stewart_nominal(), trust_table_bounds).home_command(rig.config.initial_command), CS::Ok);
  auto& ctl = rig.run(in);
  expect_no_point_lost(rig.out, in);
  for (const auto& c : rig.out) {
    EXPECT_NE(c.status, CS::Ok);
    EXPECT_TRUE(c.flags & kCommandHeld);
    EXPECT_TRUE(c.q.allFinite());
  }
  EXPECT_EQ(ctl.counters().held, in.size());
}

// ---- bad points: status, held output, counted, nothing lost ------------------

// Checks the commands of `bad` points are the previous command (held) with
// the expected status, the others are new commands with status Ok.
void expect_held_at(const std::vector<JointCommand<double>>& out, const std::vector<std::size_t>& bad, CS status) {
  for (std::size_t k = 0; k < out.size(); ++k) {
    const bool is_bad = std::find(bad.begin(), bad.end(), k) != bad.end();
    if (is_bad) {
      EXPECT_EQ(out[k].status, status) << "command " << k;
      EXPECT_TRUE(out[k].flags & kCommandHeld) << "command " << k;
      ASSERT_GT(k, 0u);
      EXPECT_EQ(out[k].q, out[k - 1].q) << "command " << k << " does not hold the previous output";
    } else {
      EXPECT_EQ(out[k].status, CS::Ok) << "command " << k;
      EXPECT_FALSE(out[k].flags & kCommandHeld) << "command " << k;
    }
  }
}

TEST(PortController, NanAndInfInTheStreamAreRejectedHeldAndCounted) {
  Rig<HybridM> rig(hybrid_calibrated(), hybrid_nominal());
  auto in = hybrid_path(12);
  in[3].pose(0) = kNan;
  in[5].pose(5) = kInf;
  in[7].pose(2) = -kInf;
  in[8].has_temperature = true;
  in[8].temperature = kNan;
  in[10].valid = false;  // a record the stream could not parse
  auto& ctl = rig.run(in);
  expect_no_point_lost(rig.out, in);
  expect_held_at(rig.out, {3, 5, 7, 8, 10}, CS::InvalidInput);
  EXPECT_EQ(ctl.state().count(CS::InvalidInput), 5u);
  EXPECT_EQ(ctl.counters().held, 5u);
  EXPECT_EQ(ctl.counters().malformed, 1u);
  EXPECT_EQ(ctl.counters().compensated, 7u);
}

TEST(PortController, UnreachableAndOutOfLimitPosesAreHeldAndCounted) {
  Rig<HybridM> rig(hybrid_calibrated(), hybrid_nominal());
  auto in = hybrid_path(10);
  // Far below the base: the limb would have to point away from the work.
  in[2].pose << 0, 0, 5000, 0, 0, 0;
  // Outside the task cuboid, still assembled: a UPS leg beyond its stroke.
  in[6].pose << 0, 0, -400, 0, 0, 0;
  std::vector<CS> want_status;
  direct(hybrid_calibrated(), in, &want_status);
  ASSERT_EQ(want_status[2], CS::Unreachable);
  ASSERT_EQ(want_status[6], CS::OutOfLimits);
  auto& ctl = rig.run(in);
  expect_no_point_lost(rig.out, in);
  for (std::size_t k = 0; k < in.size(); ++k) {
    const CS want = k == 2 ? CS::Unreachable : k == 6 ? CS::OutOfLimits : CS::Ok;
    EXPECT_EQ(rig.out[k].status, want) << k;
    EXPECT_EQ((rig.out[k].flags & kCommandHeld) != 0, want != CS::Ok) << k;
    if (want != CS::Ok) {
      EXPECT_EQ(rig.out[k].q, rig.out[k - 1].q) << k;
    }
  }
  EXPECT_EQ(ctl.state().count(CS::Unreachable), 1u);
  EXPECT_EQ(ctl.state().count(CS::OutOfLimits), 1u);
  EXPECT_EQ(ctl.counters().held, 2u);
}

TEST(PortController, SingularPoseIsHeldAndCounted) {
  const double yaw = kincal::test::find_stewart_singular_yaw();
  ASSERT_NE(yaw, 0.0);
  Rig<StewartM> rig(stewart_calibrated(), stewart_nominal());
  auto in = stewart_path(8);
  in[4].pose << 0, 0, 200, 0, 0, yaw;
  auto& ctl = rig.run(in);
  expect_no_point_lost(rig.out, in);
  expect_held_at(rig.out, {4}, CS::Singular);
  EXPECT_EQ(ctl.state().count(CS::Singular), 1u);
}

TEST(PortController, OversizedCorrectionIsHeldAndCounted) {
  // A thermal coefficient and a tight correction bound: warm points need a
  // correction beyond the bound, the others do not.
  static const HybridCalibrationTabled table = [] {
    HybridCalibrationTabled t = hybrid_calibrated();
    t.effects.thermal = 1e-4;  // 1/°C
    for (int i = 0; i < 3; ++i) t.bounds.max_correction[i] = 1.0;  // mm
    return seal_table(t);
  }();
  ASSERT_EQ(validate_table(table), CS::Ok);
  Rig<HybridM> rig(table, hybrid_nominal());
  auto in = hybrid_path(9);
  for (auto& p : in) {
    p.has_temperature = true;
    p.temperature = 21;
  }
  // ε = 1e-2 at 255 mm from the origin of {R} (the thermal origin here):
  // the tool point moves 2.5 mm, the legs about as much.
  in[8].temperature = 120;
  auto& ctl = rig.run(in);
  expect_no_point_lost(rig.out, in);
  expect_held_at(rig.out, {8}, CS::OversizedCorrection);
  EXPECT_EQ(ctl.state().count(CS::OversizedCorrection), 1u);
}

// ---- corrupt tables: nominal fallback with a status ---------------------------

struct Corruption {
  const char* name;
  CS status;
  HybridCalibrationTabled (*make)();
};

HybridCalibrationTabled corrupt_crc() {
  HybridCalibrationTabled t = hybrid_calibrated();
  t.machine.source_errors[40] += 1e-9;  // one flipped value, CRC not updated
  return t;
}
HybridCalibrationTabled corrupt_version() {
  HybridCalibrationTabled t = hybrid_calibrated();
  t.version = kCalibrationTableVersion + 1;
  return t;
}
HybridCalibrationTabled corrupt_bounds() {
  HybridCalibrationTabled t = hybrid_calibrated();
  t.bounds.max_correction[2] = -1.0;  // resealed: the CRC is right, the bound is not
  return seal_table(t);
}
HybridCalibrationTabled corrupt_value() {
  HybridCalibrationTabled t = hybrid_calibrated();
  t.machine.nominal.tool_length = kNan;
  return seal_table(t);
}

class PortControllerCorruptTable : public ::testing::TestWithParam<Corruption> {};

TEST_P(PortControllerCorruptTable, FallsBackToTheNominalModelWithAStatus) {
  const Corruption& c = GetParam();
  const HybridCalibrationTabled bad = c.make();
  Rig<HybridM> rig(bad, hybrid_nominal());
  const auto in = hybrid_path(10);
  auto& ctl = rig.run(in);
  expect_no_point_lost(rig.out, in);
  EXPECT_EQ(ctl.report().table, c.status) << c.name;
  EXPECT_TRUE(ctl.report().nominal);
  EXPECT_EQ(ctl.report().fallback, CS::Ok);
  EXPECT_TRUE(ctl.report().ready());
  EXPECT_EQ(ctl.counters().table_failures, 1u);
  // The nominal model has no encoder offsets: the registers are cleared.
  for (int ch = 0; ch < 6; ++ch) EXPECT_EQ(rig.regs.value(ch), 0);
  const auto want = direct(hybrid_nominal(), in);
  for (std::size_t k = 0; k < in.size(); ++k) {
    EXPECT_EQ(rig.out[k].status, CS::Ok);
    EXPECT_TRUE(rig.out[k].flags & kCommandNominalModel);
    EXPECT_LT((rig.raw(rig.out[k]) - want[k]).cwiseAbs().maxCoeff(), 1e-12);
  }
}

INSTANTIATE_TEST_SUITE_P(Tables, PortControllerCorruptTable,
                         ::testing::Values(Corruption{"crc", CS::TableCrc, &corrupt_crc},
                                           Corruption{"version", CS::TableVersion, &corrupt_version},
                                           Corruption{"bounds", CS::TableValues, &corrupt_bounds},
                                           Corruption{"nan", CS::TableValues, &corrupt_value}),
                         [](const auto& p) { return std::string(p.param.name); });

TEST(PortController, BothTablesCorruptRefusesEveryPointAndHolds) {
  const HybridCalibrationTabled bad = corrupt_crc();
  HybridCalibrationTabled bad_nominal = hybrid_nominal();
  bad_nominal.version = 0;
  Rig<HybridM> rig(bad, bad_nominal);
  rig.config.has_initial_command = true;
  rig.config.initial_command << 900, 900, 900, 0, 0.5, 0;
  const auto in = hybrid_path(6);
  auto& ctl = rig.run(in);
  expect_no_point_lost(rig.out, in);
  EXPECT_FALSE(ctl.report().ready());
  EXPECT_EQ(ctl.report().fallback, CS::TableVersion);
  EXPECT_EQ(ctl.counters().table_failures, 2u);
  for (const auto& c : rig.out) {
    EXPECT_EQ(c.status, CS::TableVersion);  // the table the compensator was given
    EXPECT_TRUE(c.flags & kCommandHeld);
    EXPECT_EQ(rig.raw(c), rig.config.initial_command);
  }
  EXPECT_EQ(ctl.state().count(CS::TableVersion), 6u);
}

// ---- the held output (issue #10 item 1) ------------------------------------------
// Before, with both tables rejected or a home pose that cannot be
// compensated, every held point went out as q = 0 (outside both machines'
// strokes), and a NaN initial command went out as NaN. Now a hold must be a
// verified command inside the machine limits, or nothing is sent at all.

template <class Machine> void expect_nothing_sent(Rig<Machine>& rig, const std::vector<NcInput<double>>& in) {
  auto& ctl = rig.run(in);
  EXPECT_FALSE(ctl.report().hold);
  EXPECT_FALSE(ctl.report().ready());
  EXPECT_TRUE(rig.out.empty()) << rig.out.size() << " commands sent, first " << rig.raw(rig.out[0]).transpose();
  EXPECT_GT(ctl.counters().no_safe_hold, 0u);
  EXPECT_EQ(ctl.step(), Cycle::NoSafeHold);
}

TEST(PortController, BothTablesRejectedAndNoInitialCommandSendsNothing) {
  const HybridCalibrationTabled bad = corrupt_crc();
  HybridCalibrationTabled bad_nominal = hybrid_nominal();
  bad_nominal.version = 0;
  Rig<HybridM> rig(bad, bad_nominal);
  expect_nothing_sent(rig, hybrid_path(6));
}

TEST(PortController, AHomePoseThatCannotBeCompensatedSendsNothing) {
  // A table whose lower joint limit lies above the home command: valid, inside
  // the machine limits, but the home pose is out of its limits.
  static const HybridCalibrationTabled high_floor = [] {
    HybridCalibrationTabled t = hybrid_calibrated();
    t.bounds.min_joint[0] = t.bounds.max_joint[0] - 1.0;
    return seal_table(t);
  }();
  Rig<HybridM> rig(high_floor, hybrid_nominal());
  expect_nothing_sent(rig, hybrid_path(6));
}

TEST(PortController, AnInitialCommandThatIsNotFiniteOrOutsideTheLimitsSendsNothing) {
  for (const double bad : {std::nan(""), 0.0, 1e30}) {
    Rig<StewartM> rig(stewart_calibrated(), stewart_nominal());
    rig.config.has_initial_command = true;
    ASSERT_EQ(Compensator<StewartM>(stewart_nominal(), trust_table_bounds).home_command(rig.config.initial_command), CS::Ok);
    rig.config.initial_command(3) = bad;
    expect_nothing_sent(rig, stewart_path(5));
  }
}

// The absurd table (CRC valid, stroke bounds 0…1e6, source errors of
// 1e6): refused against the machine limits, so the controller runs on the
// nominal table and no leg goes outside the stroke.
TEST(PortController, AnAbsurdTableIsRefusedAgainstTheMachineLimits) {
  static const StewartCalibrationTabled absurd = [] {
    StewartCalibrationTabled t = stewart_calibrated();
    for (int i = 0; i < 6; ++i) {
      t.bounds.min_joint[i] = t.machine.calibrated.min_length[i] = 0;
      t.bounds.max_joint[i] = t.machine.calibrated.max_length[i] = 1e6;
      t.bounds.max_correction[i] = 1e6;
      t.machine.calibrated.length_offset[i] = 1e3;
    }
    return seal_table(t);
  }();
  ASSERT_EQ(validate_table(absurd), CS::Ok);
  Rig<StewartM> rig(absurd, stewart_nominal());
  const auto in = stewart_path(8);
  auto& ctl = rig.run(in);
  expect_no_point_lost(rig.out, in);
  EXPECT_EQ(ctl.report().table, CS::TableLimits);
  EXPECT_TRUE(ctl.report().nominal);
  EXPECT_TRUE(ctl.report().ready());
  for (const auto& c : rig.out) {
    EXPECT_TRUE(c.flags & kCommandNominalModel);
    EXPECT_TRUE(command_inside(rig.raw(c), rig.limits)) << rig.raw(c).transpose();
  }
}

// ---- encoder-offset registers --------------------------------------------------

TEST(PortController, ARetriedRegisterWriteIsCountedAndThenFine) {
  Rig<HybridM> rig(hybrid_calibrated(), hybrid_nominal());
  rig.regs.fail_writes(2, 1);  // one transient failure
  rig.regs.lose_writes(4, 1);  // one lost write, seen by the read-back
  const auto in = hybrid_path(5);
  auto& ctl = rig.run(in);
  EXPECT_TRUE(ctl.report().ready());
  EXPECT_EQ(ctl.counters().register_retries, 2u);
  EXPECT_EQ(ctl.counters().register_failures, 0u);
  expect_no_point_lost(rig.out, in);
  for (const auto& c : rig.out) EXPECT_EQ(c.status, CS::Ok);
}

struct RegisterFault {
  const char* name;
  PortStatus status;
  void (*inject)(emulator::EncoderRegisters&);
};

class PortControllerRegisterFault : public ::testing::TestWithParam<RegisterFault> {};

TEST_P(PortControllerRegisterFault, RefusesMotionHoldsAndCounts) {
  const RegisterFault& f = GetParam();
  Rig<HybridM> rig(hybrid_calibrated(), hybrid_nominal());
  f.inject(rig.regs);
  const auto in = hybrid_path(7);
  auto& ctl = rig.run(in);
  EXPECT_EQ(ctl.report().registers, f.status) << f.name;
  EXPECT_EQ(ctl.report().register_channel, 3);
  EXPECT_FALSE(ctl.report().ready());
  EXPECT_EQ(ctl.counters().register_failures, 1u);
  expect_no_point_lost(rig.out, in);
  Vec6<double> home;
  ASSERT_EQ(Compensator<HybridM>(hybrid_calibrated(), trust_table_bounds).home_command(home), CS::Ok);
  for (const auto& c : rig.out) {
    EXPECT_EQ(c.port, f.status);
    EXPECT_TRUE(c.flags & kCommandHeld);
    EXPECT_EQ(c.q, rig.out.front().q);
  }
  EXPECT_EQ(ctl.counters().held, 7u);
  EXPECT_EQ(ctl.counters().compensated, 0u);
  EXPECT_EQ(ctl.state().count(CS::Ok), 0u);  // nothing was compensated
}

INSTANTIATE_TEST_SUITE_P(
    Registers, PortControllerRegisterFault,
    ::testing::Values(
        RegisterFault{"write_failed", PortStatus::WriteFailed, [](emulator::EncoderRegisters& r) { r.fail_writes(3, 100); }},
        RegisterFault{"read_failed", PortStatus::ReadFailed, [](emulator::EncoderRegisters& r) { r.fail_reads(3, 100); }},
        RegisterFault{"lost_write", PortStatus::ReadBackMismatch,
                      [](emulator::EncoderRegisters& r) { r.lose_writes(3, 100); }},
        // ξ̂_4 = 4e-4 rad = 40000 counts: bit 0 stuck at 1 reads 40001.
        RegisterFault{"stuck_bit", PortStatus::ReadBackMismatch,
                      [](emulator::EncoderRegisters& r) { r.stick_bits(3, 0x1u, 0x1u); }}),
    [](const auto& p) { return std::string(p.param.name); });

TEST(PortController, AnOffsetBeyondTheRegisterRangeIsRefused) {
  Rig<HybridM> rig(hybrid_calibrated(), hybrid_nominal());
  rig.config.scaling.resolution[0] = 1e-13;  // 0.31 mm = 3.1e12 counts: does not fit
  const auto in = hybrid_path(3);
  auto& ctl = rig.run(in);
  EXPECT_EQ(ctl.report().registers, PortStatus::OutOfRange);
  EXPECT_EQ(ctl.report().register_channel, 0);
  expect_no_point_lost(rig.out, in);
  for (const auto& c : rig.out) EXPECT_EQ(c.port, PortStatus::OutOfRange);
}

// An undetected stuck bit would move the machine by the register error:
// what the verification protects against (the drive servos to command − R).
TEST(PortController, TheRegisterContentShiftsTheDriveFrame) {
  Rig<HybridM> rig(hybrid_calibrated(), hybrid_nominal());
  const auto in = hybrid_path(3);
  rig.run(in);
  const Vec6<double> before = rig.raw(rig.out[1]);
  rig.regs.set_value(0, rig.regs.value(0) + 1000);  // 1 µm, after verification
  EXPECT_NEAR(rig.raw(rig.out[1])(0), before(0) - 1e-3, 1e-12);
}

// ---- the stream --------------------------------------------------------------

TEST(PortController, UnderrunHoldsTheLastCommandAndIsCounted) {
  Rig<HybridM> rig(hybrid_calibrated(), hybrid_nominal());
  const auto in = hybrid_path(8);
  auto& ctl = rig.run(in, /*producer_every=*/3);
  expect_no_point_lost(rig.out, in);
  // Two idle periods after each point but the last; no command is emitted in
  // them, so the drives keep (hold) the last one.
  EXPECT_EQ(ctl.counters().underruns, 14u);
  long underrun_cycles = std::count(rig.cycles.begin(), rig.cycles.end(), Cycle::Underrun);
  EXPECT_EQ(underrun_cycles, 14);
  EXPECT_EQ(ctl.counters().compensated, 8u);
  EXPECT_EQ(rig.stream.underruns(), 14);
}

TEST(PortController, ProducerOverrunIsReportedWithThePointAndNothingIsLost) {
  Rig<HybridM, 3, 4> rig(hybrid_calibrated(), hybrid_nominal());
  const auto in = hybrid_path(20);
  // The producer tries 2 points per period, the controller takes 1: the
  // 3-deep input queue fills and refuses; the producer keeps and retries.
  auto& ctl = rig.run(in, 1, 2);
  expect_no_point_lost(rig.out, in);
  EXPECT_GT(rig.stream.producer_overruns(), 0);
  EXPECT_EQ(ctl.counters().producer_overruns, static_cast<std::uint32_t>(rig.stream.producer_overruns()));
  long flagged = 0;
  for (const auto& c : rig.out) {
    EXPECT_EQ(c.status, CS::Ok);
    flagged += (c.flags & kCommandAfterInputOverrun) ? 1 : 0;
  }
  EXPECT_GT(flagged, 0);
  EXPECT_EQ(ctl.counters().compensated, 20u);
}

TEST(PortController, OutputOverrunKeepsTheCommandAndStopsTakingPoints) {
  Rig<HybridM, 4, 2> rig(hybrid_calibrated(), hybrid_nominal());
  const auto in = hybrid_path(15);
  // The drives take commands only every 4th period; the 2-deep output fills.
  auto& ctl = rig.run(in, 1, 1, 4);
  expect_no_point_lost(rig.out, in);
  EXPECT_GT(ctl.counters().output_overruns, 0u);
  EXPECT_EQ(ctl.counters().output_overruns, static_cast<std::uint32_t>(rig.stream.send_overruns()));
  EXPECT_EQ(std::count(rig.cycles.begin(), rig.cycles.end(), Cycle::OutputBlocked),
            static_cast<long>(ctl.counters().output_overruns));
  const auto want = direct(hybrid_calibrated(), in);
  for (std::size_t k = 0; k < in.size(); ++k)
    EXPECT_LT((rig.raw(rig.out[k]) - want[k]).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(PortController, SequenceGapsAreCountedAndFlagged) {
  Rig<HybridM> rig(hybrid_calibrated(), hybrid_nominal());
  auto in = hybrid_path(10);
  // Points 4 and 5 never reached the port, and 9 arrived numbered 8 again:
  // 1 2 3 6 7 8 8 10 — a gap of two, a step back, a gap of one.
  in.erase(in.begin() + 3, in.begin() + 5);
  in[6].sequence = in[5].sequence;
  auto& ctl = rig.run(in);
  expect_no_point_lost(rig.out, in);
  EXPECT_EQ(ctl.counters().sequence_errors, 3u);
  EXPECT_EQ(ctl.counters().missing_points, 3u);
  for (std::size_t k = 0; k < rig.out.size(); ++k)
    EXPECT_EQ((rig.out[k].flags & kCommandSequenceGap) != 0, k == 3 || k == 6 || k == 7) << k;
  // A gap is the producer's loss, not a bad point: each is still compensated.
  // The repeated 8 is not executed (it would move the machine back along the
  // path): held, with its port status.
  EXPECT_EQ(ctl.counters().compensated, 7u);
  EXPECT_EQ(ctl.counters().held, 1u);
  EXPECT_TRUE(rig.out[6].flags & kCommandHeld);
  EXPECT_EQ(rig.out[6].port, PortStatus::SequenceError);
  EXPECT_EQ(rig.raw(rig.out[6]), rig.raw(rig.out[5]));
}

// A jump to 0xFFFFFFFF does not wrap the missing-point counter (issue #10 item 3).
TEST(PortController, MissingPointsSaturateInsteadOfWrapping) {
  Rig<HybridM> rig(hybrid_calibrated(), hybrid_nominal());
  auto in = hybrid_path(5);
  in[1].sequence = 0x80000000u;  // 1, then two jumps of ~2^31: 0xFFFFFFFC missing so far
  in[2].sequence = 0xFFFFFFFFu;
  in[3].sequence = 0u;           // the producer's counter wraps: no gap
  in[4].sequence = 0xFFFFFFFFu;  // another 0xFFFFFFFE missing: the sum does not fit
  auto& ctl = rig.run(in);
  expect_no_point_lost(rig.out, in);
  EXPECT_EQ(ctl.counters().missing_points, 0xFFFFFFFFu) << "saturated (it wrapped to 0xFFFFFFFA before)";
  EXPECT_EQ(ctl.counters().sequence_errors, 3u);
  EXPECT_EQ(ctl.counters().compensated, 5u);
}

// Everything at once, for the event counters' bookkeeping: points answered =
// compensated + held, and held = the compensator's failures + register holds.
TEST(PortController, CountersAddUp) {
  Rig<HybridM, 3, 2> rig(hybrid_calibrated(), hybrid_nominal());
  auto in = hybrid_path(40);
  in[5].pose(1) = kNan;
  in[11].pose << 0, 0, 5000, 0, 0, 0;
  in[17].pose << 0, 0, -400, 0, 0, 0;
  in[23].valid = false;
  auto& ctl = rig.run(in, 2, 2, 3);
  expect_no_point_lost(rig.out, in);
  const ControllerCounters& n = ctl.counters();
  EXPECT_EQ(n.points, 40u);
  EXPECT_EQ(n.compensated + n.held, n.points);
  EXPECT_EQ(n.held, ctl.state().failures());
  EXPECT_EQ(n.held, 4u);
  EXPECT_EQ(ctl.state().count(CS::Ok), n.compensated);
}

}  // namespace
