// atan2 without libm, for the 6-RUS's closed-form IK (rus6.hpp), which takes
// one per leg: libm's atan2 was ~145 of the IK's ~2 080 instructions per leg
// on x86-64 (callgrind), and the IK was over the GUIDE's 200 ns bar.
//
// Moshier's rational approximation from the Cephes library (atan.c), on
// |t| ≤ 0.66 after one reduction:
//   atan r = r + r·z·P(z)/Q(z),  z = r²  (P of degree 4, Q monic of degree 5),
// peak relative error ~1e-16 there. atan2 reduces to t = min/max of |y|, |x|
// in [0, 1]; above 0.66 it uses atan t = π/4 + atan((t − 1)/(t + 1)), and
// (t − 1)/(t + 1) = (lo − hi)/(lo + hi), so one division either way; then
// π/2 − a where |y| > |x|, π − a for x < 0, and y's sign (its sign bit: −0
// gives −π as libm does). Measured against libm (host_tests/core_atan2_test.cpp):
// within 2 ulp of π over the four quadrants in double, 1e-6 in float.
// Finite arguments; a NaN gives NaN; atan2(±0, ±0) = ±0 or ±π as libm.
#pragma once

#include <cmath>

namespace kincal {

template <class S> S atan2_rational(S y, S x) {
  const S pi = S(3.14159265358979323846), half_pi = S(1.57079632679489661923), quarter_pi = S(0.78539816339744830962);
  const S ay = std::abs(y), ax = std::abs(x);
  const bool steep = ay > ax;
  const S hi = steep ? ay : ax, lo = steep ? ax : ay;
  S a;
  if (hi == S(0)) {
    a = S(0);  // atan2(±0, ±0): 0, then π for x = −0 below
  } else {
    const bool wide = lo > S(0.66) * hi;  // t = lo / hi > 0.66
    const S r = wide ? (lo - hi) / (lo + hi) : lo / hi;
    const S z = r * r;
    const S p = (((S(-8.750608600031904122785e-1) * z - S(1.615753718733365076637e1)) * z -
                  S(7.500855792314704667340e1)) * z - S(1.228866684490136173410e2)) * z -
                S(6.485021904942025371773e1);
    const S q = ((((z + S(2.485846490142306297962e1)) * z + S(1.650270098316988542046e2)) * z +
                  S(4.328810604912902668951e2)) * z + S(4.853903996359136964868e2)) * z +
                S(1.945506571482613964425e2);
    a = r + r * z * p / q;
    if (wide) a += quarter_pi;
  }
  if (steep) a = half_pi - a;
  if (std::signbit(x)) a = pi - a;
  return std::signbit(y) ? -a : a;
}

}  // namespace kincal
