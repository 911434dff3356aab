// The "actual machine" of `kincal simulate` (docs/simulate.md): joint commands
// from the nominal model, the pose the erroneous machine really reaches for
// them (nonlinear FK, no linearisation), then optional measurement noise —
// the procedure of seed 001 Section 5.2.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>
#include <string>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal::identify {

struct SimulateOptions {
  double noise_mm = 0;   // σ of Gaussian noise on mx, my, mz and on each target coordinate
  double noise_rad = 0;  // σ of Gaussian noise on mrx, mry, mrz
  std::uint64_t seed = 1;  // std::mt19937_64 seed; same seed → same noise
  // Physical effects of the actual machine (core/effects.hpp): joint-space
  // effects change the joints the FK is driven with (q + Δq at the node's
  // approach directions and static load), thermal scales the reached pose
  // about the base origin; needs a temp column when thermal is non-zero.
  EffectValues effects;
  // Measure laser-tracker targets at these positions on the platform (6-UPS,
  // platform frame) or the tool (hybrid, tool frame), mm; 1–3 of them: the
  // machine's true targets, which may differ from the description's
  // `targets`. Instead of full poses (6-UPS) or the gauge (hybrid).
  std::vector<Vec3<double>> targets;
  // With `targets`: the pose of the robot's base frame in the instrument's
  // frame (the registration); the targets are written in the instrument frame.
  std::optional<Pose<double>> instrument_frame;
  // Measure the pose alone: no columns of the family's own targets (the
  // hybrid's gauge), as a 6-DOF instrument (a tracker's pose probe) gives.
  bool pose_only = false;
};

struct SimulateReport {
  std::size_t simulated = 0;  // rows with a measurement
  std::size_t failed = 0;     // rows flagged in the status column
};

// Positions of the three gauge targets P1..P3 (columns) in the workpiece frame
// for a tool pose there: P0 = P − tool_length · (tool axis P0→P); P_j at
// `radius` from P0 in the plane normal to the tool axis, at 90°, 210°, 330°
// from the tool frame's x axis toward its y axis (so P0P1 ∥ y, P2P3 ∥ x).
Eigen::Matrix<double, 3, 3> gauge_targets(const HybridGeometry<double>& g, double radius, const Pose<double>& tool);

// Simulates every row of `poses`: q = the row's q1..q6 if given, else the
// nominal IK of the commanded pose; the actual pose = FK of `actual` from the
// commanded pose (stewart) or the nominal IK's passive configuration (hybrid).
// Output: measured pose columns (stewart), target positions t1..tk (either
// family with options.targets; noise_mm on each coordinate) or pose + gauge
// targets (hybrid; the pose alone with options.pose_only); the
// input's id/layer/role/q/temp/time/dir columns are kept. A row whose IK or FK
// fails keeps empty measurements, gets its reason in a `status` column, and is
// reported through `warn` as "FILE:LINE: warning: ...".
PoseTable simulate(const Robot& nominal, const Robot& actual, const PoseTable& poses, const SimulateOptions& options,
                   SimulateReport& report, const std::function<void(const std::string&)>& warn = {});

}  // namespace kincal::identify
