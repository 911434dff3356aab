// Seed 001's calibration of the 6-UPS: the linearised 42-parameter error model
// against the nonlinear machine, identification against known truth, and
// compensation re-simulated on the erroneous machine.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>

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
    EXPECT_NE(std::string(e.what()).find("at least 7"), std::string::npos) << e.what();
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
  const StewartOutlierSearch search = stewart_outlier_search(nominal, t4);
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
