// Issue #33: one identify(robot, data, options) in the library that the
// command line only prints (kincal/identify/identify.hpp). Each family's
// example machine (its errors.csv: the 6-UPS's seed 001 Table 3, the hybrid's
// seed 000 set, the 6-RUS's) is measured as its own pipeline reads it and as
// tracker targets, through the library alone: the family's own pipeline or
// the target fit is chosen from the data, its narrative goes to the stream
// given, and the residual it reports falls; a family without a pipeline of
// its own refuses data without targets, naming them; an option a pipeline
// refuses is refused before any data are read.
#include <gtest/gtest.h>

#include <sstream>
#include <string>

#include "kincal/identify/effect_calibration.hpp"
#include "kincal/identify/identify.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/simulate.hpp"

namespace ki = kincal::identify;

namespace {

const std::string kExamples = std::string(KINCAL_SOURCE_DIR) + "/examples";

struct Case {
  const char* robot;
  const char* dir;
  bool targets;         // measure 2 tracker targets (else the family's own measurement / full poses)
  const char* opening;  // the narrative's first words after the data file
};

ki::PoseTable measured(const ki::Robot& nominal, const std::string& dir, bool targets) {
  const ki::Robot actual = ki::apply_parameters(nominal, ki::read_parameters(dir + "/errors.csv", nominal));
  ki::SimulateOptions o;
  o.noise_mm = 0.002;
  o.noise_rad = 5e-6;
  o.seed = 9;
  if (targets) {
    o.targets = {{40, -30, 20}, {-35, 25, 30}};
    o.noise_rad = 0;
  }
  ki::SimulateReport report;
  ki::PoseTable data = ki::simulate(nominal, actual, ki::read_pose_table(dir + "/diagnosis_poses.csv"), o, report);
  EXPECT_EQ(report.failed, 0u);
  data.file = "measured.csv";
  return data;
}

TEST(IdentifyPipeline, OneEntryPointChoosesThePipelineAndItsResidualFalls) {
  const Case cases[] = {
      {"stewart-seed001", "/seed001", false, "-parameter model of seed 001"},
      {"stewart-seed001", "/seed001", true, "target(s) measured in the robot's base frame"},
      {"hybrid-seed000", "/hybrid-seed000", false, "seed 000: coarse encoder offsets"},
      {"rus6-ref", "/rus6", false, "from full poses"},
      {"rus6-ref", "/rus6", true, "target(s) measured in the robot's base frame"},
  };
  for (const Case& c : cases) {
    ki::Robot robot = ki::builtin_robot(c.robot);
    if (c.targets) robot.targets = {{40, -30, 20}, {-35, 25, 30}};
    const ki::PoseTable data = measured(robot, kExamples + c.dir, c.targets);
    ki::IdentifyOptions o;
    o.data_file = data.file;
    o.summary = true;
    std::ostringstream narrative;
    const ki::Identification id = ki::identify(robot, data, o, narrative);
    const std::string tag = std::string(c.robot) + (c.targets ? " targets" : "");
    EXPECT_EQ(narrative.str().rfind("identify: measured.csv, robot " + std::string(c.robot), 0), 0u) << tag;
    EXPECT_NE(narrative.str().find(c.opening), std::string::npos) << tag << ":\n" << narrative.str();
    EXPECT_NE(narrative.str().find("outliers"), std::string::npos) << tag;  // the screen is part of it
    EXPECT_EQ(id.model.nominal.name, robot.name) << tag;
    EXPECT_EQ(id.model.data_file, "measured.csv") << tag;
    EXPECT_FALSE(id.model.parameters.empty()) << tag;
    EXPECT_FALSE(id.summary.empty()) << tag;
    EXPECT_EQ(id.summary.count("rank"), 1u) << tag;
    EXPECT_FALSE(id.nominal.empty()) << tag;
    ASSERT_GT(id.before.all.count, 0u) << tag;
    EXPECT_LT(id.after.all.rms_position_mm, 0.1 * id.before.all.rms_position_mm) << tag;
  }
}

TEST(IdentifyPipeline, AFamilyWithoutItsOwnPipelineAsksForTargetsAndOptionsAreCheckedFirst) {
  // Commands only: nothing the target fit reads, and the 6-RUS has no other.
  const ki::Robot rus6 = ki::builtin_robot("rus6-ref");
  ki::PoseTable commands = ki::read_pose_table(kExamples + "/rus6/diagnosis_poses.csv");
  std::ostringstream narrative;
  try {
    (void)ki::identify(rus6, commands, {}, narrative);
    ADD_FAILURE() << "identified without a measurement";
  } catch (const ki::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("nor tracker targets"), std::string::npos) << e.what();
  }
  ki::IdentifyOptions liu;
  liu.estimator = "liu";
  EXPECT_THROW(ki::check_identify_options(ki::builtin_robot("stewart-seed001"), liu), ki::InputError);
  EXPECT_NO_THROW(ki::check_identify_options(ki::builtin_robot("hybrid-seed000"), liu));
  EXPECT_NO_THROW(ki::check_identify_options(rus6, liu));
}

TEST(IdentifyPipeline, WithEffectsTheTargetFitsDataRefuseTheHybridsRidgeBase) {
  // The ridge base is the hybrid's own pipeline's (toward its coarse
  // machine). Tracker targets, here in the tracker's frame, go to the
  // target fit whatever the family: its base is OLS, and asking for the
  // ridge is refused before any fit (it used to be accepted, then ignored).
  const ki::Robot hybrid = ki::builtin_robot("hybrid-seed000");
  ki::PoseTable tracker;
  tracker.file = "tracker.csv";
  tracker.has_targets = true;
  tracker.target_count = 1;
  tracker.in_instrument_frame = true;
  ki::EffectCalibrationOptions ridge;
  ridge.estimator = ki::EstimatorKind::Ridge;
  try {
    (void)ki::calibrate_with_effects(hybrid, tracker, {"compliance"}, ridge);
    ADD_FAILURE() << "the ridge base was accepted on tracker data";
  } catch (const ki::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("ols (the target fit's Gauss-Newton)"), std::string::npos) << e.what();
  }
}

}  // namespace
