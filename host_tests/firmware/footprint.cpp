// Firmware footprint image: the core kinematics of ONE machine in double, in the
// shape of a controller loop, so that flash / static RAM / stack are measured on
// code a controller would really contain (scripts/firmware-footprint.sh,
// docs/benchmarks.md "Firmware footprint (Cortex-M7)").
//
// Built twice, once per machine:
//   KINCAL_FOOTPRINT_MACHINE=1  stewart-seed001 (6-UPS)
//   KINCAL_FOOTPRINT_MACHINE=2  hybrid-seed000
// Each cycle takes a setpoint, runs IK without and with the Jacobian, then FK
// from the previous cycle's pose (as a controller's position feedback would),
// and checks the statuses and the IK -> FK round trip. It is also a firmware
// test: any failed check prints one line and makes main() return non-zero.
// No test framework and no printf: only semihosting writes, so the image holds
// the core, libm and the run-time, nothing else.
#include "kincal/core/reference_machines.hpp"

extern "C" {
#include "semihosting.h"
}

#ifndef KINCAL_FOOTPRINT_MACHINE
#error "define KINCAL_FOOTPRINT_MACHINE=1 (stewart-seed001) or 2 (hybrid-seed000)"
#endif

namespace {

using S = double;
using kincal::Status;

constexpr S kDeg = kincal::pi<S>() / S(180);
constexpr int kSetpoints = 6;

// Round-trip tolerances: FK stops at ~1e-13 relative joint residual, so the
// pose comes back to ~1e-11 mm; these leave margin for the conditioning.
constexpr S kPositionTolerance = 1e-8;   // mm
constexpr S kRotationTolerance = 1e-10;  // rad

#if KINCAL_FOOTPRINT_MACHINE == 1
constexpr const char* kMachine = "stewart-seed001";
// (x, y, z mm, rx, ry, rz deg) around the home pose (0, 0, 200, 0, 0, 0).
constexpr S kSetpoint[kSetpoints][6] = {
    {10, 5, 205, 2, 1.5, -3},   {-20, 15, 190, -3, 2, 5},  {30, -25, 215, 1, -2, 10},
    {0, 0, 230, 0, 0, 0},       {-15, -30, 195, 4, 0, -6}, {0, 0, 200, 0, 0, 0}};
// Far above the stroke: every leg would exceed max_length.
constexpr S kOutOfRange[6] = {0, 0, 400, 0, 0, 0};
using Geometry = kincal::StewartGeometry<S>;
Geometry make_geometry() { return kincal::make_stewart_seed001<S>(); }
#elif KINCAL_FOOTPRINT_MACHINE == 2
constexpr const char* kMachine = "hybrid-seed000";
// Workpiece frame {R}; the task cuboid is [-250, 250] x [-250, 250] x [-60, 60] mm.
constexpr S kSetpoint[kSetpoints][6] = {
    {120, -80, 30, 0, 0, 0},   {-200, 150, -40, 3, -2, 5}, {240, 240, 60, -5, 4, -8},
    {-240, -240, -60, 2, 2, 2}, {0, 0, 0, 10, -10, 0},      {0, 0, 0, 0, 0, 0}};
// Far outside the work space.
constexpr S kOutOfRange[6] = {0, 0, 3000, 0, 0, 0};
using Geometry = kincal::HybridGeometry<S>;
Geometry make_geometry() { return kincal::make_hybrid_seed000<S>(); }
#else
#error "KINCAL_FOOTPRINT_MACHINE must be 1 or 2"
#endif

// Controller state lives in static RAM, as it would in a product: the machine
// parameters (later loaded from a parameter table), the setpoint input written
// by the interpolator (volatile, so the compiler cannot constant-fold the
// kinematics on the known setpoints) and the last feedback.
Geometry g_geometry;
volatile S g_setpoint_input[6];
kincal::Pose<S> g_feedback;
#if KINCAL_FOOTPRINT_MACHINE == 2
kincal::HybridPassive<S> g_passive;
#endif

long g_failures = 0;

void fail(int cycle, const char* what) {
  ++g_failures;
  kincal_semihost_write("FAIL cycle ");
  kincal_semihost_write_int(cycle);
  kincal_semihost_write(": ");
  kincal_semihost_write(what);
  kincal_semihost_write("\n");
}

kincal::Pose<S> read_setpoint(const S (&v)[6]) {
  for (int i = 0; i < 6; ++i) g_setpoint_input[i] = v[i];
  S x[6];
  for (int i = 0; i < 6; ++i) x[i] = g_setpoint_input[i];
  return kincal::Pose<S>::from_xyz_rpy(x[0], x[1], x[2], x[3] * kDeg, x[4] * kDeg, x[5] * kDeg);
}

Status ik(const kincal::Pose<S>& pose, kincal::Vec6<S>& q) {
#if KINCAL_FOOTPRINT_MACHINE == 1
  return kincal::stewart_ik(g_geometry, pose, q);
#else
  return kincal::hybrid_ik(g_geometry, pose, q);
#endif
}

Status ik_jacobian(const kincal::Pose<S>& pose, kincal::Vec6<S>& q, kincal::Mat6<S>& J) {
#if KINCAL_FOOTPRINT_MACHINE == 1
  return kincal::stewart_ik(g_geometry, pose, q, &J);
#else
  kincal::HybridPassive<S> passive;
  return kincal::hybrid_ik(g_geometry, pose, q, &J, &passive);
#endif
}

// FK seeded with the previous cycle's result, which is how a controller runs it.
Status fk(const kincal::Vec6<S>& q, kincal::Pose<S>& pose) {
#if KINCAL_FOOTPRINT_MACHINE == 1
  const kincal::FkReport<S> r = kincal::stewart_fk(g_geometry, q, g_feedback, pose);
#else
  kincal::HybridPassive<S> passive;
  const kincal::FkReport<S> r = kincal::hybrid_fk(g_geometry, q, g_passive, pose, &passive);
  if (r.status == Status::Ok) g_passive = passive;
#endif
  return r.status;
}

void cycle(int n, const S (&setpoint)[6]) {
  const kincal::Pose<S> pose = read_setpoint(setpoint);
  kincal::Vec6<S> q, qj;
  kincal::Mat6<S> J;
  if (ik(pose, q) != Status::Ok) return fail(n, "IK status");
  if (ik_jacobian(pose, qj, J) != Status::Ok) return fail(n, "IK+J status");
  if (!(q == qj)) fail(n, "IK and IK+J commands differ");
  if (!kincal::all_finite(J)) fail(n, "Jacobian not finite");
  kincal::Pose<S> back;
  if (fk(q, back) != Status::Ok) return fail(n, "FK status");
  const kincal::Twist<S> e = kincal::pose_error(back, pose);
  if (!(e.head<3>().norm() < kPositionTolerance)) fail(n, "FK position round trip");
  if (!(e.tail<3>().norm() < kRotationTolerance)) fail(n, "FK rotation round trip");
  g_feedback = back;
}

}  // namespace

int main() {
  g_geometry = make_geometry();
#if KINCAL_FOOTPRINT_MACHINE == 1
  g_feedback = g_geometry.home;
#else
  g_passive = g_geometry.home;
#endif
  // Two passes: the second starts every FK from the last pose of the first.
  for (int pass = 0; pass < 2; ++pass)
    for (int i = 0; i < kSetpoints; ++i) cycle(pass * kSetpoints + i, kSetpoint[i]);

  // An unreachable setpoint must give a status and leave the command untouched
  // (the controller holds its last safe output).
  kincal::Vec6<S> q = kincal::Vec6<S>::Constant(S(1));
  const kincal::Vec6<S> held = q;
  if (ik(read_setpoint(kOutOfRange), q) == Status::Ok) fail(-1, "out-of-range setpoint accepted");
  if (!(q == held)) fail(-1, "out-of-range setpoint changed the command");

  kincal_semihost_write("footprint ");
  kincal_semihost_write(kMachine);
  kincal_semihost_write(": ");
  kincal_semihost_write_int(2 * kSetpoints);
  kincal_semihost_write(" cycles, ");
  kincal_semihost_write_int(g_failures);
  kincal_semihost_write(" failures\n");
  return g_failures == 0 ? 0 : 1;
}
