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

template <class S> int stewart_ik_loop(long n, bool with_jacobian) {
  StewartGeometry<S> g = make_stewart_seed001<S>();
  Pose<S> pose = stewart_target<S>();
  Vec6<S> q = Vec6<S>::Zero();
  Mat6<S> J = Mat6<S>::Zero();
  Status s = stewart_ik(g, pose, q, with_jacobian ? &J : nullptr);
  std::printf("status=%s\n", to_string(s));
  opaque(g);
  if (with_jacobian) {
    for (long i = 0; i < n; ++i) {
      opaque(pose);
      s = stewart_ik(g, pose, q, &J);
      opaque(s);
      opaque(q);
      opaque(J);
    }
  } else {
    for (long i = 0; i < n; ++i) {
      opaque(pose);
      s = stewart_ik(g, pose, q);
      opaque(s);
      opaque(q);
    }
  }
  return 0;
}

template <class S> int stewart_fk_loop(long n) {
  StewartGeometry<S> g = make_stewart_seed001<S>();
  Vec6<S> q = Vec6<S>::Zero();
  stewart_ik(g, stewart_target<S>(), q);
  Pose<S> guess = g.home;
  Pose<S> out;
  FkReport<S> r = stewart_fk(g, q, guess, out);
  const FkAccuracy acc = fk_accuracy(out, stewart_target<double>());
  std::printf("status=%s iterations=%d pos_err_mm=%.3e rot_err_rad=%.3e\n", to_string(r.status), r.iterations,
              acc.position_mm, acc.orientation_rad);
  opaque(g);
  for (long i = 0; i < n; ++i) {
    opaque(q);
    opaque(guess);
    r = stewart_fk(g, q, guess, out);
    opaque(r);
    opaque(out);
  }
  return 0;
}

template <class S> int hybrid_ik_loop(long n, bool with_jacobian) {
  HybridGeometry<S> g = make_hybrid_seed000<S>();
  Pose<S> pose = hybrid_target<S>();
  Vec6<S> q = Vec6<S>::Zero();
  Mat6<S> J = Mat6<S>::Zero();
  HybridPassive<S> passive;
  Status s = hybrid_ik(g, pose, q, with_jacobian ? &J : nullptr, with_jacobian ? &passive : nullptr);
  std::printf("status=%s\n", to_string(s));
  opaque(g);
  if (with_jacobian) {
    for (long i = 0; i < n; ++i) {
      opaque(pose);
      s = hybrid_ik(g, pose, q, &J, &passive);
      opaque(s);
      opaque(q);
      opaque(J);
      opaque(passive);
    }
  } else {
    for (long i = 0; i < n; ++i) {
      opaque(pose);
      s = hybrid_ik(g, pose, q);
      opaque(s);
      opaque(q);
    }
  }
  return 0;
}

template <class S> int hybrid_fk_loop(long n) {
  HybridGeometry<S> g = make_hybrid_seed000<S>();
  Vec6<S> q = Vec6<S>::Zero();
  hybrid_ik(g, hybrid_target<S>(), q);
  HybridPassive<S> guess = g.home;
  Pose<S> out;
  FkReport<S> r = hybrid_fk(g, q, guess, out);
  const FkAccuracy acc = fk_accuracy(out, hybrid_target<double>());
  std::printf("status=%s iterations=%d pos_err_mm=%.3e rot_err_rad=%.3e\n", to_string(r.status), r.iterations,
              acc.position_mm, acc.orientation_rad);
  opaque(g);
  for (long i = 0; i < n; ++i) {
    opaque(q);
    opaque(guess);
    r = hybrid_fk(g, q, guess, out);
    opaque(r);
    opaque(out);
  }
  return 0;
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
