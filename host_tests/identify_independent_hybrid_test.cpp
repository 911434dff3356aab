// Issue #31: the hybrid identified and compensated on data kincal did not
// make. The machine is independent/hybrid_simulator.hpp: a product of
// exponentials about perturbed joint LINES with its own physical errors
// (joint centres, U axis directions and offsets, leg offsets, the UP limb's
// lines, the wrist's axis lines, the tool point and tool frame on joint 6's
// body, encoder offsets) — not HybridErrorModel's frames, not hybrid_fk.
// The loop is the user's, through the command line: `kincal identify` on
// the measured cal poses, `kincal compensate` of held-out poses, and the
// independent machine driven by those commands; what it reaches is compared
// with what was asked.
//
// What differs from the data the code was developed on: random poses over
// the task cuboid with tilts up to ±0.1 rad (not seed 000's grid layers),
// errors by physical group (not by source-error column), no noise level given
// to identify, commands written by the nominal IK of another code path.
#include <gtest/gtest.h>

#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "independent/cli_loop.hpp"
#include "independent/hybrid_simulator.hpp"

namespace {

namespace ind = kincal::independent;
using V6 = kincal::Vec6<double>;

const std::string kDir = "identify_independent_hybrid";

// Seed 000's 500 × 500 × 120 mm task cuboid, each angle within ±tilt.
std::vector<V6> random_poses(int n, double tilt, std::uint64_t seed) {
  V6 half;
  half << 250, 250, 60, tilt, tilt, tilt;
  return ind::random_box_poses(n, V6::Zero(), half, seed);
}

enum class Instrument { FullPose, Gauge, Targets };

// The built-in hybrid with three tracker targets on its tool (identify fits
// their positions; the gauge's known positions as the nominal ones).
std::string robot_with_targets() {
  const kincal_test::ToolRun r =
      kincal_test::run_tool_in(kDir, "robot --robot hybrid-seed000 --out " + kDir + "/hybrid.json");
  EXPECT_EQ(r.code, 0) << r.err;
  std::string text = kincal::identify::read_text_file(kDir + "/hybrid.json");
  std::ostringstream targets;
  targets.precision(17);
  targets << "\"targets\": [";
  const std::vector<ind::V3> t = ind::HybridSimulator::gauge_targets();
  for (std::size_t k = 0; k < t.size(); ++k)
    targets << (k ? ", " : "") << "[" << t[k](0) << ", " << t[k](1) << ", " << t[k](2) << "]";
  targets << "],";
  text.insert(text.find('{') + 1, targets.str());
  kincal_test::write_in(kDir, "hybrid_targets.json", text);
  return kDir + "/hybrid_targets.json";
}

// One case of the loop: `e` measured with `inst` on the `cal` poses,
// identified, the `test` poses compensated and driven; printed, and held to
// the bar (0.05 µm / 0.2 µrad; with fitted targets, where the
// targets go: the tool frame is then the fit's convention).
ind::HeldOut absorbed_to_the_bar(Instrument inst, const std::string& name, const ind::HybridErrors& e,
                                 const std::vector<V6>& cal, const std::vector<V6>& test,
                                 const std::string& targets_robot) {
  ind::MeasurementSpec spec;
  if (inst != Instrument::FullPose) spec.targets = ind::HybridSimulator::gauge_targets();
  const bool fitted_targets = inst == Instrument::Targets;
  const ind::HeldOut h = ind::identify_and_compensate(
      kDir, fitted_targets ? targets_robot : "hybrid-seed000", name, ind::HybridSimulator(e),
      ind::make_hybrid_dataset(e, cal, spec), test, fitted_targets ? &spec.targets : nullptr);
  std::printf("  %-32s held-out RMS %.4f um, worst %.4f um, %.4f urad, targets %.4f um (%d poses)\n", name.c_str(),
              h.rms_um, h.position_um, h.rotation_urad, h.target_um, h.poses);
  EXPECT_EQ(h.poses, int(test.size())) << name;
  if (fitted_targets) {
    EXPECT_LE(h.target_um, 0.05) << name;
  } else {
    EXPECT_LE(h.position_um, 0.05) << name;
    EXPECT_LE(h.rotation_urad, 0.2) << name;
  }
  return h;
}

constexpr Instrument kInstruments[] = {Instrument::FullPose, Instrument::Gauge, Instrument::Targets};

// Noise-free, each physical group alone: what the identified model leaves
// on held-out poses after compensation, at 0.1 mm / 0.3 mrad: the issue's
// bar, 0.05 µm / 0.2 µrad for the worst held-out pose, for full poses, the
// gauge and three tracker targets (judged by where the fitted targets go).
// Measured (worst group, worst pose): full pose 0.019 µm / 0.016 µrad, gauge
// 0.019 µm / 0.015 µrad, targets 0.018 µm but the UPS joint centres (below).
// The full-pose and target fits keep
// columns down to 1e-4 from the span of those before them on noise-free
// data (hybrid_errors.cpp); at 1e-3, the tolerance noisy data need, the UPS
// joint centres were left 0.26 µm, the UP limb and the wrist's axis lines
// 0.15 µm. Before the tool frame was in the model the `tool` group was left
// 14 µm off from full poses.
TEST(IndependentHybrid, EachPhysicalGroupIsAbsorbedAndCompensated) {
  const std::vector<V6> cal = random_poses(90, 0.1, 3101), test = random_poses(40, 0.1, 3102);
  const std::string targets_robot = robot_with_targets();
  // (With the first-order error twist, seed 000 Eq. (16), the UPS joint
  // centres were left 0.129 µm at the targets; the exact model reaches the bar.)
  for (const Instrument inst : kInstruments) {
    const char* label = inst == Instrument::FullPose ? "pose" : inst == Instrument::Gauge ? "gauge" : "targets";
    for (const std::string& group : ind::HybridErrors::group_names()) {
      const std::string name = std::string(label) + "_" + group;
      const ind::HeldOut h = absorbed_to_the_bar(inst, name, ind::random_hybrid_errors(0.1, 3e-4, 17, {group}), cal,
                                                 test, targets_robot);
      if (group == "tool" && inst != Instrument::Targets) {
        EXPECT_LE(h.position_um, 1e-3) << name;  // the new frame, exactly
      }
    }
  }
}

// The same loop at 1 mm / 2 mrad, every group at once and each alone, noise
// free: where a first-order model leaves micrometres (the issue measured
// 1.1 µm / 2.8 µrad), the erroneous machine's own kinematics
// (core/hybrid_exact.hpp) in identify and in the compensator must absorb
// them to the same bar as at 0.1 mm, from full poses, the gauge and three
// fitted targets. What differs from the test above: ten times the errors,
// another random design and error draw, tilts to ±0.15 rad. Before the S
// centres on the platform were in the model (joint 6's Δx, Δy after its
// motion; docs/hybrid-error-model.md §3) the UPS joint centres were left
// 1.31 µm, the UP limb 0.81 µm, all groups 1.66 µm from full poses.
TEST(IndependentHybrid, MillimetreErrorsAreAbsorbedByTheExactModel) {
  const std::vector<V6> cal = random_poses(90, 0.15, 3111), test = random_poses(40, 0.15, 3112);
  std::vector<std::vector<std::string>> cases = {ind::HybridErrors::group_names()};
  for (const std::string& g : ind::HybridErrors::group_names()) cases.push_back({g});
  const std::string targets_robot = robot_with_targets();
  for (const Instrument inst : kInstruments) {
    const char* label = inst == Instrument::FullPose ? "mm_pose_" : inst == Instrument::Gauge ? "mm_gauge_" : "mm_targets_";
    for (const auto& groups : cases) {
      const std::string name = label + (groups.size() > 1 ? std::string("all") : groups[0]);
      absorbed_to_the_bar(inst, name, ind::random_hybrid_errors(1.0, 2e-3, 29, groups), cal, test, targets_robot);
    }
  }
}

}  // namespace
