// Issue #10, "Real fuzzing": a property test of the controller path. Random
// tables — every one with a valid CRC, its values perturbed at random, many
// absurdly (0, ±1e6, ×1e3, sign flips) — and random NC streams (poses in
// and far outside the workspace, NaN and Inf, random sequence numbers,
// temperatures, malformed records) drive the Controller on the emulator
// backends. The property: every command that leaves the controller is finite
// and, in the model's joint frame (what the drives servo to), inside the
// machine limits compiled in apart from the tables. 10^6 points in Release;
// 10^5 under the sanitizers (the same code, ~20× slower there).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <random>

#include "kincal/core/compensation.hpp"
#include "kincal/core/reference_machines.hpp"
#include "kincal/port/controller.hpp"
#include "kincal/port/emulator/encoder_registers.hpp"
#include "kincal/port/emulator/nc_stream.hpp"

namespace {

using namespace kincal;
using namespace kincal::port;

#if defined(__SANITIZE_ADDRESS__) || defined(KINCAL_SANITIZE_BUILD)
constexpr long kPointsInAll = 100000;
#else
constexpr long kPointsInAll = 1000000;
#endif
constexpr int kTablesPerFamily = 50;

struct Tally {
  long emitted = 0, compensated = 0, held = 0, refused_periods = 0, nominal_fallback = 0, violations = 0;
  long by_status[kCompensationStatusCount] = {};
  long by_port[16] = {};
};

// One table value perturbed the way a corrupt or hand-edited table would be.
double perturb(double v, std::mt19937_64& rng) {
  std::uniform_int_distribution<int> kind(0, 7);
  std::normal_distribution<double> n(0.0, 1.0);
  switch (kind(rng)) {
    case 0: return 0.0;
    case 1: return 1e6;
    case 2: return -1e6;
    case 3: return v * 1e3;
    case 4: return -v;
    case 5: return v + 10.0 * n(rng);
    case 6: return v * (1.0 + 0.01 * n(rng));
    default: return v + 1e-3 * n(rng);
  }
}

template <class Machine>
CalibrationTable<Machine> random_table(const CalibrationTable<Machine>& base, std::mt19937_64& rng) {
  constexpr std::size_t n = table_value_count<Machine>();
  double values[n];
  table_to_values(base, values);
  // A few tables untouched, most with a handful of values changed, some with many.
  std::uniform_int_distribution<int> how_many(0, 3);
  const int level = how_many(rng);
  const int changes = level == 0 ? 0 : level == 1 ? 1 : level == 2 ? 5 : 60;
  std::uniform_int_distribution<std::size_t> which(0, n - 1);
  for (int k = 0; k < changes; ++k) {
    const std::size_t i = which(rng);
    values[i] = perturb(values[i], rng);
  }
  CalibrationTable<Machine> t = table_from_values<Machine>(values, 0u);
  seal(t);  // a valid CRC: the generator's promise, whatever the values
  return t;
}

// A pose around the workspace centre `c` with spans `s`, sometimes far out,
// sometimes not finite.
Vec6<double> random_pose(const Vec6<double>& c, const Vec6<double>& s, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> kind(0, 19);
  Vec6<double> p;
  for (int i = 0; i < 6; ++i) p(i) = c(i) + s(i) * u(rng);
  switch (kind(rng)) {
    case 0: p(std::size_t(rng() % 6)) = std::numeric_limits<double>::quiet_NaN(); break;
    case 1: p(std::size_t(rng() % 6)) = std::numeric_limits<double>::infinity(); break;
    case 2: p *= 10.0; break;              // far outside
    case 3: p(3 + rng() % 3) += 3.0; break;  // a large rotation
    default: break;
  }
  return p;
}

template <class Machine>
void run_one(const CalibrationTable<Machine>& calibration, const CalibrationTable<Machine>& nominal,
             const MachineLimits<double>& limits, const Vec6<double>& centre, const Vec6<double>& span, long points,
             std::mt19937_64& rng, Tally& tally) {
  emulator::EncoderRegisters regs;
  emulator::NcStream<double, 4, 4> stream;
  ControllerConfig<double> config;
  if constexpr (Machine::family == MachineFamily::Hybrid)
    config.scaling = EncoderOffsetScaling<double>::hybrid_default();
  std::uniform_int_distribution<int> coin(0, 9);
  if (coin(rng) == 0) {  // sometimes an initial command, good or not
    config.has_initial_command = true;
    for (int i = 0; i < 6; ++i) config.initial_command(i) = perturb(0.5 * (limits.min_joint[i] + limits.max_joint[i]), rng);
  }
  Controller<Machine, emulator::EncoderRegisters, emulator::NcStream<double, 4, 4>> ctl(regs, stream, calibration,
                                                                                        nominal, limits, config);
  ctl.start();
  if (ctl.report().nominal) ++tally.nominal_fallback;
  auto check = [&](const JointCommand<double>& c) {
    ++tally.emitted;
    Vec6<double> model_frame = c.q;  // the drives servo their raw encoder to q − R
    for (int k = 0; k < 6; ++k) model_frame(k) -= config.scaling.to_joint(k, regs.value(k));
    if (!all_finite(c.q) || !command_inside(model_frame, limits)) {
      ++tally.violations;
      ADD_FAILURE() << "command " << c.sequence << " outside the limits or not finite: " << model_frame.transpose()
                    << " (flags " << int(c.flags) << ", status " << to_string(c.status) << ")";
    }
    ++tally.by_status[int(c.status)];
    ++tally.by_port[int(c.port) & 15];
    if ((c.flags & kCommandHeld) != 0)
      ++tally.held;
    else
      ++tally.compensated;
  };
  std::uint32_t sequence = 1;
  std::uniform_real_distribution<double> temperature(-20.0, 80.0);
  for (long k = 0; k < points; ++k) {
    NcInput<double> p;
    const int seq_kind = coin(rng);
    sequence = seq_kind == 0 ? std::uint32_t(rng()) : seq_kind == 1 ? sequence : sequence + 1;
    p.sequence = sequence;
    p.pose = random_pose(centre, span, rng);
    p.has_temperature = coin(rng) < 3;
    p.temperature = temperature(rng);
    p.valid = coin(rng) != 0;
    stream.push(p);
    const Cycle cycle = ctl.step();
    if (cycle == Cycle::NoSafeHold) ++tally.refused_periods;
    JointCommand<double> c;
    while (stream.pop(c)) check(c);
  }
}

template <class Machine>
Tally property(const CalibrationTable<Machine>& good, const CalibrationTable<Machine>& nominal, const Vec6<double>& centre,
               const Vec6<double>& span, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  // The compiled-in limits: the nominal machine's stroke and correction bound.
  const MachineLimits<double> limits = limits_from_bounds(nominal.bounds);
  const long per_table = kPointsInAll / (2 * kTablesPerFamily);
  Tally tally;
  for (int t = 0; t < kTablesPerFamily; ++t) {
    // Both tables random: the fallback may be corrupt as well.
    const CalibrationTable<Machine> cal = random_table(good, rng);
    const CalibrationTable<Machine> nom = (t % 4 == 3) ? random_table(nominal, rng) : nominal;
    run_one(cal, nom, limits, centre, span, per_table, rng, tally);
  }
  return tally;
}

void report(const char* name, const Tally& t) {
  std::printf("%s: %ld points answered (%ld compensated, %ld held), %ld periods refused (no safe hold), "
              "%ld controllers on the nominal fallback, %ld violations\n",
              name, t.emitted, t.compensated, t.held, t.refused_periods, t.nominal_fallback, t.violations);
  std::printf("  statuses:");
  for (int k = 0; k < kCompensationStatusCount; ++k)
    if (t.by_status[k] > 0) std::printf(" %s %ld;", to_string(CompensationStatus(k)), t.by_status[k]);
  for (int k = 0; k < 16; ++k)
    if (t.by_port[k] > 0) std::printf(" port %s %ld;", to_string(PortStatus(k)), t.by_port[k]);
  std::printf("\n");
}

TEST(PortControllerProperty, RandomTablesAndStreamsNeverEmitACommandOutsideTheLimits) {
  // 6-UPS: seed 001 with hinge and leg errors of up to 50 µm.
  const StewartGeometry<double> gs = make_stewart_seed001<double>();
  StewartCalibrationTable<double> s_nominal = nominal_table(gs);
  StewartCalibrationTable<double> s_good = s_nominal;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> e(-0.05, 0.05);
  for (double& v : s_good.machine.calibrated.base) v += e(rng);
  for (double& v : s_good.machine.calibrated.length_offset) v += e(rng);
  seal(s_good);
  Vec6<double> sc, ss;
  sc << 0, 0, 200, 0, 0, 0;
  ss << 40, 40, 30, 0.1, 0.1, 0.15;
  const Tally st = property(s_good, s_nominal, sc, ss, 1001);

  // Hybrid: seed 000 with encoder offsets and structural errors.
  const HybridGeometry<double> gh = make_hybrid_seed000<double>();
  HybridCalibrationTable<double> h_nominal = nominal_table(gh);
  HybridCalibrationTable<double> h_good = h_nominal;
  const double xi[6] = {0.3, -0.25, 0.2, 5e-4, -4e-4, 3e-4};
  for (int i = 0; i < 6; ++i) h_good.machine.encoder_offsets[i] = xi[i];
  std::uniform_real_distribution<double> se(-1e-4, 1e-4);
  for (int k = 6; k < kHybridSourceErrorCount; ++k) h_good.machine.source_errors[k] = se(rng);
  seal(h_good);
  Vec6<double> hc, hs;
  hc << 0, 0, 0, 0, 0, 0;
  hs << 300, 300, 80, 0.1, 0.1, 0.1;
  const Tally ht = property(h_good, h_nominal, hc, hs, 2002);

  report("6-UPS", st);
  report("hybrid", ht);
  EXPECT_EQ(st.violations + ht.violations, 0);
  // The property was exercised: points answered, both held and compensated.
  EXPECT_GE(st.emitted + ht.emitted + st.refused_periods + ht.refused_periods, kPointsInAll);
  EXPECT_GT(st.compensated, 0);
  EXPECT_GT(ht.compensated, 0);
  EXPECT_GT(st.held + ht.held, 0);
  EXPECT_GT(st.nominal_fallback + ht.nominal_fallback, 0);
}

}  // namespace
