// Issue #11 item 5: a measurement blunder must not spoil the model. One
// mechanism (identify/outliers.hpp) for plain identification and for
// identification with effects: the flagged row is listed with its statistic
// and left out of the fit, and the held-out compensation is then as good as
// on the same data without the blunder.
//
// How this data differs from the rest of the suite: random poses (no grid, no
// layer / dir / q columns) on seed 001's geometry, 42 random errors of up to
// 30 µm (not Table 3), measured by this test's own generator — core's FK at
// the physical joints, the scale effect applied here by hand as
// q_physical = (1 + s_i)·q_i, Gaussian noise of 1 µm / 2 µrad drawn here —
// and one row's x made 50 µm wrong (a blunder of 50 σ), at a row the code
// does not know in advance.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "kincal/core/stewart.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/diagnosis.hpp"
#include "kincal/identify/effect_calibration.hpp"
#include "kincal/identify/outliers.hpp"
#include "kincal/identify/robot.hpp"
#include "kincal/identify/stewart_calibration.hpp"

namespace ki = kincal::identify;
using kincal::Pose;
using kincal::Status;
using kincal::Vec6;

namespace {

struct Machine {
  kincal::StewartGeometry<double> geometry;  // the real one (stroke opened: the machine goes where it goes)
  Vec6<double> scale = Vec6<double>::Zero();
};

Machine machine(const ki::Robot& robot, std::uint64_t seed, bool with_scale) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-0.03, 0.03);
  Eigen::VectorXd e(42);
  for (auto& v : e) v = u(rng);
  Machine m;
  m.geometry = ki::stewart_with_errors(robot.stewart(), e);
  m.geometry.min_length.setConstant(-1e6);
  m.geometry.max_length.setConstant(1e6);
  if (with_scale) m.scale << 4e-4, -3e-4, 2e-4, -4e-4, 3e-4, -2e-4;
  return m;
}

// Random poses inside the stroke (5 mm margin), x, y ±40 mm, z 175–225 mm,
// tilts ±4°, yaw ±6°.
std::vector<Vec6<double>> poses(const ki::Robot& robot, std::size_t count, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> xy(-40, 40), z(175, 225), tilt(-4 * M_PI / 180, 4 * M_PI / 180),
      yaw(-6 * M_PI / 180, 6 * M_PI / 180);
  const auto& g = robot.stewart();
  std::vector<Vec6<double>> out;
  while (out.size() < count) {
    Vec6<double> p;
    p << xy(rng), xy(rng), z(rng), tilt(rng), tilt(rng), yaw(rng);
    Vec6<double> q;
    if (kincal::stewart_ik(g, Pose<double>::from_xyz_rpy(p), q) != Status::Ok) continue;
    if ((q.array() < g.min_length.array() + 5).any() || (q.array() > g.max_length.array() - 5).any()) continue;
    out.push_back(p);
  }
  return out;
}

Pose<double> reached(const ki::Robot& robot, const Machine& m, const Vec6<double>& q_command, const Pose<double>& guess) {
  const Vec6<double> q = q_command.cwiseProduct(Vec6<double>::Ones() + m.scale);
  Pose<double> p;
  EXPECT_EQ(kincal::stewart_fk(m.geometry, q, guess, p).status, Status::Ok);
  (void)robot;
  return p;
}

// 100 cal rows measured with noise; row `blunder` (if ≥ 0) 50 µm off in x.
ki::PoseTable measure(const ki::Robot& robot, const Machine& m, const std::vector<Vec6<double>>& cal, int blunder) {
  std::mt19937_64 rng(77);
  std::normal_distribution<double> n(0.0, 1.0);
  ki::PoseTable t;
  t.file = "blunder.csv";
  t.has_measured = true;
  for (std::size_t k = 0; k < cal.size(); ++k) {
    ki::PoseRow r;
    r.id = "r" + std::to_string(k);
    r.line = k + 2;
    r.commanded = cal[k];
    const Pose<double> commanded = Pose<double>::from_xyz_rpy(cal[k]);
    Vec6<double> q;
    EXPECT_EQ(kincal::stewart_ik(robot.stewart(), commanded, q), Status::Ok);
    Vec6<double> noise;
    noise << 1e-3 * n(rng), 1e-3 * n(rng), 1e-3 * n(rng), 2e-6 * n(rng), 2e-6 * n(rng), 2e-6 * n(rng);
    r.measured = reached(robot, m, q, commanded).to_xyz_rpy() + noise;
    if (int(k) == blunder) (*r.measured)(0) += 0.050;
    t.rows.push_back(r);
  }
  return t;
}

// RMS position error (µm) of the real machine at held-out poses compensated
// with `model` by the controller's routine.
double held_out_um(const ki::Robot& robot, const Machine& m, const ki::CalibrationModel& model,
                   const std::vector<Vec6<double>>& test) {
  ki::PoseTable t;
  for (std::size_t k = 0; k < test.size(); ++k) {
    ki::PoseRow r;
    r.id = "t" + std::to_string(k);
    r.commanded = test[k];
    t.rows.push_back(r);
  }
  const ki::CompensatedStream s = ki::compensate_rows(ki::calibration_table(model), model, t);
  double sum = 0;
  for (std::size_t k = 0; k < test.size(); ++k) {
    EXPECT_EQ(s.rows[k].status, kincal::CompensationStatus::Ok);
    const Pose<double> target = Pose<double>::from_xyz_rpy(test[k]);
    sum += (reached(robot, m, s.rows[k].q, target).p - target.p).squaredNorm();
  }
  return 1e3 * std::sqrt(sum / double(test.size()));
}

}  // namespace

TEST(identifyBlunder, PlainIdentifyLeavesTheBlunderOutAndCompensatesAsWithoutIt) {
  const ki::Robot robot = ki::builtin_robot("stewart-seed001");
  const Machine m = machine(robot, 5, false);
  std::mt19937_64 rng(41);
  const std::vector<Vec6<double>> cal = poses(robot, 100, rng), test = poses(robot, 40, rng);
  const int bad = 63;
  const ki::PoseTable clean = measure(robot, m, cal, -1), blundered = measure(robot, m, cal, bad);

  const ki::StewartCalibration clean_fit = ki::calibrate_stewart(robot, clean);
  const ki::StewartOutlierSearch clean_search = ki::stewart_outlier_search(robot, clean, clean_fit);
  EXPECT_TRUE(clean_search.removed.empty()) << "clean data: nothing flagged";
  const double floor = held_out_um(robot, m, ki::stewart_model(robot, clean_fit, clean.file), test);

  const ki::StewartCalibration all = ki::calibrate_stewart(robot, blundered);
  const ki::StewartOutlierSearch search = ki::stewart_outlier_search(robot, blundered, all);
  ASSERT_EQ(search.removed.size(), 1u);
  EXPECT_FALSE(search.systematic);
  EXPECT_EQ(search.removed.front().id, "r63");
  EXPECT_EQ(search.removed.front().line, 65u);
  EXPECT_LT(search.removed.front().p_value, 1e-6);
  EXPECT_EQ(search.rest.nodes, 99u);
  const double kept = held_out_um(robot, m, ki::stewart_model(robot, all, blundered.file), test);
  const double left_out = held_out_um(robot, m, ki::stewart_model(robot, search.rest, blundered.file), test);
  std::printf("plain: held-out %.3f um with the blunder fitted, %.3f um left out, %.3f um on clean data\n", kept,
              left_out, floor);
  EXPECT_GT(kept, 1.2 * floor) << "the blunder must matter, else the test shows nothing";
  EXPECT_LT(left_out, 1.1 * floor);
}

TEST(identifyBlunder, IdentifyWithEffectsUsesTheSameScreen) {
  const ki::Robot robot = ki::builtin_robot("stewart-seed001");
  const Machine m = machine(robot, 9, true);
  std::mt19937_64 rng(43);
  const std::vector<Vec6<double>> cal = poses(robot, 100, rng), test = poses(robot, 40, rng);
  const ki::PoseTable clean = measure(robot, m, cal, -1), blundered = measure(robot, m, cal, 17);

  ki::EffectCalibrationReport clean_report;
  const ki::CalibrationModel clean_model = ki::calibrate_with_effects(robot, clean, {"scale"}, {}, &clean_report);
  EXPECT_TRUE(ki::screen_outliers(clean_report.final_problem, clean_report.nodes).flagged.empty());
  const double floor = held_out_um(robot, m, clean_model, test);

  struct Fit {
    ki::CalibrationModel model;
    ki::EffectCalibrationReport report;
  };
  const auto fit = [&](const ki::PoseTable& rows) {
    Fit f;
    f.model = ki::calibrate_with_effects(robot, rows, {"scale"}, {}, &f.report);
    return f;
  };
  const Fit everything = fit(blundered);
  const ki::ScreenedFit<Fit> screened = ki::screen_and_refit(
      blundered, everything, [](const Fit& f) -> const ki::LinearProblem& { return f.report.final_problem; },
      [](const Fit& f) -> const std::vector<ki::NodeTest>& { return f.report.nodes; }, fit);
  const ki::OutlierScreen& screen = screened.screen;
  ASSERT_EQ(screen.flagged.size(), 1u);
  EXPECT_FALSE(screen.systematic);
  EXPECT_EQ(screen.flagged.front().id, "r17");
  EXPECT_EQ(screen.flagged.front().line, 19u);
  EXPECT_LT(screen.flagged.front().p_value, 1e-6);
  EXPECT_TRUE(ki::leave_out(screen, false));
  EXPECT_FALSE(ki::leave_out(screen, true)) << "--keep-outliers";
  EXPECT_EQ(screened.rest.report.nodes.size(), 99u);
  const ki::CalibrationModel& all = everything.model;
  const ki::CalibrationModel& left_out = screened.rest.model;
  const double kept_um = held_out_um(robot, m, all, test), left_out_um = held_out_um(robot, m, left_out, test);
  std::printf("with scale: held-out %.3f um with the blunder fitted, %.3f um left out, %.3f um on clean data\n",
              kept_um, left_out_um, floor);
  EXPECT_GT(kept_um, 1.2 * floor) << "the blunder must matter, else the test shows nothing";
  EXPECT_LT(left_out_um, 1.1 * floor);
  // The identified scale is the truth within its noise either way.
  EXPECT_LT((left_out.effects.values.at("scale") - m.scale).lpNorm<Eigen::Infinity>(), 2e-5);
}

// diagnose: the same screen on the final model (base + accepted effects).
// Scale on the legs and one 50 µm blunder among 100 cal rows, 40 held-out
// rows measured too; the noise given (1 µm) and not given.
TEST(identifyBlunder, DiagnoseLeavesTheBlunderOutAndExplainsTheData) {
  const ki::Robot robot = ki::builtin_robot("stewart-seed001");
  const Machine m = machine(robot, 13, true);
  std::mt19937_64 rng(47);
  std::vector<Vec6<double>> all_poses = poses(robot, 140, rng);
  ki::PoseTable data = measure(robot, m, all_poses, 29);
  for (std::size_t k = 100; k < data.rows.size(); ++k) data.rows[k].role = ki::Role::Test;
  data.has_role = true;
  for (const std::optional<double> noise : {std::optional<double>(1.0), std::optional<double>()}) {
    ki::DiagnoseOptions o;
    o.noise_um = noise;
    const ki::Diagnosis d = ki::diagnose(robot, data, o);
    ASSERT_EQ(d.outliers.flagged.size(), 1u) << (noise ? "given" : "estimated");
    EXPECT_EQ(d.outliers.flagged.front().id, "r29");
    EXPECT_TRUE(d.outliers.excluded);
    EXPECT_EQ(d.rms.cal_nodes, 99u);
    ASSERT_FALSE(d.accepted.empty());
    EXPECT_EQ(d.accepted.front(), "scale");
    EXPECT_EQ(d.verdict, "explained") << (noise ? "given" : "estimated") << ": final test RMS " << d.final_rms.test;
    EXPECT_TRUE(d.hotspots.empty());
    const std::string json = ki::diagnosis_to_json(d);
    EXPECT_NE(json.find("\"outlier_tests\""), std::string::npos);
    EXPECT_NE(json.find("\"r29\""), std::string::npos);
    EXPECT_NE(ki::diagnosis_report_html(d).find("Outliers"), std::string::npos);
  }
  // --keep-outliers: listed, not left out.
  ki::DiagnoseOptions keep;
  keep.noise_um = 1.0;
  keep.keep_outliers = true;
  const ki::Diagnosis kept = ki::diagnose(robot, data, keep);
  ASSERT_EQ(kept.outliers.flagged.size(), 1u);
  EXPECT_FALSE(kept.outliers.excluded);
  EXPECT_EQ(kept.rms.cal_nodes, 100u);
  std::printf("diagnose with the blunder kept: verdict %s, final test RMS %.3f um\n", kept.verdict.c_str(),
              kept.final_rms.test);
}
