// Wall-clock benchmarks of the controller's compensation (core/compensation.hpp),
// one NC point per iteration, double and float (GUIDE bar: compensating one NC
// point with a full identified model ≤ 1 µs; results in docs/benchmarks.md).
// The cases are in compensation_cases.hpp. As in core_kinematics_bench.cpp the
// inputs and outputs go through benchmark::DoNotOptimize every iteration, and
// nothing is asserted inside the timed loop: the `ok` counter says whether every
// timed point was accepted.
#include <benchmark/benchmark.h>

#include <vector>

#include "compensation_cases.hpp"

namespace {

using namespace kincal;
using namespace kincal::bench;

// `path`: the points of an NC stream (path_point), each 0.1 mm from the
// last, instead of nc_point's scattered ones (5–10 mm apart).
template <class Machine, class S = typename Machine::Scalar>
void run(benchmark::State& state, const CalibrationTable<Machine>& table, bool temperature, bool path = false) {
  const Compensator<Machine> c(table, trust_table_bounds);
  Vec6<S> home = Vec6<S>::Zero();
  c.home_command(home);
  CompensatorState<S> s = c.start(home);
  const int count = path ? kPathPointCount : kPointCount;
  std::vector<Pose<S>> points(count);
  for (int k = 0; k < count; ++k)
    points[k] = path ? path_point<S>(Machine::family, k) : nc_point<S>(Machine::family, k);
  Vec6<S> q = Vec6<S>::Zero();
  int k = 0;
  for (auto _ : state) {
    NcPoint<S> p;
    p.pose = points[k];
    p.temperature = S(31.5);
    p.has_temperature = temperature;
    benchmark::DoNotOptimize(p);
    const CompensationStatus st = c.compensate(s, p, q);
    benchmark::DoNotOptimize(st);
    benchmark::DoNotOptimize(q);
    k = (k + 1) % count;
  }
  state.counters["ok"] = c.status() == CompensationStatus::Ok && s.failures() == 0 && s.count(CompensationStatus::Ok) > 0;
}

template <class S> void BM_CompensateHybrid(benchmark::State& state) {
  run(state, table_cast<S>(hybrid_full_model(false)), false);
}
template <class S> void BM_CompensateHybridPath(benchmark::State& state) {
  run(state, table_cast<S>(hybrid_full_model(false)), false, true);
}
template <class S> void BM_CompensateHybridOffsetS(benchmark::State& state) {
  run(state, table_cast<S>(hybrid_full_model(false, false)), false);
}
template <class S> void BM_CompensateHybridOffsetSPath(benchmark::State& state) {
  run(state, table_cast<S>(hybrid_full_model(false, false)), false, true);
}
template <class S> void BM_CompensateHybridEffects(benchmark::State& state) {
  run(state, table_cast<S>(hybrid_full_model(true)), true);
}
template <class S> void BM_CompensateHybridEffectsPath(benchmark::State& state) {
  run(state, table_cast<S>(hybrid_full_model(true)), true, true);
}
template <class S> void BM_CompensateStewart(benchmark::State& state) {
  run(state, table_cast<S>(stewart_full_model(false)), false);
}
template <class S> void BM_CompensateStewartEffects(benchmark::State& state) {
  run(state, table_cast<S>(stewart_full_model(true)), true);
}

// The hybrid's error twist B·Δχ̂ alone (hybrid_error_twist.hpp), at a fixed
// configuration, and the table check done once at start-up.
template <class S> void BM_HybridErrorTwist(benchmark::State& state) {
  const HybridCalibrationTable<S> t = table_cast<S>(hybrid_full_model(false));
  const HybridGeometry<S> g = to_core(t.machine.nominal);
  HybridFrames<S> f;
  Vec3<S> angles;
  hybrid_frames_at_pose(g, hybrid_target<S>(), f, angles);
  Twist<S> out = Twist<S>::Zero();
  Status st = Status::Ok;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f);
    st = hybrid_error_twist(g, t.machine.up_split, f, t.machine.source_errors, out);
    benchmark::DoNotOptimize(st);
    benchmark::DoNotOptimize(out);
  }
  state.counters["ok"] = st == Status::Ok;
}
template <class S> void BM_ValidateHybridTable(benchmark::State& state) {
  const HybridCalibrationTable<S> t = table_cast<S>(hybrid_full_model(true));
  CompensationStatus st = CompensationStatus::Ok;
  for (auto _ : state) {
    benchmark::DoNotOptimize(t);
    st = validate_table(t);
    benchmark::DoNotOptimize(st);
  }
  state.counters["ok"] = st == CompensationStatus::Ok;
}

BENCHMARK_TEMPLATE(BM_CompensateHybrid, double);
BENCHMARK_TEMPLATE(BM_CompensateHybrid, float);
BENCHMARK_TEMPLATE(BM_CompensateHybridPath, double);
BENCHMARK_TEMPLATE(BM_CompensateHybridPath, float);
BENCHMARK_TEMPLATE(BM_CompensateHybridOffsetS, double);
BENCHMARK_TEMPLATE(BM_CompensateHybridOffsetSPath, double);
BENCHMARK_TEMPLATE(BM_CompensateHybridEffects, double);
BENCHMARK_TEMPLATE(BM_CompensateHybridEffects, float);
BENCHMARK_TEMPLATE(BM_CompensateHybridEffectsPath, double);
BENCHMARK_TEMPLATE(BM_CompensateHybridEffectsPath, float);
BENCHMARK_TEMPLATE(BM_CompensateStewart, double);
BENCHMARK_TEMPLATE(BM_CompensateStewart, float);
BENCHMARK_TEMPLATE(BM_CompensateStewartEffects, double);
BENCHMARK_TEMPLATE(BM_CompensateStewartEffects, float);
BENCHMARK_TEMPLATE(BM_HybridErrorTwist, double);
BENCHMARK_TEMPLATE(BM_HybridErrorTwist, float);
BENCHMARK_TEMPLATE(BM_ValidateHybridTable, double);
BENCHMARK_TEMPLATE(BM_ValidateHybridTable, float);

}  // namespace

BENCHMARK_MAIN();
