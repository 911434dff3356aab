// A formula that reads what the 6-RUS offers per joint, in the generated
// header (issue #33: rods expanding with temperature, which the library's
// uniform `thermal` cannot carry). `kincal table` writes
// examples/formula/rus6-rod-thermal-model.json — rus6-ref with
// examples/rus6/errors.csv and `rod_thermal`, a · rod · (temp − 20) / lever
// (examples/formula/rus6-rod-thermal.json), identified by kincal from its
// own simulation — as C++ whose policy reads core's family slots
// (FormulaSlot::family_joint, filled by rus6_formula_joint_values at the
// nominal configuration). Checked three ways:
//   - against the host's `kincal compensate` path (identify's compiled
//     program, HostFormulaEffects, its own layout), double and float;
//   - against the physics the formula stands for, by another route: the
//     calibrated geometry with every rod lengthened by a·ℓ·(T − 20), solved
//     by core's closed-form IK (no formula, no lever, no fixed point);
//   - the formula moves the commands (its number zeroed, they differ).
// Poses: random about rus6-ref's home (±30 mm, ±0.1 rad), 15–35 °C, every
// tenth 400 mm above the reach (refused by both paths).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "kincal/core/compensation.hpp"
#include "kincal/core/reference_machines.hpp"
#include "kincal/core/rus6_machine.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/model.hpp"
#include "generated_stream.hpp"
#include KINCAL_GENERATED_TABLE

namespace {

namespace ki = kincal::identify;
using kincal::CompensationStatus;
using kincal::Vec6;

using kincal_test::StreamPoint;

std::vector<StreamPoint> random_points(unsigned seed, int count) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Vec6<double> home = kincal::make_rus6_ref<double>().home.to_xyz_rpy();
  std::vector<StreamPoint> out;
  for (int k = 0; k < count; ++k) {
    StreamPoint p;
    Vec6<double> d;
    d << 30 * u(rng), 30 * u(rng), 30 * u(rng), 0.1 * u(rng), 0.1 * u(rng), 0.1 * u(rng);
    p.pose = home + d;
    if (k % 10 == 9) p.pose(2) += 400;
    p.temp = 25 + 10 * u(rng);
    out.push_back(p);
  }
  return out;
}

template <class Scalar>
using GeneratedCompensator =
    kincal::Compensator<kincal::generated::Machine<Scalar>, kincal::generated::Formulas<Scalar>>;

template <class Scalar> kincal_test::StreamCommands generated_commands(const std::vector<StreamPoint>& points) {
  using Tables = kincal::generated::Tables<Scalar>;
  return kincal_test::stream_commands(GeneratedCompensator<Scalar>(Tables::calibration(), Tables::limits()), points);
}

TEST(GeneratedRus6FormulaTable, TheFamilysNumbersReachTheGeneratedFormula) {
  using F = kincal::generated::Formulas<double>;
  static_assert(F::present && F::reads_family, "rod_thermal reads rod and lever");
  static_assert(!F::pose_twist && !F::reads_load && !F::reads_stream, "and nothing else the compensator computes");
  const ki::CalibrationModel model = ki::read_model_file(KINCAL_FORMULA_MODEL);
  const std::vector<StreamPoint> points = random_points(23, 80);
  const ki::CompensatedStream host = ki::compensate_rows(ki::calibration_table(model), model, kincal_test::stream_pose_table(points));
  ASSERT_TRUE(host.home_ok);

  for (const bool single : {false, true}) {
    const kincal_test::StreamCommands gen = single ? generated_commands<float>(points) : generated_commands<double>(points);
    int compensated = 0;
    const double worst = kincal_test::largest_difference(host, gen, compensated);
    for (std::size_t k = 9; k < gen.size(); k += 10)
      EXPECT_NE(gen[k].first, CompensationStatus::Ok) << "pose " << k << " is out of reach";
    EXPECT_EQ(compensated, 72);
    // double: the same numbers by two code paths; float: its rounding of
    // a ~1 rad command (a few 1e-7) through the IK and the fixed point.
    EXPECT_LE(worst, single ? 2e-5 : 1e-10) << (single ? "float" : "double");
    std::printf("generated rod_thermal vs host over %d poses (%s): %.3g rad\n", compensated,
                single ? "float" : "double", worst);
  }
}

TEST(GeneratedRus6FormulaTable, TheFormulaIsTheRodsLengthenedToFirstOrder) {
  using Tables = kincal::generated::Tables<double>;
  const auto& table = Tables::calibration();
  const double a = table.effects.user[0];
  ASSERT_GT(a, 1e-5);  // the identified coefficient, ~2.3e-5 /°C
  const GeneratedCompensator<double> c(table, Tables::limits());
  ASSERT_EQ(c.status(), CompensationStatus::Ok);
  double worst = 0, largest_effect = 0;
  int compared = 0;
  for (const StreamPoint& p : random_points(5, 40)) {
    if (p.pose(2) > 600) continue;
    const kincal::Pose<double> pose = kincal::Pose<double>::from_xyz_rpy(p.pose);
    kincal::NcPoint<double> point;
    point.pose = pose;
    point.temperature = p.temp;
    point.has_temperature = true;
    Vec6<double> q;
    auto state = c.start(Vec6<double>::Zero());
    ASSERT_EQ(c.compensate(state, point, q), CompensationStatus::Ok);
    // The machine the formula describes: the calibrated rods longer by
    // a·ℓ·(T − 20), and only them; its IK is the command to send.
    kincal::Rus6Geometry<double> warm = kincal::to_core(table.machine.calibrated);
    warm.rod_length *= 1 + a * (p.temp - 20);
    Vec6<double> truth = Vec6<double>::Zero(), cold = Vec6<double>::Zero();
    ASSERT_EQ(kincal::rus6_ik(warm, pose, truth), kincal::Status::Ok);
    ASSERT_EQ(kincal::rus6_ik(kincal::to_core(table.machine.calibrated), pose, cold), kincal::Status::Ok);
    worst = std::max(worst, (q - truth).cwiseAbs().maxCoeff());
    largest_effect = std::max(largest_effect, (truth - cold).cwiseAbs().maxCoeff());
    ++compared;
  }
  EXPECT_GE(compared, 30);
  // The effect is ~1e-3 rad at 15 °C from 20; the formula's lever is the
  // nominal machine's at the commanded pose and first order in the rod's
  // change: what is left is ~1e-3 of the effect.
  EXPECT_GT(largest_effect, 5e-4);
  EXPECT_LT(worst, 1e-2 * largest_effect);
  std::printf("rod_thermal against the lengthened rods over %d poses: largest effect %.3g rad, left %.3g rad\n",
              compared, largest_effect, worst);
}

}  // namespace
