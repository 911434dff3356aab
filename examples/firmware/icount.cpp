// Instruction count per compensated NC point on the target
// (docs/benchmarks.md "Firmware example (Cortex-M7)"; examples/firmware/icount.sh).
//
// qemu does not model the DWT cycle counter, so the count is taken from qemu's
// own execution trace: run this image once with N = 0 and once with N points
// (`-append N`), count the executed instructions of each run (-singlestep
// -d exec,nochain: one trace line per guest instruction) and divide the
// difference by N. Everything but the loop below is identical in both runs
// and cancels out.
//
// The loop is the controller's per-point work without I/O: the pose of the
// point (x, y, z, rx, ry, rz → R = Rz·Ry·Rx) and Compensator::compensate with
// the example's calibration table (the full identified hybrid model: encoder
// offsets and 156 structural errors, seed 000 Eq. (16) with the end frames). The points sweep the
// task cuboid with small tool tilts, so IK and B·Δχ see varied configurations.
#include "kincal/core/compensation.hpp"
#include KINCAL_CALIBRATION_TABLE_HEADER

extern "C" {
#include "semihosting.h"
}

#ifndef KINCAL_EXAMPLE_SCALAR
#define KINCAL_EXAMPLE_SCALAR double
#endif

namespace {

using Scalar = KINCAL_EXAMPLE_SCALAR;
using Tables = kincal::generated::Tables<Scalar>;
using Machine = kincal::generated::Machine<Scalar>;

// The points' input, as an interpolator would write it: volatile, so the
// compiler cannot fold the kinematics of known poses.
volatile Scalar g_input[6];
volatile Scalar g_sink;

long parse_count(const char* s) {
  long n = 0;
  for (; *s >= '0' && *s <= '9'; ++s) n = 10 * n + (*s - '0');
  return n;
}

}  // namespace

int main() {
  char line[256];
  long n = 0;
  if (kincal_semihost_get_cmdline(line, sizeof line) == 0) {
    const char* p = line;
    while (*p != '\0' && *p != ' ') ++p;  // the program name
    while (*p == ' ') ++p;
    n = parse_count(p);
  }
  const kincal::Compensator<Machine, kincal::generated::Formulas<Scalar>> comp(Tables::calibration(), Tables::limits());
  kincal::Vec6<Scalar> home;
  if (comp.home_command(home) != kincal::CompensationStatus::Ok) return 1;
  kincal::CompensatorState<Scalar> state = comp.start(home);
  long ok = 0;
  Scalar sum = Scalar(0);
  for (long k = 0; k < n; ++k) {
    // A 7 × 7 × 3 sweep of the hybrid's 500 × 500 × 120 mm task cuboid.
    const Scalar x = Scalar(-240) + Scalar(80) * Scalar(k % 7);
    const Scalar y = Scalar(-240) + Scalar(80) * Scalar((k / 7) % 7);
    const Scalar z = Scalar(-50) + Scalar(50) * Scalar((k / 49) % 3);
    const Scalar t = Scalar(0.01) * Scalar(k % 5);
    g_input[0] = x, g_input[1] = y, g_input[2] = z, g_input[3] = t, g_input[4] = -t, g_input[5] = Scalar(0.5) * t;
    kincal::NcPoint<Scalar> point;
    point.pose = kincal::Pose<Scalar>::from_xyz_rpy(g_input[0], g_input[1], g_input[2], g_input[3], g_input[4],
                                                    g_input[5]);
    kincal::Vec6<Scalar> q;
    if (comp.compensate(state, point, q) == kincal::CompensationStatus::Ok) ++ok;
    sum += q.sum();
  }
  g_sink = sum;
  kincal_semihost_write("icount: ");
  kincal_semihost_write_int(n);
  kincal_semihost_write(" points, ");
  kincal_semihost_write_int(ok);
  kincal_semihost_write(" compensated\n");
  return ok == n ? 0 : 1;
}
