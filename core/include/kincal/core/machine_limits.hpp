// What a controller knows about its machine independently of any parameter
// table (issue #10 item 2): the drives' physical command range, the largest
// correction any model may ask for, and sane maxima for every identified
// value. A CRC only proves that a table is the one the generator wrote, not
// that the generator was fed a sane model: a hand-edited MODEL.json with
// stroke bounds 0…1e6 and source errors of 1e6 makes a CRC-valid table whose
// compensation sends legs of two metres with status Ok. So the firmware
// compiles these limits in separately (the generated header emits them from
// the NOMINAL robot description, never from identified values; a port may
// write its own) and checks the table against them at start-up
// (validate_table(table, limits) → TableLimits), and the compensator checks
// every command against them again before it leaves (belt and braces: no
// command outside the drives' range can leave core, whatever the table says).
#pragma once

#include "kincal/core/calibration_table.hpp"
#include "kincal/core/hybrid_error_twist.hpp"  // HybridErrorLayout::angular

namespace kincal {

template <class Scalar> struct MachineLimits {
  Scalar min_joint[6];       // the drives' physical command range, mm / rad
  Scalar max_joint[6];
  Scalar max_correction[6];  // the largest |q − q_nominal| a table may allow, per joint
  // The largest identified geometric error in length: 6-UPS |calibrated −
  // nominal| per B_i / P_i coordinate, hybrid |Δχ̂_k| per structural source
  // error that is a length (HybridErrorLayout::angular), mm.
  Scalar max_geometry_error;
  Scalar max_scale;    // |s_i|, dimensionless
  Scalar max_thermal;  // |c|, 1/°C
  // The largest identified angular error: hybrid |Δχ̂_k| per structural source
  // error that is an angle, rad (the 6-UPS has none). Last, so that a
  // generated header written before it still initializes the members above in
  // place; it then reads 0 here, which refuses every non-zero angular error:
  // such a header fails its static_assert (regenerate it) instead of passing
  // an angle unchecked.
  Scalar max_angle_error;
};
using MachineLimitsd = MachineLimits<double>;
using MachineLimitsf = MachineLimits<float>;

// Sane maxima that no calibration of a machine of these sizes needs: 10 mm of
// geometric error (seed 001 Table 3 and seed 000 Table 3 are < 1 mm; a
// machine before its first calibration a few mm), 0.1 rad of angular error
// (seed 000 Table 3 is < 1 mrad), scale 1 % (a leadscrew is
// off by 1e-4), thermal 1e-3 /°C (steel 1.2e-5, aluminium 2.3e-5). A robot
// description may set each (identify's machine_limits: the keys
// max_geometry_error, max_angle_error, max_scale, max_thermal).
template <class Scalar> struct DefaultLimitCaps {
  static constexpr Scalar geometry_error = Scalar(10);
  static constexpr Scalar angle_error = Scalar(0.1);
  static constexpr Scalar scale = Scalar(0.01);
  static constexpr Scalar thermal = Scalar(1e-3);
};

// Limits from a machine's nominal geometry (its stroke / joint limits) and
// the default correction bound (default_bounds in compensation.hpp: 5 mm,
// 0.02 rad), with the default caps.
template <class Scalar> MachineLimits<Scalar> limits_from_bounds(const TableBounds<Scalar>& b) {
  MachineLimits<Scalar> l{};
  for (int i = 0; i < 6; ++i) {
    l.min_joint[i] = b.min_joint[i];
    l.max_joint[i] = b.max_joint[i];
    l.max_correction[i] = b.max_correction[i];
  }
  l.max_geometry_error = DefaultLimitCaps<Scalar>::geometry_error;
  l.max_angle_error = DefaultLimitCaps<Scalar>::angle_error;
  l.max_scale = DefaultLimitCaps<Scalar>::scale;
  l.max_thermal = DefaultLimitCaps<Scalar>::thermal;
  return l;
}

namespace limits_detail {

using table_detail::abs;
using table_detail::finite;

template <class Scalar> constexpr bool within(Scalar x, Scalar cap) { return abs(x) <= cap; }

template <class Scalar> constexpr bool sane(const MachineLimits<Scalar>& l) {
  for (int i = 0; i < 6; ++i)
    if (!finite(l.min_joint[i]) || !finite(l.max_joint[i]) || !(l.min_joint[i] < l.max_joint[i]) ||
        !finite(l.max_correction[i]) || !(l.max_correction[i] > Scalar(0)))
      return false;
  return finite(l.max_geometry_error) && l.max_geometry_error >= Scalar(0) && finite(l.max_angle_error) &&
         l.max_angle_error >= Scalar(0) && finite(l.max_scale) && l.max_scale >= Scalar(0) &&
         finite(l.max_thermal) && l.max_thermal >= Scalar(0);
}

template <class Scalar> constexpr bool bounds_inside(const TableBounds<Scalar>& b, const MachineLimits<Scalar>& l) {
  for (int i = 0; i < 6; ++i)
    if (!(b.min_joint[i] >= l.min_joint[i]) || !(b.max_joint[i] <= l.max_joint[i]) ||
        !(b.max_correction[i] <= l.max_correction[i]))
      return false;
  return true;
}

template <class Scalar>
constexpr bool effects_inside(const EffectTable<Scalar>& e, const TableBounds<Scalar>& b, const MachineLimits<Scalar>& l) {
  for (int i = 0; i < 6; ++i) {
    // Every joint-space effect is a correction of joint i: each alone within
    // the table's (already limited) correction bound; compliance per unit of
    // the static load of a unit weight (of order 1).
    const Scalar cap = b.max_correction[i];
    if (!within(e.scale[i], l.max_scale) || !within(e.backlash[i], cap) || !within(e.compliance[i], cap) ||
        !within(e.cyclic_sin[i], cap) || !within(e.cyclic_cos[i], cap))
      return false;
  }
  return within(e.thermal, l.max_thermal);
}

template <class Scalar>
constexpr bool machine_inside(const StewartMachine<Scalar>& m, const TableBounds<Scalar>& b, const MachineLimits<Scalar>& l) {
  for (int k = 0; k < 18; ++k)
    if (!within(m.calibrated.base[k] - m.nominal.base[k], l.max_geometry_error) ||
        !within(m.calibrated.platform[k] - m.nominal.platform[k], l.max_geometry_error))
      return false;
  // The leg offsets dl_i act at every point like the hybrid's encoder
  // offsets: each within the correction bound.
  for (int i = 0; i < 6; ++i)
    if (!within(m.calibrated.length_offset[i] - m.nominal.length_offset[i], b.max_correction[i])) return false;
  // A leg's line within max_geometry_error of its U centre: s_i = o_i² (mm²)
  // within its square.
  for (int i = 0; i < 6; ++i)
    if (!within(m.calibrated.leg_offset_sq[i] - m.nominal.leg_offset_sq[i],
                l.max_geometry_error * l.max_geometry_error))
      return false;
  return true;
}

template <class Scalar>
constexpr bool machine_inside(const HybridMachine<Scalar>& m, const TableBounds<Scalar>&, const MachineLimits<Scalar>& l) {
  static_assert(HybridErrorLayout::size() == kHybridSourceErrorCount, "one layout of Δχ");
  for (int k = 0; k < kHybridSourceErrorCount; ++k)
    if (!within(m.source_errors[k], HybridErrorLayout::angular(k) ? l.max_angle_error : l.max_geometry_error))
      return false;
  return true;  // encoder offsets: validate_table bounds them by max_correction
}

}  // namespace limits_detail

// validate_table, then the table against limits known without it:
//   TableLimits  the limits themselves are not sane (non-finite, unordered,
//                a correction bound ≤ 0); the table's command range is not
//                inside the limits' or its correction bound above theirs; a
//                geometric error above max_geometry_error (lengths) or
//                max_angle_error (the hybrid's angles), a 6-UPS leg offset
//                above the correction bound; an effect value above its cap
//                (scale, thermal) or above the correction bound (backlash,
//                compliance, cyclic).
template <class Machine>
constexpr CompensationStatus validate_table(const CalibrationTable<Machine>& t,
                                            const MachineLimits<typename Machine::Scalar>& limits) {
  const CompensationStatus st = validate_table(t);
  if (st != CompensationStatus::Ok) return st;
  using namespace limits_detail;
  if (!sane(limits) || !bounds_inside(t.bounds, limits) || !effects_inside(t.effects, t.bounds, limits) ||
      !machine_inside(t.machine, t.bounds, limits))
    return CompensationStatus::TableLimits;
  return CompensationStatus::Ok;
}

// A command the drives may execute: finite and inside the limits' range.
template <class Scalar> bool command_inside(const Vec6<Scalar>& q, const MachineLimits<Scalar>& l) {
  for (int i = 0; i < 6; ++i)
    if (!(q(i) >= l.min_joint[i] && q(i) <= l.max_joint[i])) return false;  // false for NaN
  return true;
}

}  // namespace kincal
