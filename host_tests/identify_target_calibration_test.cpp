// Laser-tracker targets on a 6-UPS (issue #12 item 2): the measurement
// model's derivatives against finite differences of its own prediction, and
// the identification against known truth.
//
// The data are made here, not by `simulate`: the true machine is the nominal
// geometry with its joints moved directly (uniform errors, not the Gaussian
// draws of the examples), poses drawn at random in the workspace (no grid,
// no example file), targets placed by the test, a registration with a 2 rad
// yaw and metres of offset, Gaussian noise on each target coordinate. The
// machine is judged as the tracker sees it — held-out poses compensated by the
// identified model and driven on the true machine, their targets compared in
// the tracker's frame — which is independent of the frame convention the fit
// chose (a constant rigid motion on either side is absorbed by the identified
// registration and targets).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "kincal/core/hybrid.hpp"
#include "kincal/core/stewart.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/diagnosis.hpp"
#include "kincal/identify/effect_calibration.hpp"
#include "kincal/identify/hybrid_calibration.hpp"
#include "kincal/identify/hybrid_error_model.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/robot.hpp"
#include "kincal/identify/stewart_calibration.hpp"
#include "kincal/identify/target_calibration.hpp"
#include "kincal/identify/target_measurement.hpp"
#include "large_hexapod.hpp"

namespace {

using namespace kincal;
using namespace kincal::identify;

Pose<double> random_pose(std::mt19937_64& rng, double reach_mm, double z_mm, double tilt_rad) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return Pose<double>::from_xyz_rpy(reach_mm * u(rng), reach_mm * u(rng), z_mm + 0.5 * reach_mm * u(rng),
                                    tilt_rad * u(rng), tilt_rad * u(rng), 1.5 * tilt_rad * u(rng));
}

TEST(TargetMeasurement, MapAndInstrumentColumnsMatchFiniteDifferences) {
  std::mt19937_64 rng(41);
  const Pose<double> registration = Pose<double>::from_xyz_rpy(1200, -300, 450, 0.3, -0.2, 2.1);
  const Pose<double> platform = random_pose(rng, 40, 200, 0.1);
  const std::vector<Vec3<double>> targets{{60, 5, 20}, {-30, 50, 25}, {-25, -55, 15}};
  const Eigen::MatrixXd M = target_map(registration, platform, targets);
  const Eigen::MatrixXd C = instrument_columns(registration, platform, targets);
  const double h = 1e-6;
  auto flat = [](const TargetPoints& t) { return Eigen::VectorXd(t.reshaped()); };
  const Eigen::VectorXd y0 = flat(predicted_targets(registration, platform, targets));
  for (int j = 0; j < 6; ++j) {  // platform twist: apply_twist of core/pose.hpp
    const Eigen::VectorXd fd =
        (flat(predicted_targets(registration, apply_twist(platform, Twist<double>(h * Twist<double>::Unit(j))), targets)) -
         y0) / h;
    EXPECT_LT((fd - M.col(j)).norm(), 1e-5 * (1 + M.col(j).norm())) << "platform twist " << j;
  }
  for (int j = 0; j < 6; ++j) {  // registration twist
    const Eigen::VectorXd fd =
        (flat(predicted_targets(moved_registration(registration, h * Vec6<double>::Unit(j)), platform, targets)) - y0) / h;
    EXPECT_LT((fd - C.col(j)).norm(), 1e-4 * (1 + C.col(j).norm())) << "registration " << j;
  }
  for (int j = 0; j < 9; ++j) {  // target offsets
    std::vector<Vec3<double>> moved = targets;
    moved[std::size_t(j / 3)](j % 3) += h;
    const Eigen::VectorXd fd = (flat(predicted_targets(registration, platform, moved)) - y0) / h;
    EXPECT_LT((fd - C.col(6 + j)).norm(), 1e-5) << "target coordinate " << j;
  }
}

TEST(TargetMeasurement, RigidFitAndRigidMotionRows) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-500, 500);
  TargetPoints from(3, 12);
  for (Eigen::Index j = 0; j < from.cols(); ++j) from.col(j) = Vec3<double>(u(rng), u(rng), u(rng));
  const Pose<double> T = Pose<double>::from_xyz_rpy(300, -2000, 40, -0.7, 0.4, 3.0);
  TargetPoints to(3, from.cols());
  for (Eigen::Index j = 0; j < from.cols(); ++j) to.col(j) = T.transform(from.col(j));
  const Pose<double> fit = rigid_fit(from, to);
  EXPECT_LT((fit.R - T.R).norm(), 1e-12);
  EXPECT_LT((fit.p - T.p).norm(), 1e-9);
  // The six rows are independent and annihilate nothing but non-rigid
  // motions: every small rigid motion of the points lies in their span.
  const Eigen::Matrix<double, 6, Eigen::Dynamic> C = rigid_motion_rows(from);
  EXPECT_EQ(Eigen::FullPivLU<Eigen::MatrixXd>(C).rank(), 6);
  for (int j = 0; j < 6; ++j) {
    Eigen::VectorXd d(3 * from.cols());
    const Vec6<double> t = Vec6<double>::Unit(j);
    for (Eigen::Index i = 0; i < from.cols(); ++i)
      d.segment<3>(3 * i) = t.head<3>() + Vec3<double>(t.tail<3>()).cross(Vec3<double>(from.col(i)));
    const Eigen::VectorXd coefficients = C.transpose().colPivHouseholderQr().solve(d);
    EXPECT_LT((C.transpose() * coefficients - d).norm(), 1e-9 * d.norm()) << "rigid motion " << j;
  }
}

// A machine measured by a tracker: truth, data, and the judgement.
struct TrackerCase {
  Robot nominal;                       // with the nominal `targets`
  std::vector<Vec3<double>> true_targets;
  Pose<double> registration;           // true base frame in the tracker frame
  double joint_error_mm = 0.3;
  double noise_mm = 0.005;
  double reach_mm = 40, z_mm = 200, tilt_rad = 0.12;
  int cal = 70, test = 40;
  std::uint64_t seed = 1;
  bool instrument_frame = true;
  // A hidden backlash (mm per actuator): the machine's joints are q + b_i·dir_i,
  // with the approach directions drawn at random per row and written as
  // dir1..dir6 columns (not derived from a motion order, as simulate does).
  Vec6<double> backlash = Vec6<double>::Zero();
};

struct TrackerResult {
  TargetCalibration calibration;
  double held_out_prediction_rms_um = 0;  // measured − predicted at held-out targets (3-D, RMS)
  double compensated_rms_um = 0;          // compensated held-out poses, targets as the tracker sees them (3-D, RMS)
};

StewartGeometry<double> true_machine(const StewartGeometry<double>& nominal, double error_mm, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-std::sqrt(3.0) * error_mm, std::sqrt(3.0) * error_mm);  // σ = error_mm
  StewartGeometry<double> g = nominal;
  for (int i = 0; i < 6; ++i) {
    for (int a = 0; a < 3; ++a) g.base(a, i) += u(rng), g.platform(a, i) += u(rng);
    g.length_offset(i) += u(rng);
  }
  return g;
}

void make_data(const TrackerCase& c, const StewartGeometry<double>& truth, std::mt19937_64& rng, PoseTable& data,
               std::vector<Pose<double>>& held_out) {
  std::normal_distribution<double> noise(0.0, c.noise_mm);
  const Pose<double> frame = c.instrument_frame ? c.registration : Pose<double>{};
  data.file = "tracker.csv";
  data.has_role = data.has_targets = true;
  data.has_dir = c.backlash != Vec6<double>::Zero();
  data.target_count = int(c.true_targets.size());
  for (int k = 0; k < c.cal + c.test; ++k) {
    PoseRow row;
    // Poses inside the stroke with room for the errors (drawn again if not).
    Pose<double> commanded, reached;
    for (int attempt = 0;; ++attempt) {
      ASSERT_LT(attempt, 100) << "no pose in reach";
      commanded = random_pose(rng, c.reach_mm, c.z_mm, c.tilt_rad);
      Vec6<double> q;
      if (stewart_ik(c.nominal.stewart(), commanded, q) != Status::Ok) continue;
      row.dir = Eigen::VectorXi(6);
      for (int i = 0; i < 6; ++i) (*row.dir)(i) = rng() % 2 == 0 ? -1 : 1;
      const Vec6<double> room = (q - c.nominal.stewart().min_length).cwiseMin(c.nominal.stewart().max_length - q);
      const Vec6<double> driven = q + c.backlash.cwiseProduct(row.dir->cast<double>());
      if (room.minCoeff() > 10 * c.joint_error_mm && stewart_fk(truth, driven, commanded, reached).status == Status::Ok)
        break;
    }
    row.id = "P" + std::to_string(k);
    row.line = std::size_t(k) + 2;
    row.role = k < c.cal ? Role::Cal : Role::Test;
    row.commanded = commanded.to_xyz_rpy();
    Eigen::Matrix<double, 3, 3> t = Eigen::Matrix<double, 3, 3>::Zero();
    for (std::size_t j = 0; j < c.true_targets.size(); ++j)
      t.col(Eigen::Index(j)) = (frame * reached).transform(c.true_targets[j]) + Vec3<double>(noise(rng), noise(rng), noise(rng));
    row.targets = t;
    data.rows.push_back(row);
    if (!data.has_dir) row.dir.reset();
    if (row.role == Role::Test) held_out.push_back(commanded);
  }
}

// The registration and targets of a MODEL.json's instrument section.
void instrument_of(const CalibrationModel& m, Pose<double>& registration, std::vector<Vec3<double>>& targets) {
  Vec6<double> reg = Vec6<double>::Zero();
  targets.clear();
  for (const ModelParameter& p : m.instrument) {
    if (p.name.rfind("reg_", 0) == 0) {
      const char* names[6] = {"reg_x", "reg_y", "reg_z", "reg_rx", "reg_ry", "reg_rz"};
      for (int j = 0; j < 6; ++j)
        if (p.name == names[j]) reg(j) = p.value;
    } else {
      const std::size_t k = std::size_t(p.name[1] - '1');
      if (targets.size() <= k) targets.resize(k + 1, Vec3<double>::Zero());
      targets[k](p.name[2] - 'x') = p.value;
    }
  }
  registration = Pose<double>::from_xyz_rpy(reg);
}

TrackerResult run_case(const TrackerCase& c) {
  std::mt19937_64 rng(c.seed);
  const StewartGeometry<double> truth = true_machine(c.nominal.stewart(), c.joint_error_mm, rng);
  const Pose<double> frame = c.instrument_frame ? c.registration : Pose<double>{};
  PoseTable data;
  std::vector<Pose<double>> held_out;
  make_data(c, truth, rng, data, held_out);
  if (::testing::Test::HasFatalFailure()) return {};
  data.in_instrument_frame = c.instrument_frame;
  TrackerResult out;
  out.calibration = calibrate_targets(c.nominal, data);
  const TargetCalibration& cal = out.calibration;
  const PoseErrorReport residual = target_residuals(c.nominal, cal.errors, cal.registration, cal.targets, data);
  out.held_out_prediction_rms_um = 1e3 * residual.groups.at("test").rms_position_mm;
  // Compensation: the identified machine's IK of each held-out pose, driven
  // on the true machine; desired and reached targets in the tracker frame.
  const StewartGeometry<double> identified = stewart_with_errors(c.nominal.stewart(), cal.errors);
  double sum = 0;
  int count = 0;
  for (const Pose<double>& desired : held_out) {
    Vec6<double> q;
    Pose<double> reached;
    EXPECT_EQ(stewart_ik(identified, desired, q), Status::Ok);
    EXPECT_EQ(stewart_fk(truth, q, desired, reached).status, Status::Ok);
    for (std::size_t j = 0; j < c.true_targets.size(); ++j) {
      const Vec3<double> want = (cal.registration * desired).transform(cal.targets[j]);
      const Vec3<double> got = (frame * reached).transform(c.true_targets[j]);
      sum += (got - want).squaredNorm();
      ++count;
    }
  }
  out.compensated_rms_um = 1e3 * std::sqrt(sum / count);
  return out;
}

Robot with_targets(Robot r, std::vector<Vec3<double>> targets) {
  r.targets = std::move(targets);
  return r;
}

std::vector<Vec3<double>> moved_targets(const std::vector<Vec3<double>>& nominal, std::uint64_t seed, double mm) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-mm, mm);
  std::vector<Vec3<double>> out = nominal;
  for (Vec3<double>& t : out) t += Vec3<double>(u(rng), u(rng), u(rng));
  return out;
}

// The issue's case (joints and targets off by ~0.3 mm, 5 µm noise, tracker
// frame unknown) with three targets and with one, on seed 001's machine and
// on a machine four times its size; the noise floor is the same design,
// noise draws and fit on a machine whose joints are 100× closer to nominal.
struct TrackerScenario {
  const char* name;
  Robot robot;
  std::vector<Vec3<double>> targets;
  double reach_mm, z_mm;
};

class TrackerIdentification : public ::testing::TestWithParam<int> {};

TEST_P(TrackerIdentification, CompensatesHeldOutTargetsWithinOneAndAHalfTimesTheNoiseFloor) {
  const std::vector<TrackerScenario> scenarios{
      {"seed 001, three targets", builtin_robot("stewart-seed001"), {{60, 0, 20}, {-30, 52, 20}, {-30, -52, 20}}, 40, 200},
      {"seed 001, one target", builtin_robot("stewart-seed001"), {{20, 10, 30}}, 40, 200},
      {"large hexapod, one target", kincal_test::large_hexapod(), {{-70, 110, 45}}, 150, 800},
      {"large hexapod, three targets", kincal_test::large_hexapod(), {{150, 0, 30}, {-75, 130, 30}, {-75, -130, 60}}, 150, 800}};
  const TrackerScenario& s = scenarios[std::size_t(GetParam())];
  TrackerCase c;
  c.nominal = with_targets(s.robot, s.targets);
  c.true_targets = moved_targets(s.targets, 100 + std::uint64_t(GetParam()), 0.5);
  c.registration = Pose<double>::from_xyz_rpy(2400, -900, -350, 0.05, -0.08, 2.0);
  c.reach_mm = s.reach_mm;
  c.z_mm = s.z_mm;
  c.seed = 7 + std::uint64_t(GetParam());
  const TrackerResult big = run_case(c);
  TrackerCase floor_case = c;
  floor_case.joint_error_mm = c.joint_error_mm / 100;
  floor_case.true_targets = moved_targets(s.targets, 100 + std::uint64_t(GetParam()), 0.005);
  const TrackerResult floor = run_case(floor_case);
  const double noise_3d_um = 1e3 * c.noise_mm * std::sqrt(3.0);
  std::cout << s.name << ": compensated " << big.compensated_rms_um << " um (floor " << floor.compensated_rms_um
            << "), held-out prediction " << big.held_out_prediction_rms_um << " um (noise " << noise_3d_um
            << "), condition " << big.calibration.condition_number << ", worst combination sd "
            << 1e3 * big.calibration.weakest.front().standard_deviation_mm << " um\n";
  EXPECT_EQ(big.calibration.rank, big.calibration.free_parameters);
  EXPECT_LE(big.compensated_rms_um, 1.5 * floor.compensated_rms_um) << s.name;
  EXPECT_LE(big.held_out_prediction_rms_um, 1.5 * floor.held_out_prediction_rms_um) << s.name;
  // Prediction at held-out points cannot beat the noise it is measured with.
  EXPECT_GT(big.held_out_prediction_rms_um, 0.7 * noise_3d_um);
  // The registration is found from a 2 rad yaw: within a few standard errors.
  const Twist<double> reg_error = pose_error(big.calibration.registration, c.registration);
  EXPECT_LT(reg_error.tail<3>().norm(), 5 * big.calibration.registration_standard_error.tail<3>().norm() + 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Scenarios, TrackerIdentification, ::testing::Range(0, 4));

TEST(TrackerIdentification, TargetsInTheBaseFrameNeedNoRegistration) {
  TrackerCase c;
  c.nominal = with_targets(builtin_robot("stewart-seed001"), {{55, 10, 25}, {-35, 45, 25}});
  c.true_targets = moved_targets(c.nominal.targets, 9, 0.3);
  c.instrument_frame = false;
  c.joint_error_mm = 1.0;  // millimetres, not tenths
  c.noise_mm = 0.002;
  const TrackerResult r = run_case(c);
  EXPECT_EQ(r.calibration.free_parameters, 42 + 6 - 6);
  EXPECT_TRUE(r.calibration.registration.R.isIdentity(0));
  EXPECT_LT(r.compensated_rms_um, 3 * 1e3 * c.noise_mm * std::sqrt(3.0));
}

TEST(TrackerIdentification, RefusesWhatTheDataCannotCarry) {
  const Robot plain = builtin_robot("stewart-seed001");
  PoseTable data;
  data.file = "few.csv";
  data.has_targets = true;
  data.target_count = 1;
  EXPECT_THROW(calibrate_targets(plain, data), InputError);  // no `targets` in the description
  const Robot two = with_targets(plain, {{0, 0, 20}, {10, 0, 20}});
  try {
    calibrate_targets(two, data);
    ADD_FAILURE() << "a table of one target against a description of two was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("measures 1 target"), std::string::npos) << e.what();
  }
  const Robot one = with_targets(plain, {{0, 0, 20}});
  for (int k = 0; k < 5; ++k) {
    PoseRow row;
    row.id = "R" + std::to_string(k);
    row.commanded << 0, 0, 200, 0, 0, 0;
    row.targets = Eigen::Matrix<double, 3, 3>::Zero();
    data.rows.push_back(row);
  }
  try {
    calibrate_targets(one, data);
    ADD_FAILURE() << "five nodes of one target were accepted for 39 parameters";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("only 5 calibration nodes"), std::string::npos) << e.what();
  }
}

TEST(TargetColumns, OneToThreeTargetsReadAndWritten) {
  const PoseTable one = parse_pose_table("id,x,y,z,rx,ry,rz,t1x,t1y,t1z\nA,0,0,200,0,0,0,1,2,3\n", "one.csv");
  EXPECT_EQ(one.target_count, 1);
  EXPECT_TRUE(one.has_targets);
  EXPECT_EQ(one.rows[0].targets->col(0), Vec3<double>(1, 2, 3));
  EXPECT_EQ(pose_table_text(one), "id,x,y,z,rx,ry,rz,t1x,t1y,t1z\nA,0,0,200,0,0,0,1,2,3\n");
  try {
    parse_pose_table("id,x,y,z,rx,ry,rz,t2x,t2y,t2z\nA,0,0,200,0,0,0,1,2,3\n", "gap.csv");
    ADD_FAILURE() << "t2 without t1 was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("without t1x"), std::string::npos) << e.what();
  }
  EXPECT_THROW(parse_pose_table("id,x,y,z,rx,ry,rz,t1x,t1y\nA,0,0,200,0,0,0,1,2\n", "part.csv"), InputError);
}

TEST(TargetModel, InstrumentRoundTripsThroughModelJson) {
  CalibrationModel m;
  m.nominal = with_targets(builtin_robot("stewart-seed001"), {{0, 0, 20}});
  m.estimator = "ols";
  m.instrument = {{"reg_x", 1500.25, 0.3, true}, {"reg_rz", 2.0, 1e-4, true}, {"t1z", 20.3, 0.05, true}};
  const CalibrationModel back = parse_model(model_to_json(m), "m.json");
  ASSERT_EQ(back.instrument.size(), 3u);
  EXPECT_EQ(back.instrument[0].name, "reg_x");
  EXPECT_DOUBLE_EQ(back.instrument[0].value, 1500.25);
  EXPECT_DOUBLE_EQ(back.instrument[2].standard_error, 0.05);
  std::string text = model_to_json(m);
  text.replace(text.find("\"t1z\""), 5, "\"t4z\"");
  EXPECT_THROW(parse_model(text, "m.json"), InputError);
}

}  // namespace

namespace {

// The issue's loop with a hidden effect: diagnose names the backlash hidden
// in target data from the tracker's frame, identify --effects fits it with
// the base, and the compensated machine (identified IK, backlash taken off
// each command by its direction) reaches held-out targets within 1.5× of
// the floor: the same design, noise draws and fit on a machine with 100×
// smaller joint, target and backlash errors.
struct EffectRun {
  Diagnosis diagnosis;
  double compensated_rms_um = 0;
  Vec6<double> backlash = Vec6<double>::Zero();
};

EffectRun run_effect_case(const TrackerCase& c) {
  std::mt19937_64 rng(c.seed);
  const StewartGeometry<double> truth = true_machine(c.nominal.stewart(), c.joint_error_mm, rng);
  PoseTable data;
  std::vector<Pose<double>> held_out;
  make_data(c, truth, rng, data, held_out);
  data.in_instrument_frame = c.instrument_frame;
  EffectRun out;
  out.diagnosis = diagnose(c.nominal, data);
  const CalibrationModel model = calibrate_with_effects(c.nominal, data, {"backlash"});
  out.backlash = model.effects.values.at("backlash");
  Pose<double> registration;
  std::vector<Vec3<double>> targets;
  instrument_of(model, registration, targets);
  const StewartGeometry<double> identified = calibrated_robot(model).stewart();
  const Pose<double> frame = c.instrument_frame ? c.registration : Pose<double>{};
  std::mt19937_64 dir_rng(c.seed + 99);
  double sum = 0;
  int count = 0;
  for (const Pose<double>& desired : held_out) {
    Vec6<double> q, dir;
    for (int i = 0; i < 6; ++i) dir(i) = dir_rng() % 2 == 0 ? -1.0 : 1.0;
    EXPECT_EQ(stewart_ik(identified, desired, q), Status::Ok);
    const Vec6<double> command = q - out.backlash.cwiseProduct(dir);  // the compensator's correction
    Pose<double> reached;
    EXPECT_EQ(stewart_fk(truth, Vec6<double>(command + c.backlash.cwiseProduct(dir)), desired, reached).status, Status::Ok);
    for (std::size_t j = 0; j < c.true_targets.size(); ++j) {
      const Vec3<double> want = (registration * desired).transform(targets[j]);
      const Vec3<double> got = (frame * reached).transform(c.true_targets[j]);
      sum += (got - want).squaredNorm();
      ++count;
    }
  }
  out.compensated_rms_um = 1e3 * std::sqrt(sum / count);
  return out;
}

class TrackerEffect : public ::testing::TestWithParam<int> {};

TEST_P(TrackerEffect, HiddenBacklashIsNamedFittedAndCompensatedNearTheFloor) {
  const bool three = GetParam() == 0;
  const std::vector<Vec3<double>> nominal_targets =
      three ? std::vector<Vec3<double>>{{60, 0, 20}, {-30, 52, 20}, {-30, -52, 20}} : std::vector<Vec3<double>>{{20, 10, 30}};
  TrackerCase c;
  c.nominal = with_targets(builtin_robot("stewart-seed001"), nominal_targets);
  c.true_targets = moved_targets(nominal_targets, 300 + std::uint64_t(GetParam()), 0.5);
  c.registration = Pose<double>::from_xyz_rpy(-1800, 600, 250, -0.04, 0.06, -2.5);
  c.backlash << 0, 0.02, 0, 0, -0.015, 0;
  c.cal = 80;
  c.seed = 21 + std::uint64_t(GetParam());
  const EffectRun big = run_effect_case(c);
  TrackerCase floor_case = c;
  floor_case.joint_error_mm /= 100;
  floor_case.backlash /= 100;
  floor_case.true_targets = moved_targets(nominal_targets, 300 + std::uint64_t(GetParam()), 0.005);
  const EffectRun floor = run_effect_case(floor_case);
  std::cout << (three ? "three targets" : "one target") << ": diagnosis " << big.diagnosis.verdict << " (accepted "
            << (big.diagnosis.accepted.empty() ? std::string("none") : big.diagnosis.accepted.front())
            << "), backlash b2 " << big.backlash(1) << " b5 " << big.backlash(4) << " mm, compensated "
            << big.compensated_rms_um << " um (floor " << floor.compensated_rms_um << ")\n";
  ASSERT_FALSE(big.diagnosis.accepted.empty());
  EXPECT_EQ(big.diagnosis.accepted.front(), "backlash");
  EXPECT_EQ(big.diagnosis.verdict, "explained");
  EXPECT_NEAR(big.backlash(1), 0.02, 0.003);
  EXPECT_NEAR(big.backlash(4), -0.015, 0.003);
  EXPECT_LE(big.compensated_rms_um, 1.5 * floor.compensated_rms_um);
}

INSTANTIATE_TEST_SUITE_P(ThreeAndOneTargets, TrackerEffect, ::testing::Range(0, 2));

}  // namespace

namespace {

// The hybrid measured by tracker targets on its tool, in the tracker's frame
// (issue #12 item 2, the second family). The data are made here: the true
// machine's 150 source errors drawn uniformly (lengths ±0.3 mm, angles
// ±0.3 mrad, encoder offsets alike), random tool poses that turn the tool
// (the seed 000 layers are translations only, which cannot separate a
// target's offset from the registration), the true machine's exact FK
// (HybridErrorModel::actual_fk) and the tracker's registration. Held-out
// poses are compensated by the model's HybridCompensation (seed 000 Eq. (16):
// the controller's first-order error twist, not the exact model the fit used)
// and driven on the true machine; targets compared in the tracker's frame.
//
// Without targets (`nominal_targets` empty) the instrument measures the full
// tool pose in the robot's base frame (a 6-DOF probe; the hybrid's own
// pipeline reads only seed 000's gauge): noise is a random small rotation
// and translation applied to the reached pose (simulate adds it to the
// x..rz numbers instead), and the held-out poses are judged by the tool
// point's position and the tool's orientation.
struct HybridTrackerRun {
  TargetCalibration calibration;
  double compensated_rms_um = 0;
  double compensated_orientation_rms_urad = 0;  // full poses
  double held_out_prediction_rms_um = 0;
  std::optional<Diagnosis> diagnosis;  // with a hidden backlash
  Vec6<double> backlash = Vec6<double>::Zero();
};

// `backlash` (mm per actuated joint; the wrist's in rad): hidden in the data
// (joints q + b∘dir, directions drawn per row and written as dir columns);
// then the run diagnoses, fits base and backlash together and compensates
// both.
HybridTrackerRun run_hybrid_case(const std::vector<Vec3<double>>& nominal_targets,
                                 const std::vector<Vec3<double>>& true_targets, double error_scale, std::uint64_t seed,
                                 const Vec6<double>& backlash = Vec6<double>::Zero()) {
  Robot nominal = builtin_robot("hybrid-seed000");
  nominal.targets = nominal_targets;
  const bool full_pose = nominal_targets.empty();
  const HybridGeometry<double>& g = nominal.hybrid();
  const HybridErrorModel model(g);
  // Three streams, so that the machine's errors do not change the poses or
  // the noise: the floor run (error_scale 0.01) measures the same poses with
  // the same noise draws as the big one; a pose the true machine cannot
  // reach is left out, not redrawn.
  std::mt19937_64 rng(seed), pose_rng(seed + 1000), noise_rng(seed + 2000);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd truth(HybridErrorModel::kParameterCount);
  for (Eigen::Index j = 0; j < truth.size(); ++j)
    truth(j) = error_scale * (model.parameters()[std::size_t(j)].angular() ? 3e-4 : 0.3) * u(rng);
  const Pose<double> registration = Pose<double>::from_xyz_rpy(-1200, 2500, 400, 0.03, -0.06, 2.6);
  std::normal_distribution<double> noise(0.0, 0.005);
  std::normal_distribution<double> angle_noise(0.0, 5e-6);
  PoseTable data;
  data.file = "hybrid-tracker.csv";
  data.has_role = true;
  data.has_targets = !full_pose;
  data.has_measured = full_pose;
  data.target_count = int(true_targets.size());
  data.in_instrument_frame = !full_pose;
  data.has_dir = backlash != Vec6<double>::Zero();
  std::vector<Pose<double>> held_out;
  std::vector<Vec6<double>> held_out_dir;
  for (int k = 0; k < 120; ++k) {
    PoseRow row;
    Pose<double> commanded, reached;
    Vec6<double> q;
    HybridPassive<double> passive;
    for (int attempt = 0;; ++attempt) {
      if (attempt == 200) {
        ADD_FAILURE() << "no reachable pose";
        return {};
      }
      commanded = Pose<double>::from_xyz_rpy(250 * u(pose_rng), 250 * u(pose_rng), -60 + 40 * u(pose_rng),
                                             0.3 * u(pose_rng), 0.3 * u(pose_rng), 0.5 * u(pose_rng));
      passive = g.home;
      if (hybrid_ik(g, commanded, q, nullptr, &passive) == Status::Ok) break;
    }
    row.dir = Eigen::VectorXi(6);
    for (int i = 0; i < 6; ++i) (*row.dir)(i) = pose_rng() % 2 == 0 ? -1 : 1;
    Twist<double> e;  // drawn for every pose, used or not
    e << noise(noise_rng), noise(noise_rng), noise(noise_rng), angle_noise(noise_rng), angle_noise(noise_rng),
        angle_noise(noise_rng);
    Eigen::Matrix<double, 3, 3> target_noise;
    for (Eigen::Index j = 0; j < 9; ++j) target_noise.data()[j] = noise(noise_rng);
    const Vec6<double> driven = q + backlash.cwiseProduct(row.dir->cast<double>());
    if (model.actual_fk(truth, driven, passive, reached).status != Status::Ok) continue;
    row.id = "H" + std::to_string(k);
    row.line = std::size_t(k) + 2;
    row.role = k < 80 ? Role::Cal : Role::Test;
    row.commanded = commanded.to_xyz_rpy();
    if (full_pose) {
      row.measured = apply_twist(reached, e).to_xyz_rpy();
    } else {
      Eigen::Matrix<double, 3, 3> t = Eigen::Matrix<double, 3, 3>::Zero();
      for (std::size_t j = 0; j < true_targets.size(); ++j)
        t.col(Eigen::Index(j)) = (registration * reached).transform(true_targets[j]) + target_noise.col(Eigen::Index(j));
      row.targets = t;
    }
    if (row.role == Role::Test) {
      held_out.push_back(commanded);
      held_out_dir.push_back(row.dir->cast<double>());
    }
    if (!data.has_dir) row.dir.reset();
    data.rows.push_back(row);
  }
  HybridTrackerRun out;
  out.calibration = calibrate_targets(nominal, data);
  const TargetCalibration& cal = out.calibration;
  out.held_out_prediction_rms_um =
      1e3 * target_residuals(nominal, cal.errors, cal.registration, cal.targets, data).groups.at("test").rms_position_mm;
  CalibrationModel fitted = target_model(nominal, cal, data.file);
  Pose<double> fitted_registration = cal.registration;
  std::vector<Vec3<double>> fitted_targets = cal.targets;
  if (data.has_dir) {
    out.diagnosis = diagnose(nominal, data);
    fitted = calibrate_with_effects(nominal, data, {"backlash"});
    out.backlash = fitted.effects.values.at("backlash");
    if (!full_pose) instrument_of(fitted, fitted_registration, fitted_targets);
  }
  const HybridCompensation compensation = hybrid_compensation_from_model(fitted);
  double sum = 0, sum_rotation = 0;
  int count = 0;
  for (std::size_t h = 0; h < held_out.size(); ++h) {
    const Pose<double>& desired = held_out[h];
    Vec6<double> q;
    Pose<double> reached;
    HybridPassive<double> passive = g.home;
    Vec6<double> q_nominal;
    hybrid_ik(g, desired, q_nominal, nullptr, &passive);
    EXPECT_EQ(compensate_hybrid(compensation, desired, q), Status::Ok);
    // The backlash taken off each command by its direction (the compensator's
    // correction), and put back by the true machine.
    const Vec6<double> command = q - out.backlash.cwiseProduct(held_out_dir[h]);
    EXPECT_EQ(model.actual_fk(truth, Vec6<double>(command + backlash.cwiseProduct(held_out_dir[h])), passive, reached).status,
              Status::Ok);
    if (full_pose) {
      const Twist<double> e = pose_error(reached, desired);
      sum += e.head<3>().squaredNorm();
      sum_rotation += e.tail<3>().squaredNorm();
      ++count;
    }
    for (std::size_t j = 0; j < true_targets.size(); ++j) {
      const Vec3<double> want = (fitted_registration * desired).transform(fitted_targets[j]);
      const Vec3<double> got = (registration * reached).transform(true_targets[j]);
      sum += (got - want).squaredNorm();
      ++count;
    }
  }
  out.compensated_rms_um = 1e3 * std::sqrt(sum / count);
  out.compensated_orientation_rms_urad = 1e6 * std::sqrt(sum_rotation / count);
  return out;
}

class HybridTracker : public ::testing::TestWithParam<int> {};

TEST_P(HybridTracker, CompensatesHeldOutTargetsWithinOneAndAHalfTimesTheNoiseFloor) {
  const bool three = GetParam() == 0;
  const std::vector<Vec3<double>> nominal_targets =
      three ? std::vector<Vec3<double>>{{60, 0, -40}, {-30, 52, -40}, {-30, -52, -40}}
            : std::vector<Vec3<double>>{{40, 20, -50}};
  const std::vector<Vec3<double>> true_targets = moved_targets(nominal_targets, 500 + std::uint64_t(GetParam()), 0.3);
  const HybridTrackerRun big = run_hybrid_case(nominal_targets, true_targets, 1.0, 31);
  const HybridTrackerRun floor = run_hybrid_case(nominal_targets, moved_targets(nominal_targets, 500 + std::uint64_t(GetParam()), 0.003), 0.01, 31);
  std::cout << "hybrid, " << (three ? "three targets" : "one target") << ": " << big.calibration.free_parameters
            << " free, condition " << big.calibration.condition_number << ", compensated " << big.compensated_rms_um
            << " um (floor " << floor.compensated_rms_um << "), held-out prediction "
            << big.held_out_prediction_rms_um << " um (floor " << floor.held_out_prediction_rms_um << ")\n";
  EXPECT_EQ(big.calibration.rank, big.calibration.free_parameters);
  EXPECT_LE(big.compensated_rms_um, 1.5 * floor.compensated_rms_um);
  EXPECT_LE(big.held_out_prediction_rms_um, 1.5 * floor.held_out_prediction_rms_um);
}

INSTANTIATE_TEST_SUITE_P(ThreeAndOneTargets, HybridTracker, ::testing::Range(0, 2));

// The two tests above and below hold one machine each; this one draws eight
// more (seeds 1..8: other source errors, poses, target nests and noise) for
// each instrument, so that no bar rests on one lucky draw. Before the target
// fit's column-selection tolerance (hybrid_errors.cpp kSelectionTolerance)
// 6 of 12 such machines measured by full poses, and 1 of 12 by one target,
// were over 1.5x their floor (worst 2.93x).
TEST(HybridAcrossMachines, FullPoseAndOneAndThreeTargetsStayWithinOneAndAHalfTimesTheFloor) {
  const std::vector<Vec3<double>> three{{60, 0, -40}, {-30, 52, -40}, {-30, -52, -40}};
  const std::vector<Vec3<double>> one{{40, 20, -50}};
  for (const auto& [label, nominal_targets] :
       {std::pair{"full pose", std::vector<Vec3<double>>{}}, std::pair{"three targets", three},
        std::pair{"one target", one}}) {
    std::vector<double> ratios;
    for (std::uint64_t seed = 1; seed <= 8; ++seed) {
      const HybridTrackerRun big =
          run_hybrid_case(nominal_targets, moved_targets(nominal_targets, 700 + seed, 0.3), 1.0, seed);
      const HybridTrackerRun floor =
          run_hybrid_case(nominal_targets, moved_targets(nominal_targets, 700 + seed, 0.003), 0.01, seed);
      ratios.push_back(big.compensated_rms_um / floor.compensated_rms_um);
      EXPECT_LE(big.compensated_rms_um, 1.5 * floor.compensated_rms_um)
          << label << ", seed " << seed << ": " << big.compensated_rms_um << " um (floor " << floor.compensated_rms_um
          << ")";
      if (nominal_targets.empty()) {
        EXPECT_LE(big.compensated_orientation_rms_urad, 1.5 * floor.compensated_orientation_rms_urad)
            << label << ", seed " << seed;
      }
    }
    std::sort(ratios.begin(), ratios.end());
    std::cout << "hybrid, " << label << ", 8 machines: compensated / floor from " << ratios.front() << " to "
              << ratios.back() << "\n";
  }
}

// The hybrid from full poses (issue #12 item 2: the full pose is one of the
// measurement models either family reads): no targets, no registration, the
// same 0.3 mm / 0.3 mrad machine and 5 µm / 5 µrad noise.
TEST(HybridFullPose, CompensatesHeldOutPosesWithinOneAndAHalfTimesTheNoiseFloor) {
  const HybridTrackerRun big = run_hybrid_case({}, {}, 1.0, 37);
  const HybridTrackerRun floor = run_hybrid_case({}, {}, 0.01, 37);
  const TargetCalibration& c = big.calibration;
  std::cout << "hybrid, full poses: " << c.free_parameters << " free, condition " << c.condition_number
            << ", compensated " << big.compensated_rms_um << " um / " << big.compensated_orientation_rms_urad
            << " urad (floor " << floor.compensated_rms_um << " / " << floor.compensated_orientation_rms_urad
            << "), held-out prediction " << big.held_out_prediction_rms_um << " um (floor "
            << floor.held_out_prediction_rms_um << ")\n";
  EXPECT_TRUE(c.full_pose);
  EXPECT_TRUE(c.targets.empty());
  EXPECT_EQ(c.rank, c.free_parameters);
  // Far fewer of the 150 than all (errors along a joint's own axis, and
  // combinations no pose separates, stay held), among them the six encoder
  // offsets; the kept columns well apart (hybrid_errors.cpp
  // kSelectionTolerance: 5e6 at rounding's tolerance).
  EXPECT_GT(c.free_parameters, 6);
  EXPECT_LT(c.free_parameters, 100);
  EXPECT_LT(c.condition_number, 1e5);
  EXPECT_LE(big.compensated_rms_um, 1.5 * floor.compensated_rms_um);
  EXPECT_LE(big.compensated_orientation_rms_urad, 1.5 * floor.compensated_orientation_rms_urad);
  EXPECT_LE(big.held_out_prediction_rms_um, 1.5 * floor.held_out_prediction_rms_um);
  // Without the fit the same machine is hundreds of µm off: the floor is
  // reached by identification, not by an error too small to matter.
  EXPECT_GT(1e3 * c.history.front().rms_position_mm, 20 * big.held_out_prediction_rms_um);
}

}  // namespace

namespace {

class HybridTrackerEffect : public ::testing::TestWithParam<int> {};

TEST_P(HybridTrackerEffect, HiddenBacklashIsNamedFittedAndCompensated) {
  const bool three = GetParam() == 0;
  const std::vector<Vec3<double>> nominal_targets =
      three ? std::vector<Vec3<double>>{{60, 0, -40}, {-30, 52, -40}, {-30, -52, -40}}
            : std::vector<Vec3<double>>{{40, 20, -50}};
  const std::vector<Vec3<double>> true_targets = moved_targets(nominal_targets, 600, 0.3);
  Vec6<double> backlash;
  backlash << 0.02, -0.015, 0, 0, 0, 0;
  const HybridTrackerRun big = run_hybrid_case(nominal_targets, true_targets, 1.0, 41, backlash);
  const HybridTrackerRun floor =
      run_hybrid_case(nominal_targets, moved_targets(nominal_targets, 600, 0.003), 0.01, 41, backlash / 100);
  ASSERT_TRUE(big.diagnosis);
  std::cout << "hybrid, " << (three ? "three targets" : "one target") << ", hidden backlash: diagnosis "
            << big.diagnosis->verdict << " (accepted "
            << (big.diagnosis->accepted.empty() ? std::string("none") : big.diagnosis->accepted.front())
            << "), b1 " << big.backlash(0) << " b2 " << big.backlash(1) << " mm, compensated " << big.compensated_rms_um
            << " um (floor " << floor.compensated_rms_um << ")\n";
  ASSERT_FALSE(big.diagnosis->accepted.empty());
  EXPECT_EQ(big.diagnosis->accepted.front(), "backlash");
  EXPECT_NEAR(big.backlash(0), 0.02, 0.003);
  EXPECT_NEAR(big.backlash(1), -0.015, 0.003);
  EXPECT_LE(big.compensated_rms_um, 1.5 * floor.compensated_rms_um);
}

INSTANTIATE_TEST_SUITE_P(ThreeAndOneTargets, HybridTrackerEffect, ::testing::Range(0, 2));

TEST(HybridFullPose, HiddenBacklashIsNamedFittedAndCompensated) {
  Vec6<double> backlash;
  backlash << 0.02, -0.015, 0, 0, 0, 0;
  const HybridTrackerRun big = run_hybrid_case({}, {}, 1.0, 43, backlash);
  const HybridTrackerRun floor = run_hybrid_case({}, {}, 0.01, 43, backlash / 100);
  ASSERT_TRUE(big.diagnosis);
  std::cout << "hybrid, full poses, hidden backlash: diagnosis " << big.diagnosis->verdict << " (accepted "
            << (big.diagnosis->accepted.empty() ? std::string("none") : big.diagnosis->accepted.front()) << "), b1 "
            << big.backlash(0) << " b2 " << big.backlash(1) << " mm, compensated " << big.compensated_rms_um
            << " um / " << big.compensated_orientation_rms_urad << " urad (floor " << floor.compensated_rms_um << " / "
            << floor.compensated_orientation_rms_urad << ")\n";
  ASSERT_FALSE(big.diagnosis->accepted.empty());
  EXPECT_EQ(big.diagnosis->accepted.front(), "backlash");
  EXPECT_NEAR(big.backlash(0), 0.02, 0.003);
  EXPECT_NEAR(big.backlash(1), -0.015, 0.003);
  EXPECT_LE(big.compensated_rms_um, 1.5 * floor.compensated_rms_um);
  EXPECT_LE(big.compensated_orientation_rms_urad, 1.5 * floor.compensated_orientation_rms_urad);
}

}  // namespace
