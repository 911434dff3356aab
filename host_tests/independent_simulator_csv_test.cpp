// The independent simulators' measurement CSV is what kincal reads: written by
// independent/independent_common.hpp's writer, parsed by identify's
// parse_pose_table, every value back bit for bit. Kept apart from
// independent_simulator_test (which needs core only) because this one links
// the identify library.
#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <vector>

#include "independent/hybrid_simulator.hpp"
#include "independent/stewart_simulator.hpp"
#include "kincal/core/reference_machines.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/simulate.hpp"

namespace ind = kincal::independent;
using ind::V3;
using ind::V6;
using kincal::Pose;

namespace {

std::vector<V6> grid_poses() {
  std::vector<V6> out;
  for (double x : {-200.0, 0.0, 200.0})
    for (double y : {-150.0, 150.0}) out.push_back((V6() << x, y, 30.0, 0.0, 0.0, 0.0).finished());
  out.push_back((V6() << 50, -20, -40, 0.1, -0.05, 0.08).finished());
  return out;
}

kincal::identify::PoseTable parse(const ind::Dataset& d, std::vector<std::string>& warnings) {
  std::ostringstream text;
  ind::write_measurement_csv(text, d);
  kincal::identify::PoseTableOptions options;
  options.warn = [&](const std::string& w) { warnings.push_back(w); };
  return kincal::identify::parse_pose_table(text.str(), "independent.csv", options);
}

void expect_same_rows(const ind::Dataset& d, const kincal::identify::PoseTable& t) {
  ASSERT_EQ(t.rows.size(), d.rows.size());
  for (std::size_t i = 0; i < d.rows.size(); ++i) {
    const auto& r = t.rows[i];
    const auto& s = d.rows[i];
    EXPECT_EQ(r.id, s.id);
    EXPECT_EQ(r.commanded, s.commanded);
    ASSERT_EQ(r.measured.has_value(), s.measured.has_value());
    if (s.measured) {
      EXPECT_EQ(*r.measured, *s.measured);
    }
    ASSERT_EQ(r.q.has_value(), d.has_q);
    if (d.has_q) {
      EXPECT_EQ(Eigen::VectorXd(*r.q), Eigen::VectorXd(s.q));
    }
    ASSERT_EQ(r.targets.has_value(), !s.targets.empty());
    for (std::size_t k = 0; k < s.targets.size(); ++k) EXPECT_EQ(V3(r.targets->col(Eigen::Index(k))), s.targets[k]);
  }
}

}  // namespace

TEST(IndependentSimulatorCsv, HybridPoseAndGaugeReadBackByKincal) {
  ind::MeasurementSpec spec;
  spec.targets = ind::HybridSimulator::gauge_targets();
  spec.pose_and_targets = true;  // like `kincal simulate` for the hybrid
  spec.sigma_mm = 0.002;
  spec.sigma_rad = 5e-6;
  spec.seed = 9;
  const ind::Dataset d = ind::make_hybrid_dataset(ind::random_hybrid_errors(0.05, 1e-4, 1), grid_poses(), spec);
  ASSERT_TRUE(d.skipped.empty());
  std::vector<std::string> warnings;
  const auto t = parse(d, warnings);
  EXPECT_TRUE(warnings.empty());
  EXPECT_TRUE(t.has_measured);
  EXPECT_TRUE(t.has_targets);
  EXPECT_EQ(t.target_count, 3);
  EXPECT_TRUE(t.has_q);
  EXPECT_TRUE(t.ignored_columns.empty());
  expect_same_rows(d, t);
}

TEST(IndependentSimulatorCsv, GaugeTargetsAreKincalsGauge) {
  // Same tool pose → the independent gauge targets equal identify's
  // gauge_targets (the ones `identify` predicts from a measured hybrid).
  const kincal::HybridGeometry<double> g = kincal::make_hybrid_seed000<double>();
  ind::MeasurementSpec spec;
  spec.targets = ind::HybridSimulator::gauge_targets();
  spec.pose_and_targets = true;
  const ind::Dataset d = ind::make_hybrid_dataset(ind::HybridErrors{}, grid_poses(), spec);
  double worst = 0;
  for (const auto& r : d.rows) {
    const Eigen::Matrix3d k = kincal::identify::gauge_targets(g, 200.0, r.actual);
    for (int j = 0; j < 3; ++j) worst = std::max(worst, (V3(k.col(j)) - r.targets[std::size_t(j)]).norm());
  }
  EXPECT_LE(worst, 1e-9);
}

TEST(IndependentSimulatorCsv, StewartTargetsInInstrumentFrameReadBack) {
  ind::MeasurementSpec spec;
  spec.targets = {V3(100, 0, 20), V3(-50, 80, 20)};
  spec.instrument_from_base = Pose<double>::from_xyz_rpy(1500, -300, 400, 0.01, -0.02, 2.0);
  spec.sigma_mm = 0.005;
  spec.write_q = false;
  std::vector<V6> poses;
  for (double z : {180.0, 220.0}) poses.push_back((V6() << 10, -15, z, 0.03, 0.02, -0.05).finished());
  const ind::Dataset d = ind::make_stewart_dataset(ind::random_stewart_errors(0.1, 1e-3, 2), poses, spec);
  ASSERT_TRUE(d.skipped.empty());
  std::vector<std::string> warnings;
  const auto t = parse(d, warnings);
  EXPECT_TRUE(warnings.empty());
  EXPECT_FALSE(t.has_measured);
  EXPECT_FALSE(t.has_q);
  EXPECT_EQ(t.target_count, 2);
  expect_same_rows(d, t);
}

TEST(IndependentSimulatorCsv, StewartEffectDatasetTempAndRoleReadBack) {
  // The 6-UPS effect dataset's `role` and `temp` columns (issue #32's formula
  // effects read `temp`) come back through identify's parser, bit for bit.
  ind::StewartEffects fx;
  fx.thermal = {1.2e-5, 2.3e-5, 0, 0, 0, 0};
  fx.ramp_gain[2] = fx.ramp_gain[5] = 1e-4;
  fx.ramp_knee[2] = fx.ramp_knee[5] = 240;
  fx.clearance = {0.01, 0.01, 0.01, 0.01, 0.01, 0.01};
  fx.payload_com = V3(100, 0, 0);
  std::vector<V6> poses;
  std::vector<double> temps;
  std::vector<std::string> roles;
  for (int k = 0; k < 6; ++k) {
    poses.push_back((V6() << -25 + 10 * k, 15 - 6 * k, 180 + 7 * k, 0.02 * k - 0.05, 0.03, -0.01 * k).finished());
    temps.push_back(15.0 + 3.7 * k);
    roles.push_back(k == 4 ? "test" : "cal");
  }
  ind::MeasurementSpec spec;
  spec.sigma_mm = 0.002;
  spec.sigma_rad = 5e-6;
  const ind::Dataset d =
      ind::make_stewart_effect_dataset(ind::random_stewart_errors(0.1, 1e-3, 3), fx, poses, spec, temps, roles);
  ASSERT_TRUE(d.skipped.empty());
  std::vector<std::string> warnings;
  const auto t = parse(d, warnings);
  EXPECT_TRUE(warnings.empty());
  EXPECT_TRUE(t.has_temp);
  EXPECT_TRUE(t.has_role);
  EXPECT_FALSE(t.has_dir);
  EXPECT_TRUE(t.ignored_columns.empty());
  expect_same_rows(d, t);
  for (std::size_t i = 0; i < d.rows.size(); ++i) {
    ASSERT_TRUE(t.rows[i].temp.has_value());
    EXPECT_EQ(*t.rows[i].temp, d.rows[i].temp);
    EXPECT_EQ(t.rows[i].role == kincal::identify::Role::Test, d.rows[i].role == "test");
  }
}
