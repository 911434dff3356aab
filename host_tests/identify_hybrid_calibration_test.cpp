// Seed 000's calibration pipeline for the hybrid robot (identify/hybrid_calibration.hpp):
// coarse encoder offsets by iterated OLS (Eq. (15)), fine Liu / OLS on the
// reconstructed Jacobian, compensation by Eq. (16), a Table-5-like evaluation
// on examples/hybrid-seed000 (layers 1 and 3 calibrate, layer 2 tests), the
// Monte Carlo index η (Eqs. (17)–(18)) and the MODEL.json round trip.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/hybrid_calibration.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/robot.hpp"
#include "kincal/identify/simulate.hpp"

namespace {

using kincal::HybridGeometry;
using kincal::Pose;
using kincal::Status;
using kincal::Vec6;
using namespace kincal::identify;

const Robot& nominal() {
  static const Robot r = builtin_robot("hybrid-seed000");
  return r;
}

const PoseTable& poses() {
  static const PoseTable t = read_pose_table(std::string(KINCAL_SOURCE_DIR) + "/examples/hybrid-seed000/poses.csv");
  return t;
}

// The erroneous machine of the evaluation (docs/hybrid-calibration.md):
// encoder offsets ±0.3 mm (UPS) / ±0.5 mrad (wrist) with random signs,
// structural errors uniform in ±50 µm / ±100 µrad (every one of seed 000's
// 144; the tool frame's six, which seed 000's gauge on its constant-
// orientation layers cannot separate from Δη_6,4, stay 0).
Robot machine(std::uint64_t seed) {
  Robot m = nominal();
  const HybridErrorModel em(m.hybrid());
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  m.hybrid_description().source_errors = Eigen::VectorXd::Zero(em.size());
  for (int k = 0; k < HybridErrorModel::kSeedParameterCount; ++k) {
    const auto& p = em.parameters()[static_cast<std::size_t>(k)];
    if (p.encoder())
      m.hybrid_description().source_errors(k) = (u(rng) < 0 ? -1.0 : 1.0) * (p.angular() ? 0.5e-3 : 0.3);
    else
      m.hybrid_description().source_errors(k) = u(rng) * (p.angular() ? 100e-6 : 0.050);
  }
  return m;
}

PoseTable measure(const Robot& m, double noise_mm, std::uint64_t seed) {
  SimulateOptions o;
  o.noise_mm = noise_mm;
  o.seed = seed;
  SimulateReport rep;
  PoseTable data = simulate(nominal(), m, poses(), o, rep);
  EXPECT_EQ(rep.failed, 0u);
  return data;
}

struct Row {
  const char* label;
  std::vector<HybridLayerError> e;
};

void print_table(const char* title, const std::vector<Row>& rows) {
  std::printf(
      "%s\n| case | layer | role | max pos (mm) | mean pos (mm) | max ori (deg) | mean ori (deg) |\n"
      "|---|---|---|---|---|---|---|\n",
      title);
  for (const Row& r : rows)
    for (const auto& l : r.e)
      std::printf("| %s | %lld | %s | %.4f | %.4f | %.4f | %.4f |\n", r.label, l.layer, l.layer == 2 ? "test" : "cal",
                  l.max_position, l.mean_position, l.max_orientation, l.mean_orientation);
}

const HybridLayerError& layer(const std::vector<HybridLayerError>& e, long long id) {
  for (const auto& l : e)
    if (l.layer == id) return l;
  ADD_FAILURE() << "no layer " << id;
  return e.front();
}

struct Evaluation {
  HybridCalibration cal;
  std::vector<HybridLayerError> none, coarse, ols, liu;
};

Evaluation evaluate(std::uint64_t machine_seed, double noise_mm) {
  const Robot m = machine(machine_seed);
  const PoseTable data = measure(m, noise_mm, machine_seed + 100);
  Evaluation ev;
  ev.cal = calibrate_hybrid(nominal(), data);
  const HybridGeometry<double>& g = nominal().hybrid();
  ev.none = evaluate_hybrid(m, g, poses(), nullptr);
  const HybridCompensation c0 = ev.cal.compensation(std::nullopt);  // the coarse stage alone
  const HybridCompensation co = ev.cal.compensation(EstimatorKind::Ols);
  const HybridCompensation cl = ev.cal.compensation(EstimatorKind::Liu);
  ev.coarse = evaluate_hybrid(m, g, poses(), &c0);
  ev.ols = evaluate_hybrid(m, g, poses(), &co);
  ev.liu = evaluate_hybrid(m, g, poses(), &cl);
  for (const auto* v : {&ev.none, &ev.coarse, &ev.ols, &ev.liu}) {
    EXPECT_EQ(v->size(), 3u);
    for (const auto& l : *v) {
      EXPECT_EQ(l.failed, 0u);
      EXPECT_EQ(l.nodes, 49u);
      EXPECT_TRUE(std::isfinite(l.max_position) && std::isfinite(l.max_orientation));
    }
  }
  return ev;
}

void print_calibration(const HybridCalibration& cal) {
  std::printf("coarse: %zu iteration(s), converged %d; xi =", cal.coarse_history.size(), cal.coarse_converged ? 1 : 0);
  for (int k = 0; k < 6; ++k) std::printf(" %.5g", cal.coarse_xi(k));
  std::printf("\n");
  for (std::size_t k = 0; k < cal.coarse_history.size(); ++k)
    std::printf("  round %zu: rms residual %.4g mm, |dxi| %.3g, relative change %.3g\n", k + 1,
                cal.coarse_history[k].rms_residual, cal.coarse_history[k].delta_xi.norm(),
                cal.coarse_history[k].relative_change);
  std::printf(
      "fine: %zu nodes, kept %zu (rank %lld), dropped %zu, condition number %.3g, Liu d = %.4g "
      "(Eq. 14: %.4g), sigma2 = %.3g mm^2\n",
      cal.cal_nodes, cal.kept.size(), static_cast<long long>(cal.rank), cal.dropped.size(), cal.condition_number,
      cal.liu.liu_d, cal.liu.liu_d_unclamped, cal.liu.sigma2);
}

TEST(identifyHybridCalibration, Table5LikeCompensationWithGaugeNoise) {
  const Evaluation ev = evaluate(7, 0.005);
  print_calibration(ev.cal);
  print_table("Pose errors (gauge noise 5 um), machine seed 7:",
              {{"uncompensated", ev.none}, {"coarse", ev.coarse}, {"coarse+OLS", ev.ols}, {"coarse+Liu", ev.liu}});
  EXPECT_TRUE(ev.cal.coarse_converged);
  EXPECT_TRUE(ev.cal.fine_done);
  EXPECT_EQ(ev.cal.cal_nodes, 98u);
  for (long long id : {1LL, 2LL, 3LL}) {
    // coarse removes most of the encoder-dominated error
    EXPECT_LT(layer(ev.coarse, id).max_position, 0.5 * layer(ev.none, id).max_position) << id;
    EXPECT_LT(layer(ev.coarse, id).mean_position, 0.5 * layer(ev.none, id).mean_position) << id;
    // fine improves on coarse
    EXPECT_LT(layer(ev.liu, id).mean_position, layer(ev.coarse, id).mean_position) << id;
    EXPECT_LT(layer(ev.liu, id).mean_orientation, layer(ev.coarse, id).mean_orientation) << id;
  }
  EXPECT_LT(layer(ev.liu, 2).max_position, layer(ev.coarse, 2).max_position);
}

TEST(identifyHybridCalibration, NoiseFreeFineCalibrationCompensatesToMicrometres) {
  const Evaluation ev = evaluate(11, 0.0);
  print_calibration(ev.cal);
  print_table("Pose errors (no noise), machine seed 11:",
              {{"uncompensated", ev.none}, {"coarse", ev.coarse}, {"coarse+OLS", ev.ols}, {"coarse+Liu", ev.liu}});
  for (long long id : {1LL, 2LL, 3LL}) {
    EXPECT_LT(layer(ev.liu, id).max_position, 0.005) << id;
    EXPECT_LT(layer(ev.ols, id).max_position, 0.005) << id;
    EXPECT_LT(layer(ev.liu, id).max_orientation, 0.005e-3 * 180 / 3.14159265358979) << id;  // 5 µrad
  }
}

TEST(identifyHybridCalibration, MonteCarloRobustnessIndexEta) {
  const Robot m = machine(7);
  const HybridCalibration cal = calibrate_hybrid(nominal(), measure(m, 0.005, 107));
  const HybridMonteCarlo mc = hybrid_monte_carlo(cal, 1000, 0.005, 3);
  std::printf(
      "Monte Carlo N = %d, sigma = %.3g mm, %lld parameters: sigma(OLS) = %.4g, sigma(Liu) = %.4g, "
      "eta = %.1f %% (seed 000: 63.9 %%), mean d = %.4g, %.1f ms\n",
      mc.runs, mc.sigma_mm, static_cast<long long>(cal.kept.size()), mc.sigma_ols, mc.sigma_liu, mc.eta, mc.mean_d,
      mc.seconds * 1e3);
  EXPECT_TRUE(std::isfinite(mc.eta));
  EXPECT_GT(mc.eta, 0.0);
  EXPECT_LT(mc.eta, 100.0);
  // The 10^4-run timing (GUIDE bar 1 s) is a benchmark: kincal_identify_bench.
}

TEST(identifyHybridCalibration, ModelRoundTripCompensatesIdentically) {
  const HybridCalibration cal = calibrate_hybrid(nominal(), measure(machine(7), 0.005, 107));
  const CalibrationModel model = hybrid_model(nominal(), cal, EstimatorKind::Liu, "data.csv");
  EXPECT_EQ(model.estimator, "liu");
  EXPECT_EQ(model.parameters.size(), 6 + (cal.kept.size() - 6) + cal.dropped.size());
  const CalibrationModel back = parse_model(model_to_json(model), "MODEL.json");
  const HybridCompensation from_model = hybrid_compensation_from_model(back);
  const HybridCompensation direct = cal.compensation(EstimatorKind::Liu);
  for (const PoseRow& row : poses().rows) {
    const Pose<double> p = Pose<double>::from_xyz_rpy(row.commanded);
    Vec6<double> q1, q2;
    ASSERT_EQ(compensate_hybrid(direct, p, q1), Status::Ok);
    ASSERT_EQ(compensate_hybrid(from_model, p, q2), Status::Ok);
    EXPECT_LT((q1 - q2).cwiseAbs().maxCoeff(), 1e-9) << row.id;
  }
}

TEST(identifyHybridCalibration, CompensationInvertsTheModelledMachine) {
  // A machine made exactly of the compensation's beliefs: commanding the
  // compensated joints lands on the requested pose to first order.
  const HybridCalibration cal = calibrate_hybrid(nominal(), measure(machine(7), 0.0, 107));
  const HybridCompensation c = cal.compensation(EstimatorKind::Liu);
  Robot believed = nominal();
  believed.hybrid_description().source_errors = c.structural;
  believed.hybrid_description().source_errors.head<6>() = c.encoder_offsets;
  const auto e = evaluate_hybrid(believed, nominal().hybrid(), poses(), &c);
  for (const auto& l : e) {
    EXPECT_LT(l.max_position, 1e-3) << l.layer;
    EXPECT_EQ(l.failed, 0u);
  }
}

TEST(identifyHybridCalibration, RejectsBadInput) {
  PoseTable empty = poses();
  empty.rows.clear();
  EXPECT_THROW(calibrate_hybrid(nominal(), empty), InputError);
  EXPECT_THROW(calibrate_hybrid(nominal(), poses()), InputError);  // no gauge targets
  EXPECT_THROW(calibrate_hybrid(builtin_robot("stewart-seed001"), poses()), InputError);
  CalibrationModel bad;
  bad.nominal = nominal();
  bad.parameters.push_back({"no_such_parameter", 1.0, 0.0, true});
  EXPECT_THROW(hybrid_compensation_from_model(bad), InputError);
}

}  // namespace

namespace {
// docs/hybrid-calibration.md "The reconstruction tolerance matters more than
// the estimator": the sweep that table quotes (printed), and what the text
// says of it, asserted. Gauge noise 5 µm, machine seed 7.
TEST(identifyHybridCalibration, SweepSelectionToleranceAndScaling) {
  const Robot m = machine(7);
  const PoseTable data = measure(m, 0.005, 107);
  struct Sweep {
    double tolerance;
    bool scaled;
    std::size_t kept = 0;
    double cond = 0, ols_mean = 0, liu_mean = 0, max_chi_ols = 0;
  };
  std::vector<Sweep> rows = {{1e-8, false}, {1e-4, false}, {1e-4, true}, {1e-3, false}, {1e-2, false}};
  std::printf(
      "| tolerance | scaled | kept | cond | d | test max/mean OLS (mm) | test max/mean Liu (mm) | max|chi| OLS | eta "
      "%% |\n");
  for (Sweep& r : rows) {
    HybridCalibrationOptions o;
    o.selection_tolerance = r.tolerance;
    o.scale_columns = r.scaled;
    const HybridCalibration cal = calibrate_hybrid(nominal(), data, o);
    const HybridCompensation co = cal.compensation(EstimatorKind::Ols);
    const HybridCompensation cl = cal.compensation(EstimatorKind::Liu);
    const auto eo = evaluate_hybrid(m, nominal().hybrid(), poses(), &co);
    const auto el = evaluate_hybrid(m, nominal().hybrid(), poses(), &cl);
    const HybridMonteCarlo mc = hybrid_monte_carlo(cal, 300, 0.005, 5);
    r.kept = cal.kept.size();
    r.cond = cal.condition_number;
    r.ols_mean = layer(eo, 2).mean_position;
    r.liu_mean = layer(el, 2).mean_position;
    r.max_chi_ols = cal.chi_ols.cwiseAbs().maxCoeff();
    std::printf("| %.0e | %d | %zu | %.3g | %.3g | %.4f / %.4f | %.4f / %.4f | %.3g | %.1f |\n", r.tolerance,
                r.scaled ? 1 : 0, r.kept, r.cond, cal.liu.liu_d, layer(eo, 2).max_position, r.ols_mean,
                layer(el, 2).max_position, r.liu_mean, r.max_chi_ols, mc.eta);
  }
  const Sweep &rounding = rows[0], &by_default = rows[1], &scaled = rows[2], &wide = rows[3], &widest = rows[4];
  // A larger tolerance keeps fewer columns, and the design is better conditioned.
  EXPECT_GT(rounding.kept, by_default.kept);
  EXPECT_GT(by_default.kept, wide.kept);
  EXPECT_GT(wide.kept, widest.kept);
  EXPECT_GT(rounding.cond, 10 * by_default.cond);
  EXPECT_GT(by_default.cond, 10 * widest.cond);
  // At a rounding-level tolerance the OLS estimates reach hundreds of mm / rad
  // (noise along the near-dependent directions) and its compensation is far
  // worse than at the default.
  EXPECT_GT(rounding.max_chi_ols, 50.0);
  EXPECT_LT(by_default.max_chi_ols, 10.0);
  EXPECT_GT(rounding.ols_mean, 10 * by_default.ols_mean);
  // At the default OLS and Liu compensate alike with the exact model (issue
  // #31: first-order, Liu won 4.9 against 9.0 µm — its shrinkage hid the
  // linearisation's error at OLS's larger values); at 1e-2 H is well enough
  // conditioned that OLS is at least as good (Liu's bias costs).
  EXPECT_NEAR(by_default.liu_mean, by_default.ols_mean, 0.2 * by_default.ols_mean);
  EXPECT_LE(widest.ols_mean, widest.liu_mean);
  // Scaling the columns cannot change the OLS fit, only Liu's shrinkage.
  EXPECT_EQ(scaled.kept, by_default.kept);
  EXPECT_NEAR(scaled.ols_mean, by_default.ols_mean, 1e-9);
}
}  // namespace

namespace {

HybridCalibrationOptions fine_with(EstimatorKind e) {
  HybridCalibrationOptions o;
  o.estimator = e;
  return o;
}

TEST(identifyHybridCalibration, EachFineEstimatorCompensatesTheMachine) {
  // Issue #3: OLS, Liu, ridge (k by GCV) and PCR (components by GCV) as the
  // fine estimator, all from one SVD. Noise-free (machine seed 11) each
  // compensates every layer, the test layer included, to 0.5 µm; with 5 µm
  // gauge noise (machine seed 7, the Table 5 case) the stated tolerance for
  // ridge and PCR is 5 µm maximum position error in the test layer — both
  // shrink the noise in the ill-conditioned directions more than Liu, whose
  // shrinkage is bounded by d (docs/hybrid-calibration.md).
  const EstimatorKind all[] = {EstimatorKind::Ols, EstimatorKind::Liu, EstimatorKind::Ridge, EstimatorKind::Pcr};
  {
    const Robot m = machine(11);
    const PoseTable data = measure(m, 0.0, 111);
    const HybridCalibration cal = calibrate_hybrid(nominal(), data);
    for (EstimatorKind e : all) {
      const HybridCompensation c = cal.compensation(e);
      for (const auto& l : evaluate_hybrid(m, nominal().hybrid(), poses(), &c))
        EXPECT_LT(l.max_position, 0.0005) << to_string(e) << " layer " << l.layer;
    }
    // GCV on data without noise (only the linearisation error is left): next
    // to no shrinkage, every component.
    EXPECT_LT(cal.ridge.ridge_k, 1e-6);
    EXPECT_EQ(cal.pcr.pcr_components, cal.rank);
  }
  const Robot m = machine(7);
  const PoseTable data = measure(m, 0.005, 107);
  std::map<std::string, HybridLayerError> test_layer;
  for (EstimatorKind e : all) {
    const HybridCalibration cal = calibrate_hybrid(nominal(), data, fine_with(e));
    EXPECT_EQ(cal.options.estimator, e);
    const HybridCompensation c = cal.compensation();  // the options' estimator
    const auto errors = evaluate_hybrid(m, nominal().hybrid(), poses(), &c);
    test_layer[to_string(e)] = layer(errors, 2);
    const Estimate& est = *cal.estimate(e);
    std::printf("%-5s: k %.3g, components %lld, d %.3g; test layer max %.4f mm, mean %.4f mm; cal layer 1 max %.4f mm\n",
                to_string(e), est.ridge_k, static_cast<long long>(est.pcr_components), est.liu_d,
                layer(errors, 2).max_position, layer(errors, 2).mean_position, layer(errors, 1).max_position);
  }
  EXPECT_LT(test_layer["ridge"].max_position, 0.005);
  EXPECT_LT(test_layer["pcr"].max_position, 0.005);
  EXPECT_LT(test_layer["ridge"].max_position, test_layer["ols"].max_position);
  EXPECT_LT(test_layer["pcr"].max_position, test_layer["ols"].max_position);
  // Liu no longer beats OLS here: the compensation now inverts the model's
  // twist (a fixed point, not Eq. (16)'s one step), so OLS's large
  // ill-conditioned values cost it nothing on the test layer (measured max
  // 4.9 um OLS, 6.4 um Liu; before, Liu was the better). Liu's case is its
  // robustness η (MonteCarlo tests).
  EXPECT_LT(test_layer["liu"].max_position, 0.0075);
  EXPECT_LT(test_layer["ols"].max_position, 0.0075);
}

TEST(identifyHybridCalibration, ModelRecordsTheSelectedEstimator) {
  const PoseTable data = measure(machine(7), 0.005, 107);
  const HybridCalibration cal = calibrate_hybrid(nominal(), data, fine_with(EstimatorKind::Ridge));
  const CalibrationModel model = hybrid_model(nominal(), cal, "data.csv");
  EXPECT_EQ(model.estimator, "ridge");
  EXPECT_GT(model.settings.at("ridge_k"), 0.0);
  EXPECT_EQ(model.settings.at("ridge_k_gcv"), 1.0);
  EXPECT_EQ(model.settings.at("coarse_nodes"), 98.0);
  EXPECT_EQ(model.settings.count("liu_d"), 0u);
  const CalibrationModel pcr = hybrid_model(nominal(), cal, EstimatorKind::Pcr);
  EXPECT_EQ(pcr.estimator, "pcr");
  EXPECT_EQ(pcr.settings.at("pcr_components"), static_cast<double>(cal.pcr.pcr_components));
  EXPECT_EQ(hybrid_model(nominal(), cal, EstimatorKind::Liu).settings.at("liu_d"), cal.liu.liu_d);
  // The model compensates as the calibration's ridge estimate does.
  const HybridCompensation from_model = hybrid_compensation_from_model(parse_model(model_to_json(model), "m.json"));
  const HybridCompensation direct = cal.compensation();
  const Pose<double> p = Pose<double>::from_xyz_rpy(poses().rows[60].commanded);
  Vec6<double> q1, q2;
  ASSERT_EQ(compensate_hybrid(direct, p, q1), Status::Ok);
  ASSERT_EQ(compensate_hybrid(from_model, p, q2), Status::Ok);
  EXPECT_LT((q1 - q2).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(identifyHybridCalibration, CoarseStageOnItsOwnLayer) {
  // Seed 000 Sec. 5: the coarse stage on the middle layer alone (here 7 × 7
  // nodes, the test layer of the fine stage), the fine stage on layers 1 and 3.
  const Robot m = machine(7);
  const PoseTable data = measure(m, 0.005, 107);
  HybridCalibrationOptions o;
  o.coarse_layers = {2};
  const HybridCalibration own = calibrate_hybrid(nominal(), data, o);
  const HybridCalibration all = calibrate_hybrid(nominal(), data);
  EXPECT_EQ(own.coarse_ids.size(), 49u);
  EXPECT_EQ(own.coarse_test_rows, 49u);
  EXPECT_EQ(own.coarse_ids.front().rfind("L2-", 0), 0u);
  EXPECT_EQ(own.cal_nodes, 98u);  // the fine stage keeps the cal rows
  EXPECT_EQ(all.coarse_ids.size(), 98u);
  EXPECT_TRUE(own.coarse_converged);
  const double dxi = (own.coarse_xi - all.coarse_xi).norm();
  std::printf("coarse on layer 2 (49 nodes) vs on the 98 cal nodes: |xi difference| = %.2g, %zu rounds\n", dxi,
              own.coarse_history.size());
  EXPECT_LT(dxi, 0.005);
  const HybridCompensation c0 = own.compensation(std::nullopt), c1 = own.compensation();  // coarse alone, + Liu
  const auto coarse = evaluate_hybrid(m, nominal().hybrid(), poses(), &c0);
  const auto fine = evaluate_hybrid(m, nominal().hybrid(), poses(), &c1);
  print_table("coarse on layer 2, fine (Liu) on layers 1 and 3:", {{"coarse", coarse}, {"coarse+Liu", fine}});
  EXPECT_LT(layer(coarse, 2).max_position, 0.15);
  EXPECT_LT(layer(fine, 2).max_position, 0.010);
  HybridCalibrationOptions none;
  none.coarse_layers = {9};
  EXPECT_THROW(calibrate_hybrid(nominal(), data, none), InputError);
}

TEST(identifyHybridCalibration, SequentialOutlierSearchFindsAMisSeatedTarget) {
  // A reflector not seated in its nest: target 1 of one node 50 µm off along
  // x (10 × the 5 µm gauge noise). The deleted-node F test on the fine design
  // flags that node first; set aside, the rest is clean.
  const Robot m = machine(7);
  const PoseTable clean = measure(m, 0.005, 107);
  PoseTable bad = clean;
  for (PoseRow& r : bad.rows)
    if (r.id == "L3-34") (*r.targets)(0, 0) += 0.050;
  const HybridCalibration flagged = calibrate_hybrid(nominal(), bad);
  ASSERT_FALSE(flagged.outliers.empty());
  const HybridOutlierSearch search = hybrid_outlier_search(nominal(), bad, flagged);
  ASSERT_EQ(search.removed.size(), 1u);
  EXPECT_EQ(search.removed.front().id, "L3-34");
  EXPECT_GT(search.removed.front().line, 0u);
  EXPECT_LT(search.removed.front().p_value, 1e-10);
  EXPECT_EQ(search.rest.cal_nodes, 97u);
  EXPECT_TRUE(search.rest.outliers.empty());
  std::printf("mis-seated target: set aside %s (F = %.3g, p = %.2g); threshold p < %.2g\n",
              search.removed.front().id.c_str(), search.removed.front().f, search.removed.front().p_value,
              flagged.outlier_p_threshold);
  EXPECT_FALSE(search.systematic);
  // Clean data: nothing flagged, nothing set aside.
  const HybridCalibration clean_fit = calibrate_hybrid(nominal(), clean);
  EXPECT_TRUE(clean_fit.outliers.empty());
  EXPECT_TRUE(hybrid_outlier_search(nominal(), clean, clean_fit).removed.empty());
  // Without noise the residual is the linearisation error, not noise: nodes
  // keep being flagged, and the search stops at a tenth of them, saying so.
  const PoseTable exact_data = measure(machine(11), 0.0, 111);
  const HybridOutlierSearch exact = hybrid_outlier_search(nominal(), exact_data, calibrate_hybrid(nominal(), exact_data));
  EXPECT_TRUE(exact.systematic);
  EXPECT_EQ(exact.removed.size(), 9u);
}

TEST(identifyHybridCalibration, IdentifiabilityHintForPureTranslationLayers) {
  // Seed 000's calibration poses are pure translations in two layers; of the
  // 150 source errors the fine stage keeps 48. The hint says what would
  // separate the dropped ones: rotated poses for most, nothing for the exact
  // redundancies of the model (e.g. an encoder offset and the offset along
  // the same joint axis).
  const HybridCalibration cal = calibrate_hybrid(nominal(), measure(machine(7), 0.005, 107));
  const IdentifiabilityHint hint = hybrid_identifiability_hint(nominal(), cal);
  std::printf("%s\n", hint.text.c_str());
  ASSERT_EQ(hint.combinations.size(), cal.dropped.size());
  std::size_t rotations = 0, none = 0, positions = 0;
  for (const CombinationHint& h : hint.combinations) {
    bool rot = false, pos = false;
    for (PoseDof d : h.revealed_by) (static_cast<int>(d) >= 3 ? rot : pos) = true;
    rotations += rot ? 1 : 0;
    positions += pos ? 1 : 0;
    none += h.revealed_by.empty() && !h.revealed_jointly ? 1 : 0;
  }
  std::printf("%zu dropped: %zu separated by a rotation, %zu by a move, %zu by no change of pose\n",
              hint.combinations.size(), rotations, positions, none);
  EXPECT_GT(rotations, cal.dropped.size() / 2);
  EXPECT_GT(none, 0u);
  EXPECT_NE(hint.text.find("add poses with different orientations (ry, rz)"), std::string::npos);
  EXPECT_NE(hint.text.find("a redundancy of the model"), std::string::npos);
  EXPECT_EQ(hint.text.find('\n'), std::string::npos);
}

}  // namespace
