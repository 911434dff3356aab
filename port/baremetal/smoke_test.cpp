// Smoke test of the firmware tool chain, before the real core tests exist:
// Eigen fixed-size dense algebra, libm, the FPU, semihosting console and files,
// and the exit status reaching ctest.  Prints "smoke: N checks, F failures".
#include <Eigen/Dense>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "semihosting.h"

namespace {

int g_checks = 0;
int g_failures = 0;

void check(bool ok, const char* what) {
  ++g_checks;
  if (!ok) {
    ++g_failures;
    kincal_semihost_write("smoke: FAILED: ");
    kincal_semihost_write(what);
    kincal_semihost_write("\n");
  }
}

// A runtime value the compiler cannot see through, so the arithmetic below is
// really executed on the target FPU rather than folded at compile time.
volatile int g_one = 1;

// Solve A x = b for a fixed, well-conditioned 6x6 A with PartialPivLU (the
// decomposition the core's FK Newton step uses) and check the residual.
template <typename Scalar>
void check_lu(const char* scalar_name, Scalar tolerance) {
  using Mat = Eigen::Matrix<Scalar, 6, 6>;
  using Vec = Eigen::Matrix<Scalar, 6, 1>;
  const Scalar one = static_cast<Scalar>(g_one);
  Mat a;
  Vec x_true;
  for (int i = 0; i < 6; ++i) {
    x_true(i) = one * static_cast<Scalar>(i - 2);  // includes a zero entry
    for (int j = 0; j < 6; ++j) a(i, j) = std::sin(one * static_cast<Scalar>(6 * i + j + 1));
    a(i, i) += static_cast<Scalar>(3);  // diagonal dominance: cond(A) is small
  }
  const Vec b = a * x_true;
  const Eigen::PartialPivLU<Mat> lu(a);
  const Vec x = lu.solve(b);
  const Scalar residual = (a * x - b).norm() / b.norm();
  const Scalar error = (x - x_true).norm() / x_true.norm();
  kincal_semihost_write("smoke: ");
  kincal_semihost_write(scalar_name);
  kincal_semihost_write(" LU: relative residual = ");
  kincal_semihost_write_int(static_cast<long>(static_cast<Scalar>(100) * residual / Eigen::NumTraits<Scalar>::epsilon()));
  kincal_semihost_write("% of machine epsilon\n");
  check(residual < tolerance, "PartialPivLU residual");
  check(error < tolerance * static_cast<Scalar>(100), "PartialPivLU solution error");
  check(std::abs(lu.determinant()) > static_cast<Scalar>(1), "PartialPivLU determinant");
}

// libm through <cmath>: the overloads pick sin/sinf etc. by Scalar.
template <typename Scalar>
void check_libm(Scalar tolerance) {
  const Scalar t = static_cast<Scalar>(g_one) * static_cast<Scalar>(0.7);
  const Scalar s = std::sin(t);
  const Scalar c = std::cos(t);
  check(std::abs(s * s + c * c - static_cast<Scalar>(1)) < tolerance, "sin^2 + cos^2 == 1");
  check(std::abs(std::atan2(s, c) - t) < tolerance, "atan2(sin t, cos t) == t");
  const Scalar r = std::sqrt(static_cast<Scalar>(2) * static_cast<Scalar>(g_one));
  check(std::abs(r * r - static_cast<Scalar>(2)) < tolerance * static_cast<Scalar>(4), "sqrt(2)^2 == 2");
  const Scalar quarter_pi = std::atan2(static_cast<Scalar>(g_one), static_cast<Scalar>(g_one));
  check(std::abs(static_cast<Scalar>(4) * quarter_pi - static_cast<Scalar>(EIGEN_PI)) < tolerance * static_cast<Scalar>(4),
        "4 atan2(1, 1) == pi");
}

// Semihosting file round trip (later used to stream measurement CSVs).
void check_files() {
  static const char path[] = "firmware_smoke_semihost.txt";
  static const char text[] = "id,x\n1,2.5\n";
  const std::size_t length = sizeof text - 1;
  int handle = kincal_semihost_open(path, KINCAL_SEMIHOST_WRITE);
  check(handle >= 0, "semihosting open for writing");
  if (handle < 0) return;
  check(kincal_semihost_write_file(handle, text, length) == length, "semihosting write");
  check(kincal_semihost_close(handle) == 0, "semihosting close");
  char back[32] = {};
  handle = kincal_semihost_open(path, KINCAL_SEMIHOST_READ);
  check(handle >= 0, "semihosting open for reading");
  if (handle < 0) return;
  check(kincal_semihost_read_file(handle, back, sizeof back) == length, "semihosting read length");
  check(std::memcmp(back, text, length) == 0, "semihosting read content");
  check(kincal_semihost_read_file(handle, back, sizeof back) == 0, "semihosting read at end of file");
  check(kincal_semihost_close(handle) == 0, "semihosting close after read");
}

// The FPU the compiler targets must be the one the core has.  MVFR0 (Armv7-M ARM
// B4.1.4) bits [11:8] are 2 when double precision is implemented; qemu's
// cortex-m7 model has it, its cortex-m4 does not.
void check_fpu() {
  const std::uint32_t mvfr0 = *reinterpret_cast<volatile const std::uint32_t*>(0xE000EF40u);
  kincal_semihost_write("smoke: MVFR0 = ");
  kincal_semihost_write_hex(mvfr0);
  kincal_semihost_write("\n");
  check(((mvfr0 >> 4) & 0xFu) == 2u, "FPU: single precision implemented");
#if defined(__ARM_FP) && (__ARM_FP & 0x8)
  check(((mvfr0 >> 8) & 0xFu) == 2u, "FPU: double precision implemented (compiled for it)");
#endif
}

}  // namespace

int main() {
  check_fpu();
#if KINCAL_FIRMWARE_HAS_DOUBLE
  check_lu<double>("double", 1e-12);
  check_libm<double>(1e-12);
#endif
  check_lu<float>("float", 1e-5f);
  check_libm<float>(1e-5f);
  check_files();
  kincal_semihost_write("smoke: ");
  kincal_semihost_write_int(g_checks);
  kincal_semihost_write(" checks, ");
  kincal_semihost_write_int(g_failures);
  kincal_semihost_write(" failures\n");
  return g_failures == 0 ? 0 : 1;
}
