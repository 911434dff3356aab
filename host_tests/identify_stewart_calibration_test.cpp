// Seed 001's calibration of the 6-UPS: the linearised 42-parameter error model
// against the nonlinear machine, identification against known truth, and
// compensation re-simulated on the erroneous machine.
#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <random>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/simulate.hpp"
#include "kincal/identify/stewart_calibration.hpp"

using namespace kincal;
using namespace kincal::identify;

namespace {

const std::string kExamples = std::string(KINCAL_SOURCE_DIR) + "/examples";

Eigen::VectorXd table3() {
  const Robot r = builtin_robot("stewart-seed001");
  const ParameterSet p = read_parameters(kExamples + "/seed001/errors.csv", r);
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(kStewartParameterCount);
  const std::vector<std::string> names = parameter_names(r);
  for (const ParameterValue& v : p.values)
    theta(std::find(names.begin(), names.end(), v.name) - names.begin()) = v.value;
  return theta;
}

Pose<double> fk(const StewartGeometry<double>& g, const Vec6<double>& q, const Pose<double>& guess) {
  Pose<double> out;
  EXPECT_EQ(stewart_fk(g, q, guess, out).status, Status::Ok);
  return out;
}

}  // namespace

TEST(identifyStewartCalibration, ParameterOrderMatchesTheParameterTable) {
  const Robot r = builtin_robot("stewart-seed001");
  const Eigen::VectorXd theta = table3();
  ParameterSet set;
  const std::vector<std::string> names = parameter_names(r);
  for (int j = 0; j < kStewartParameterCount; ++j) set.values.push_back({names[std::size_t(j)], theta(j), 0});
  const StewartGeometry<double> a = apply_parameters(r, set).stewart();
  const StewartGeometry<double> b = stewart_with_errors(r.stewart(), theta);
  EXPECT_EQ(a.base, b.base);
  EXPECT_EQ(a.platform, b.platform);
  EXPECT_EQ(a.length_offset, b.length_offset);
}

TEST(identifyStewartCalibration, ErrorJacobianMatchesFiniteDifferencesOfTheMachine) {
  const StewartGeometry<double> g = builtin_robot("stewart-seed001").stewart();
  for (const Pose<double>& pose : {Pose<double>::from_xyz_rpy(10, 5, 205, 0.03, 0.02, -0.05),
                                   Pose<double>::from_xyz_rpy(-15, 12, 195, -0.06, 0.04, 0.08)}) {
    Vec6<double> q;
    ASSERT_EQ(stewart_ik(g, pose, q), Status::Ok);
    const StewartErrorJacobian E = stewart_error_jacobian(g, pose);
    const double h = 1e-6;
    double worst = 0;
    for (int j = 0; j < kStewartParameterCount; ++j) {
      Eigen::VectorXd d = Eigen::VectorXd::Zero(kStewartParameterCount);
      d(j) = h;
      const Twist<double> plus = pose_error(fk(stewart_with_errors(g, d), q, pose), pose);
      const Twist<double> minus = pose_error(fk(stewart_with_errors(g, -d), q, pose), pose);
      worst = std::max(worst, ((plus - minus) / (2 * h) - E.col(j)).norm() / (1 + E.col(j).norm()));
    }
    EXPECT_LT(worst, 1e-6);
  }
}

TEST(identifyStewartCalibration, LinearModelPredictsTheNonlinearMachineWithinOnePercent) {
  // Issue #3: with source errors of 10 µm size, predicted and simulated pose
  // errors agree to within 1 %.
  const StewartGeometry<double> g = builtin_robot("stewart-seed001").stewart();
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n01(0, 1);
  double worst = 0;
  for (int k = 0; k < 20; ++k) {
    Eigen::VectorXd theta(kStewartParameterCount);
    for (int j = 0; j < kStewartParameterCount; ++j) theta(j) = 0.010 * n01(rng);
    const Pose<double> pose = Pose<double>::from_xyz_rpy(15 * n01(rng), 15 * n01(rng), 207 + 10 * n01(rng),
                                                         0.05 * n01(rng), 0.05 * n01(rng), 0.05 * n01(rng));
    Vec6<double> q;
    if (stewart_ik(g, pose, q) != Status::Ok) continue;
    const Twist<double> actual = pose_error(fk(stewart_with_errors(g, theta), q, pose), pose);
    const Twist<double> predicted = stewart_error_jacobian(g, pose) * theta;
    Twist<double> w = actual - predicted;
    w.tail<3>() *= 200;  // compare rotations at the platform radius (mm)
    Twist<double> a = actual;
    a.tail<3>() *= 200;
    worst = std::max(worst, w.norm() / a.norm());
  }
  std::printf("worst relative difference, linear model vs nonlinear machine: %.3e\n", worst);
  EXPECT_LT(worst, 0.01);
  EXPECT_GT(worst, 0.0);
}

TEST(identifyStewartCalibration, RecoversTable3FromNoiseFreeData) {
  const Robot nominal = builtin_robot("stewart-seed001");
  const Robot actual = apply_parameters(nominal, read_parameters(kExamples + "/seed001/errors.csv", nominal));
  const PoseTable poses = read_pose_table(kExamples + "/seed001/grid_poses.csv");
  SimulateReport rep;
  const PoseTable meas = simulate(nominal, actual, poses, SimulateOptions{}, rep);
  const StewartCalibration c = calibrate_stewart(nominal, meas);
  EXPECT_EQ(c.rank, 42);
  EXPECT_LT((c.theta - table3()).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LE(c.history.size(), 6u);
  EXPECT_LT(c.history.back().rms_position_mm, 1e-9);
}

TEST(identifyStewartCalibration, IdentifyThenCompensateBringsHeldOutErrorsToTheNoise) {
  const Robot nominal = builtin_robot("stewart-seed001");
  const Robot actual = apply_parameters(nominal, read_parameters(kExamples + "/seed001/errors.csv", nominal));
  const PoseTable poses = read_pose_table(kExamples + "/seed001/grid_poses.csv");
  SimulateOptions noisy;
  noisy.noise_mm = 0.001;
  noisy.noise_rad = 5e-6;
  noisy.seed = 5;
  SimulateReport rep;
  const PoseTable meas = simulate(nominal, actual, poses, noisy, rep);
  const CalibrationModel model = stewart_model(nominal, calibrate_stewart(nominal, meas), "grid");
  const Robot calibrated = calibrated_robot(model);
  // Compensate the held-out poses and run them on the erroneous machine.
  double before2 = 0, after2 = 0;
  int n = 0;
  for (const PoseRow& r : poses.rows) {
    if (r.role != Role::Test) continue;
    const Pose<double> want = Pose<double>::from_xyz_rpy(r.commanded);
    Vec6<double> q_nominal, q_comp;
    ASSERT_EQ(nominal.inverse(want, q_nominal), Status::Ok);
    ASSERT_EQ(calibrated.inverse(want, q_comp), Status::Ok);
    before2 += pose_error(fk(actual.stewart(), q_nominal, want), want).head<3>().squaredNorm();
    after2 += pose_error(fk(actual.stewart(), q_comp, want), want).head<3>().squaredNorm();
    ++n;
  }
  ASSERT_EQ(n, 30);
  const double before = std::sqrt(before2 / n), after = std::sqrt(after2 / n);
  std::printf("held-out position error rms: uncompensated %.2f um, compensated %.3f um\n", 1e3 * before, 1e3 * after);
  EXPECT_GT(before, 0.040);  // ~55 µm uncompensated
  EXPECT_LT(after, 0.0017);  // below the 3-D noise level √3·1 µm of one measurement
}

TEST(identifyStewartCalibration, TooFewNodesAndDegeneratePosesAreClearErrors) {
  const Robot nominal = builtin_robot("stewart-seed001");
  PoseTable t = parse_pose_table(
      "id,x,y,z,rx,ry,rz,mx,my,mz,mrx,mry,mrz\n"
      "a,0,0,200,0,0,0,0,0,200,0,0,0\nb,1,0,200,0,0,0,1,0,200,0,0,0\n",
      "few.csv");
  try {
    calibrate_stewart(nominal, t);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("at least 8"), std::string::npos) << e.what();
  }
  // Ten copies of one pose: the 42 parameters cannot be separated.
  std::string text = "id,x,y,z,rx,ry,rz,mx,my,mz,mrx,mry,mrz\n";
  for (int k = 0; k < 10; ++k) text += "p" + std::to_string(k) + ",0,0,200,0,0,0,0,0,200,0,0,0\n";
  try {
    calibrate_stewart(nominal, parse_pose_table(text, "same.csv"));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not identifiable"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("same.csv"), std::string::npos) << e.what();
  }
}

TEST(identifyStewartCalibration, ModelFileRoundTrip) {
  const Robot nominal = builtin_robot("stewart-seed001");
  CalibrationModel m;
  m.nominal = nominal;
  m.estimator = "ols";
  m.settings["iterations"] = 3;
  m.parameters.push_back({"dXB1", 0.02, 0.001, true});
  m.parameters.push_back({"dl6", -0.04, 0.002, true});
  const CalibrationModel back = parse_model(model_to_json(m), "m.json");
  ASSERT_EQ(back.parameters.size(), 2u);
  EXPECT_EQ(back.parameters[1].name, "dl6");
  EXPECT_EQ(back.parameters[1].value, -0.04);
  EXPECT_EQ(back.settings.at("iterations"), 3);
  EXPECT_EQ(calibrated_robot(back).stewart().length_offset(5), -0.04);
  try {
    parse_model("{\"format\": \"kincal-model\", \"version\": 1}", "bad.json");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("robot"), std::string::npos);
  }
  try {
    parse_model("{\"format\": ", "cut.json");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cut.json:1:"), std::string::npos) << e.what();
  }
}

TEST(identifyStewartCalibration, Table4AsMeasuredDataFlagsRowA2) {
  // Issue #3: seed 001's Table 4 used as measured data — the tool reports
  // which rows are inconsistent with the others and what the rest gives.
  const Robot nominal = builtin_robot("stewart-seed001");
  const PoseTable t4 = read_pose_table(kExamples + "/seed001/table4_paper.csv");
  const StewartCalibration all = calibrate_stewart(nominal, t4);
  ASSERT_FALSE(all.outliers.empty());
  const StewartOutlierSearch search = stewart_outlier_search(nominal, t4, all);
  ASSERT_FALSE(search.removed.empty());
  EXPECT_EQ(search.removed.front().id, "A2");
  EXPECT_LT(search.removed.front().p_value, 1e-12);
  std::printf("set aside:");
  for (const NodeTest& n : search.removed) std::printf(" %s (p = %.2g)", n.id.c_str(), n.p_value);
  std::printf("; the rest fits to %.4f um RMS (all rows: %.3f um)\n", 1e3 * search.rest.history.back().rms_position_mm,
              1e3 * all.history.back().rms_position_mm);
  // Without the inconsistent rows the paper's data fit to its printed digits.
  EXPECT_LT(search.rest.history.back().rms_position_mm, 1e-4);
  EXPECT_GT(all.history.back().rms_position_mm, 1e-3);
}

TEST(identifyStewartCalibration, CleanDataFlagsNoOutlier) {
  const Robot nominal = builtin_robot("stewart-seed001");
  const Robot actual = apply_parameters(nominal, read_parameters(kExamples + "/seed001/errors.csv", nominal));
  SimulateOptions noisy;
  noisy.noise_mm = 0.001;
  noisy.noise_rad = 5e-6;
  noisy.seed = 21;
  SimulateReport rep;
  const PoseTable meas = simulate(nominal, actual, read_pose_table(kExamples + "/seed001/grid_poses.csv"), noisy, rep);
  EXPECT_TRUE(calibrate_stewart(nominal, meas).outliers.empty());
}

namespace {

PoseTable simulated_grid(double noise_mm, double noise_rad, std::uint64_t seed) {
  const Robot nominal = builtin_robot("stewart-seed001");
  const Robot actual = apply_parameters(nominal, read_parameters(kExamples + "/seed001/errors.csv", nominal));
  SimulateOptions o;
  o.noise_mm = noise_mm;
  o.noise_rad = noise_rad;
  o.seed = seed;
  SimulateReport rep;
  return simulate(nominal, actual, read_pose_table(kExamples + "/seed001/grid_poses.csv"), o, rep);
}

StewartCalibrationOptions with(EstimatorKind kind) {
  StewartCalibrationOptions o;
  o.estimator.kind = kind;
  return o;
}

// RMS position error of the held-out grid poses, compensated by `model`, on the erroneous machine (mm).
double held_out_rms(const CalibrationModel& model) {
  const Robot nominal = builtin_robot("stewart-seed001");
  const Robot actual = apply_parameters(nominal, read_parameters(kExamples + "/seed001/errors.csv", nominal));
  const Robot calibrated = calibrated_robot(model);
  double sum2 = 0;
  int n = 0;
  for (const PoseRow& r : read_pose_table(kExamples + "/seed001/grid_poses.csv").rows) {
    if (r.role != Role::Test) continue;
    const Pose<double> want = Pose<double>::from_xyz_rpy(r.commanded);
    Vec6<double> q;
    EXPECT_EQ(calibrated.inverse(want, q), Status::Ok);
    sum2 += pose_error(fk(actual.stewart(), q, want), want).head<3>().squaredNorm();
    ++n;
  }
  return std::sqrt(sum2 / n);
}

}  // namespace

TEST(identifyStewartCalibration, EachEstimatorRecoversTable3WithoutNoise) {
  // Issue #3: ridge and PCR as the linear step. Noise-free, GCV chooses k = 0
  // and keeps all 42 components, so each estimator recovers Table 3 exactly.
  const PoseTable meas = simulated_grid(0, 0, 1);
  const Robot nominal = builtin_robot("stewart-seed001");
  for (EstimatorKind kind : {EstimatorKind::Ols, EstimatorKind::Ridge, EstimatorKind::Pcr}) {
    const StewartCalibration c = calibrate_stewart(nominal, meas, with(kind));
    EXPECT_LT((c.theta - table3()).cwiseAbs().maxCoeff(), 1e-8) << to_string(kind);
    EXPECT_EQ(c.fit.method, to_string(kind));
    EXPECT_LE(c.history.size(), 6u) << to_string(kind);
    if (kind == EstimatorKind::Ridge) {
      EXPECT_EQ(c.fit.ridge_k, 0.0);
    }
    if (kind == EstimatorKind::Pcr) {
      EXPECT_EQ(c.fit.pcr_components, 42);
    }
  }
  // A fixed ridge k and a fixed number of components are biased by design:
  // the iteration converges to the shrunk / truncated total error.
  StewartCalibrationOptions fixed = with(EstimatorKind::Pcr);
  fixed.estimator.pcr = PcrOptions{30, 0, 0, false};
  const StewartCalibration pcr30 = calibrate_stewart(nominal, meas, fixed);
  EXPECT_EQ(pcr30.fit.pcr_components, 30);
  EXPECT_GT((pcr30.theta - table3()).cwiseAbs().maxCoeff(), 1e-4);
}

TEST(identifyStewartCalibration, EachEstimatorRecoversTable3WithNoise) {
  // 1 µm / 5 µrad noise (seed 5): the stated tolerances are an RMS parameter
  // error below 50 µm for OLS (its standard errors reach 60 µm: the grid's
  // column-scaled condition number is 1.8e3) and below 30 µm for ridge and
  // PCR, whose shrinkage halves it; every model compensates the held-out
  // poses to the noise level (√3 · 1 µm).
  const PoseTable meas = simulated_grid(0.001, 5e-6, 5);
  const Robot nominal = builtin_robot("stewart-seed001");
  std::map<std::string, double> rms;
  for (EstimatorKind kind : {EstimatorKind::Ols, EstimatorKind::Ridge, EstimatorKind::Pcr}) {
    const StewartCalibration c = calibrate_stewart(nominal, meas, with(kind));
    const Eigen::VectorXd err = c.theta - table3();
    rms[to_string(kind)] = std::sqrt(err.squaredNorm() / kStewartParameterCount);
    const double held_out = held_out_rms(stewart_model(nominal, c, "grid"));
    std::printf("%-5s: %zu iterations, k %.3g, components %lld, parameter error rms %.1f um (max %.1f um), "
                "held-out compensated rms %.3f um\n",
                to_string(kind), c.history.size(), c.fit.ridge_k, static_cast<long long>(c.fit.pcr_components),
                1e3 * rms[to_string(kind)], 1e3 * err.cwiseAbs().maxCoeff(), 1e3 * held_out);
    EXPECT_LT(held_out, 0.0017) << to_string(kind);
    EXPECT_TRUE(c.outliers.empty()) << to_string(kind);
  }
  EXPECT_LT(rms["ols"], 0.050);
  EXPECT_LT(rms["ridge"], 0.030);
  EXPECT_LT(rms["pcr"], 0.030);
}

TEST(identifyStewartCalibration, ModelRecordsTheEstimatorAndItsSettings) {
  const Robot nominal = builtin_robot("stewart-seed001");
  const PoseTable meas = simulated_grid(0.001, 5e-6, 5);
  const CalibrationModel ridge = stewart_model(nominal, calibrate_stewart(nominal, meas, with(EstimatorKind::Ridge)), "g");
  EXPECT_EQ(ridge.estimator, "ridge");
  EXPECT_GT(ridge.settings.at("ridge_k"), 0.0);
  EXPECT_EQ(ridge.settings.at("ridge_k_gcv"), 1.0);
  EXPECT_EQ(ridge.settings.at("orientation_weight_mm"), 200.0);
  const CalibrationModel pcr = stewart_model(nominal, calibrate_stewart(nominal, meas, with(EstimatorKind::Pcr)), "g");
  EXPECT_EQ(pcr.estimator, "pcr");
  EXPECT_EQ(pcr.settings.at("pcr_components_gcv"), 1.0);
  EXPECT_GT(pcr.settings.at("pcr_components"), 0.0);
  const CalibrationModel back = parse_model(model_to_json(pcr), "m.json");
  EXPECT_EQ(back.estimator, "pcr");
  EXPECT_EQ(back.settings.at("pcr_components"), pcr.settings.at("pcr_components"));
  EXPECT_EQ(stewart_model(nominal, calibrate_stewart(nominal, meas), "g").estimator, "ols");
  EXPECT_THROW(calibrate_stewart(nominal, meas, with(EstimatorKind::Liu)), InputError);
}

TEST(identifyStewartCalibration, RankDeficientDesignSaysWhichPosesWouldSeparateTheParameters) {
  // Issue #3: 27 poses on a 3 × 3 × 3 grid of positions, all at one
  // orientation. A base hinge offset dB_i and the platform hinge offset
  // R·dP_i = dB_i move the leg end by the same vector, so every pair is
  // confounded; the error Jacobian at rotated poses separates them: the x
  // offsets by turns about y or z, y offsets about x or z, z offsets by tilts.
  const Robot nominal = builtin_robot("stewart-seed001");
  std::string text = "id,x,y,z,rx,ry,rz\n";
  int k = 0;
  for (int x : {-20, 0, 20})
    for (int y : {-20, 0, 20})
      for (int z : {190, 205, 220})
        text += "o" + std::to_string(k++) + "," + std::to_string(x) + "," + std::to_string(y) + "," +
                std::to_string(z) + ",0,0,0\n";
  const Robot actual = apply_parameters(nominal, read_parameters(kExamples + "/seed001/errors.csv", nominal));
  SimulateReport rep;
  const PoseTable meas = simulate(nominal, actual, parse_pose_table(text, "one_orientation.csv"), SimulateOptions{}, rep);
  try {
    calibrate_stewart(nominal, meas);
    FAIL() << "a single orientation cannot determine the 42 parameters";
  } catch (const InputError& e) {
    const std::string m = e.what();
    std::printf("%s\n", m.c_str());
    EXPECT_EQ(m.find('\n'), std::string::npos);
    EXPECT_NE(m.find("one_orientation.csv"), std::string::npos);
    EXPECT_NE(m.find("(rank 24)"), std::string::npos);
    EXPECT_NE(m.find("not identifiable: dXB1, dYB1, dZB1, dXP1"), std::string::npos);
    EXPECT_EQ(m.find("dl1"), std::string::npos);  // the leg length offsets stay identifiable
    EXPECT_NE(m.find("dXB1, dXP1, dXB2, dXP2, dXB3, dXP3, dXB4, dXP4, dXB5, dXP5, dXB6, dXP6: add poses with "
                     "different orientations (ry, rz)"),
              std::string::npos);
    EXPECT_NE(m.find("dYB1, dYP1, dYB2, dYP2, dYB3, dYP3, dYB4, dYP4, dYB5, dYP5, dYB6, dYP6: add poses with "
                     "different orientations (rx, rz)"),
              std::string::npos);
    EXPECT_NE(m.find("dZB1, dZP1, dZB2, dZP2, dZB3, dZP3, dZB4, dZP4, dZB5, dZP5, dZB6, dZP6: add tilted poses (rx, ry)"),
              std::string::npos);
  }
  // Tilting the same grid (seed 001's grid has tilts within ±5°) removes the deficiency.
  EXPECT_EQ(calibrate_stewart(nominal, simulated_grid(0, 0, 1)).rank, 42);
}
