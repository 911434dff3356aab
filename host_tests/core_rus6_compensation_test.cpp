// The 6-RUS on the controller (core/rus6_machine.hpp): its table's checks,
// its compensator's answers against independent evidence, and its behaviour
// under bad input.
//
// Evidence other than the code under test: the compensated command driven
// through the CALIBRATED geometry's forward kinematics (Newton, rus6_fk)
// must land on the requested pose — the compensator itself uses the
// closed-form IK, so the two meet only if both are right; float against
// double; every refusal a status with the last safe command held.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "kincal/core/reference_machines.hpp"
#include "kincal/core/rus6_machine.hpp"

using namespace kincal;

namespace {

template <class S> Rus6CalibrationTable<S> calibrated_table() {
  Rus6CalibrationTable<S> t = nominal_table(make_rus6_ref<S>());
  std::mt19937 rng(9);
  std::normal_distribution<double> n(0.0, 1.0);
  Rus6Geometry<double> g = make_rus6_ref<double>();
  for (int i = 0; i < 6; ++i) {
    g.shaft_points.col(i) += 0.05 * Vec3<double>(n(rng), n(rng), n(rng));
    g.platform_joints.col(i) += 0.05 * Vec3<double>(n(rng), n(rng), n(rng));
    g.crank_length(i) += 0.03 * n(rng);
    g.rod_length(i) += 0.03 * n(rng);
    g.joint_offset(i) += 2e-3 * n(rng);
    // A tilted shaft: the frame turned about the crank-zero direction.
    const Eigen::Matrix3d R = Eigen::AngleAxisd(4e-4 * n(rng), Vec3<double>(g.crank_zero.col(i))).toRotationMatrix();
    g.shaft_axes.col(i) = R * g.shaft_axes.col(i);
  }
  t.machine.calibrated = to_table(g.cast<S>());
  return seal_table(t);
}

template <class S> Pose<S> random_pose(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  return Pose<double>::from_xyz_rpy(35 * u(rng), 35 * u(rng), 274 + 35 * u(rng), 0.15 * u(rng), 0.15 * u(rng),
                                    0.15 * u(rng))
      .cast<S>();
}

TEST(Rus6Compensation, CommandsReachTheRequestedPoseOnTheCalibratedMachine) {
  const Rus6CalibrationTable<double> table = calibrated_table<double>();
  ASSERT_EQ(validate_table(table), CompensationStatus::Ok);
  const Compensator<Rus6Machine<double>> c(table, trust_table_bounds);
  ASSERT_EQ(c.status(), CompensationStatus::Ok);
  const Rus6Geometry<double> calibrated = to_core(table.machine.calibrated);
  Vec6<double> home;
  ASSERT_EQ(c.home_command(home), CompensationStatus::Ok);
  auto state = c.start(home);
  std::mt19937 rng(4);
  int reached = 0;
  for (int k = 0; k < 300; ++k) {
    const Pose<double> pose = random_pose<double>(rng);
    Vec6<double> q;
    if (c.compensate(state, pose, q) != CompensationStatus::Ok) continue;
    Pose<double> fk;
    ASSERT_EQ(rus6_fk(calibrated, q, pose, fk).status, Status::Ok);
    EXPECT_LT(pose_error(fk, pose).template head<3>().norm(), 1e-9);
    EXPECT_LT(pose_error(fk, pose).template tail<3>().norm(), 1e-11);
    ++reached;
  }
  EXPECT_GT(reached, 280);  // the ±35 mm / ±0.15 rad box is inside rus6-ref's workspace
}

TEST(Rus6Compensation, FloatFollowsDouble) {
  const Rus6CalibrationTable<double> td = calibrated_table<double>();
  const Compensator<Rus6Machine<double>> d(td, trust_table_bounds);
  const Rus6CalibrationTable<float> tf = calibrated_table<float>();
  ASSERT_EQ(validate_table(tf), CompensationStatus::Ok);
  const Compensator<Rus6Machine<float>> f(tf, trust_table_bounds);
  ASSERT_EQ(f.status(), CompensationStatus::Ok);
  auto sd = d.start(Vec6<double>::Zero());
  auto sf = f.start(Vec6<float>::Zero());
  std::mt19937 rng(5);
  double worst = 0;
  for (int k = 0; k < 200; ++k) {
    std::mt19937 copy = rng;
    const Pose<double> pd = random_pose<double>(rng);
    const Pose<float> pf = random_pose<float>(copy);
    Vec6<double> qd;
    Vec6<float> qf;
    if (d.compensate(sd, pd, qd) != CompensationStatus::Ok) continue;
    ASSERT_EQ(f.compensate(sf, pf, qf), CompensationStatus::Ok);
    worst = std::max(worst, (qf.cast<double>() - qd).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 2e-5);  // rad: float's rounding through a 300 mm rod
  EXPECT_GT(worst, 0.0);
}

TEST(Rus6Compensation, BadInputIsAStatusAndTheLastSafeCommandIsHeld) {
  const Rus6CalibrationTable<double> table = calibrated_table<double>();
  const Compensator<Rus6Machine<double>> c(table, trust_table_bounds);
  Vec6<double> home;
  ASSERT_EQ(c.home_command(home), CompensationStatus::Ok);
  auto state = c.start(home);
  Vec6<double> q;
  ASSERT_EQ(c.compensate(state, Pose<double>::from_xyz_rpy(5, -3, 280, 0.01, 0.02, -0.03), q), CompensationStatus::Ok);
  const Vec6<double> safe = q;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const struct {
    Pose<double> pose;
    CompensationStatus expected;
  } cases[] = {
      {Pose<double>::from_xyz_rpy(nan, 0, 274, 0, 0, 0), CompensationStatus::InvalidInput},
      {Pose<double>::from_xyz_rpy(0, 0, 1000, 0, 0, 0), CompensationStatus::Unreachable},  // rods too short
      // 81.8 mm below home: the rods still reach (to 82.3 mm), the cranks
      // would pass their −80° limit (docs/reference-machines.md).
      {Pose<double>::from_xyz_rpy(0, 0, 274.0438 - 81.8, 0, 0, 0), CompensationStatus::OutOfLimits},
  };
  for (const auto& bad : cases) {
    Vec6<double> out = Vec6<double>::Constant(123);
    EXPECT_EQ(c.compensate(state, bad.pose, out), bad.expected);
    EXPECT_TRUE(out.allFinite());
    EXPECT_EQ(out, safe);
  }
}

TEST(Rus6Table, ChecksRefuseCorruptAndOversizedTables) {
  const Rus6CalibrationTable<double> good = calibrated_table<double>();
  Rus6CalibrationTable<double> t = good;
  t.machine.calibrated.rod_length[2] += 1.0;  // changed after sealing
  EXPECT_EQ(validate_table(t), CompensationStatus::TableCrc);
  t = good;
  t.machine.calibrated.shaft_axes[0] += 0.1;  // no longer a unit vector
  EXPECT_EQ(validate_table(seal_table(t)), CompensationStatus::TableValues);
  t = good;
  t.machine.calibrated.joint_offset[3] = 0.05;  // a crank zero beyond the 0.02 rad bound
  EXPECT_EQ(validate_table(seal_table(t)), CompensationStatus::TableValues);
  t = good;
  t.machine.calibrated.max_joint[0] = t.machine.calibrated.min_joint[0] + 7.0;  // more than a turn
  EXPECT_EQ(validate_table(seal_table(t)), CompensationStatus::TableValues);
  t = good;
  t.family = MachineFamily::Stewart6Ups;  // a 6-UPS's table where a 6-RUS's belongs
  EXPECT_EQ(validate_table(t), CompensationStatus::TableFamily);
  // Machine limits compiled in apart from the table: a rod 12 mm off is
  // beyond max_geometry_error (10 mm), a shaft turned 0.2 rad beyond
  // max_angle_error (0.1 rad).
  const MachineLimits<double> limits = limits_from_bounds(good.bounds);
  EXPECT_EQ(validate_table(good, limits), CompensationStatus::Ok);
  t = good;
  t.machine.calibrated.rod_length[1] += 12.0;
  EXPECT_EQ(validate_table(seal_table(t), limits), CompensationStatus::TableLimits);
  t = good;
  Rus6Geometry<double> g = to_core(good.machine.calibrated);
  g.shaft_axes.col(4) = Eigen::AngleAxisd(0.2, Vec3<double>(g.crank_zero.col(4))) * Vec3<double>(g.shaft_axes.col(4));
  t.machine.calibrated = to_table(g);
  EXPECT_EQ(validate_table(seal_table(t)), CompensationStatus::Ok);  // a valid geometry…
  EXPECT_EQ(validate_table(seal_table(t), limits), CompensationStatus::TableLimits);  // …beyond the cap
  // A broken table makes every compensate() answer its status.
  t = good;
  t.crc ^= 1u;
  const Compensator<Rus6Machine<double>> c(t, trust_table_bounds);
  EXPECT_EQ(c.status(), CompensationStatus::TableCrc);
  auto state = c.start(Vec6<double>::Zero());
  Vec6<double> q;
  EXPECT_EQ(c.compensate(state, Pose<double>::from_xyz_rpy(0, 0, 274, 0, 0, 0), q), CompensationStatus::TableCrc);
}

}  // namespace
