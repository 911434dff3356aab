// The poses the core kinematics benchmarks run at, shared by the Google
// Benchmark program and the callgrind harness so both measure the same thing.
// GUIDE "Bars every change is held to" fixes the 6-UPS FK case; the others are
// representative poses inside each machine's workspace.
#pragma once

#include "kincal/core/reference_machines.hpp"

namespace kincal::bench {

template <class S> S deg(double d) { return S(d * 3.14159265358979323846 / 180.0); }

// 6-UPS (stewart-seed001) IK pose and the GUIDE's FK target: from the home pose
// (0, 0, 200, 0, 0, 0) to (10, 5, 205, 2°, 1.5°, −3°).
template <class S> Pose<S> stewart_target() {
  return Pose<S>::from_xyz_rpy(S(10), S(5), S(205), deg<S>(2.0), deg<S>(1.5), deg<S>(-3.0));
}

// hybrid-seed000: a pose inside the 500 × 500 × 120 mm task cuboid of {R}.
template <class S> Pose<S> hybrid_target() {
  return Pose<S>::from_xyz_rpy(S(120), S(-80), S(30), S(0), S(0), S(0));
}

// Position / orientation error of an FK result against the true pose, always
// evaluated in double (so the float result is judged against the exact pose).
struct FkAccuracy {
  double position_mm = 0;
  double orientation_rad = 0;
};
template <class S> FkAccuracy fk_accuracy(const Pose<S>& got, const Pose<double>& truth) {
  const Twist<double> e = pose_error(got.template cast<double>(), truth);
  return {e.head<3>().norm(), e.tail<3>().norm()};
}

}  // namespace kincal::bench
