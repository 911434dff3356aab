// core/atan2.hpp (the 6-RUS IK's atan2 without libm) against libm's atan2,
// the independent evidence: random arguments over many magnitudes in the
// four quadrants, arguments on the diagonal and on the reduction's edge
// (|y| = 0.66 |x|), the axes and signed zeros, NaN; double and float.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "kincal/core/atan2.hpp"

namespace {

template <class S> S libm_atan2(S y, S x) { return S(std::atan2(double(y), double(x))); }

// The largest |ours − libm's| over `count` random pairs, with a third of
// them placed on the diagonal or the 0.66 edge.
template <class S> S worst_difference(int count, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  S worst = 0;
  for (int k = 0; k < count; ++k) {
    S y = S(u(rng) * std::pow(10.0, 3 * u(rng))), x = S(u(rng) * std::pow(10.0, 3 * u(rng)));
    if (k % 3 == 1) y = x * S(1 + 1e-4 * u(rng)) * (u(rng) < 0 ? S(-1) : S(1));
    if (k % 3 == 2) y = S(0.66) * x * S(1 + 1e-6 * u(rng)) * (u(rng) < 0 ? S(-1) : S(1));
    worst = std::max(worst, S(std::abs(kincal::atan2_rational(y, x) - libm_atan2(y, x))));
  }
  return worst;
}

TEST(CoreAtan2, DoubleWithinTwoUlpOfPiOfLibm) {
  const double ulp_pi = std::nextafter(M_PI, 4.0) - M_PI;
  EXPECT_LE(worst_difference<double>(300000, 1), 2 * ulp_pi);
}

TEST(CoreAtan2, FloatWithinTwoUlpOfPiOfLibm) {
  const float ulp_pi = std::nextafter(float(M_PI), 4.0f) - float(M_PI);
  EXPECT_LE(worst_difference<float>(300000, 2), 2 * ulp_pi);
}

TEST(CoreAtan2, AxesSignedZerosAndNaNAsLibm) {
  for (const double y : {0.0, -0.0, 1.0, -1.0, 2.5e-300})
    for (const double x : {0.0, -0.0, 1.0, -1.0, 3e300}) {
      const double ours = kincal::atan2_rational(y, x), libm = std::atan2(y, x);
      EXPECT_NEAR(ours, libm, 1e-15) << "atan2(" << y << ", " << x << ")";
      EXPECT_EQ(std::signbit(ours), std::signbit(libm)) << "atan2(" << y << ", " << x << ")";
    }
  EXPECT_TRUE(std::isnan(kincal::atan2_rational(std::numeric_limits<double>::quiet_NaN(), 1.0)));
  EXPECT_TRUE(std::isnan(kincal::atan2_rational(1.0, std::numeric_limits<double>::quiet_NaN())));
}

}  // namespace
