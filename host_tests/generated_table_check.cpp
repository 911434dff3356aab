// Compiles a header written by `kincal table` at build time (issue #10 item
// 4: a 6-UPS header once named a type core does not have, and the test only
// string-matched it). Built once per family from a model the build generates
// the header for (host_tests/CMakeLists.txt); the header's own static_asserts
// (CRC, validate_table against the machine limits, format version) run in
// this compile, and at run time both scalars' tables start a compensator and
// compensate the machine's home pose.
#include <gtest/gtest.h>

#include <cmath>

#include "kincal/core/compensation.hpp"
#include KINCAL_GENERATED_TABLE

namespace {

using namespace kincal;

template <class Scalar> void check_scalar() {
  using Tables = generated::Tables<Scalar>;
  static_assert(validate_table(Tables::calibration(), Tables::limits()) == CompensationStatus::Ok, "calibration");
  static_assert(validate_table(Tables::nominal(), Tables::limits()) == CompensationStatus::Ok, "nominal");
  static_assert(Tables::calibration().family == generated::kFamily, "family");
  static_assert(!generated::Formulas<Scalar>::present, "this model has no formula effects");
  const Compensator<generated::Machine<Scalar>, generated::Formulas<Scalar>> calibrated(Tables::calibration(),
                                                                                       Tables::limits());
  const Compensator<generated::Machine<Scalar>, generated::Formulas<Scalar>> nominal(Tables::nominal(), Tables::limits());
  ASSERT_EQ(calibrated.status(), CompensationStatus::Ok);
  ASSERT_EQ(nominal.status(), CompensationStatus::Ok);
  Vec6<Scalar> q_cal, q_nom;
  ASSERT_EQ(calibrated.home_command(q_cal), CompensationStatus::Ok);
  ASSERT_EQ(nominal.home_command(q_nom), CompensationStatus::Ok);
  EXPECT_TRUE(command_inside(q_cal, Tables::limits()));
  // The calibration moves the command, by less than the correction bound.
  EXPECT_GT((q_cal - q_nom).cwiseAbs().maxCoeff(), Scalar(0));
  for (int i = 0; i < 6; ++i) EXPECT_LE(std::abs(q_cal(i) - q_nom(i)), Tables::limits().max_correction[i]);
}

TEST(GeneratedTable, DoubleCompilesValidatesAndCompensates) { check_scalar<double>(); }
TEST(GeneratedTable, FloatCompilesValidatesAndCompensates) { check_scalar<float>(); }

}  // namespace
