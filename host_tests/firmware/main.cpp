// Target side of the portable core checks: the very checks GoogleTest runs on
// the host (portable/core_checks.hpp), cross-compiled and run under qemu.
// Output and exit status go through semihosting, so ctest sees a failure.
#include "portable/core_checks.hpp"

extern "C" {
#include "semihosting.h"
}

namespace {

void semihost_sink(const char* file, int line, const char* what) {
  kincal_semihost_write("FAIL ");
  kincal_semihost_write(file);
  kincal_semihost_write(":");
  kincal_semihost_write_int(line);
  kincal_semihost_write(": ");
  kincal_semihost_write(what);
  kincal_semihost_write("\n");
}

// The same count as the host: 10^4 random poses per machine and scalar.
constexpr int kRoundTrips = 10000;

template <class Scalar> long run(const char* name) {
  kincal::test::Checker c(&semihost_sink);
  kincal::test::run_core_checks<Scalar>(c, kRoundTrips);
  kincal_semihost_write(name);
  kincal_semihost_write(": ");
  kincal_semihost_write_int(c.checks());
  kincal_semihost_write(" checks, ");
  kincal_semihost_write_int(c.failures());
  kincal_semihost_write(" failures\n");
  // A suite that ran (almost) nothing is a failure too.
  return c.failures() + (c.checks() < 4 * kRoundTrips ? 1 : 0);
}

}  // namespace

int main() {
  long failures = 0;
#if KINCAL_FIRMWARE_HAS_DOUBLE
  failures += run<double>("core checks (double)");
#endif
#if KINCAL_FIRMWARE_HAS_FLOAT
  failures += run<float>("core checks (float)");
#endif
  return failures == 0 ? 0 : 1;
}
