// Issue #11 item 3: the correction bound belongs to the machine. The robot
// description's optional key `max_correction` (one number or one per joint,
// mm or rad) goes into MODEL.json, the calibration table and the machine
// limits the firmware checks; `identify` warns when the model needs more.
//
// How this data differs from the rest of the suite: a hexapod of another size
// (legs 600–1100 mm, large_hexapod.hpp) whose joints are off by up to 5 mm —
// a machine before its first calibration — measured by this test's own
// generator (core's FK on the erroneous geometry with its stroke opened, then
// Gaussian noise drawn here: 1 µm on positions, 2 µrad on angles), random
// poses (no grid, no layer / dir / q / temp columns), held-out poses drawn
// separately. The floor it is judged against is the same design, the same
// noise draws and the same identification on a machine whose errors are
// 100 times smaller: what the noise allows, whatever the start.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "kincal/core/stewart.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/robot.hpp"
#include "kincal/identify/stewart_calibration.hpp"
#include "large_hexapod.hpp"

namespace ki = kincal::identify;
using kincal::Pose;
using kincal::Status;
using kincal::Vec6;
using kincal_test::large_hexapod;

namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

std::string error_of(const std::string& extra_keys) {
  try {
    (void)large_hexapod(extra_keys);
  } catch (const ki::InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(identifyCorrectionBound, TheRobotDescriptionCarriesIt) {
  // Unset: core's default_bounds, per family.
  EXPECT_EQ(large_hexapod().correction_bound(), (Vec6<double>() << 5, 5, 5, 5, 5, 5).finished());
  EXPECT_FALSE(large_hexapod().max_correction.has_value());
  EXPECT_EQ(ki::builtin_robot("hybrid-seed000").correction_bound(),
            (Vec6<double>() << 5, 5, 5, 0.02, 0.02, 0.02).finished());
  // One number for every joint, or one per joint.
  EXPECT_EQ(large_hexapod("\"max_correction\": 20,").correction_bound(), Vec6<double>::Constant(20));
  const ki::Robot per_joint = large_hexapod("\"max_correction\": [8, 9, 10, 11, 12, 13],");
  EXPECT_EQ(per_joint.correction_bound(), (Vec6<double>() << 8, 9, 10, 11, 12, 13).finished());
  // Written back and read again: the description and MODEL.json keep it.
  EXPECT_EQ(ki::parse_robot(ki::robot_to_json(per_joint), "again.json").correction_bound(), per_joint.correction_bound());
  ki::CalibrationModel model;
  model.nominal = per_joint;
  model.estimator = "ols";
  const ki::CalibrationModel read = ki::parse_model(ki::model_to_json(model), "MODEL.json");
  EXPECT_EQ(read.nominal.correction_bound(), per_joint.correction_bound());
  // And into the table and the limits the firmware checks it against.
  const ki::AnyCalibrationTable table = ki::calibration_table(read);
  const auto& t = std::get<kincal::StewartCalibrationTable<double>>(table);
  const kincal::MachineLimits<double> limits = ki::machine_limits(read.nominal);
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(t.bounds.max_correction[i], 8.0 + i);
    EXPECT_EQ(limits.max_correction[i], 8.0 + i);
  }
  // The hybrid reads the key too.
  std::string hybrid = ki::robot_to_json(ki::builtin_robot("hybrid-seed000"));
  hybrid.insert(hybrid.find("\"screw_lead\""), "\"max_correction\": [6, 6, 6, 0.05, 0.05, 0.05],\n  ");
  EXPECT_EQ(ki::parse_robot(hybrid, "h.json").correction_bound(), (Vec6<double>() << 6, 6, 6, 0.05, 0.05, 0.05).finished());
}

TEST(identifyCorrectionBound, BadValuesAreOneLineErrorsWithAPosition) {
  for (const std::string& bad :
       {std::string("\"max_correction\": 0,"), std::string("\"max_correction\": -2,"),
        std::string("\"max_correction\": [1, 2, 3],"), std::string("\"max_correction\": [1, 1, 1, 1, 1, -1],"),
        std::string("\"max_correction\": \"20\","), std::string("\"max_correction\": {\"all\": 20},")}) {
    const std::string e = error_of(bad);
    EXPECT_TRUE(contains(e, "large-hexapod.json:")) << bad << " -> " << e;
    EXPECT_TRUE(contains(e, "max_correction")) << bad << " -> " << e;
    EXPECT_FALSE(contains(e, "\n")) << e;
  }
}

namespace {

struct Draws {
  std::vector<Vec6<double>> cal_poses, test_poses, cal_noise;
};

// Random cal poses over x, y ±400 mm, z 500–1000 mm, tilts ±15° (the
// measured machine goes there, whatever the stroke says); held-out poses
// inside the stroke with 10 mm margin (the controller must serve them).
Draws draw(const ki::Robot& robot, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> xy(-400, 400), z(500, 1000), tilt(-15 * M_PI / 180, 15 * M_PI / 180);
  std::normal_distribution<double> n(0.0, 1.0);
  Draws d;
  while (d.cal_poses.size() < 60) {
    Vec6<double> p;
    p << xy(rng), xy(rng), z(rng), tilt(rng), tilt(rng), tilt(rng);
    Vec6<double> q;
    if (kincal::stewart_ik(robot.stewart(), Pose<double>::from_xyz_rpy(p), q) != Status::Ok) continue;
    d.cal_poses.push_back(p);
    Vec6<double> e;
    e << 1e-3 * n(rng), 1e-3 * n(rng), 1e-3 * n(rng), 2e-6 * n(rng), 2e-6 * n(rng), 2e-6 * n(rng);
    d.cal_noise.push_back(e);
  }
  const auto& g = robot.stewart();
  while (d.test_poses.size() < 40) {
    Vec6<double> p;
    p << 0.8 * xy(rng), 0.8 * xy(rng), z(rng), 0.7 * tilt(rng), 0.7 * tilt(rng), 0.7 * tilt(rng);
    Vec6<double> q;
    if (kincal::stewart_ik(g, Pose<double>::from_xyz_rpy(p), q) != Status::Ok) continue;
    if ((q.array() < g.min_length.array() + 10).any() || (q.array() > g.max_length.array() - 10).any()) continue;
    d.test_poses.push_back(p);
  }
  return d;
}

kincal::StewartGeometry<double> opened(kincal::StewartGeometry<double> g) {
  g.min_length.setConstant(-1e6);
  g.max_length.setConstant(1e6);
  return g;
}

struct Outcome {
  double before_mm = 0;       // worst position error of the uncalibrated machine on the cal poses
  double held_out_um = 0;     // RMS position error on the held-out poses, compensated
  std::size_t compensated = 0;
  ki::CorrectionNeed need;
};

// Measure the machine (nominal + `errors`) at the cal poses, identify, then
// compensate the held-out poses with the identified model and drive the
// real machine there.
Outcome run(const ki::Robot& robot, const Eigen::VectorXd& errors, const Draws& d) {
  const kincal::StewartGeometry<double> actual = opened(ki::stewart_with_errors(robot.stewart(), errors));
  ki::PoseTable data;
  data.file = "large-noisy.csv";
  data.has_measured = true;
  Outcome o;
  for (std::size_t k = 0; k < d.cal_poses.size(); ++k) {
    ki::PoseRow r;
    r.id = "c" + std::to_string(k);
    r.line = k + 2;
    r.commanded = d.cal_poses[k];
    const Pose<double> commanded = Pose<double>::from_xyz_rpy(r.commanded);
    Vec6<double> q;
    EXPECT_EQ(kincal::stewart_ik(robot.stewart(), commanded, q), Status::Ok);
    Pose<double> reached;
    EXPECT_EQ(kincal::stewart_fk(actual, q, commanded, reached).status, Status::Ok);
    o.before_mm = std::max(o.before_mm, (reached.p - commanded.p).norm());
    r.measured = reached.to_xyz_rpy() + d.cal_noise[k];
    data.rows.push_back(r);
  }
  const ki::StewartCalibration c = ki::calibrate_stewart(robot, data);
  const ki::CalibrationModel model = ki::stewart_model(robot, c, data.file);
  ki::PoseTable test;
  test.file = "held-out.csv";
  for (std::size_t k = 0; k < d.test_poses.size(); ++k) {
    ki::PoseRow r;
    r.id = "t" + std::to_string(k);
    r.commanded = d.test_poses[k];
    test.rows.push_back(r);
  }
  o.need = ki::correction_need(model, test);
  const ki::CompensatedStream s = ki::compensate_rows(ki::calibration_table(model), model, test);
  double sum = 0;
  for (std::size_t k = 0; k < test.rows.size(); ++k) {
    if (s.rows[k].status != kincal::CompensationStatus::Ok) continue;
    const Pose<double> target = Pose<double>::from_xyz_rpy(test.rows[k].commanded);
    Pose<double> reached;
    EXPECT_EQ(kincal::stewart_fk(actual, s.rows[k].q, target, reached).status, Status::Ok);
    sum += (reached.p - target.p).squaredNorm();
    ++o.compensated;
  }
  o.held_out_um = o.compensated ? 1e3 * std::sqrt(sum / double(o.compensated)) : HUGE_VAL;
  return o;
}

}  // namespace

TEST(identifyCorrectionBound, ALargeErrorHexapodIsCompensatedOnceItsDescriptionRaisesTheBound) {
  const ki::Robot default_bound = large_hexapod();
  const ki::Robot raised = large_hexapod("\"max_correction\": 25,");
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> err(-5, 5);
  Eigen::VectorXd truth(42);
  for (auto& v : truth) v = err(rng);
  const Draws d = draw(default_bound, 11);

  // With core's default 5 mm bound the identified model cannot be served:
  // the need is reported (and `identify` warns, naming the key).
  const Outcome refused = run(default_bound, truth, d);
  EXPECT_GT(refused.before_mm, 10.0) << "a machine before its first calibration";
  ASSERT_TRUE(refused.need.exceeds());
  EXPECT_LT(refused.compensated, d.test_poses.size()) << "some held-out poses need more than 5 mm";
  const std::string warning = ki::correction_need_warning(refused.need);
  EXPECT_TRUE(contains(warning, "'max_correction'")) << warning;
  EXPECT_FALSE(contains(warning, "\n"));

  // The bound raised in the description: every held-out pose compensated,
  // to within 1.5x of what the same noise allows on a nearly exact machine.
  const Outcome served = run(raised, truth, d);
  EXPECT_FALSE(served.need.exceeds()) << served.need.largest.transpose();
  EXPECT_TRUE(ki::correction_need_warning(served.need).empty());
  EXPECT_EQ(served.compensated, d.test_poses.size());
  const Outcome floor = run(raised, truth / 100, d);
  EXPECT_EQ(floor.compensated, d.test_poses.size());
  EXPECT_LT(served.held_out_um, 1.5 * floor.held_out_um)
      << "large errors " << served.held_out_um << " um, floor " << floor.held_out_um << " um";
  EXPECT_GT(floor.held_out_um, 0.05) << "the noise must show (else the comparison is empty)";
  std::cout << "large-error hexapod: uncalibrated worst " << served.before_mm << " mm; held-out compensated "
            << served.held_out_um << " um RMS; floor (errors /100, same noise) " << floor.held_out_um
            << " um; largest correction " << served.need.largest.maxCoeff() << " mm\n";
}
