// Issue #31 ("the 6-UPS likewise"): the 6-UPS identified and compensated on
// data kincal did not make. The machine is independent/stewart_simulator.hpp:
// its own Newton FK over legs solved as lines beside their U centres, with
// physical errors by group (base and platform joint centres, leg offsets —
// the prismatic line not through the U centre, which kincal's 42-parameter
// model has no parameter for —, encoder offsets, a tool frame on the
// platform) — not stewart_fk, not StewartErrorModel. The loop is the user's,
// through the command line (independent/cli_loop.hpp).
//
// What differs from the data the code was developed on: random poses over
// a box with tilts up to ±0.08 rad (not seed 001's 10 poses), errors by
// physical group (not seed 001's Table 3), a tool frame offset from the
// platform frame, three targets on the platform as well as full poses, no
// noise level given.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "independent/cli_loop.hpp"
#include "independent/stewart_simulator.hpp"

namespace {

namespace ind = kincal::independent;
using V6 = kincal::Vec6<double>;

const std::string kDir = "identify_independent_stewart";

std::vector<V6> random_poses(int n, std::uint64_t seed) {
  V6 centre, half;
  // Inside seed 001's leg stroke at every pose (compensate refuses a pose
  // past the robot file's limits, and that is not this test's subject).
  centre << 0, 0, 195, 0, 0, 0;
  half << 30, 30, 20, 0.08, 0.08, 0.08;
  return ind::random_box_poses(n, centre, half, seed);
}

// The built-in 6-UPS with extra keys (written after its opening brace) as
// a robot file; returns its path.
std::string robot_with(const std::string& name, const std::string& keys) {
  const kincal_test::ToolRun r =
      kincal_test::run_tool_in(kDir, "robot --robot stewart-seed001 --out " + kDir + "/stewart.json");
  EXPECT_EQ(r.code, 0) << r.err;
  std::string text = kincal::identify::read_text_file(kDir + "/stewart.json");
  const std::size_t brace = text.find('{');
  text.insert(brace + 1, keys);
  kincal_test::write_in(kDir, name, text);
  return kDir + "/" + name;
}
const std::string kTargetsKey = "\"targets\": [[60, 0, 20], [-30, 52, 20], [-30, -52, 40]],";
// Leg lines beside their U centres modelled (core/stewart.hpp): zeros, the
// nominal machine's, and the identification fits dsq1..dsq6.
const std::string kLegOffsetsKey = "\"leg_offset_sq\": [0, 0, 0, 0, 0, 0],";

// The built-in 6-UPS with three tracker targets on its platform.
std::string robot_with_targets() { return robot_with("stewart_targets.json", kTargetsKey); }

// One case: `e` measured (full poses, or the three targets whose positions
// identify fits) on the `cal` poses, identified, the `test` poses
// compensated and driven; printed. Returns what the machine reached.
ind::HeldOut run_case(bool full_pose, const std::string& name, const ind::StewartErrors& e,
                      const std::vector<V6>& cal, const std::vector<V6>& test, const std::string& targets_robot,
                      const std::string& pose_robot = "stewart-seed001") {
  ind::MeasurementSpec spec;
  if (!full_pose) spec.targets = {{60, 0, 20}, {-30, 52, 20}, {-30, -52, 40}};
  const ind::HeldOut h = ind::identify_and_compensate(
      kDir, full_pose ? pose_robot : targets_robot, name, ind::StewartSimulator(e),
      ind::make_stewart_dataset(e, cal, spec), test, full_pose ? nullptr : &spec.targets);
  std::printf("  %-30s held-out RMS %.4f um, worst %.4f um, %.4f urad, targets %.4f um (%d poses)\n", name.c_str(),
              h.rms_um, h.position_um, h.rotation_urad, h.target_um, h.poses);
  EXPECT_EQ(h.poses, int(test.size())) << name;
  return h;
}

// Noise-free, each physical group alone at 0.1 mm / 0.3 mrad: the issue's
// bar, 0.05 µm / 0.2 µrad on held-out poses after compensation.
TEST(IndependentStewart, EachPhysicalGroupIsAbsorbedAndCompensated) {
  const std::vector<V6> cal = random_poses(60, 4101), test = random_poses(30, 4102);
  const std::string targets_robot = robot_with_targets();
  for (const bool full_pose : {true, false}) {
    for (const std::string& group : ind::StewartErrors::group_names()) {
      const std::string name = std::string(full_pose ? "pose" : "targets") + "_" + group;
      const ind::HeldOut h =
          run_case(full_pose, name, ind::random_stewart_errors(0.1, 3e-4, 23, {group}), cal, test, targets_robot);
      if (full_pose) {
        EXPECT_LE(h.position_um, 0.05) << name;
        EXPECT_LE(h.rotation_urad, 0.2) << name;
      } else {
        // The platform frame is the fit's convention (docs/identify.md): the
        // targets are what the machine is judged by.
        EXPECT_LE(h.target_um, 0.05) << name;
      }
    }
  }
}

// The same at 1 mm / 2 mrad, every group at once and each alone (issue #31:
// "the same at 1 mm / 2 mrad (the nonlinear model); the 6-UPS likewise").
// The 6-UPS's model is its own nonlinear kinematics (seed 001's FK of the
// calibrated geometry); what differs from the test above: ten times the
// errors, another design and error draw.
//
// Leg offsets (the prismatic line beside the U centre) have no parameter in
// seed 001's 42: to first order the others absorb them (the test above), at
// 1 mm they leave 0.15 µm / 0.90 µrad from full poses and 0.18 µm at the
// targets. The robot files here carry `leg_offset_sq`, so the model is
// seed 001's and the six squared leg-line offsets (core/stewart.hpp), and
// every case is held to the bar; the last case shows the 42 alone
// on leg offsets still leave what was measured before.
TEST(IndependentStewart, MillimetreErrorsAreAbsorbed) {
  const std::vector<V6> cal = random_poses(60, 4111), test = random_poses(30, 4112);
  const std::string targets_robot = robot_with("stewart_targets_legs.json", kTargetsKey + kLegOffsetsKey);
  const std::string pose_robot = robot_with("stewart_legs.json", kLegOffsetsKey);
  std::vector<std::vector<std::string>> cases = {ind::StewartErrors::group_names()};
  for (const std::string& g : ind::StewartErrors::group_names()) cases.push_back({g});
  for (const bool full_pose : {true, false}) {
    for (const auto& groups : cases) {
      const std::string name = std::string(full_pose ? "mm_pose_" : "mm_targets_") +
                               (groups.size() > 1 ? std::string("all") : groups[0]);
      const ind::HeldOut h = run_case(full_pose, name, ind::random_stewart_errors(1.0, 2e-3, 31, groups), cal, test,
                                      targets_robot, pose_robot);
      if (full_pose) {
        EXPECT_LE(h.position_um, 0.05) << name;
        EXPECT_LE(h.rotation_urad, 0.2) << name;
      } else {
        EXPECT_LE(h.target_um, 0.05) << name;
      }
    }
  }
  // Without the key: seed 001's 42 on 1 mm leg offsets leave 0.15 µm (more
  // than the bar: the key is what absorbs them).
  const ind::HeldOut without = run_case(true, "mm_pose_leg_offsets_42", ind::random_stewart_errors(1.0, 2e-3, 31, {"leg_offsets"}),
                                        cal, test, targets_robot);
  EXPECT_GT(without.position_um, 0.05);
  EXPECT_LE(without.position_um, 0.31);
}

}  // namespace
