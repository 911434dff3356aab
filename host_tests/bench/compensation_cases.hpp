// The compensation benchmark cases, shared by the Google Benchmark program and
// the callgrind harness: "a full identified model" of each machine as a
// CalibrationTable, and the NC points the compensator is fed.
//
//   hybrid: hybrid-seed000 with seed 000's encoder offsets (the sizes of
//     examples/hybrid-seed000/errors.csv) and the structural errors
//     non-zero (uniform ±1e-4, mm or rad) except, with `balls`, those
//     identify holds on every design it documents: the S joints' axis
//     offsets (dx_5_i, dy_5_i, dz_5_i) and last-axis tilts (dalpha_6_i,
//     dbeta_6_i), so each S stays a ball and the compensator closes its limb
//     on the ball's centre (core/hybrid_exact.hpp close_ups_on_centre);
//     without `balls` all 150 are non-zero and every limb takes the
//     six-joint closure (a model with S offsets, as examples/firmware/
//     model.json, identified before those were held). "+effects" adds
//     scale, backlash, compliance, cyclic and thermal (with a temperature
//     input).
//   6-UPS: stewart-seed001 with a calibrated geometry (every hinge and leg
//     length off by up to 50 µm); "+effects" as above.
// The points cycle through 8 poses around bench_cases.hpp's target, so the
// joints move and reverse as in a real NC stream.
#pragma once

#include <cmath>

#include "bench_cases.hpp"
#include "kincal/core/compensation.hpp"

namespace kincal::bench {

inline double lcg_uniform(unsigned& s, double lo, double hi) {
  s = s * 1664525u + 1013904223u;
  return lo + (hi - lo) * double(s >> 8) / double(1u << 24);
}

template <class Machine> CalibrationTable<Machine> add_effects(CalibrationTable<Machine> t) {
  for (int i = 0; i < 6; ++i) {
    t.effects.scale[i] = 1e-4 * (i % 2 == 0 ? 1 : -1);
    t.effects.backlash[i] = i < 3 ? -0.01 : -2e-5;
    t.effects.compliance[i] = i < 3 ? 2e-3 : 1e-6;
    t.effects.cyclic_sin[i] = i < 3 ? 0.002 : 0.0;
    t.effects.cyclic_cos[i] = i < 3 ? -0.0015 : 0.0;
  }
  t.effects.thermal = 1.2e-5;
  if (t.effects.screw_joints == 0) t.effects.screw_joints = 63;
  return seal_table(t);
}

inline HybridCalibrationTable<double> hybrid_full_model(bool effects, bool balls = true) {
  const HybridGeometry<double> g = make_hybrid_seed000<double>();
  EffectParameters<double> frame;
  frame.load_direction = g.workpiece_rotation * Vec3<double>(0, 0, -1);
  frame.thermal_origin = -(g.workpiece_rotation * g.workpiece_origin);
  frame.screw_joints = 0x07;
  HybridCalibrationTable<double> t = nominal_table(g, 345.0, frame);
  const double xi[6] = {0.3, -0.25, 0.2, 5e-4, -4e-4, 3e-4};
  for (int i = 0; i < 6; ++i) t.machine.encoder_offsets[i] = xi[i];
  unsigned s = 12345u;
  for (int k = 6; k < kHybridSourceErrorCount; ++k) t.machine.source_errors[k] = lcg_uniform(s, -1e-4, 1e-4);
  for (int i = 0; i < 3 && balls; ++i) {
    double* eta = t.machine.source_errors + HybridErrorLayout::ups(i);
    for (int k = 0; k < 3; ++k) eta[6 + 5 * 4 + k] = 0.0;  // joint 4's translations
    for (int k = 3; k < 5; ++k) eta[6 + 5 * 5 + k] = 0.0;  // joint 5's tilts
  }
  t = seal_table(t);
  return effects ? add_effects(t) : t;
}

inline StewartCalibrationTable<double> stewart_full_model(bool effects) {
  const StewartGeometry<double> g = make_stewart_seed001<double>();
  StewartGeometry<double> cal = g;
  unsigned s = 777u;
  for (int i = 0; i < 6; ++i) {
    for (int k = 0; k < 3; ++k) {
      cal.base(k, i) += lcg_uniform(s, -0.05, 0.05);
      cal.platform(k, i) += lcg_uniform(s, -0.05, 0.05);
    }
    cal.length_offset(i) = lcg_uniform(s, -0.05, 0.05);
  }
  StewartCalibrationTable<double> t = nominal_table(g);
  t.machine.calibrated = to_table(cal);
  t = seal_table(t);
  return effects ? add_effects(t) : t;
}

constexpr int kPointCount = 8;

// 8 NC points around the target of bench_cases.hpp (mm, rad).
template <class S> Pose<S> nc_point(MachineFamily family, int k) {
  static const double d[kPointCount][3] = {{0, 0, 0},  {4, -2, 1},  {9, 1, -1}, {5, 6, 2},
                                           {-3, 4, 0}, {-8, -1, 1}, {-2, -7, -2}, {1, -3, 0}};
  const Pose<S> base = family == MachineFamily::Hybrid ? hybrid_target<S>() : stewart_target<S>();
  Pose<S> p = base;
  p.p += Vec3<S>(S(d[k][0]), S(d[k][1]), S(d[k][2]));
  return p;
}

// An NC stream: a circle of radius 20 mm about that target, 0.1 mm a point
// (6 m/min at 1 kHz), the tool tilting ±0.02 rad about x and y as it goes;
// kPathPointCount points close the circle (the last step is a regular one).
constexpr int kPathPointCount = 1257;
template <class S> Pose<S> path_point(MachineFamily family, int k) {
  const double a = 2 * 3.141592653589793 * k / kPathPointCount;
  const Pose<S> base = family == MachineFamily::Hybrid ? hybrid_target<S>() : stewart_target<S>();
  const Pose<S> turn = Pose<S>::from_xyz_rpy(S(20 * std::cos(a)), S(20 * std::sin(a)), S(0), S(0.02 * std::sin(a)),
                                             S(0.02 * std::cos(a)), S(0));
  Pose<S> p = base;
  p.p += turn.p;
  p.R = base.R * turn.R;
  return p;
}

}  // namespace kincal::bench
