// Issue #33: the 6-RUS identified from ONE tracker target in the tracker's
// own frame, on data kincal did not make. The machine is the second
// independent simulator, independent/rus6_simulator.hpp (rus6_ref_nominal:
// kincal's rus6-ref re-entered; motor frames perturbed in motor
// coordinates, a crank pin with three offsets, a tool frame of its own, its
// own IK and damped FK), errors of 0.05 mm / 0.5 mrad, 2 µm noise on the
// target, 100 random poses in its box, every fifth held out.
//
// The loop through the command line: `kincal identify --instrument-frame`
// with a robot description naming one target (nominal position 1.5 mm from
// the true one), `kincal compensate` of the held-out poses, the simulator
// driven by those commands. With one target the model's platform frame
// and base frame are its convention's, so what is compared is where the
// target goes, in the tracker's frame: the model's registration ·
// pose · target against the true registration · reached pose · true target.
// kincal's 66 parameters are the true model of this machine for one target
// (the pin offsets are a longer crank, a crank zero and a shaft point; the
// tool frame is absorbed by the target's position), so the bar is the noise:
// the held-out error within 2 × σ·√3 (RMS of a 3-D point error of σ per
// coordinate), and at least 50 times below the uncompensated one.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "independent/rus6_simulator.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/diagnosis.hpp"
#include "kincal/identify/files.hpp"
#include "kincal/identify/robot.hpp"
#include "tool_run.hpp"

namespace {

namespace ind = kincal::independent;
using V6 = kincal::Vec6<double>;
using V3 = kincal::Vec3<double>;

TEST(IndependentRus6Tracker, OneTargetInTheTrackersFrameCompensatesToTheNoise) {
  const std::string dir = "identify_independent_rus6_tracker";
  std::filesystem::create_directories(dir);
  const ind::Rus6Nominal nominal = ind::rus6_ref_nominal();
  const ind::Rus6Errors errors = ind::random_rus6_errors(0.05, 5e-4, 29);
  const V3 true_target(62.0, -35.0, 31.0);  // on the platform, mm
  const kincal::Pose<double> tracker = kincal::Pose<double>::from_xyz_rpy(1800, 600, -250, 0.03, -0.02, 2.6);
  const std::vector<V6> poses = ind::rus6_random_poses(nominal, 100, 31);
  std::vector<std::string> roles;
  for (std::size_t k = 0; k < poses.size(); ++k) roles.push_back(k % 5 == 4 ? "test" : "cal");
  ind::Rus6DatasetOptions options;
  options.roles = roles;
  const ind::Dataset d =
      ind::make_rus6_dataset(nominal, errors, {}, poses, ind::rus6_measurement(2, 5, 7, {true_target}, tracker), options);
  ASSERT_TRUE(d.skipped.empty()) << d.skipped.front();
  const std::string data = dir + "/measured.csv";
  ind::write_measurement_csv_file(data, d);
  kincal::identify::Robot robot = kincal::identify::builtin_robot("rus6-ref");
  robot.targets = {true_target + V3(1.0, -1.0, 0.5)};
  const std::string robot_file = kincal_test::write_in(dir, "rus6_one_target.json", kincal::identify::robot_to_json(robot));
  const std::string model = dir + "/model.json";
  const kincal_test::ToolRun id = kincal_test::run_tool_in(
      dir, "identify --robot " + robot_file + " --data " + data + " --instrument-frame --out " + model);
  ASSERT_EQ(id.code, 0) << id.err;
  // The held-out poses, compensated.
  std::string text = "id,x,y,z,rx,ry,rz\n";
  std::vector<V6> held_out;
  for (const ind::DatasetRow& r : d.rows)
    if (r.role == "test") {
      held_out.push_back(r.commanded);
      text += r.id;
      for (int k = 0; k < 6; ++k) text += "," + ind::csv_number(r.commanded(k));
      text += "\n";
    }
  const std::string poses_file = kincal_test::write_in(dir, "test_poses.csv", text);
  const std::string joints = dir + "/joints.csv";
  const kincal_test::ToolRun comp = kincal_test::run_tool_in(
      dir, "compensate --robot " + robot_file + " --model " + model + " --poses " + poses_file + " --out " + joints);
  ASSERT_EQ(comp.code, 0) << comp.err;
  // The model's instrument: registration (base frame in the tracker's) and the target.
  const nlohmann::json j = nlohmann::json::parse(kincal::identify::read_text_file(model));
  std::map<std::string, double> inst;
  for (const auto& e : j.at("instrument")) inst[e.at("name").get<std::string>()] = e.at("value").get<double>();
  const kincal::Pose<double> registration = kincal::Pose<double>::from_xyz_rpy(
      inst.at("reg_x"), inst.at("reg_y"), inst.at("reg_z"), inst.at("reg_rx"), inst.at("reg_ry"), inst.at("reg_rz"));
  const V3 target(inst.at("t1x"), inst.at("t1y"), inst.at("t1z"));
  const kincal::identify::PoseTable table = kincal::identify::read_pose_table(joints);
  ASSERT_EQ(table.rows.size(), held_out.size());
  const ind::Rus6Simulator machine(nominal, errors);
  const ind::Rus6Simulator controller(nominal);
  double before = 0, after = 0;
  for (std::size_t k = 0; k < held_out.size(); ++k) {
    const kincal::Pose<double> asked = kincal::Pose<double>::from_xyz_rpy(held_out[k]);
    const V3 promised = registration.transform(asked.transform(target));
    ASSERT_TRUE(table.rows[k].q.has_value());
    const ind::Rus6FkResult compensated = machine.fk(table.rows[k].q->head<6>(), &asked);
    V6 q_nominal;
    ASSERT_TRUE(controller.ik(asked, q_nominal));
    const ind::Rus6FkResult uncompensated = machine.fk(q_nominal, &asked);
    ASSERT_TRUE(compensated.ok && uncompensated.ok) << k;
    after += (tracker.transform(compensated.pose.transform(true_target)) - promised).squaredNorm();
    before += (tracker.transform(uncompensated.pose.transform(true_target)) - promised).squaredNorm();
  }
  const double n = double(held_out.size());
  const double rms_after_um = 1e3 * std::sqrt(after / n), rms_before_um = 1e3 * std::sqrt(before / n);
  RecordProperty("rms_before_um", std::to_string(rms_before_um));
  RecordProperty("rms_after_um", std::to_string(rms_after_um));
  std::printf("  one target, tracker's frame: held-out %.3f um uncompensated -> %.3f um compensated (%zu poses)\n",
              rms_before_um, rms_after_um, held_out.size());
  EXPECT_LT(rms_after_um, 2 * 2.0 * std::sqrt(3.0));
  EXPECT_GT(rms_before_um, 50 * rms_after_um);
}

// The diagnosis's per-node picture from one target (the report's vectors,
// the by-covariate slopes): the target's own displacement, turned into the
// base frame — what the data determine. Checked against the diagnosis's own
// base RMS, which is taken straight from the residual vector: with one
// target the picture's length at each cal node is that node's residual's
// (R is a rotation), so their RMS per coordinate are equal. The least-norm
// twist's translation, the picture before, put a rotation 5 000× cheaper
// than a translation at a 75 mm arm and kept little more than the
// displacement along the arm (here 1.02 of 1.68 µm RMS: about a third of
// the energy of a displacement in no particular direction). Same machine and
// tracker as above, the residual 2 µm noise (kincal's 66 parameters are
// this machine's true model), no held-out rows, the library's diagnose().
TEST(IndependentRus6Tracker, OneTargetNodePictureIsTheTargetsDisplacement) {
  const ind::Rus6Nominal nominal = ind::rus6_ref_nominal();
  const ind::Rus6Errors errors = ind::random_rus6_errors(0.05, 5e-4, 29);
  const V3 true_target(62.0, -35.0, 31.0);
  const kincal::Pose<double> tracker = kincal::Pose<double>::from_xyz_rpy(1800, 600, -250, 0.03, -0.02, 2.6);
  const std::vector<V6> poses = ind::rus6_random_poses(nominal, 80, 37);
  const ind::Dataset d =
      ind::make_rus6_dataset(nominal, errors, {}, poses, ind::rus6_measurement(2, 5, 11, {true_target}, tracker), {});
  ASSERT_TRUE(d.skipped.empty()) << d.skipped.front();
  const std::string dir = "identify_independent_rus6_tracker";
  std::filesystem::create_directories(dir);
  const std::string data_file = dir + "/picture_measured.csv";
  ind::write_measurement_csv_file(data_file, d);
  kincal::identify::Robot robot = kincal::identify::builtin_robot("rus6-ref");
  robot.targets = {true_target + V3(1.0, -1.0, 0.5)};
  kincal::identify::PoseTableOptions o;
  o.joint_count = 6;
  kincal::identify::PoseTable data = kincal::identify::read_pose_table(data_file, o);
  data.in_instrument_frame = true;
  kincal::identify::DiagnoseOptions options;
  options.noise_um = 2.0;
  options.candidates = {"thermal"};  // the base model's residual is what is compared
  options.keep_outliers = true;      // every cal node in both numbers
  const kincal::identify::Diagnosis diag = kincal::identify::diagnose(robot, data, options);
  ASSERT_GT(diag.rms.cal, 0.5);  // the noise left by the fit
  double sum = 0;
  std::size_t cal = 0;
  for (const kincal::identify::NodeResidual& n : diag.nodes) {
    if (n.test) continue;
    sum += n.before.squaredNorm();
    ++cal;
  }
  ASSERT_EQ(cal, diag.rms.cal_nodes);
  const double picture_rms = std::sqrt(sum / double(3 * cal));
  std::printf("  one target: base RMS %.4f um; the per-node picture's RMS %.4f um\n", diag.rms.cal, picture_rms);
  EXPECT_NEAR(picture_rms, diag.rms.cal, 1e-6 * diag.rms.cal);
}

// The verdict's σ-free held-out-against-cal test (diagnosis.cpp judge;
// docs/diagnosis.md "Structure forbids `explained`"): under a complete model
// the ratio of the held-out mean square, in the metric of the prediction's
// covariance, to the cal mean square per degree of freedom is
// F(n_test, n_cal − p), so it averages ~1 and falls below α = 0.01 about once
// in a hundred. Checked where the prediction's spread matters most, one
// target in the tracker's frame (held-out leverage ~0.4: without it the
// ratio would average ~1.4): 30 fresh noise draws
// of the independent simulator on one machine whose true model kincal has
// (other target, tracker, poses and role pattern than the tests above: 90
// random poses, every fourth held out, 3 µm noise, the noise estimated).
TEST(IndependentRus6Tracker, HeldOutAgainstCalRatioIsCalibratedOnACompleteModel) {
  const ind::Rus6Nominal nominal = ind::rus6_ref_nominal();
  const ind::Rus6Errors errors = ind::random_rus6_errors(0.08, 3e-4, 43);
  const V3 true_target(-48.0, 57.0, 24.0);
  const kincal::Pose<double> tracker = kincal::Pose<double>::from_xyz_rpy(-900, -1700, 400, -0.04, 0.01, 0.7);
  const std::vector<V6> poses = ind::rus6_random_poses(nominal, 90, 53);
  ind::Rus6DatasetOptions options;
  for (std::size_t k = 0; k < poses.size(); ++k) options.roles.push_back(k % 4 == 3 ? "test" : "cal");
  kincal::identify::Robot robot = kincal::identify::builtin_robot("rus6-ref");
  robot.targets = {true_target + V3(-0.8, 1.2, 0.4)};
  const std::string dir = "identify_independent_rus6_tracker";
  std::filesystem::create_directories(dir);
  const int draws = 30;
  double sum = 0;
  int below_alpha = 0;
  std::printf("  held-out / cal ratio over %d noise draws:", draws);
  for (int draw = 0; draw < draws; ++draw) {
    const ind::Dataset d = ind::make_rus6_dataset(
        nominal, errors, {}, poses, ind::rus6_measurement(3, 0, 1000 + std::uint64_t(draw), {true_target}, tracker),
        options);
    ASSERT_TRUE(d.skipped.empty()) << d.skipped.front();
    const std::string data_file = dir + "/calibration_measured.csv";
    ind::write_measurement_csv_file(data_file, d);
    kincal::identify::PoseTableOptions o;
    o.joint_count = 6;
    kincal::identify::PoseTable data = kincal::identify::read_pose_table(data_file, o);
    data.in_instrument_frame = true;
    const kincal::identify::Diagnosis diag = kincal::identify::diagnose(robot, data, {});
    ASSERT_GT(diag.held_out_ratio, 0.0) << "draw " << draw;
    EXPECT_TRUE(diag.accepted.empty()) << "draw " << draw;
    sum += diag.held_out_ratio;
    if (diag.held_out_p < 0.01) ++below_alpha;
    std::printf(" %.2f", diag.held_out_ratio);
  }
  const double mean = sum / draws;
  std::printf("\n  mean %.3f; p < 0.01 in %d of %d\n", mean, below_alpha, draws);
  // F(≈70, ≈140) has a spread of ~0.21: the mean of 30 within ±0.12 is 3
  // standard errors; more than 2 of 30 below α has probability ~0.4 %.
  EXPECT_NEAR(mean, 1.0, 0.12);
  EXPECT_LE(below_alpha, 2);
}

}  // namespace
