// The controller's compensation (core/compensation.hpp) and its parameter
// table (core/calibration_table.hpp), core only: the CRC and the table check,
// the effect corrections inverting the effects, the reliability statuses
// (each gives its status, holds the last safe command, counts the event, never
// emits NaN), float against double, and no heap. identify's reference
// comparisons are in identify_calibration_table_test.cpp.
//
// "No malloc" is enforced as in core_no_malloc_test.cpp: EIGEN_RUNTIME_NO_MALLOC
// with eigen_assert routed to abort().
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "eigen_no_malloc.hpp"  // first: before anything includes Eigen

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <limits>
#include <type_traits>

#include "kincal/core/compensation.hpp"
#include "kincal/core/reference_machines.hpp"
#include "portable/core_checks.hpp"  // find_stewart_singular_yaw, find_hybrid_singular_theta5

// Both scalars, both machines, explicitly instantiated (Sophus / manif style).
template class kincal::Compensator<kincal::HybridMachine<double>>;
template class kincal::Compensator<kincal::HybridMachine<float>>;
template class kincal::Compensator<kincal::StewartMachine<double>>;
template class kincal::Compensator<kincal::StewartMachine<float>>;
template kincal::Status kincal::hybrid_error_twist<double>(const HybridGeometry<double>&, double,
                                                           const HybridFrames<double>&, const double*, Twist<double>&);
template kincal::Status kincal::hybrid_error_twist<float>(const HybridGeometry<float>&, float, const HybridFrames<float>&,
                                                          const float*, Twist<float>&);

namespace {

using namespace kincal;
using CS = CompensationStatus;

constexpr double kDeg = 3.14159265358979323846 / 180.0;

struct HeapForbidden {
  HeapForbidden() { Eigen::internal::set_is_malloc_allowed(false); }
  ~HeapForbidden() { Eigen::internal::set_is_malloc_allowed(true); }
};

// ---- tables -------------------------------------------------------------------

// seed 001 geometry with every hinge and leg length off by up to 50 µm.
StewartCalibrationTable<double> stewart_table(std::uint64_t seed = 7) {
  test::Random rng(seed);
  const StewartGeometry<double> g = make_stewart_seed001<double>();
  StewartGeometry<double> cal = g;
  for (int i = 0; i < 6; ++i) {
    for (int k = 0; k < 3; ++k) {
      cal.base(k, i) += rng.uniform(-0.05, 0.05);
      cal.platform(k, i) += rng.uniform(-0.05, 0.05);
    }
    cal.length_offset(i) = rng.uniform(-0.05, 0.05);
  }
  StewartCalibrationTable<double> t = nominal_table(g);
  t.machine.calibrated = to_table(cal);
  return seal_table(t);
}

// hybrid-seed000 with seed 000's sizes of encoder offsets (examples/hybrid-seed000/errors.csv)
// and every structural error up to ±1e-4 (mm or rad).
HybridCalibrationTable<double> hybrid_table(bool structural = true, std::uint64_t seed = 9) {
  test::Random rng(seed);
  const HybridGeometry<double> g = make_hybrid_seed000<double>();
  EffectParameters<double> frame;
  frame.load_direction = g.workpiece_rotation * Vec3<double>(0, 0, -1);  // identify's effect frame
  frame.thermal_origin = -(g.workpiece_rotation * g.workpiece_origin);
  frame.screw_joints = 0x07;
  HybridCalibrationTable<double> t = nominal_table(g, 345.0, frame);
  const double xi[6] = {0.3, -0.25, 0.2, 5e-4, -4e-4, 3e-4};
  for (int i = 0; i < 6; ++i) t.machine.encoder_offsets[i] = xi[i];
  if (structural)
    for (int k = 6; k < kHybridSourceErrorCount; ++k) t.machine.source_errors[k] = rng.uniform(-1e-4, 1e-4);
  return seal_table(t);
}

template <class Machine> CalibrationTable<Machine> with_effects(CalibrationTable<Machine> t) {
  for (int i = 0; i < 6; ++i) {
    t.effects.scale[i] = 1e-4 * (i % 2 == 0 ? 1 : -1);
    t.effects.backlash[i] = (i < 3 ? -0.01 : -2e-5) * (i + 1);
    t.effects.compliance[i] = (i < 3 ? 2e-3 : 1e-6) * (6 - i);
    t.effects.cyclic_sin[i] = i < 3 ? 0.002 : 0.0;
    t.effects.cyclic_cos[i] = i < 3 ? -0.0015 : 0.0;
  }
  if (t.effects.screw_joints == 0) t.effects.screw_joints = 63;  // 6-UPS: every leg screw driven
  return seal_table(t);
}

Pose<double> stewart_pose(test::Random& rng) {
  return Pose<double>::from_xyz_rpy(rng.uniform(-20, 20), rng.uniform(-20, 20), rng.uniform(185, 215),
                                    rng.uniform(-3, 3) * kDeg, rng.uniform(-3, 3) * kDeg, rng.uniform(-3, 3) * kDeg);
}
Pose<double> hybrid_pose(test::Random& rng) {
  return Pose<double>::from_xyz_rpy(rng.uniform(-250, 250), rng.uniform(-250, 250), rng.uniform(-60, 60),
                                    rng.uniform(-5, 5) * kDeg, rng.uniform(-5, 5) * kDeg, rng.uniform(-5, 5) * kDeg);
}

// ---- CRC and the table check ----------------------------------------------------

constexpr Crc32 crc_of(const char* s) {
  Crc32 c;
  while (*s != '\0') c.byte(static_cast<std::uint8_t>(*s++));
  return c;
}
static_assert(crc_of("123456789").value() == 0xCBF43926u, "CRC-32/IEEE check value");
static_assert(table_value_count<StewartMachine<double>>() == 220, "6-UPS table layout (leg_offset_sq: 12 more; 16 user numbers: 8 more)");
static_assert(table_value_count<HybridMachine<double>>() == 303, "hybrid table layout (156 source errors; 16 user numbers)");

// What a generated header does: values, the CRC as a literal, static_assert.
constexpr double kNominalValues[table_value_count<StewartMachine<double>>()] = {};
constexpr StewartCalibrationTable<double> kZeros = table_from_values<StewartMachine<double>>(kNominalValues, 0u);
static_assert(table_crc(kZeros) != 0u, "constexpr CRC");
constexpr StewartCalibrationTable<double> kSealed = seal_table(kZeros);
static_assert(table_crc(kSealed) == kSealed.crc, "a sealed table carries its CRC");
static_assert(validate_table(kSealed) == CS::TableValues, "all-zero geometry is not a machine");

TEST(coreCompensation, TableCrcCoversEveryBit) {
  const HybridCalibrationTable<double> t = hybrid_table();
  ASSERT_EQ(validate_table(t), CS::Ok);
  // Flip single bits of single values (low mantissa, exponent, sign, the
  // screw mask): each is caught by the CRC.
  constexpr int kCount = table_value_count<HybridMachine<double>>();
  double values[kCount];
  table_to_values(t, values);
  test::Random rng(3);
  for (int trial = 0; trial < 200; ++trial) {
    const int k = static_cast<int>(rng.uniform(0, kCount));
    const int bit = trial < 64 ? trial : static_cast<int>(rng.uniform(0, 64));
    double v[kCount];
    std::memcpy(v, values, sizeof v);
    std::uint64_t bits;
    std::memcpy(&bits, &v[k], 8);
    bits ^= std::uint64_t(1) << bit;
    std::memcpy(&v[k], &bits, 8);
    const HybridCalibrationTable<double> bad = table_from_values<HybridMachine<double>>(v, t.crc);
    EXPECT_EQ(validate_table(bad), CS::TableCrc) << "value " << k << " bit " << bit;
  }
  // The float table has its own CRC, of its rounded values.
  const HybridCalibrationTable<float> tf = table_cast<float>(t);
  EXPECT_EQ(validate_table(tf), CS::Ok);
  EXPECT_NE(tf.crc, t.crc);
  HybridCalibrationTable<float> tf_with_double_crc = tf;
  tf_with_double_crc.crc = t.crc;
  EXPECT_EQ(validate_table(tf_with_double_crc), CS::TableCrc);
}

TEST(coreCompensation, ValidateTableNamesEachFailure) {
  const HybridCalibrationTable<double> good = hybrid_table();
  auto resealed = [](HybridCalibrationTable<double> t) {
    t.crc = table_crc(t);
    return t;
  };
  HybridCalibrationTable<double> t = good;
  t.version = kCalibrationTableVersion + 1;
  EXPECT_EQ(validate_table(resealed(t)), CS::TableVersion);
  t = good;
  t.family = MachineFamily::Stewart6Ups;
  EXPECT_EQ(validate_table(resealed(t)), CS::TableFamily);
  t = good;
  t.machine.source_errors[40] += 1e-9;
  EXPECT_EQ(validate_table(t), CS::TableCrc);
  t = good;
  t.machine.source_errors[40] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(validate_table(resealed(t)), CS::TableValues);
  t = good;
  t.effects.thermal = std::numeric_limits<double>::infinity();
  EXPECT_EQ(validate_table(resealed(t)), CS::TableValues);
  t = good;
  t.bounds.max_correction[2] = 0;
  EXPECT_EQ(validate_table(resealed(t)), CS::TableValues);
  t = good;
  t.bounds.min_joint[4] = t.bounds.max_joint[4];
  EXPECT_EQ(validate_table(resealed(t)), CS::TableValues);
  t = good;
  t.bounds.max_correction[0] = 0.1;  // below the 0.3 mm encoder offset
  EXPECT_EQ(validate_table(resealed(t)), CS::TableValues);
  t = good;
  t.machine.source_errors[2] = 0.1;  // encoder entries belong in encoder_offsets
  EXPECT_EQ(validate_table(resealed(t)), CS::TableValues);
  t = good;
  t.machine.nominal.workpiece_rotation[1] += 0.01;  // not a rotation
  EXPECT_EQ(validate_table(resealed(t)), CS::TableValues);
  t = good;
  t.effects.screw_joints = 2.5;
  EXPECT_EQ(validate_table(resealed(t)), CS::TableValues);
  t = good;
  t.machine.nominal.tool_length = -250;
  EXPECT_EQ(validate_table(resealed(t)), CS::TableValues);
  StewartCalibrationTable<double> s = stewart_table();
  EXPECT_EQ(validate_table(s), CS::Ok);
  s.machine.calibrated.min_length[3] = 1e4;
  s.crc = table_crc(s);
  EXPECT_EQ(validate_table(s), CS::TableValues);
}

// Issue #10 item 2: a CRC-valid table with absurd numbers passed
// validate_table (which trusts finite values) and the compensator then sent
// legs of 908–2003 mm with status Ok. Against machine limits compiled in apart
// from the table, each absurdity is refused (TableLimits).
TEST(coreCompensation, ValidateTableAgainstMachineLimits) {
  const StewartCalibrationTable<double> good_s = stewart_table();
  const HybridCalibrationTable<double> good_h = hybrid_table();
  const MachineLimits<double> ls = limits_from_bounds(nominal_table(make_stewart_seed001<double>()).bounds);
  const MachineLimits<double> lh = limits_from_bounds(nominal_table(make_hybrid_seed000<double>()).bounds);
  EXPECT_EQ(validate_table(good_s, ls), CS::Ok);
  EXPECT_EQ(validate_table(good_h, lh), CS::Ok);
  EXPECT_EQ(validate_table(with_effects(good_s), ls), CS::Ok);
  EXPECT_EQ(validate_table(with_effects(good_h), lh), CS::Ok);

  // The table: stroke bounds 0…1e6 and source errors of 1e6. It
  // passes the table's own check (the defect) and fails against the limits.
  StewartCalibrationTable<double> absurd = good_s;
  for (int i = 0; i < 6; ++i) {
    absurd.bounds.min_joint[i] = absurd.machine.calibrated.min_length[i] = 0;
    absurd.bounds.max_joint[i] = absurd.machine.calibrated.max_length[i] = 1e6;
    absurd.bounds.max_correction[i] = 1e6;
    absurd.machine.calibrated.base[3 * i] += 1e6;
  }
  absurd = seal_table(absurd);
  EXPECT_EQ(validate_table(absurd), CS::Ok) << "the table's own check cannot see it";
  EXPECT_EQ(validate_table(absurd, ls), CS::TableLimits);
  // ... and a compensator given the limits refuses it, where one without
  // them would compensate with it.
  EXPECT_EQ(StewartCompensator<double>(absurd, ls).status(), CS::TableLimits);

  // One absurdity at a time.
  auto refused = [&](auto t, const MachineLimits<double>& l, const char* what) {
    t = seal_table(t);
    EXPECT_EQ(validate_table(t), CS::Ok) << what;
    EXPECT_EQ(validate_table(t, l), CS::TableLimits) << what;
  };
  {
    auto t = good_s;
    t.bounds.max_joint[2] = ls.max_joint[2] + 1;  // a stroke past the drives'
    refused(t, ls, "stroke past the limits");
  }
  {
    auto t = good_s;
    t.bounds.max_correction[4] = ls.max_correction[4] * 2;
    refused(t, ls, "correction bound above the limits'");
  }
  {
    auto t = good_s;  // a leg offset dl_i above the correction bound (was unchecked for the 6-UPS)
    t.machine.calibrated.length_offset[1] = t.machine.nominal.length_offset[1] + 1.5 * t.bounds.max_correction[1];
    refused(t, ls, "leg offset above the correction bound");
  }
  {
    auto t = good_s;
    t.machine.calibrated.platform[7] += 2 * ls.max_geometry_error;
    refused(t, ls, "platform joint error above the cap");
  }
  {
    auto t = good_h;
    t.machine.source_errors[77] = 1e6;
    refused(t, lh, "hybrid source error of 1e6");
  }
  {
    auto t = with_effects(good_h);
    t.effects.scale[0] = 0.5;
    refused(t, lh, "scale 0.5");
  }
  {
    auto t = with_effects(good_s);
    t.effects.thermal = 0.1;
    refused(t, ls, "thermal 0.1 /C");
  }
  {
    auto t = with_effects(good_s);
    t.effects.backlash[3] = 2 * t.bounds.max_correction[3];
    refused(t, ls, "backlash above the correction bound");
  }
  // Limits that are not limits.
  MachineLimits<double> nan_limits = ls;
  nan_limits.max_joint[0] = std::nan("");
  EXPECT_EQ(validate_table(good_s, nan_limits), CS::TableLimits);
  MachineLimits<double> unordered = ls;
  unordered.min_joint[5] = unordered.max_joint[5];
  EXPECT_EQ(validate_table(good_s, unordered), CS::TableLimits);
}

// Issue #31: the hybrid's source errors are lengths (mm) and angles (rad);
// each kind has its own cap (max_geometry_error, max_angle_error), where one
// cap of 10 "mm" used to serve both. An angle of 0.05 rad and a length of
// 0.05 mm are each checked against their own cap only.
TEST(coreCompensation, TheHybridsAngleCapBoundsAnglesAndTheLengthCapLengths) {
  using L = HybridErrorLayout;
  static_assert(!L::angular(0) && !L::angular(2) && L::angular(3) && L::angular(5), "encoders: legs mm, wrist rad");
  static_assert(!L::angular(L::ups(1) + 2) && L::angular(L::ups(1) + 3), "frame 0: x y z α β γ");
  static_assert(!L::angular(L::ups(0) + 6 + 2) && L::angular(L::ups(0) + 6 + 3), "revolute frame 1: x y z | α β");
  static_assert(!L::angular(L::ups(2) + 16 + 1) && L::angular(L::ups(2) + 16 + 2), "prismatic frame 3: x y | α β γ");
  static_assert(!L::angular(L::up() + 16 + 1) && L::angular(L::up() + 20), "the UP limb's prismatic frame 3");
  static_assert(!L::angular(L::wrist() + 12) && L::angular(L::wrist() + 14), "wrist frame 6: x y z | α β");
  int angles = 0;
  for (int k = L::kEncoders; k < L::size(); ++k) angles += L::angular(k) ? 1 : 0;
  // 64 structural angles of seed 000, 3 of the tool frame
  EXPECT_EQ(angles, 3 * (3 + 2 + 2 + 3 + 2 + 2 + 2) + (3 + 2 + 2 + 3) + 3 * 2 + 3);

  const HybridCalibrationTable<double> good = hybrid_table();
  MachineLimits<double> l = limits_from_bounds(nominal_table(make_hybrid_seed000<double>()).bounds);
  EXPECT_EQ(l.max_angle_error, 0.1);  // DefaultLimitCaps: today's results unchanged
  EXPECT_EQ(l.max_geometry_error, 10.0);
  l.max_angle_error = 0.04;
  l.max_geometry_error = 0.06;
  const int angle = L::ups(1) + 4, length = L::ups(1) + 1;  // Δβ_0,2 and Δy_0,2
  auto status_with = [&](int k, double v) {
    HybridCalibrationTable<double> t = good;
    t.machine.source_errors[k] = v;
    return validate_table(seal_table(t), l);
  };
  EXPECT_EQ(validate_table(good, l), CS::Ok);
  EXPECT_EQ(status_with(angle, 0.05), CS::TableLimits);  // above the angle cap
  EXPECT_EQ(status_with(angle, -0.03), CS::Ok);
  EXPECT_EQ(status_with(length, 0.05), CS::Ok);  // above the angle cap, below the length cap
  EXPECT_EQ(status_with(length, -0.07), CS::TableLimits);
  l.max_angle_error = 1.0;  // a large angle cap does not open lengths
  EXPECT_EQ(status_with(length, 0.07), CS::TableLimits);
  EXPECT_EQ(status_with(angle, 0.07), CS::Ok);
  // Not a sane cap.
  l.max_angle_error = -1;
  EXPECT_EQ(validate_table(good, l), CS::TableLimits);
  l.max_angle_error = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(validate_table(good, l), CS::TableLimits);
}

// Issue #31: Compensator(table) took the table's own bounds as the machine's
// limits; a firmware must not get that by accident. The trusting form is
// spelled out (trust_table_bounds), the limits form is the other, and a
// temporary table is refused for both. (`Compensator(t, {})` does not
// compile either: the tag's explicit constructor makes it ambiguous.)
TEST(coreCompensation, TheTrustingFormIsExplicit) {
  using M = HybridMachine<double>;
  using C = Compensator<M>;
  using T = CalibrationTable<M>;
  static_assert(!std::is_constructible<C, const T&>::value, "no one-argument Compensator(table)");
  static_assert(!std::is_constructible<C, T&>::value, "no one-argument Compensator(table)");
  static_assert(std::is_constructible<C, const T&, TrustTableBounds>::value, "the trusting form");
  static_assert(std::is_constructible<C, const T&, const MachineLimits<double>&>::value, "the limits form");
  static_assert(!std::is_constructible<C, T&&, TrustTableBounds>::value, "a temporary table would dangle");
  static_assert(!std::is_constructible<C, T&&, const MachineLimits<double>&>::value, "a temporary table would dangle");
  static_assert(!std::is_convertible<const T&, C>::value, "not implicitly from a table");
  static_assert(!std::is_constructible<Compensator<StewartMachine<float>>, const CalibrationTable<StewartMachine<float>>&>::value,
                "no one-argument Compensator(table), any machine or scalar");
  const T t = hybrid_table();
  EXPECT_EQ(C(t, trust_table_bounds).status(), CS::Ok);
  EXPECT_EQ(C(t, limits_from_bounds(t.bounds)).status(), CS::Ok);
}

// Issue #10 item 3: a rotation that is not one (×1.001) and approach
// directions other than ±1 (0, −5, 1e30) were compensated; now InvalidInput.
TEST(coreCompensation, SkewedRotationsAndBadDirectionsAreInvalidInput) {
  const StewartCalibrationTable<double> t = with_effects(stewart_table());
  const StewartCompensator<double> c(t, trust_table_bounds);
  Vec6<double> home;
  ASSERT_EQ(c.home_command(home), CS::Ok);
  auto state = c.start(home);
  NcPoint<double> p;
  p.pose = Pose<double>::from_xyz_rpy(5, -3, 205, 0.02, -0.01, 0.03);
  Vec6<double> q;
  ASSERT_EQ(c.compensate(state, p, q), CS::Ok);
  NcPoint<double> skewed = p;
  skewed.pose.R *= 1.001;
  EXPECT_EQ(c.compensate(state, skewed, q), CS::InvalidInput);
  EXPECT_EQ(q, state.command);
  for (const double bad : {0.0, -5.0, 1e30, 0.999}) {
    Vec6<double> dir = Vec6<double>::Ones();
    dir(2) = bad;
    NcPoint<double> d = p;
    d.direction = &dir;
    EXPECT_EQ(c.compensate(state, d, q), CS::InvalidInput) << bad;
  }
  Vec6<double> ok_dir;
  ok_dir << 1, -1, 1, -1, 1, -1;
  NcPoint<double> d = p;
  d.direction = &ok_dir;
  EXPECT_EQ(c.compensate(state, d, q), CS::Ok);
  // float: its own rounding of a rotation built in float is accepted.
  const auto tf = table_cast<float>(t);
  const StewartCompensator<float> cf(tf, trust_table_bounds);
  Vec6<float> hf;
  ASSERT_EQ(cf.home_command(hf), CS::Ok);
  auto sf = cf.start(hf);
  Vec6<float> qf;
  EXPECT_EQ(cf.compensate(sf, Pose<float>::from_xyz_rpy(5.f, -3.f, 205.f, 0.02f, -0.01f, 0.03f), qf), CS::Ok);
  Pose<float> skewed_f = Pose<float>::from_xyz_rpy(5.f, -3.f, 205.f, 0.02f, -0.01f, 0.03f);
  skewed_f.R *= 1.001f;
  EXPECT_EQ(cf.compensate(sf, skewed_f, qf), CS::InvalidInput);
}

template <class Machine> void check_corrupt_table_holds(CalibrationTable<Machine> t, const Pose<double>& pose) {
  using S = typename Machine::Scalar;
  const Compensator<Machine> good(t, trust_table_bounds);
  ASSERT_EQ(good.status(), CS::Ok);
  Vec6<S> home;
  ASSERT_EQ(good.home_command(home), CS::Ok);
  t.bounds.max_correction[1] *= S(2);  // not resealed: the CRC no longer matches
  const Compensator<Machine> bad(t, trust_table_bounds);
  EXPECT_EQ(bad.status(), CS::TableCrc);
  auto state = bad.start(home);
  Vec6<S> out = Vec6<S>::Constant(S(-7));
  EXPECT_EQ(bad.compensate(state, pose.cast<S>(), out), CS::TableCrc);
  EXPECT_EQ(out, home);
  EXPECT_EQ(state.count(CS::TableCrc), 1u);
  EXPECT_EQ(state.count(CS::Ok), 0u);
  EXPECT_EQ(state.last, CS::TableCrc);
  Vec6<S> q;
  EXPECT_EQ(bad.home_command(q), CS::TableCrc);
}

TEST(coreCompensation, CorruptTableHoldsAndCounts) {
  check_corrupt_table_holds(stewart_table(), Pose<double>::from_xyz_rpy(5, 5, 205, 0, 0, 0));
  check_corrupt_table_holds(hybrid_table(), Pose<double>::from_xyz_rpy(100, -50, 20, 0, 0, 0));
  check_corrupt_table_holds(table_cast<float>(hybrid_table()), Pose<double>::from_xyz_rpy(100, -50, 20, 0, 0, 0));
}

// ---- the effect corrections invert the effects -----------------------------------

// Static joint load of a unit weight at the nominal configuration (what the
// compensator uses), computed here through the kinematics' own Jacobians.
Vec6<double> nominal_load(const StewartCalibrationTable<double>& t, const Pose<double>& pose) {
  Vec6<double> q, load;
  Mat6<double> J;
  EXPECT_EQ(stewart_ik(to_core(t.machine.nominal), pose, q, &J), Status::Ok);
  EXPECT_TRUE(static_load_inverse(J, to_core(t.effects).load_direction, load));
  return load;
}
Vec6<double> nominal_load(const HybridCalibrationTable<double>& t, const Pose<double>& pose) {
  const HybridGeometry<double> g = to_core(t.machine.nominal);
  Vec6<double> q;
  Mat6<double> Jik;
  EXPECT_EQ(hybrid_ik(g, pose, q, &Jik), Status::Ok);
  return static_load_forward(Mat6<double>(Jik.inverse()), to_core(t.effects).load_direction);
}

template <class Machine>
void check_effects_inverted(const CalibrationTable<Machine>& plain, Pose<double> (*make_pose)(test::Random&)) {
  const CalibrationTable<Machine> effects = with_effects(plain);
  const Compensator<Machine> with(effects, trust_table_bounds), without(plain, trust_table_bounds);
  ASSERT_EQ(with.status(), CS::Ok);
  const EffectParameters<double> e = to_core(effects.effects);
  Vec6<double> home;
  ASSERT_EQ(without.home_command(home), CS::Ok);
  auto s_with = with.start(home), s_without = without.start(home);
  test::Random rng(21);
  double worst = 0, largest_correction = 0;
  Vec6<double> previous_ideal = home, seen_negative = Vec6<double>::Zero();
  for (int k = 0; k < 60; ++k) {
    const Pose<double> pose = make_pose(rng);
    Vec6<double> q, ideal;
    ASSERT_EQ(without.compensate(s_without, pose, ideal), CS::Ok);
    ASSERT_EQ(with.compensate(s_with, pose, q), CS::Ok);
    // The direction record: the sign of the change of the ideal joints.
    for (int i = 0; i < 6; ++i) {
      EXPECT_EQ(s_with.direction(i), ideal(i) > previous_ideal(i) ? 1.0 : -1.0) << "joint " << i << " point " << k;
      if (s_with.direction(i) < 0) seen_negative(i) = 1;
    }
    previous_ideal = ideal;
    // The machine adds Δq(q) to the command it gets: it reaches the ideal joints.
    EffectInputs<double> in;
    in.direction = s_with.direction;
    in.load = nominal_load(effects, pose);
    const Vec6<double> actual = q + effect_joint_error(e, q, in);
    worst = std::max(worst, (actual - ideal).cwiseAbs().maxCoeff());
    largest_correction = std::max(largest_correction, (q - ideal).cwiseAbs().maxCoeff());
  }
  std::printf("effects: largest correction %.3g, residual after the machine's effect %.2e\n", largest_correction,
              worst);
  EXPECT_GT(largest_correction, 1e-2);
  EXPECT_LT(worst, 1e-10);
  EXPECT_EQ(seen_negative.sum(), 6.0);  // every joint reversed at least once
  // A point repeated: the directions stay.
  const Vec6<double> kept = s_with.direction;
  Vec6<double> q;
  const Pose<double> again = make_pose(rng);
  ASSERT_EQ(with.compensate(s_with, again, q), CS::Ok);
  const Vec6<double> after_move = s_with.direction;
  ASSERT_EQ(with.compensate(s_with, again, q), CS::Ok);
  EXPECT_EQ(s_with.direction, after_move);
  (void)kept;
  // Explicit directions override the record.
  NcPoint<double> p;
  p.pose = again;
  const Vec6<double> down = -Vec6<double>::Ones();
  p.direction = &down;
  ASSERT_EQ(with.compensate(s_with, p, q), CS::Ok);
  EXPECT_EQ(s_with.direction, down);
}

TEST(coreCompensation, EffectCorrectionsInvertTheEffects) {
  check_effects_inverted(stewart_table(), stewart_pose);
  check_effects_inverted(hybrid_table(), hybrid_pose);
}

TEST(coreCompensation, ThermalPreScalesThePose) {
  // 6-UPS: the calibrated machine, warm, reaches the requested pose.
  StewartCalibrationTable<double> s = stewart_table();
  s.effects.thermal = 1.2e-5;
  s = seal_table(s);
  const StewartCompensator<double> cs(s, trust_table_bounds);
  const StewartGeometry<double> cal = to_core(s.machine.calibrated);
  const EffectParameters<double> e = to_core(s.effects);
  auto state = cs.start(Vec6<double>::Constant(233.0));
  test::Random rng(4);
  double worst = 0;
  for (int k = 0; k < 30; ++k) {
    const Pose<double> pose = stewart_pose(rng);
    const double temp = rng.uniform(10, 45);
    Vec6<double> q;
    ASSERT_EQ(cs.compensate(state, pose, temp, q), CS::Ok);
    Pose<double> cold;
    ASSERT_EQ(stewart_fk(cal, q, cold).status, Status::Ok);
    worst = std::max(worst, pose_error(thermal_reached(e, cold, temp), pose).norm());
  }
  EXPECT_LT(worst, 1e-9);
  // hybrid (encoder offsets only, so the ideal IK is exact): the same.
  HybridCalibrationTable<double> h = hybrid_table(false);
  h.effects.thermal = 1.2e-5;
  h = seal_table(h);
  const HybridCompensator<double> ch(h, trust_table_bounds);
  HybridGeometry<double> controller = to_core(h.machine.nominal);
  for (int i = 0; i < 6; ++i) controller.joint_offset(i) += h.machine.encoder_offsets[i];
  const EffectParameters<double> eh = to_core(h.effects);
  auto hs = ch.start(Vec6<double>::Zero());
  worst = 0;
  for (int k = 0; k < 30; ++k) {
    const Pose<double> pose = hybrid_pose(rng);
    const double temp = rng.uniform(10, 45);
    Vec6<double> q;
    ASSERT_EQ(ch.compensate(hs, pose, temp, q), CS::Ok);
    Pose<double> cold;
    ASSERT_EQ(hybrid_fk(controller, q, cold).status, Status::Ok);
    worst = std::max(worst, pose_error(thermal_reached(eh, cold, temp), pose).norm());
  }
  EXPECT_LT(worst, 1e-9);
  // Without a temperature the table's T0 is used: no thermal correction.
  Vec6<double> q0, q20;
  const Pose<double> p = Pose<double>::from_xyz_rpy(10, 20, 30, 0, 0, 0);
  ASSERT_EQ(ch.compensate(hs, p, q0), CS::Ok);
  ASSERT_EQ(ch.compensate(hs, p, 20.0, q20), CS::Ok);
  EXPECT_EQ(q0, q20);
}

// ---- reliability ------------------------------------------------------------------

// Runs one failing point after a good one: the status, the held output, the
// counter, and the state untouched otherwise; then a good point again.
template <class Machine>
void expect_failure(const Compensator<Machine>& c, CompensatorState<typename Machine::Scalar>& state,
                    const NcPoint<typename Machine::Scalar>& bad, const Pose<typename Machine::Scalar>& good,
                    CS expected, const char* what) {
  using S = typename Machine::Scalar;
  Vec6<S> q;
  ASSERT_EQ(c.compensate(state, good, q), CS::Ok) << what;
  const CompensatorState<S> before = state;
  Vec6<S> out = Vec6<S>::Constant(std::numeric_limits<S>::quiet_NaN());
  EXPECT_EQ(c.compensate(state, bad, out), expected) << what;
  EXPECT_EQ(out, before.command) << what;  // the last safe command, never NaN
  EXPECT_TRUE(all_finite(out)) << what;
  EXPECT_EQ(state.count(expected), before.count(expected) + 1) << what;
  EXPECT_EQ(state.last, expected) << what;
  EXPECT_EQ(state.command, before.command) << what;
  EXPECT_EQ(state.reference, before.reference) << what;
  EXPECT_EQ(state.direction, before.direction) << what;
  EXPECT_EQ(c.compensate(state, good, q), CS::Ok) << what;
}

template <class S> NcPoint<S> point(const Pose<S>& p) {
  NcPoint<S> n;
  n.pose = p;
  return n;
}

template <class S> void check_stewart_reliability() {
  using P = Pose<S>;
  const S nan = std::numeric_limits<S>::quiet_NaN(), inf = std::numeric_limits<S>::infinity();
  StewartCalibrationTable<S> t = table_cast<S>(stewart_table());
  const StewartCompensator<S> c(t, trust_table_bounds);
  ASSERT_EQ(c.status(), CS::Ok);
  Vec6<S> home;
  ASSERT_EQ(c.home_command(home), CS::Ok);
  auto st = c.start(home);
  const P good = P::from_xyz_rpy(S(5), S(-3), S(204), S(0.01), S(0), S(0.02));
  expect_failure(c, st, point(P::from_xyz_rpy(nan, 0, 200, 0, 0, 0)), good, CS::InvalidInput, "NaN pose");
  expect_failure(c, st, point(P::from_xyz_rpy(0, 0, 200, 0, inf, 0)), good, CS::InvalidInput, "Inf pose");
  NcPoint<S> hot = point(good);
  hot.temperature = nan;
  hot.has_temperature = true;
  expect_failure(c, st, hot, good, CS::InvalidInput, "NaN temperature");
  NcPoint<S> nandir = point(good);
  const Vec6<S> d = Vec6<S>::Constant(nan);
  nandir.direction = &d;
  expect_failure(c, st, nandir, good, CS::InvalidInput, "NaN direction");
  expect_failure(c, st, point(P::from_xyz_rpy(0, 0, -150, 0, 0, 0)), good, CS::Unreachable, "below the base");
  expect_failure(c, st, point(P::from_xyz_rpy(0, 0, 300, 0, 0, 0)), good, CS::OutOfLimits, "legs too long");
  // Out of the table's command limits although inside the stroke.
  {
    StewartCalibrationTable<S> lim = t;
    Vec6<S> q;
    ASSERT_EQ(c.compensate(st, good, q), CS::Ok);
    lim.bounds.max_joint[2] = q(2) + S(1);
    lim = seal_table(lim);
    const StewartCompensator<S> cl(lim, trust_table_bounds);
    auto sl = cl.start(home);
    expect_failure(cl, sl, point(P::from_xyz_rpy(S(5), S(-3), S(210), S(0.01), S(0), S(0.02))), good,
                   CS::OutOfLimits, "table command limit");
  }
  // Singular: the torsional singularity, stroke and limits widened so that
  // only the singularity can stop the point.
  {
    StewartCalibrationTable<S> wide = t;
    for (int i = 0; i < 6; ++i) {
      wide.machine.nominal.min_length[i] = wide.machine.calibrated.min_length[i] = wide.bounds.min_joint[i] = S(1);
      wide.machine.nominal.max_length[i] = wide.machine.calibrated.max_length[i] = wide.bounds.max_joint[i] = S(1000);
    }
    wide = seal_table(wide);
    const StewartCompensator<S> cw(wide, trust_table_bounds);
    auto sw = cw.start(home);
    const double yaw = test::find_stewart_singular_yaw();
    ASSERT_GT(yaw, 0.1);
    expect_failure(cw, sw, point(P::from_xyz_rpy(S(0), S(0), S(200), S(0), S(0), S(yaw))), good, CS::Singular,
                   "singular");
  }
  // Oversized: the calibrated joints differ by up to ~0.1 mm; a 10 µm bound.
  // The leg offsets dl_i act at every point, so a table whose dl_i exceed the
  // bound is refused outright (TableLimits, below); here they are zeroed and
  // the joint positions' errors alone make the correction too large.
  {
    StewartCalibrationTable<S> tight = t;
    for (int i = 0; i < 6; ++i) {
      tight.bounds.max_correction[i] = S(0.01);
      tight.machine.calibrated.length_offset[i] = tight.machine.nominal.length_offset[i];
    }
    tight = seal_table(tight);
    const StewartCompensator<S> ct(tight, trust_table_bounds);
    auto s2 = ct.start(home);
    Vec6<S> q;
    EXPECT_EQ(ct.compensate(s2, good, q), CS::OversizedCorrection);
    EXPECT_EQ(q, home);
    EXPECT_EQ(s2.count(CS::OversizedCorrection), 1u);
  }
  EXPECT_EQ(st.failures(), 6u);
}

template <class S> void check_hybrid_reliability() {
  using P = Pose<S>;
  const S nan = std::numeric_limits<S>::quiet_NaN();
  const HybridCalibrationTable<S> t = table_cast<S>(hybrid_table());
  const HybridCompensator<S> c(t, trust_table_bounds);
  ASSERT_EQ(c.status(), CS::Ok);
  Vec6<S> home;
  ASSERT_EQ(c.home_command(home), CS::Ok);
  auto st = c.start(home);
  const P good = P::from_xyz_rpy(S(100), S(-50), S(20), S(0), S(0.01), S(0));
  const HybridGeometry<S> g = to_core(t.machine.nominal);
  expect_failure(c, st, point(P::from_xyz_rpy(0, nan, 0, 0, 0, 0)), good, CS::InvalidInput, "NaN pose");
  expect_failure(c, st, point(P::from_xyz_rpy(0, 0, -400, 0, 0, 0)), good, CS::OutOfLimits, "UPS too long");
  {
    // The wrist centre P0 at A0: no limb line.
    const Mat3<S> F6 = g.workpiece_rotation.transpose() * g.tool_offset.transpose();
    P pose;
    pose.p = g.workpiece_rotation * (F6.col(2) * g.tool_length - g.workpiece_origin);
    expect_failure(c, st, point(pose), good, CS::Unreachable, "P0 at A0");
  }
  {
    // A wrist singularity, limits widened so that only it can stop the point.
    HybridCalibrationTable<S> wide = t;
    for (int i = 0; i < 6; ++i) {
      wide.machine.nominal.min_joint[i] = wide.bounds.min_joint[i] = S(-1e4);
      wide.machine.nominal.max_joint[i] = wide.bounds.max_joint[i] = S(1e4);
    }
    wide = seal_table(wide);
    const HybridCompensator<S> cw(wide, trust_table_bounds);
    auto sw = cw.start(home);
    const double t5 = test::find_hybrid_singular_theta5();
    ASSERT_GT(t5, 0.1);
    const HybridGeometry<S> gw = to_core(wide.machine.nominal);
    const P singular = hybrid_tool_pose(gw, hybrid_frames(gw, gw.home, Vec3<S>(S(0), S(t5), S(0))));
    expect_failure(cw, sw, point(singular), good, CS::Singular, "wrist singularity");
  }
  {
    // Oversized: structural errors of 0.05 (mm and rad) against a 0.5 mm /
    // 0.001 rad bound (the encoder offsets alone fit).
    HybridCalibrationTable<S> big = t;
    for (int k = 6; k < kHybridSourceErrorCount; ++k) big.machine.source_errors[k] = S(k % 2 == 0 ? 0.05 : -0.05);
    for (int i = 0; i < 6; ++i) big.bounds.max_correction[i] = i < 3 ? S(0.5) : S(0.001);
    big = seal_table(big);
    ASSERT_EQ(validate_table(big), CS::Ok);
    const HybridCompensator<S> cb(big, trust_table_bounds);
    auto sb = cb.start(home);
    Vec6<S> q;
    EXPECT_EQ(cb.compensate(sb, good, q), CS::OversizedCorrection);
    EXPECT_EQ(q, home);
  }
  EXPECT_EQ(st.failures(), 3u);
}

TEST(coreCompensation, EveryFailureHasItsStatusHoldsAndCounts) {
  check_stewart_reliability<double>();
  check_stewart_reliability<float>();
  check_hybrid_reliability<double>();
  check_hybrid_reliability<float>();
}

// ---- float against double ---------------------------------------------------------

template <class Machine>
void float_vs_double(const CalibrationTable<Machine>& t, Pose<double> (*make_pose)(test::Random&), const char* name) {
  using FloatMachine = typename std::conditional<Machine::family == MachineFamily::Hybrid, HybridMachine<float>,
                                                 StewartMachine<float>>::type;
  const Compensator<Machine> cd(t, trust_table_bounds);
  const auto float_table = table_cast<float>(t);  // the compensator reads it in place
  const Compensator<FloatMachine> cf(float_table, trust_table_bounds);
  ASSERT_EQ(cf.status(), CS::Ok);
  Vec6<double> home;
  ASSERT_EQ(cd.home_command(home), CS::Ok);
  auto sd = cd.start(home);
  auto sf = cf.start(home.cast<float>());
  test::Random rng(77);
  double mm = 0, rad = 0;
  for (int k = 0; k < 500; ++k) {
    const Pose<double> pose = make_pose(rng);
    Vec6<double> qd;
    Vec6<float> qf;
    ASSERT_EQ(cd.compensate(sd, pose, qd), CS::Ok);
    ASSERT_EQ(cf.compensate(sf, pose.cast<float>(), qf), CS::Ok);
    const Vec6<double> d = (qf.cast<double>() - qd).cwiseAbs();
    if (Machine::family == MachineFamily::Hybrid) {
      mm = std::max(mm, d.head<3>().maxCoeff());
      rad = std::max(rad, d.tail<3>().maxCoeff());
    } else {
      mm = std::max(mm, d.maxCoeff());
    }
  }
  std::printf("%s float vs double joint commands: %.2e mm, %.2e rad\n", name, mm, rad);
  // 7 significant digits on 230 mm (6-UPS) / 1200 mm (hybrid) legs.
  EXPECT_LT(mm, Machine::family == MachineFamily::Hybrid ? 1e-3 : 1e-4);
  EXPECT_LT(rad, 1e-5);
}

TEST(coreCompensation, FloatAgainstDouble) {
  float_vs_double(with_effects(stewart_table()), stewart_pose, "6-UPS");
  float_vs_double(with_effects(hybrid_table()), hybrid_pose, "hybrid");
}

// A stream's state carries the hybrid's exact-IK starts (host,
// HybridExactWarmStart): with effects and a temperature, along a helix of
// 0.2 mm steps with a 30 mm jump every 50 points and a refused point in
// between (an orientation the wrist cannot take), the streamed commands equal
// those of a fresh state per point (every closure cold) to 1e-9.
TEST(coreCompensation, AStreamsStartsGiveTheColdCommands) {
  const HybridCalibrationTable<double> table = with_effects(hybrid_table(true, 31));
  const HybridCompensator<double> c(table, trust_table_bounds);
  ASSERT_EQ(c.status(), CS::Ok);
  Vec6<double> home;
  ASSERT_EQ(c.home_command(home), CS::Ok);
  CompensatorState<double> stream = c.start(home);
  double worst = 0;
  for (int n = 0; n < 300; ++n) {
    const double a = 0.01 * n;
    NcPoint<double> point;
    point.pose = Pose<double>::from_xyz_rpy(40 * std::cos(a) + (n / 50) * 30.0, 40 * std::sin(a), -50 + 0.05 * n,
                                            0.03 * std::sin(a), 0.02, 0.0);
    point.temperature = 20.0 + 0.02 * n;
    point.has_temperature = true;
    if (n == 120) point.pose.R = Pose<double>::from_xyz_rpy(0, 0, 0, 0, 3.0, 0).R;  // refused: holds
    Vec6<double> streamed, cold;
    CompensatorState<double> fresh = c.start(stream.command, stream.direction);
    fresh.reference = stream.reference;
    const CS s_stream = c.compensate(stream, point, streamed);
    const CS s_cold = c.compensate(fresh, point, cold);
    ASSERT_EQ(s_stream, s_cold) << n;
    if (n == 120) {
      EXPECT_NE(s_stream, CS::Ok);
      continue;
    }
    ASSERT_EQ(s_stream, CS::Ok) << n;
    worst = std::max(worst, (streamed - cold).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-9);
#if KINCAL_HYBRID_STORED_CHAINS
  // Most points started from the last one (not the first, the jumps, the
  // refused point and the one after it).
  EXPECT_GT(stream.hybrid_start.serial.reused, 280u);
#endif
}

// ---- no heap ----------------------------------------------------------------------

TEST(coreCompensationDeathTest, TrapFiresOnDynamicEigen) {
  EXPECT_DEATH(
      {
        HeapForbidden guard;
        Eigen::MatrixXd m(8, 8);
        m.setIdentity();
        std::printf("%f\n", m.trace());
      },
      "eigen_assert failed");
}

template <class Machine> void run_without_heap(const CalibrationTable<Machine>& t, const Pose<double>& pose) {
  using S = typename Machine::Scalar;
  HeapForbidden guard;
  EXPECT_EQ(validate_table(t), CS::Ok);
  const Compensator<Machine> c(t, trust_table_bounds);
  Vec6<S> home, q;
  ASSERT_EQ(c.home_command(home), CS::Ok);
  auto state = c.start(home);
  EXPECT_EQ(c.compensate(state, pose.cast<S>(), S(30), q), CS::Ok);
  const S nan = std::numeric_limits<S>::quiet_NaN();
  EXPECT_EQ(c.compensate(state, Pose<S>::from_xyz_rpy(nan, S(0), S(0), S(0), S(0), S(0)), q), CS::InvalidInput);
  EXPECT_NE(c.compensate(state, Pose<S>::from_xyz_rpy(S(0), S(0), S(-1e4), S(0), S(0), S(0)), q), CS::Ok);
}

TEST(coreCompensation, NoHeap) {
  run_without_heap(with_effects(stewart_table()), Pose<double>::from_xyz_rpy(5, 5, 205, 0.01, 0, 0));
  run_without_heap(table_cast<float>(with_effects(stewart_table())), Pose<double>::from_xyz_rpy(5, 5, 205, 0.01, 0, 0));
  run_without_heap(with_effects(hybrid_table()), Pose<double>::from_xyz_rpy(100, -50, 20, 0, 0.01, 0));
  run_without_heap(table_cast<float>(with_effects(hybrid_table())), Pose<double>::from_xyz_rpy(100, -50, 20, 0, 0.01, 0));
}

}  // namespace

// The portable compensation check (portable/core_checks.hpp), which also runs
// under qemu on the Cortex-M targets.
namespace {
void gtest_sink(const char* file, int line, const char* what) {
  ADD_FAILURE_AT(file, line) << "core check failed: " << what;
}
template <class Scalar> void portable_compensation() {
  kincal::test::Checker c(&gtest_sink);
  kincal::test::check_compensation<Scalar>(c);
  EXPECT_EQ(c.failures(), 0);
  EXPECT_GE(c.checks(), 45);
}
}  // namespace

TEST(coreCompensation, PortableCheck) {
  portable_compensation<double>();
  portable_compensation<float>();
}

