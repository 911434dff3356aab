// Instruction-count harness of the compensation, for callgrind
// (host_tests/bench/icount.sh works on it unchanged):
//
//   kincal_core_compensation_icount <operation> <N>
//   kincal_core_compensation_icount --list
//
// Set-up (table, compensator, start state) is done for N = 0 too, so
// (Ir(N) − Ir(0)) / N is the instruction count of one compensated NC point.
// The cases are those of core_compensation_bench.cpp (compensation_cases.hpp).
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "compensation_cases.hpp"

namespace {

using namespace kincal;
using namespace kincal::bench;

template <class T> inline __attribute__((always_inline)) void opaque(T& value) {
  asm volatile("" : "+m"(value) : : "memory");
}

// `path`: compensation_cases.hpp's NC stream (0.1 mm a point) instead of
// its scattered points.
template <class Machine, class S = typename Machine::Scalar>
int loop(long n, const CalibrationTable<Machine>& table, bool temperature, bool path = false) {
  const Compensator<Machine> c(table, trust_table_bounds);
  Vec6<S> home = Vec6<S>::Zero();
  c.home_command(home);
  CompensatorState<S> s = c.start(home);
  const int count = path ? kPathPointCount : kPointCount;
  std::vector<Pose<S>> points(count);
  for (int k = 0; k < count; ++k)
    points[k] = path ? path_point<S>(Machine::family, k) : nc_point<S>(Machine::family, k);
  Vec6<S> q = Vec6<S>::Zero();
  for (long i = 0; i < n; ++i) {
    NcPoint<S> p;
    p.pose = points[i % count];
    p.temperature = S(31.5);
    p.has_temperature = temperature;
    opaque(p);
    CompensationStatus st = c.compensate(s, p, q);
    opaque(st);
    opaque(q);
  }
  std::printf("table=%s accepted=%u failed=%u\n", to_string(c.status()), unsigned(s.count(CompensationStatus::Ok)),
              unsigned(s.failures()));
  return c.status() == CompensationStatus::Ok && s.failures() == 0 ? 0 : 1;
}

struct Operation {
  const char* name;
  int (*run)(long);
};

const Operation kOperations[] = {
    {"compensate_hybrid_d", [](long n) { return loop(n, hybrid_full_model(false), false); }},
    {"compensate_hybrid_path_d", [](long n) { return loop(n, hybrid_full_model(false), false, true); }},
    {"compensate_hybrid_path_f",
     [](long n) { return loop(n, table_cast<float>(hybrid_full_model(false)), false, true); }},
    {"compensate_hybrid_offset_s_d", [](long n) { return loop(n, hybrid_full_model(false, false), false); }},
    {"compensate_hybrid_offset_s_path_d",
     [](long n) { return loop(n, hybrid_full_model(false, false), false, true); }},
    {"compensate_hybrid_effects_d", [](long n) { return loop(n, hybrid_full_model(true), true); }},
    {"compensate_hybrid_effects_path_d", [](long n) { return loop(n, hybrid_full_model(true), true, true); }},
    {"compensate_stewart_d", [](long n) { return loop(n, stewart_full_model(false), false); }},
    {"compensate_stewart_effects_d", [](long n) { return loop(n, stewart_full_model(true), true); }},
    {"compensate_hybrid_f", [](long n) { return loop(n, table_cast<float>(hybrid_full_model(false)), false); }},
    {"compensate_hybrid_effects_f", [](long n) { return loop(n, table_cast<float>(hybrid_full_model(true)), true); }},
    {"compensate_stewart_f", [](long n) { return loop(n, table_cast<float>(stewart_full_model(false)), false); }},
    {"compensate_stewart_effects_f",
     [](long n) { return loop(n, table_cast<float>(stewart_full_model(true)), true); }},
};

}  // namespace

int main(int argc, char** argv) {
  if (argc == 2 && std::strcmp(argv[1], "--list") == 0) {
    for (const Operation& op : kOperations) std::printf("%s\n", op.name);
    return 0;
  }
  if (argc != 3) {
    std::fprintf(stderr, "usage: kincal_core_compensation_icount <operation> <N>\n       kincal_core_compensation_icount --list\n");
    return 2;
  }
  const long n = std::strtol(argv[2], nullptr, 10);
  for (const Operation& op : kOperations)
    if (std::strcmp(argv[1], op.name) == 0) return op.run(n);
  std::fprintf(stderr, "unknown operation '%s' (--list)\n", argv[1]);
  return 2;
}
