// sin and cos without libm, for everything core/ rotates by.
//
// Why not std::sin / std::cos: libm's versions carry an argument reduction
// for huge arguments (newlib's __kernel_rem_pio2 and __ieee754_rem_pio2:
// 2.4 KiB of Cortex-M flash and 0.7 KiB of stack on the controller's deepest
// path; docs/benchmarks.md). A machine's angles are bounded, so a short
// Cody–Waite reduction to [−π, π] does, and the rest is exact arithmetic:
// the angle halved until |a| ≤ 1/8, the series there (to a⁹ and a¹⁰: the
// next terms are below 1e-17), then doubled back (sin 2a = 2 sin a cos a,
// cos 2a = 1 − 2 sin² a), at most five doublings of about a rounding each.
// Measured against libm (host_tests/identify_hybrid_exact_test.cpp): within
// 1e-14 to 4 rad and 2e-14 to 1000 rad in double, 2e-5 in float.
#pragma once

#include <cmath>
#include <type_traits>

namespace kincal {

// sin a and cos a; false, with both NaN, for an angle that is not finite or
// beyond ±1e9 rad (where 2π's rounding would show: no joint turns that far).
template <class S> bool sin_cos(S a, S& sine, S& cosine) {
  const S limit = S(1e9);
  if (!(a <= limit && a >= -limit)) {
    sine = cosine = S(NAN);
    return false;
  }
  const S half_turn = S(3.14159265358979323846);
  if (a > half_turn || a < -half_turn) {
    // a − k·2π with k the nearest integer, 2π in two parts (Cody–Waite) so
    // the product k·2π_hi is exact for the k this range allows.
    const S turns = a * S(0.15915494309189533577);
    const S k = S(static_cast<long long>(turns + (turns < S(0) ? S(-0.5) : S(0.5))));
    a = (a - k * S(6.28318530717958623200)) - k * S(2.44929359829470635445e-16);
  }
  int halvings = 0;
  while (a > S(0.125) || a < S(-0.125)) {
    a *= S(0.5);
    ++halvings;
  }
  // The series' divisions as products by their reciprocals: a division costs
  // ten or more multiplications on both targets, and 1/n rounded differs from
  // the quotient by less than the series' own last term.
  const S t = a * a;
  S s = a * (S(1) - t * S(1.0 / 6) * (S(1) - t * S(1.0 / 20) * (S(1) - t * S(1.0 / 42) * (S(1) - t * S(1.0 / 72)))));
  S c = S(1) - t * S(0.5) *
                   (S(1) - t * S(1.0 / 12) * (S(1) - t * S(1.0 / 30) * (S(1) - t * S(1.0 / 56) * (S(1) - t * S(1.0 / 90)))));
  for (int k = 0; k < halvings; ++k) {
    const S s2 = S(2) * s * c;
    c = S(1) - S(2) * s * s;
    s = s2;
  }
  sine = s;
  cosine = c;
  return true;
}

// sin and cos of any scalar core is instantiated with: float and double by
// sin_cos above; anything else (identify's automatic-differentiation scalars)
// by its own sin / cos, found by argument-dependent lookup, so derivatives
// stay exact.
template <class S> void sin_and_cos(const S& a, S& sine, S& cosine) {
  if constexpr (std::is_floating_point_v<S>) {
    sin_cos(a, sine, cosine);
  } else {
    using std::cos;
    using std::sin;
    sine = sin(a);
    cosine = cos(a);
  }
}

}  // namespace kincal
