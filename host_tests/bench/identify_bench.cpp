// Wall-clock benchmarks of the host identification (GUIDE bars: the hybrid
// coarse + fine pipeline on 2 × 49 nodes ≤ 100 ms; 10^4 Monte Carlo runs ≤ 1 s
// on two cores; one diagnosis of a ~100-node data set with all candidate
// effects ≤ 0.5 s). Results and the command: docs/benchmarks.md.
//
// The data are built once, before any timing, by our own simulator from the
// examples' pose lists and error files (the same machines the tests use).
// Counters report what the timed call produced so that a row that timed an
// early exit is visible: `kept` (fine-stage parameters), `eta_pct`, `accepted`
// (effects the diagnosis accepted), `rms_um` (held-out residual). Only
// pointers go through DoNotOptimize: Debian's Google Benchmark 1.7 passes a
// double through a general-purpose register constraint and returns garbage.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <string>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/diagnosis.hpp"
#include "kincal/identify/effect_calibration.hpp"
#include "kincal/identify/estimators.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/hybrid_calibration.hpp"
#include "kincal/identify/hybrid_error_model.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/plan.hpp"
#include "kincal/identify/robot.hpp"
#include "kincal/identify/simulate.hpp"
#include "kincal/identify/stewart_calibration.hpp"
#include "kincal/identify/target_calibration.hpp"

namespace {

namespace ki = kincal::identify;

const std::string kExamples = std::string(KINCAL_SOURCE_DIR) + "/examples";

ki::PoseTable simulated(const ki::Robot& nominal, const ki::Robot& actual, const ki::PoseTable& poses,
                        double noise_mm, double noise_rad, const ki::EffectValues& effects = {},
                        std::uint64_t seed = 11) {
  ki::SimulateOptions o;
  o.noise_mm = noise_mm;
  o.noise_rad = noise_rad;
  o.seed = seed;
  o.effects = effects;
  ki::SimulateReport report;
  return ki::simulate(nominal, actual, poses, o, report);
}

const ki::Robot& hybrid_nominal() {
  static const ki::Robot r = ki::builtin_robot("hybrid-seed000");
  return r;
}

// Seed 000's evaluation machine (docs/hybrid-calibration.md): encoder offsets
// ±0.3 mm / ±0.5 mrad, every structural error uniform in ±50 µm / ±100 µrad;
// measured on examples/hybrid-seed000/poses.csv (layers 1 and 3 of 7 × 7
// calibrate, layer 2 tests) with 5 µm gauge noise: the data set of
// docs/hybrid-calibration.md's η (machine seed 7, noise seed 107).
const ki::PoseTable& hybrid_data() {
  static const ki::PoseTable data = [] {
    ki::Robot m = hybrid_nominal();
    const ki::HybridErrorModel em(m.hybrid());
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    m.hybrid_description().source_errors = Eigen::VectorXd::Zero(em.size());
    for (int k = 0; k < em.size(); ++k) {
      const auto& p = em.parameters()[static_cast<std::size_t>(k)];
      m.hybrid_description().source_errors(k) = p.encoder() ? (u(rng) < 0 ? -1.0 : 1.0) * (p.angular() ? 0.5e-3 : 0.3)
                                                            : u(rng) * (p.angular() ? 100e-6 : 0.050);
    }
    return simulated(hybrid_nominal(), m, ki::read_pose_table(kExamples + "/hybrid-seed000/poses.csv"), 0.005, 0,
                     {}, 107);
  }();
  return data;
}

void BM_HybridCoarseFine2x49(benchmark::State& state) {
  const ki::PoseTable& data = hybrid_data();
  ki::HybridCalibrationOptions o;
  o.test_nodes = state.range(0) != 0;
  std::size_t kept = 0;
  for (auto _ : state) {
    const ki::HybridCalibration c = ki::calibrate_hybrid(hybrid_nominal(), data, o);
    kept = c.kept.size();
    benchmark::DoNotOptimize(c.chi_liu.data());
  }
  state.counters["kept"] = double(kept);
  state.counters["node_tests"] = double(o.test_nodes);
}

const ki::HybridCalibration& hybrid_calibration() {
  static const ki::HybridCalibration c = ki::calibrate_hybrid(hybrid_nominal(), hybrid_data());
  return c;
}

void BM_HybridMonteCarlo10k(benchmark::State& state) {
  const ki::HybridCalibration& c = hybrid_calibration();
  double eta = 0;
  for (auto _ : state) {
    const ki::HybridMonteCarlo mc = ki::hybrid_monte_carlo(c, 10000, 0.005, 4);
    benchmark::DoNotOptimize(mc.sd_liu.data());
    eta = mc.eta;
  }
  state.counters["eta_pct"] = eta;
}

// The pieces of a Monte Carlo study on the hybrid's fine design (882 gauge
// rows × the kept columns): the factorisation done once (Arg 0: Q implicit,
// as every single estimate; 1: U formed, as the Monte Carlo study), then one
// OLS or one Liu (d by Eq. (14)) fit per run on fresh data (64 noise draws
// reused cyclically, so the RNG is not timed), on the study's factorisation
// (Arg 0: OLS, 1: Liu) or with Q implicit (2: OLS).
ki::PreparedDesign::Options with_u(bool explicit_u) {
  ki::PreparedDesign::Options o;
  o.explicit_u = explicit_u;
  return o;
}

void BM_PrepareHybridFineDesign(benchmark::State& state) {
  const ki::LinearProblem& p = hybrid_calibration().fine_problem;
  for (auto _ : state) {
    const ki::PreparedDesign design(p, with_u(state.range(0) != 0));
    benchmark::DoNotOptimize(&design);
  }
  state.counters["rows"] = double(p.H.rows());
  state.counters["cols"] = double(p.H.cols());
}

void BM_HybridFineRun(benchmark::State& state) {
  const ki::LinearProblem& p = hybrid_calibration().fine_problem;
  const ki::PreparedDesign design(p, with_u(state.range(0) != 2));
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.0, 0.005);
  Eigen::MatrixXd Y(p.H.rows(), 64);
  for (Eigen::Index j = 0; j < Y.cols(); ++j)
    for (Eigen::Index i = 0; i < Y.rows(); ++i) Y(i, j) = p.y(i) + g(rng);
  ki::FitWorkspace ws;
  Eigen::VectorXd x(p.H.cols());
  Eigen::Index run = 0;
  const bool liu = state.range(0) == 1;
  for (auto _ : state) {
    const Eigen::VectorXd& y = Y.col(run++ % Y.cols());
    if (liu)
      design.liu(y, x, ws);
    else
      design.ols(y, x, ws);
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["liu"] = double(liu);
}

// seed 001's iterative calibration on the 10 poses of its Table 4 (examples/seed001/poses.csv, 1 µm noise).
void BM_StewartCalibration(benchmark::State& state) {
  static const ki::Robot nominal = ki::builtin_robot("stewart-seed001");
  static const ki::PoseTable data = simulated(
      nominal, ki::apply_parameters(nominal, ki::read_parameters(kExamples + "/seed001/errors.csv", nominal)),
      ki::read_pose_table(kExamples + "/seed001/poses.csv"), 0.001, 5e-6);
  std::size_t iterations = 0;
  for (auto _ : state) {
    const ki::StewartCalibration c = ki::calibrate_stewart(nominal, data);
    iterations = c.history.size();
    benchmark::DoNotOptimize(c.history.data());
  }
  state.counters["iterations"] = double(iterations);
}

// Random poses over seed 001's working box (x, y in ±35 mm, z 180–220 mm,
// tilts ±5°, yaw ±8°), all calibration: a design of any size, for the
// identification's scaling (docs/benchmarks.md, issue #13).
ki::PoseTable random_stewart_poses(int count, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  constexpr double kDeg = 3.14159265358979323846 / 180;
  ki::PoseTable t;
  t.file = "random-poses";
  t.has_role = true;
  for (int i = 0; i < count; ++i) {
    ki::PoseRow r;
    r.id = std::to_string(i + 1);
    r.line = std::size_t(i + 2);
    r.role = ki::Role::Cal;
    r.commanded << 35 * u(rng), 35 * u(rng), 200 + 20 * u(rng), 5 * kDeg * u(rng), 5 * kDeg * u(rng), 8 * kDeg * u(rng);
    t.rows.push_back(r);
  }
  return t;
}

// What `kincal identify` does on a 6-UPS data set: seed 001's iterative
// calibration, then the sequential outlier screen (and a refit when it sets a
// node aside). Arg: nodes. Seed 001's Table 3 errors, 1 µm / 5 µrad noise.
void BM_IdentifyStewart(benchmark::State& state) {
  static const ki::Robot nominal = ki::builtin_robot("stewart-seed001");
  const ki::PoseTable data =
      simulated(nominal, ki::apply_parameters(nominal, ki::read_parameters(kExamples + "/seed001/errors.csv", nominal)),
                random_stewart_poses(int(state.range(0)), 17), 0.001, 5e-6, {}, 23);
  std::size_t iterations = 0, removed = 0;
  for (auto _ : state) {
    const ki::StewartCalibration c = ki::calibrate_stewart(nominal, data);
    const ki::StewartOutlierSearch s = ki::stewart_outlier_search(nominal, data, c, {});
    iterations = c.history.size();
    removed = s.removed.size();
    benchmark::DoNotOptimize(s.rest.history.data());
  }
  state.counters["nodes"] = double(data.rows.size());
  state.counters["iterations"] = double(iterations);
  state.counters["removed"] = double(removed);
}

// The 6-RUS (issue #33's bars: identify of ~100 nodes ≤ 10 ms, diagnose ≤
// 50 ms): rus6-ref with examples/rus6/errors.csv at the main job's 100 poses,
// full poses with 2 um / 5 urad. Identify: the target fit (its own reading of
// full poses) and its deleted-node screen, as `kincal identify` runs them.
// Diagnose: every candidate, on the same machine with gearbox backlash on
// motors 1 and 4 (the main job's data).
ki::PoseTable rus6_data(bool backlash) {
  const ki::Robot nominal = ki::builtin_robot("rus6-ref");
  const ki::Robot actual = ki::apply_parameters(nominal, ki::read_parameters(kExamples + "/rus6/errors.csv", nominal));
  ki::EffectValues effects;
  if (backlash) {
    effects.set(nominal, "backlash", "b1", 1e-4);
    effects.set(nominal, "backlash", "b4", -1.5e-4);
  }
  return simulated(nominal, actual, ki::read_pose_table(kExamples + "/rus6/diagnosis_poses.csv"), 0.002, 5e-6, effects,
                   2026);
}
void BM_IdentifyRus6(benchmark::State& state) {
  static const ki::Robot nominal = ki::builtin_robot("rus6-ref");
  const ki::PoseTable data = rus6_data(false);
  std::size_t evaluations = 0;
  for (auto _ : state) {
    const ki::TargetCalibration c = ki::calibrate_targets(nominal, data);
    const ki::TargetOutlierSearch s = ki::target_outlier_search(nominal, data, c);
    evaluations = c.history.size();
    benchmark::DoNotOptimize(s.rest.errors.data());
  }
  state.counters["nodes"] = double(data.rows.size());
  state.counters["evaluations"] = double(evaluations);
}
void BM_DiagnoseRus6(benchmark::State& state) {
  static const ki::Robot nominal = ki::builtin_robot("rus6-ref");
  const ki::PoseTable data = rus6_data(true);
  ki::DiagnoseOptions o;
  o.noise_um = 2;
  std::size_t accepted = 0;
  for (auto _ : state) {
    const ki::Diagnosis d = ki::diagnose(nominal, data, o);
    benchmark::DoNotOptimize(d.nodes.data());
    accepted = d.accepted.size();
  }
  state.counters["nodes"] = double(data.rows.size());
  state.counters["accepted"] = double(accepted);
}

// One diagnosis, every registered candidate effect, on the example's
// diagnosis poses measured on a machine with a hidden thermal effect (the
// main job's data): 100 poses on the 6-UPS, 3 layers on the hybrid.
void diagnose_case(benchmark::State& state, const std::string& robot_name, const std::string& dir,
                   double noise_mm) {
  const ki::Robot nominal = ki::builtin_robot(robot_name);
  const ki::Robot actual = ki::apply_parameters(nominal, ki::read_parameters(dir + "/errors.csv", nominal));
  ki::EffectValues thermal;
  thermal.set(nominal, "thermal", "c", 1.2e-5);
  const ki::PoseTable data = simulated(nominal, actual, ki::read_pose_table(dir + "/diagnosis_poses.csv"), noise_mm,
                                       robot_name == "stewart-seed001" ? 5e-6 : 0.0, thermal);
  ki::DiagnoseOptions o;
  o.noise_um = 1e3 * noise_mm;
  std::size_t accepted = 0;
  double rms = 0;
  for (auto _ : state) {
    const ki::Diagnosis d = ki::diagnose(nominal, data, o);
    benchmark::DoNotOptimize(d.nodes.data());
    accepted = d.accepted.size();
    rms = d.final_rms.test;
  }
  state.counters["nodes"] = double(data.rows.size());
  state.counters["accepted"] = double(accepted);
  state.counters["rms_um"] = rms;
}

void BM_DiagnoseStewart(benchmark::State& state) {
  diagnose_case(state, "stewart-seed001", kExamples + "/seed001", 0.001);
}
void BM_DiagnoseHybrid(benchmark::State& state) {
  diagnose_case(state, "hybrid-seed000", kExamples + "/hybrid-seed000", 0.005);
}

// Effects written as formulas against the built-in ones (issue #32's bar:
// diagnose with three formula effects at most 1.5x the time of three
// built-in ones). The same data as BM_DiagnoseStewart (seed 001's errors, a
// hidden thermal expansion, 100 poses); the robot is seed 001 with three
// formula effects of the built-ins' sizes: a scale per leg (6 numbers), a
// backlash per leg (6) and one leg expansion with temperature (1). Arg 0:
// candidates scale, backlash, thermal (built-in); Arg 1: the three formulas.
void BM_DiagnoseThreeEffects(benchmark::State& state) {
  const bool formulas = state.range(0) == 1;
  const ki::Robot seed001 = ki::builtin_robot("stewart-seed001");
  std::string text = ki::robot_to_json(seed001);
  text.insert(text.rfind('}'), R"json(, "effects": [
    {"name": "leg_scale", "kind": "joint", "per_joint": ["s"], "formula": "s * q"},
    {"name": "leg_backlash", "kind": "joint", "per_joint": ["b"], "formula": "b * dir / 2"},
    {"name": "leg_expansion", "kind": "joint", "shared": ["c"], "formula": "c * q * (temp - 20)"}])json");
  const ki::Robot nominal = ki::parse_robot(text, "bench.json");
  const std::string dir = kExamples + "/seed001";
  const ki::Robot actual = ki::apply_parameters(nominal, ki::read_parameters(dir + "/errors.csv", nominal));
  ki::EffectValues thermal;
  thermal.set(nominal, "thermal", "c", 1.2e-5);
  const ki::PoseTable data =
      simulated(nominal, actual, ki::read_pose_table(dir + "/diagnosis_poses.csv"), 0.001, 5e-6, thermal);
  ki::DiagnoseOptions o;
  o.noise_um = 1.0;
  o.candidates = formulas ? std::vector<std::string>{"leg_scale", "leg_backlash", "leg_expansion"}
                          : std::vector<std::string>{"scale", "backlash", "thermal"};
  std::size_t accepted = 0;
  for (auto _ : state) {
    const ki::Diagnosis d = ki::diagnose(nominal, data, o);
    benchmark::DoNotOptimize(d.nodes.data());
    accepted = d.accepted.size();
  }
  state.SetLabel(formulas ? "three formula effects" : "three built-in effects");
  state.counters["accepted"] = double(accepted);
}

// `identify --effects scale` on the hybrid's diagnosis poses measured on a
// machine with the wrist scale of the hidden-effect test (s4 = 2e-3,
// s6 = -2e-3): alternation + backward elimination of the parameters the data
// cannot tell from the base (four held). Arg 0: OLS base, 1: ridge base.
void BM_IdentifyHybridWithScale(benchmark::State& state) {
  const std::string dir = kExamples + "/hybrid-seed000";
  const ki::Robot nominal = ki::builtin_robot("hybrid-seed000");
  const ki::Robot actual = ki::apply_parameters(nominal, ki::read_parameters(dir + "/errors.csv", nominal));
  ki::EffectValues scale;
  scale.set(nominal, "scale", "s4", 2e-3);
  scale.set(nominal, "scale", "s6", -2e-3);
  const ki::PoseTable data =
      simulated(nominal, actual, ki::read_pose_table(dir + "/diagnosis_poses.csv"), 0.005, 0.0, scale);
  ki::EffectCalibrationOptions o;
  o.estimator = state.range(0) == 1 ? ki::EstimatorKind::Ridge : ki::EstimatorKind::Ols;
  ki::EffectCalibrationReport report;
  for (auto _ : state) {
    const ki::CalibrationModel m = ki::calibrate_with_effects(nominal, data, {"scale"}, o, &report);
    benchmark::DoNotOptimize(m.parameters.data());
  }
  state.counters["held"] = double(report.held.size());
  state.counters["passes"] = double(report.passes);
  state.counters["rms_um"] = report.rms_test_um_final;
}

// `kincal plan`'s work (GUIDE bar: 30 poses from 5 000 candidates ≤ 2 s):
// sampling the workspace, the design rows of every candidate, greedy +
// exchange, the grid and random comparisons. Arg: 0 the 6-UPS (30 poses),
// 1 the hybrid (49 poses).
void BM_Plan(benchmark::State& state) {
  const bool hybrid = state.range(0) == 1;
  const ki::Robot robot = ki::builtin_robot(hybrid ? "hybrid-seed000" : "stewart-seed001");
  ki::PlanOptions o;
  o.count = hybrid ? 49 : 30;
  o.sample_count = 5000;
  ki::MeasurementPlan plan;
  for (auto _ : state) {
    plan = ki::plan_measurements(robot, o);
    benchmark::DoNotOptimize(plan.poses.rows.data());
  }
  state.counters["candidates"] = double(plan.usable_candidates);
  state.counters["passes"] = double(plan.exchange_passes);
  state.counters["planned_um"] = plan.planned.predicted_test_um;
  state.counters["grid_um"] = plan.grid_assessment.predicted_test_um;
}

BENCHMARK(BM_HybridCoarseFine2x49)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_HybridMonteCarlo10k)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PrepareHybridFineDesign)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_HybridFineRun)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_StewartCalibration)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_IdentifyStewart)->Arg(108)->Arg(1000)->Arg(10000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_DiagnoseStewart)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_IdentifyRus6)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_DiagnoseRus6)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_DiagnoseHybrid)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_DiagnoseThreeEffects)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_IdentifyHybridWithScale)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Plan)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
