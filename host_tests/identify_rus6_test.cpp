// The 6-RUS family in identify (issue #33): its error model against finite
// differences at millimetre errors, the parameter table's composition, the
// identify → table → compensate round trip through the library on data of
// the family's own simulator (the independent simulator's tests are
// identify_independent_rus6_test.cpp), and what the description and the
// table check refuse.
//
// What differs from the code's own choices: errors drawn at random at two
// magnitudes (micrometres and millimetres), poses drawn at random (not a
// grid) in a box other than the reference machine's documented one, a 6-RUS
// of another size from a description file, targets in the tracker's own
// frame at true positions that are not the description's.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "../identify/src/families/family.hpp"
#include "../identify/src/families/family_errors.hpp"
#include "kincal/core/rus6_machine.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/robot.hpp"
#include "kincal/identify/rus6_error_model.hpp"
#include "kincal/identify/simulate.hpp"
#include "kincal/identify/target_calibration.hpp"
#include "large_rus6.hpp"

namespace ki = kincal::identify;
using kincal::Mat6;
using kincal::Pose;
using kincal::Status;
using kincal::Vec3;
using kincal::Vec6;

namespace {

// Errors of about `length` mm and `angle` rad on every parameter, seeded.
Eigen::VectorXd random_errors(double length, double angle, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::VectorXd x(ki::kRus6ParameterCount);
  for (const ki::ParameterSpec& s : ki::parameter_specs(ki::builtin_robot("rus6-ref"))) {
    const Eigen::Index k = &s - ki::parameter_specs(ki::builtin_robot("rus6-ref")).data();
    x(k) = (std::string(s.unit) == "rad" ? angle : length) * n(rng);
  }
  return x;
}

ki::ParameterSet as_parameters(const ki::Robot& robot, const Eigen::VectorXd& x) {
  ki::ParameterSet set;
  const std::vector<std::string> names = ki::parameter_names(robot);
  for (std::size_t k = 0; k < names.size(); ++k) set.values.push_back({names[k], x(Eigen::Index(k)), 0});
  return set;
}

// Poses at random in a box about home that the nominal IK reaches inside
// the limits.
std::vector<Vec6<double>> random_poses(const ki::Robot& robot, int count, double size, double tilt, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Vec6<double>> out;
  const Vec6<double> home = robot.home_pose().to_xyz_rpy();
  while (int(out.size()) < count) {
    Vec6<double> x = home;
    for (int d = 0; d < 3; ++d) x(d) += size * u(rng);
    for (int d = 3; d < 6; ++d) x(d) += tilt * u(rng);
    Vec6<double> q;
    if (robot.inverse(Pose<double>::from_xyz_rpy(x), q) == Status::Ok) out.push_back(x);
  }
  return out;
}

ki::PoseTable pose_table(const std::vector<Vec6<double>>& poses, int test_every) {
  ki::PoseTable t;
  t.file = "poses.csv";
  t.has_role = true;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    ki::PoseRow r;
    r.id = "n" + std::to_string(k);
    r.commanded = poses[k];
    r.role = int(k) % test_every == test_every - 1 ? ki::Role::Test : ki::Role::Cal;
    t.rows.push_back(r);
  }
  return t;
}

TEST(Rus6ErrorModel, TwistsMatchFiniteDifferencesAtMillimetreErrors) {
  // At x ≠ 0 the tilts compose (about y_i, then the turned z_i): the columns
  // must be the derivative there, not only at the nominal machine.
  for (const ki::Robot& robot : {ki::builtin_robot("rus6-ref"), kincal_test::large_rus6()}) {
    const std::unique_ptr<ki::detail::FamilyErrors> errors = ki::detail::family_errors(robot);
    const Eigen::VectorXd x = random_errors(0.8, 8e-3, 7);
    for (const Vec6<double>& commanded : random_poses(robot, 3, 25, 0.08, 3)) {
      Vec6<double> q;
      ASSERT_EQ(robot.inverse(Pose<double>::from_xyz_rpy(commanded), q), Status::Ok);
      auto pose_at = [&](const Eigen::VectorXd& values) {
        ki::detail::NodeGuess guess = errors->start(Pose<double>::from_xyz_rpy(commanded));
        Pose<double> p;
        EXPECT_TRUE(errors->pose(values, q, guess, p));
        return p;
      };
      const Pose<double> reached = pose_at(x);
      const Eigen::MatrixXd T = errors->twist_columns(x, reached);
      ASSERT_EQ(T.cols(), ki::kRus6ParameterCount);
      for (int j = 0; j < ki::kRus6ParameterCount; ++j) {
        const double h = errors->units()[std::size_t(j)] == "rad" ? 1e-6 : 1e-4;
        Eigen::VectorXd up = x, down = x;
        up(j) += h;
        down(j) -= h;
        const Vec6<double> fd = kincal::pose_error(pose_at(up), pose_at(down)) / (2 * h);
        EXPECT_LT((fd - T.col(j)).norm(), 2e-5 * std::max(1.0, T.col(j).norm())) << errors->names()[std::size_t(j)];
      }
    }
  }
}

TEST(Rus6ErrorModel, ParametersComposeInTableOrderWhateverTheFilesOrder) {
  const ki::Robot robot = ki::builtin_robot("rus6-ref");
  const Eigen::VectorXd x = random_errors(0.5, 0.01, 11);
  ki::ParameterSet set = as_parameters(robot, x);
  std::reverse(set.values.begin(), set.values.end());  // dtilt_z before dtilt_y in the file
  const kincal::Rus6Geometry<double> a = ki::apply_parameters(robot, set).rus6();
  const kincal::Rus6Geometry<double> b = ki::rus6_with_errors(robot.rus6(), x);
  EXPECT_LT((a.shaft_axes - b.shaft_axes).norm(), 1e-15);
  EXPECT_LT((a.crank_zero - b.crank_zero).norm(), 1e-15);
  EXPECT_LT((a.shaft_points - b.shaft_points).norm(), 1e-12);
  // The frames stay orthonormal: the kinematics' own validity check.
  EXPECT_TRUE(kincal::rus6_valid_geometry(a));
  // A tilt turns the shaft by its angle (0.01 rad tilts: cos of the turn).
  for (int i = 0; i < 6; ++i) {
    const double turned = std::acos(std::clamp(a.shaft_axes.col(i).dot(robot.rus6().shaft_axes.col(i)), -1.0, 1.0));
    const double expected = std::hypot(x(11 * i + 3), x(11 * i + 4));
    EXPECT_NEAR(turned, expected, 1e-3 * expected) << "motor " << i + 1;
  }
}

// identify (the target fit on full poses or 1 / 3 targets in the tracker's
// frame) → MODEL → table → compensate, then the compensated commands driven
// through the actual machine: the held-out poses' error falls to about the
// noise.
struct RoundTrip {
  const char* what;
  double length, angle;  // error magnitudes
  int targets;           // 0: full poses
};

class Rus6RoundTrip : public ::testing::TestWithParam<RoundTrip> {};

TEST_P(Rus6RoundTrip, CompensatedHeldOutPosesReachTheirTargetsNearTheNoise) {
  const RoundTrip c = GetParam();
  ki::Robot nominal = ki::builtin_robot("rus6-ref");
  // Millimetres of error need more correction than the default bound
  // (0.02 rad): the description key a user raises.
  if (c.length >= 0.5) nominal.max_correction = Vec6<double>::Constant(0.1);
  const std::vector<Vec3<double>> described = {{90, 15, 20}, {-50, 70, 25}, {-40, -80, 18}};
  std::vector<Vec3<double>> truth;
  for (int k = 0; k < c.targets; ++k) {
    nominal.targets.push_back(described[std::size_t(k)]);
    truth.push_back(described[std::size_t(k)] + Vec3<double>(0.4, -0.3, 0.2));  // not where the description says
  }
  const Eigen::VectorXd x = random_errors(c.length, c.angle, 23);
  const ki::Robot actual = ki::apply_parameters(nominal, as_parameters(nominal, x));
  ki::SimulateOptions o;
  o.noise_mm = 0.002;
  o.noise_rad = 5e-6;
  o.seed = 4;
  o.targets = truth;
  if (c.targets > 0) o.instrument_frame = Pose<double>::from_xyz_rpy(2500, -400, 300, 0.02, -0.03, 2.4);
  ki::SimulateReport report;
  const ki::PoseTable poses = pose_table(random_poses(nominal, 100, 38, 0.12, 5), 5);
  ki::PoseTable data = ki::simulate(nominal, actual, poses, o, report);
  ASSERT_EQ(report.failed, 0u);
  data.in_instrument_frame = c.targets > 0;
  const ki::TargetCalibration cal = ki::calibrate_targets(nominal, data);
  const ki::CalibrationModel model = ki::target_model(nominal, cal, "data.csv");
  // The held-out poses, compensated, then reached by the actual machine.
  std::vector<Vec6<double>> held_out;
  for (const ki::PoseRow& r : poses.rows)
    if (r.role == ki::Role::Test) held_out.push_back(r.commanded);
  const ki::PoseTable requests = pose_table(held_out, 1000);
  const ki::CompensatedStream s = ki::compensate_rows(ki::calibration_table(model), model, requests);
  double before = 0, after = 0;
  for (std::size_t k = 0; k < held_out.size(); ++k) {
    ASSERT_EQ(s.rows[k].status, kincal::CompensationStatus::Ok) << c.what << " row " << k;
    const Pose<double> requested = Pose<double>::from_xyz_rpy(held_out[k]);
    Vec6<double> q_nominal;
    ASSERT_EQ(nominal.inverse(requested, q_nominal), Status::Ok);
    Pose<double> uncompensated, compensated;
    ASSERT_EQ(kincal::rus6_fk(actual.rus6(), q_nominal, requested, uncompensated).status, Status::Ok);
    ASSERT_EQ(kincal::rus6_fk(actual.rus6(), s.rows[k].q, requested, compensated).status, Status::Ok);
    if (c.targets == 0) {
      before += (uncompensated.p - requested.p).squaredNorm();
      after += (compensated.p - requested.p).squaredNorm();
      continue;
    }
    // With targets the model's platform and base frames are its convention's
    // (no net rigid motion of the spheres and shaft points), not the true
    // ones: what it promises is where the targets go, in the tracker's frame.
    const Pose<double>& registration = *o.instrument_frame;
    for (int t = 0; t < c.targets; ++t) {
      const Vec3<double> promised = cal.registration.R * (requested.R * cal.targets[std::size_t(t)] + requested.p) +
                                    cal.registration.p;
      auto seen = [&](const Pose<double>& reached) {
        return Vec3<double>(registration.R * (reached.R * truth[std::size_t(t)] + reached.p) + registration.p);
      };
      before += (seen(uncompensated) - promised).squaredNorm() / c.targets;
      after += (seen(compensated) - promised).squaredNorm() / c.targets;
    }
  }
  const double n = double(held_out.size());
  before = std::sqrt(before / n);
  after = std::sqrt(after / n);
  RecordProperty("rms_before_um", std::to_string(1e3 * before));
  RecordProperty("rms_after_um", std::to_string(1e3 * after));
  // The estimate's own error at 2 µm noise over 80 nodes: a few µm.
  EXPECT_LT(after, 0.006) << c.what << ": RMS " << 1e3 * after << " um (before " << 1e3 * before << " um)";
  EXPECT_GT(before, 20 * after) << c.what;
}

INSTANTIATE_TEST_SUITE_P(Rus6, Rus6RoundTrip,
                         ::testing::Values(RoundTrip{"full pose, micrometre errors", 0.02, 2e-4, 0},
                                           RoundTrip{"full pose, millimetre errors", 1.0, 8e-3, 0},
                                           RoundTrip{"three targets in the tracker's frame", 0.1, 1e-3, 3},
                                           RoundTrip{"one target in the tracker's frame", 0.1, 1e-3, 1}),
                         [](const ::testing::TestParamInfo<RoundTrip>& p) { return "case" + std::to_string(p.index); });

// A blunder: one cal row's measured position 0.4 mm off (a tracker that
// lost its target for a moment). The deleted-node screen names that row,
// and the fit without it is the fit of the clean data.
TEST(Rus6Identify, ABlunderIsNamedAndLeftOut) {
  const ki::Robot nominal = ki::builtin_robot("rus6-ref");
  const ki::Robot actual = ki::apply_parameters(nominal, as_parameters(nominal, random_errors(0.05, 5e-4, 31)));
  ki::SimulateOptions o;
  o.noise_mm = 0.002;
  o.noise_rad = 5e-6;
  o.seed = 8;
  ki::SimulateReport report;
  const ki::PoseTable clean = ki::simulate(nominal, actual, pose_table(random_poses(nominal, 80, 30, 0.1, 9), 1000), o, report);
  ki::PoseTable data = clean;
  (*data.rows[17].measured)(1) += 0.4;
  const ki::TargetCalibration all = ki::calibrate_targets(nominal, data);
  const ki::TargetOutlierSearch search = ki::target_outlier_search(nominal, data, all);
  ASSERT_EQ(search.removed.size(), 1u);
  EXPECT_EQ(search.removed.front().id, data.rows[17].id);
  ki::PoseTable without = clean;
  without.rows.erase(without.rows.begin() + 17);
  const ki::TargetCalibration reference = ki::calibrate_targets(nominal, without);
  EXPECT_LT((search.rest.errors - reference.errors).norm(), 1e-6 * std::max(1.0, reference.errors.norm()));
}

// The description's refusals name the key, with the file's line.
TEST(Rus6Description, RefusesWhatTheKinematicsCannotUse) {
  const std::string good = ki::robot_to_json(ki::builtin_robot("rus6-ref"));
  auto expect_refused = [&](const std::string& from, const std::string& to, const std::string& words) {
    std::string text = good;
    const std::size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    try {
      ki::parse_robot(text, "r.json");
      ADD_FAILURE() << "accepted: " << to;
    } catch (const ki::InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(words), std::string::npos) << what;
      EXPECT_NE(what.find("r.json:"), std::string::npos) << what;
    }
  };
  expect_refused("\"axis\": [-0.9063077870366499", "\"axis\": [-0.95", "unit vector");
  expect_refused("[-0.42261826174069944, -0.9063077870366499, 0.0]", "[-0.42261826174069944, -0.9063077870366499, 0.1]",
                 "unit vectors");
  expect_refused("\"min\": [-1.3962634015954636", "\"min\": [-5.3962634015954636", "narrower than 2 pi");
  expect_refused("\"z\": 274.", "\"z\": 674.", "not reachable");
  expect_refused("\"rod_length\": 300.0", "\"rod_length\": -300.0", "positive");
  expect_refused("\"motor_axes\": [", "\"motor_axis\": [", "motor_axis");
}

// The table check's refusals name the value and the robot description key.
TEST(Rus6Table, RefusesOversizedErrorsNamingTheKey) {
  ki::CalibrationModel model;
  model.nominal = ki::builtin_robot("rus6-ref");
  auto refusal = [&](const std::string& name, double value) -> std::string {
    model.parameters = {{name, value, 0, true}};
    try {
      ki::calibration_table(model);
    } catch (const ki::InputError& e) {
      return e.message();
    }
    return {};
  };
  EXPECT_NE(refusal("drod2", 12.0).find("max_geometry_error"), std::string::npos);
  EXPECT_NE(refusal("dtilt_y3", 0.2).find("max_angle_error"), std::string::npos);
  const std::string zero = refusal("dtheta4", 0.05);
  EXPECT_NE(zero.find("dtheta4"), std::string::npos) << zero;
  EXPECT_NE(zero.find("max_correction"), std::string::npos) << zero;
  EXPECT_EQ(refusal("drod2", 0.5), "");  // within every cap
}

}  // namespace
