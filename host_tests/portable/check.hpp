// Portable test harness for the core checks: the same check code runs on the
// host (wrapped by GoogleTest, see host_tests/core_portable_test.cpp) and on
// the Cortex-M target under qemu (host_tests/firmware/main.cpp). So it uses
// neither the heap nor iostream nor exceptions: failures go to a caller-given
// sink (GoogleTest's ADD_FAILURE on the host, semihosting on the target).
#pragma once

#include <cstdint>

namespace kincal::test {

using FailureSink = void (*)(const char* file, int line, const char* what);

class Checker {
 public:
  explicit Checker(FailureSink sink) : sink_(sink) {}

  bool check(bool ok, const char* file, int line, const char* what) {
    ++checks_;
    if (!ok) {
      ++failures_;
      // Report only the first few failures of a suite: a systematic defect in a
      // 10^4-pose loop should not flood a semihosting console.
      if (failures_ <= 10 && sink_ != nullptr) sink_(file, line, what);
    }
    return ok;
  }

  long checks() const { return checks_; }
  long failures() const { return failures_; }

 private:
  FailureSink sink_;
  long checks_ = 0;
  long failures_ = 0;
};

// splitmix64: a small, allocation-free, reproducible generator for random poses.
class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [lo, hi).
  double uniform(double lo, double hi) {
    const double unit = static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0);
    return lo + (hi - lo) * unit;
  }

 private:
  std::uint64_t state_;
};

}  // namespace kincal::test

#define KINCAL_CHECK(checker, cond) (checker).check(static_cast<bool>(cond), __FILE__, __LINE__, #cond)
