// Instruction-count harness for callgrind (host_tests/bench/icount.sh).
//
//   kincal_core_kinematics_icount <operation> <N>
//
// does all the set-up (geometry, joint targets, one untimed FK for the report
// line), then calls <operation> N times. Run under
// `valgrind --tool=callgrind` with N = 1000 and N = 0: the difference of the
// two totals divided by N is the instruction count of one call, free of the
// start-up cost (dynamic loader, stdio, set-up), which cancels. The first
// output line reports the status (and for FK the iterations and accuracy) of
// the call being counted; a non-Ok status is reported, not an error.
// Wall-clock timing lives in core_kinematics_bench.cpp; this is the stable
// measure on a noisy shared machine.
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "bench_cases.hpp"

namespace {

using namespace kincal;
using namespace kincal::bench;

// Same barrier as benchmark::DoNotOptimize: the value may have been read and
// changed, and memory clobbered, so nothing is folded or hoisted across calls.
template <class T> inline __attribute__((always_inline)) void opaque(T& value) {
  asm volatile("" : "+m"(value) : : "memory");
}

// One machine's IK, N times, with or without the Jacobian.
template <class S, class Geometry, class Ik> int ik_loop(long n, bool with_jacobian, Geometry g, Pose<S> pose, Ik ik) {
  Vec6<S> q = Vec6<S>::Zero();
  Mat6<S> J = Mat6<S>::Zero();
  Mat6<S>* const jacobian = with_jacobian ? &J : nullptr;
  Status s = ik(g, pose, q, jacobian);
  std::printf("status=%s\n", to_string(s));
  opaque(g);
  for (long i = 0; i < n; ++i) {
    opaque(pose);
    s = ik(g, pose, q, jacobian);
    opaque(s);
    opaque(q);
    opaque(J);
  }
  return 0;
}

// One machine's FK from its home to the joints of `target`, N times.
template <class S, class Geometry, class Guess, class Ik, class Fk>
int fk_loop(long n, Geometry g, Guess guess, const Pose<double>& target, Ik ik, Fk fk) {
  Vec6<S> q = Vec6<S>::Zero();
  ik(g, target.template cast<S>(), q, nullptr);
  Pose<S> out;
  FkReport<S> r = fk(g, q, guess, out);
  const FkAccuracy acc = fk_accuracy(out, target);
  std::printf("status=%s iterations=%d pos_err_mm=%.3e rot_err_rad=%.3e\n", to_string(r.status), r.iterations,
              acc.position_mm, acc.orientation_rad);
  opaque(g);
  for (long i = 0; i < n; ++i) {
    opaque(q);
    opaque(guess);
    r = fk(g, q, guess, out);
    opaque(r);
    opaque(out);
  }
  return 0;
}

template <class S> int stewart_ik_loop(long n, bool with_jacobian) {
  return ik_loop<S>(n, with_jacobian, make_stewart_seed001<S>(), stewart_target<S>(),
                    [](const auto& g, const auto& p, auto& q, Mat6<S>* J) { return stewart_ik(g, p, q, J); });
}
template <class S> int hybrid_ik_loop(long n, bool with_jacobian) {
  return ik_loop<S>(n, with_jacobian, make_hybrid_seed000<S>(), hybrid_target<S>(),
                    [](const auto& g, const auto& p, auto& q, Mat6<S>* J) { return hybrid_ik(g, p, q, J); });
}
template <class S> int stewart_fk_loop(long n) {
  const StewartGeometry<S> g = make_stewart_seed001<S>();
  return fk_loop<S>(
      n, g, g.home, stewart_target<double>(),
      [](const auto& gg, const auto& p, auto& q, Mat6<S>* J) { return stewart_ik(gg, p, q, J); },
      [](const auto& gg, const auto& q, const auto& guess, auto& out) { return stewart_fk(gg, q, guess, out); });
}
template <class S> int hybrid_fk_loop(long n) {
  const HybridGeometry<S> g = make_hybrid_seed000<S>();
  return fk_loop<S>(
      n, g, g.home, hybrid_target<double>(),
      [](const auto& gg, const auto& p, auto& q, Mat6<S>* J) { return hybrid_ik(gg, p, q, J); },
      [](const auto& gg, const auto& q, const auto& guess, auto& out) { return hybrid_fk(gg, q, guess, out); });
}

struct Operation {
  const char* name;
  int (*run)(long);
};

const Operation kOperations[] = {
    {"stewart_ik_d", [](long n) { return stewart_ik_loop<double>(n, false); }},
    {"stewart_ik_jac_d", [](long n) { return stewart_ik_loop<double>(n, true); }},
    {"stewart_fk_d", [](long n) { return stewart_fk_loop<double>(n); }},
    {"hybrid_ik_d", [](long n) { return hybrid_ik_loop<double>(n, false); }},
    {"hybrid_ik_jac_d", [](long n) { return hybrid_ik_loop<double>(n, true); }},
    {"hybrid_fk_d", [](long n) { return hybrid_fk_loop<double>(n); }},
    {"stewart_ik_f", [](long n) { return stewart_ik_loop<float>(n, false); }},
    {"stewart_ik_jac_f", [](long n) { return stewart_ik_loop<float>(n, true); }},
    {"stewart_fk_f", [](long n) { return stewart_fk_loop<float>(n); }},
    {"hybrid_ik_f", [](long n) { return hybrid_ik_loop<float>(n, false); }},
    {"hybrid_ik_jac_f", [](long n) { return hybrid_ik_loop<float>(n, true); }},
    {"hybrid_fk_f", [](long n) { return hybrid_fk_loop<float>(n); }},
};

int usage() {
  std::fprintf(stderr, "usage: kincal_core_kinematics_icount <operation> <N>\n       kincal_core_kinematics_icount --list\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 2 && std::strcmp(argv[1], "--list") == 0) {
    for (const Operation& op : kOperations) std::printf("%s\n", op.name);
    return 0;
  }
  if (argc != 3) return usage();
  char* end = nullptr;
  const long n = std::strtol(argv[2], &end, 10);
  if (end == argv[2] || *end != '\0' || n < 0) return usage();
  for (const Operation& op : kOperations)
    if (std::strcmp(argv[1], op.name) == 0) return op.run(n);
  std::fprintf(stderr, "kincal_core_kinematics_icount: unknown operation '%s' (try --list)\n", argv[1]);
  return 2;
}
