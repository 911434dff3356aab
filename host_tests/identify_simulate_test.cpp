// The simulated actual machine: exact reproduction with zero errors, gauge
// geometry, reproducible noise of the requested size, flagged failures.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "kincal/identify/hybrid_error_model.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/simulate.hpp"

namespace ki = kincal::identify;
using kincal::Vec3;
using kincal::Vec6;

namespace {

ki::PoseTable table_of(const std::vector<Vec6<double>>& poses) {
  ki::PoseTable t;
  t.file = "poses.csv";
  for (std::size_t i = 0; i < poses.size(); ++i) {
    ki::PoseRow r;
    r.id = "n" + std::to_string(i);
    r.line = i + 2;
    r.commanded = poses[i];
    t.rows.push_back(r);
  }
  return t;
}

std::vector<Vec6<double>> stewart_poses() {
  std::vector<Vec6<double>> p;
  const double d = kincal::pi<double>() / 180;
  for (double x : {-15.0, 0.0, 15.0})
    for (double y : {-15.0, 0.0, 15.0})
      for (double z : {190.0, 210.0}) p.push_back((Vec6<double>() << x, y, z, 2 * d * x / 15, -3 * d * y / 15, d).finished());
  return p;
}

// The hybrid's task cuboid 500 × 500 × 120 mm about the reference pose, with
// the polishing head at constant orientation (GUIDE "Reading seed 000").
std::vector<Vec6<double>> hybrid_poses() {
  std::vector<Vec6<double>> p;
  for (double x : {-250.0, 0.0, 250.0})
    for (double y : {-250.0, 0.0, 250.0})
      for (double z : {-60.0, 0.0, 60.0}) p.push_back((Vec6<double>() << x, y, z, 0, 0, 0).finished());
  return p;
}

}  // namespace

TEST(identifySimulate, ZeroErrorsReproduceTheCommandedPoses) {
  for (const char* name : {"stewart-seed001", "hybrid-seed000"}) {
    const ki::Robot robot = ki::builtin_robot(name);
    const ki::PoseTable in = table_of(robot.is_stewart() ? stewart_poses() : hybrid_poses());
    ki::SimulateReport rep;
    const ki::PoseTable out = ki::simulate(robot, robot, in, {}, rep);
    EXPECT_EQ(rep.simulated, in.rows.size()) << name;
    EXPECT_EQ(rep.failed, 0u) << name;
    EXPECT_FALSE(out.has_status);
    EXPECT_EQ(out.has_targets, robot.is_hybrid());
    for (const ki::PoseRow& r : out.rows) {
      ASSERT_TRUE(r.measured.has_value()) << name << " " << r.id;
      EXPECT_LT((*r.measured - r.commanded).cwiseAbs().maxCoeff(), 1e-9) << name << " " << r.id;
    }
  }
}

TEST(identifySimulate, ErrorsMoveThePoseAndCommandsComeFromTheNominalModel) {
  const ki::Robot nominal = ki::builtin_robot("stewart-seed001");
  // A pure leg-length offset on all legs lifts the platform at home by about dl / cos(leg tilt).
  ki::ParameterSet p;
  for (int i = 1; i <= 6; ++i) p.values.push_back({"dl" + std::to_string(i), 0.1, 0});
  const ki::Robot actual = ki::apply_parameters(nominal, p);
  ki::SimulateReport rep;
  const ki::PoseTable out = ki::simulate(nominal, actual, table_of({(Vec6<double>() << 0, 0, 200, 0, 0, 0).finished()}), {}, rep);
  const Vec6<double> m = *out.rows[0].measured;
  // Table 2's coordinates are rounded to ~1e-6 mm, so the machine is only
  // nearly symmetric: the platform moves sideways by ~1e-9 mm.
  EXPECT_NEAR(m(0), 0, 1e-6);
  EXPECT_NEAR(m(1), 0, 1e-6);
  EXPECT_GT(m(2), 200.1);  // legs are tilted, so z rises by more than dl
  EXPECT_LT(m(2), 200.2);
  // The actual machine's legs at the measured pose are q + dl.
  Vec6<double> q_nom, q_act;
  ASSERT_EQ(kincal::stewart_ik(nominal.stewart(), kincal::Pose<double>::from_xyz_rpy(0, 0, 200, 0, 0, 0), q_nom),
            kincal::Status::Ok);
  ASSERT_EQ(kincal::stewart_ik(actual.stewart(), kincal::Pose<double>::from_xyz_rpy(m), q_act), kincal::Status::Ok);
  EXPECT_LT((q_act - q_nom).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(identifySimulate, GaugeTargetsAre200mmFromP0AndMatchThePose) {
  const ki::Robot nominal = ki::builtin_robot("hybrid-seed000");
  ki::ParameterSet p;
  p.values = {{"dq1", 0.05, 0}, {"dtheta5", 2e-4, 0}, {"dXa2", -0.1, 0}, {"d_tool_length", 0.08, 0}};
  const ki::Robot actual = ki::apply_parameters(nominal, p);
  ki::SimulateReport rep;
  const ki::PoseTable out = ki::simulate(nominal, actual, table_of(hybrid_poses()), {}, rep);
  ASSERT_EQ(rep.failed, 0u);
  const kincal::HybridGeometry<double>& g = actual.hybrid();
  for (const ki::PoseRow& r : out.rows) {
    ASSERT_TRUE(r.targets.has_value());
    const kincal::Pose<double> tool = kincal::Pose<double>::from_xyz_rpy(*r.measured);
    EXPECT_GT((tool.p - r.commanded.head<3>()).norm(), 1e-3) << "errors should move the tool";
    // P0 from the actual machine's own chain: FK's passive configuration and
    // the physical wrist angles, taken to the workpiece frame.
    Vec6<double> q;
    kincal::HybridPassive<double> s;
    ASSERT_EQ(kincal::hybrid_ik(nominal.hybrid(), kincal::Pose<double>::from_xyz_rpy(r.commanded), q, nullptr, &s),
              kincal::Status::Ok);
    kincal::Pose<double> fk_pose;
    kincal::HybridPassive<double> s_act;
    ASSERT_EQ(kincal::hybrid_fk(g, q, s, fk_pose, &s_act).status, kincal::Status::Ok);
    const Vec6<double> phys = q + g.joint_offset;
    const kincal::HybridFrames<double> f = kincal::hybrid_frames(g, s_act, Vec3<double>(phys.tail<3>()));
    const Vec3<double> p0 = g.workpiece_rotation * (f.P0 - g.workpiece_origin);
    const Vec3<double> pt = g.workpiece_rotation * (f.P - g.workpiece_origin);
    EXPECT_LT((pt - tool.p).norm(), 1e-9);
    const Eigen::Matrix3d& t = *r.targets;
    for (int j = 0; j < 3; ++j) {
      EXPECT_NEAR((t.col(j) - p0).norm(), 200.0, 1e-9) << r.id;
      EXPECT_NEAR((t.col(j) - p0).dot(pt - p0), 0.0, 1e-9) << r.id;  // plane normal to the tool axis
    }
    EXPECT_LT((t.rowwise().mean() - p0).norm(), 1e-9);  // equilateral about P0
    const Vec3<double> x_tool = tool.R.col(0), y_tool = tool.R.col(1);
    EXPECT_NEAR((t.col(0) - p0).normalized().dot(y_tool), 1.0, 1e-12);   // P0P1 along y
    EXPECT_NEAR((t.col(2) - t.col(1)).normalized().dot(x_tool), 1.0, 1e-12);  // P2P3 along x
    EXPECT_LT((t - ki::gauge_targets(g, 200.0, tool)).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(identifySimulate, NoiseIsReproducibleAndHasTheRequestedSize) {
  const ki::Robot robot = ki::builtin_robot("stewart-seed001");
  std::vector<Vec6<double>> poses;
  for (int i = 0; i < 400; ++i) poses.push_back((Vec6<double>() << (i % 20) - 10.0, (i / 20) - 10.0, 200, 0, 0, 0).finished());
  const ki::PoseTable in = table_of(poses);
  ki::SimulateOptions opt;
  opt.noise_mm = 0.01;
  opt.noise_rad = 2e-5;
  opt.seed = 42;
  ki::SimulateReport rep;
  const ki::PoseTable a = ki::simulate(robot, robot, in, opt, rep);
  const ki::PoseTable b = ki::simulate(robot, robot, in, opt, rep);
  opt.seed = 43;
  const ki::PoseTable c = ki::simulate(robot, robot, in, opt, rep);
  double sp = 0, sr = 0, mean_p = 0;
  bool differs = false;
  for (std::size_t i = 0; i < in.rows.size(); ++i) {
    EXPECT_EQ(*a.rows[i].measured, *b.rows[i].measured);
    differs = differs || *a.rows[i].measured != *c.rows[i].measured;
    const Vec6<double> e = *a.rows[i].measured - in.rows[i].commanded;
    sp += e.head<3>().squaredNorm();
    sr += e.tail<3>().squaredNorm();
    mean_p += e.head<3>().sum();
  }
  EXPECT_TRUE(differs);
  const double n = 3.0 * static_cast<double>(in.rows.size());  // 1200 samples each
  EXPECT_NEAR(std::sqrt(sp / n), 0.01, 0.001);  // σ̂ within 10 % (its own spread is ~2 %)
  EXPECT_NEAR(std::sqrt(sr / n), 2e-5, 2e-6);
  EXPECT_LT(std::abs(mean_p / n), 0.001);
  // No noise unless asked.
  const ki::PoseTable z = ki::simulate(robot, robot, in, {}, rep);
  EXPECT_LT((*z.rows[7].measured - in.rows[7].commanded).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(identifySimulate, TargetNoiseIsPerCoordinate) {
  const ki::Robot robot = ki::builtin_robot("hybrid-seed000");
  std::vector<Vec6<double>> poses;
  for (int i = 0; i < 200; ++i) poses.push_back((Vec6<double>() << 2.0 * i - 200, 0, 0, 0, 0, 0).finished());
  ki::SimulateOptions opt;
  opt.noise_mm = 0.005;
  ki::SimulateReport rep;
  const ki::PoseTable a = ki::simulate(robot, robot, table_of(poses), opt, rep);
  double s = 0;
  for (const ki::PoseRow& r : a.rows)
    s += (*r.targets - ki::gauge_targets(robot.hybrid(), 200, kincal::Pose<double>::from_xyz_rpy(r.commanded)))
             .squaredNorm();
  EXPECT_NEAR(std::sqrt(s / (9.0 * 200)), 0.005, 0.0005);
}

TEST(identifySimulate, FailingRowsAreFlaggedNotDropped) {
  const ki::Robot robot = ki::builtin_robot("stewart-seed001");
  ki::PoseTable in = table_of({(Vec6<double>() << 0, 0, 200, 0, 0, 0).finished(),
                               (Vec6<double>() << 0, 0, 400, 0, 0, 0).finished(),
                               (Vec6<double>() << 0, 0, 200, 0, 0, 0).finished()});
  // Row 3 carries joint commands outside the stroke: the FK refuses them.
  in.has_q = true;
  for (ki::PoseRow& r : in.rows) r.q = Eigen::VectorXd::Constant(6, 233.0);
  in.rows[1].q.reset();
  in.has_q = false;
  in.rows[0].q.reset();
  in.rows[2].q = Eigen::VectorXd::Constant(6, 300.0);
  std::vector<std::string> warnings;
  ki::SimulateReport rep;
  const ki::PoseTable out =
      ki::simulate(robot, robot, in, {}, rep, [&](const std::string& w) { warnings.push_back(w); });
  EXPECT_EQ(rep.simulated, 1u);
  EXPECT_EQ(rep.failed, 2u);
  ASSERT_EQ(out.rows.size(), 3u);
  EXPECT_TRUE(out.has_status);
  EXPECT_EQ(out.rows[0].status, "ok");
  EXPECT_EQ(out.rows[1].status, "out of limits");
  EXPECT_FALSE(out.rows[1].measured.has_value());
  EXPECT_EQ(out.rows[2].status, "out of limits");
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_EQ(warnings[0],
            "poses.csv:3: warning: row 'n1': inverse kinematics of the commanded pose failed (out of limits); "
            "written with empty measurements and status 'out of limits'");
  EXPECT_NE(warnings[1].find("poses.csv:4: warning: row 'n2': forward kinematics of the erroneous machine failed"),
            std::string::npos)
      << warnings[1];
}

TEST(identifySimulate, RejectsBadNoiseAndMixedFamilies) {
  const ki::Robot s = ki::builtin_robot("stewart-seed001");
  const ki::Robot h = ki::builtin_robot("hybrid-seed000");
  const ki::PoseTable in = table_of({(Vec6<double>() << 0, 0, 200, 0, 0, 0).finished()});
  ki::SimulateReport rep;
  ki::SimulateOptions bad;
  bad.noise_mm = -1;
  EXPECT_THROW(ki::simulate(s, s, in, bad, rep), ki::InputError);
  bad.noise_mm = std::nan("");
  EXPECT_THROW(ki::simulate(s, s, in, bad, rep), ki::InputError);
  EXPECT_THROW(ki::simulate(s, h, in, {}, rep), ki::InputError);
}

// PARAMS.csv can carry seed 000's source errors; simulate then runs the
// nonlinear chain model with every source error (identify/hybrid_error_model).
TEST(identifySimulate, HybridSourceErrorsDriveTheChainModel) {
  const ki::Robot nominal = ki::builtin_robot("hybrid-seed000");
  const ki::ParameterSet errors =
      ki::parse_parameters("name,value\ndxi_3_1,0.3\ndx_2_1,0.05\ndalpha_3_4,0.0002\n", "src.csv", nominal);
  const ki::Robot actual = ki::apply_parameters(nominal, errors);
  ASSERT_EQ(actual.hybrid_description().source_errors.size(), ki::HybridErrorModel::kParameterCount);
  const ki::HybridErrorModel model(nominal.hybrid());
  EXPECT_EQ(actual.hybrid_description().source_errors(model.index_of("dx_2_1")), 0.05);
  const ki::PoseTable poses = ki::parse_pose_table("id,x,y,z,rx,ry,rz\na,100,-50,20,0,0,0\n", "p.csv");
  ki::SimulateReport rep;
  const ki::PoseTable out = ki::simulate(nominal, actual, poses, ki::SimulateOptions{}, rep);
  ASSERT_TRUE(out.rows[0].measured);
  // The same as calling the chain model directly on the nominal IK's commands.
  kincal::Vec6<double> q;
  kincal::HybridPassive<double> s;
  ASSERT_EQ(kincal::hybrid_ik(nominal.hybrid(), kincal::Pose<double>::from_xyz_rpy(poses.rows[0].commanded), q, nullptr, &s),
            kincal::Status::Ok);
  kincal::Pose<double> direct;
  ASSERT_EQ(model.actual_fk(actual.hybrid_description().source_errors, q, s, direct).status, kincal::Status::Ok);
  EXPECT_LT((kincal::Pose<double>::from_xyz_rpy(*out.rows[0].measured).p - direct.p).norm(), 1e-9);
  // And the errors are felt: the encoder offset alone moves the tool ~0.3 mm.
  EXPECT_GT((direct.p - kincal::Pose<double>::from_xyz_rpy(poses.rows[0].commanded).p).norm(), 0.1);
}
