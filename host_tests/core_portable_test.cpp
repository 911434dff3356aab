// Host side of the portable core checks (the same code runs under qemu, see
// firmware/main.cpp). Each suite must run real checks and report no failure.
#include <gtest/gtest.h>

#include "portable/core_checks.hpp"

namespace {

void gtest_sink(const char* file, int line, const char* what) {
  ADD_FAILURE_AT(file, line) << "core check failed: " << what;
}

template <class Scalar> void expect_suite(void (*suite)(kincal::test::Checker&), long min_checks) {
  kincal::test::Checker c(&gtest_sink);
  suite(c);
  EXPECT_EQ(c.failures(), 0);
  EXPECT_GE(c.checks(), min_checks);  // the suite really ran
}

constexpr int kRoundTrips = 10000;

template <class Scalar> void stewart_rt(kincal::test::Checker& c) { kincal::test::check_stewart_round_trip<Scalar>(c, kRoundTrips); }
template <class Scalar> void hybrid_rt(kincal::test::Checker& c) { kincal::test::check_hybrid_round_trip<Scalar>(c, kRoundTrips); }

}  // namespace

// Explicit instantiation for both scalars (Sophus / manif practice): every
// template in core compiles for double and float.
template void kincal::test::run_core_checks<double>(kincal::test::Checker&, int);
template void kincal::test::run_core_checks<float>(kincal::test::Checker&, int);

TEST(CorePortable, PoseMathDouble) { expect_suite<double>(&kincal::test::check_pose_math<double>, 1000); }
TEST(CorePortable, PoseMathFloat) { expect_suite<float>(&kincal::test::check_pose_math<float>, 1000); }
TEST(CorePortable, SmallLuDouble) { expect_suite<double>(&kincal::test::check_small_lu<double>, 200); }
TEST(CorePortable, SmallLuFloat) { expect_suite<float>(&kincal::test::check_small_lu<float>, 200); }
TEST(CorePortable, StewartRoundTripDouble) { expect_suite<double>(&stewart_rt<double>, 2 * kRoundTrips); }
TEST(CorePortable, StewartRoundTripFloat) { expect_suite<float>(&stewart_rt<float>, 2 * kRoundTrips); }
TEST(CorePortable, StewartJacobianDouble) { expect_suite<double>(&kincal::test::check_stewart_jacobian<double>, 100); }
TEST(CorePortable, StewartJacobianFloat) { expect_suite<float>(&kincal::test::check_stewart_jacobian<float>, 100); }
TEST(CorePortable, StewartStatusesDouble) { expect_suite<double>(&kincal::test::check_stewart_statuses<double>, 15); }
TEST(CorePortable, StewartStatusesFloat) { expect_suite<float>(&kincal::test::check_stewart_statuses<float>, 15); }
TEST(CorePortable, HybridRoundTripDouble) { expect_suite<double>(&hybrid_rt<double>, 2 * kRoundTrips); }
TEST(CorePortable, HybridRoundTripFloat) { expect_suite<float>(&hybrid_rt<float>, 2 * kRoundTrips); }
TEST(CorePortable, HybridJacobianDouble) { expect_suite<double>(&kincal::test::check_hybrid_jacobian<double>, 100); }
TEST(CorePortable, HybridJacobianFloat) { expect_suite<float>(&kincal::test::check_hybrid_jacobian<float>, 100); }
TEST(CorePortable, HybridStatusesDouble) { expect_suite<double>(&kincal::test::check_hybrid_statuses<double>, 12); }
TEST(CorePortable, HybridStatusesFloat) { expect_suite<float>(&kincal::test::check_hybrid_statuses<float>, 12); }

// The checks must be able to fail: a suite run against a deliberately wrong
// expectation reports failures through the sink.
TEST(CorePortable, CheckerReportsFailures) {
  static int sunk = 0;
  kincal::test::Checker c([](const char*, int, const char*) { ++sunk; });
  KINCAL_CHECK(c, 1 + 1 == 3);
  EXPECT_EQ(c.failures(), 1);
  EXPECT_EQ(sunk, 1);
}
