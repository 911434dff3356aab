// Formula effects in the generated header (issue #32): `kincal table` writes
// the robot description's formulas as C++ templated on the scalar and a
// policy, generated::Formulas<Scalar>, that core's Compensator calls
// directly. This test compiles that header (generated at build time from
// examples/firmware/model-formula.json: four joint formulas — temperature,
// a ramp with a nonlinear shared start, a clearance that follows the
// payload's joint loads, a named input — and one pose formula) and compares
// its commands with the host's `kincal compensate` path (compensate_rows,
// which evaluates the formulas through identify's compiled program,
// HostFormulaEffects — a different code path from the printed C++).
//
// The poses are random in the 6-UPS workspace, not the model's data: temp
// 15–30 C, a time stamp, the spindle input 18–32 C, and a few poses past
// the machine's reach (both paths must refuse them with the same status).
// double: the same commands to 1e-9 mm; float (the float table and the
// float instantiation of the same C++): to 1e-4 mm.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "kincal/core/compensation.hpp"
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
  std::vector<StreamPoint> out;
  for (int k = 0; k < count; ++k) {
    StreamPoint p;
    p.pose << 30 * u(rng), 30 * u(rng), 200 + 20 * u(rng), 0.08 * u(rng), 0.08 * u(rng), 0.12 * u(rng);
    // Every tenth pose far above the stroke: refused by both paths.
    if (k % 10 == 9) p.pose(2) = 400;
    p.temp = 22.5 + 7.5 * u(rng);
    p.time = 2.0 * k;
    p.inputs = {25 + 7 * u(rng)};  // spindle_temp
    out.push_back(p);
  }
  return out;
}

template <class Scalar> kincal_test::StreamCommands generated_commands(const std::vector<StreamPoint>& points) {
  using Tables = kincal::generated::Tables<Scalar>;
  const kincal::Compensator<kincal::generated::Machine<Scalar>, kincal::generated::Formulas<Scalar>> c(
      Tables::calibration(), Tables::limits());
  return kincal_test::stream_commands(c, points);
}

TEST(GeneratedFormulaTable, TheHeadersFormulasCompensateLikeTheHost) {
  static_assert(kincal::generated::Formulas<double>::present, "the model has formula effects");
  // Every compile-time path on (the sag reads x, y and is a twist; the
  // clearance reads load; spindle an input): the paths off are the firmware
  // end-to-end chains' (leg_thermal reads only q and temp).
  using F = kincal::generated::Formulas<double>;
  static_assert(F::pose_twist && F::reads_pose && F::reads_load && F::reads_stream, "what the formulas read");
  static_assert(kincal::generated::kFormulaInputCount == 1, "one named input");
  EXPECT_STREQ(kincal::generated::kFormulaInputNames[0], "spindle_temp");
  const ki::CalibrationModel model = ki::read_model_file(KINCAL_FORMULA_MODEL);
  const std::vector<StreamPoint> points = random_points(11, 80);
  const ki::CompensatedStream host = ki::compensate_rows(ki::calibration_table(model), model, kincal_test::stream_pose_table(points, {"spindle_temp"}));

  int compensated = 0;
  const double worst_double = kincal_test::largest_difference(host, generated_commands<double>(points), compensated);
  EXPECT_GE(compensated, 70);  // the 8 poses above the stroke are refused
  EXPECT_LE(worst_double, 1e-9);
  const double worst_float = kincal_test::largest_difference(host, generated_commands<float>(points), compensated);
  EXPECT_LE(worst_float, 1e-4);
  std::printf("generated formulas vs host over %d poses: double %.3g mm, float %.3g mm\n", compensated, worst_double,
              worst_float);
}

TEST(GeneratedFormulaTable, TheFormulasMoveTheCommands) {
  // The formulas are not a no-op: the same table without them (its numbers
  // zeroed) gives other commands, by more than the float tolerance.
  using Tables = kincal::generated::Tables<double>;
  kincal::CalibrationTable<kincal::generated::Machine<double>> zeroed = Tables::calibration();
  for (double& v : zeroed.effects.user) v = 0;
  zeroed.crc = kincal::table_crc(zeroed);
  const kincal::Compensator<kincal::generated::Machine<double>, kincal::generated::Formulas<double>> with(
      Tables::calibration(), Tables::limits());
  const kincal::Compensator<kincal::generated::Machine<double>, kincal::generated::Formulas<double>> without(
      zeroed, Tables::limits());
  ASSERT_EQ(without.status(), CompensationStatus::Ok);
  double largest = 0;
  for (const StreamPoint& p : random_points(3, 20)) {
    if (p.pose(2) > 300) continue;
    kincal::NcPoint<double> point;
    point.pose = kincal::Pose<double>::from_xyz_rpy(p.pose);
    point.temperature = p.temp;
    point.has_temperature = true;
    double inputs[kincal::kFormulaInputs] = {p.inputs[0]};
    point.inputs = inputs;
    Vec6<double> a, b;
    auto s1 = with.start(Vec6<double>::Zero());
    auto s2 = without.start(Vec6<double>::Zero());
    ASSERT_EQ(with.compensate(s1, point, a), CompensationStatus::Ok);
    ASSERT_EQ(without.compensate(s2, point, b), CompensationStatus::Ok);
    largest = std::max(largest, (a - b).cwiseAbs().maxCoeff());
  }
  EXPECT_GT(largest, 1e-3);
}

}  // namespace
