// `kincal export linuxcnc` (GUIDE "Export to LinuxCNC", docs/linuxcnc.md): an
// identified 6-UPS model as the files a LinuxCNC 2.9 hexapod (`genhexkins`)
// needs, so a LinuxCNC user does not copy numbers out of MODEL.json by hand.
//
// What maps exactly onto LinuxCNC, and how (docs/linuxcnc.md "Frames"):
//   - geometry: genhexkins computes each joint as the strut length
//     |R·p_i + t − b_i| with R = Rz(C)·Ry(B)·Rx(A) (A, B, C in degrees), the
//     same closure as seed 001 Eq. (1) in kincal's base and platform frames;
//     kincal's leg i is LinuxCNC's joint/leg i − 1. The calibrated B_i and P_i
//     become `setp genhexkins.base.N.*` / `genhexkins.platform.N.*`.
//   - encoder offsets: kincal's physical leg is q + dl_i (q the drive's
//     reading); LinuxCNC's joint position is the strut length itself, so the
//     offset moves the joint's position at its home switch: HOME_OFFSET + dl_i.
//   - joint-space effects that depend on the joint alone (scale, backlash,
//     cyclic): a joint compensation table (COMP_FILE, type 1: nominal, forward
//     offset, reverse offset), which LinuxCNC looks up at the joint's commanded
//     position and adds by its direction of motion. The table holds kincal's
//     own correction, q − (L − dl) with q + Δq(q, dir) = L − dl (core's
//     effect_correct_joints), fitted by a continuous piecewise-linear function
//     (LinuxCNC interpolates linearly between entries) to within a tolerance.
// What LinuxCNC cannot carry (thermal: a pose scaling by temperature;
// compliance: a joint load from the pose; any user effect) is listed in the
// README written beside the files, with the error that remains without it,
// predicted on measured poses.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "kincal/core/pose.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/model.hpp"

namespace kincal::identify {

// LinuxCNC's joint compensation tables hold at most this many entries per
// joint (EMCMOT_COMP_SIZE in LinuxCNC 2.9's motion.h).
inline constexpr int kLinuxCncMaxCompEntries = 256;

struct LinuxCncExportOptions {
  // LinuxCNC's machine units ([TRAJ] LINEAR_UNITS): every length written is in
  // these (1 inch = 25.4 mm).
  bool inch = false;
  // The HOME_OFFSET each joint has in the configuration today (the strut
  // length LinuxCNC assigns at the home switch), in the export's units;
  // default: the nominal strut lengths at the robot's home pose (a hexapod
  // homed with its platform at home).
  std::optional<Vec6<double>> home_offsets;
  // Largest deviation of LinuxCNC's linear interpolation of a compensation
  // table from kincal's correction over the stroke, mm. Tables aim at half of
  // it where LinuxCNC's 256 entries allow; above it the export warns.
  double comp_tolerance_mm = 1e-4;
  int max_comp_entries = kLinuxCncMaxCompEntries;
  // Measured poses (the model's data) on which the README predicts the error
  // that remains from what LinuxCNC cannot carry; none: not predicted.
  const PoseTable* data = nullptr;
};

// One joint's compensation table, in the export's units.
struct LinuxCncCompTable {
  std::vector<double> nominal, forward, reverse;  // joint position; offsets added moving + / −
  double max_error_mm = 0;  // largest |interpolated − kincal's correction| over the stroke, mm
};

// The predicted held-out error of one way of commanding the machine the
// model describes, over the measured poses.
struct LinuxCncPrediction {
  std::string what;  // e.g. "LinuxCNC with these files", "without thermal"
  std::size_t poses = 0;
  double rms_position_mm = 0, max_position_mm = 0, rms_orientation_rad = 0;
};

struct LinuxCncExport {
  std::map<std::string, std::string> files;  // file name in DIR → text
  std::vector<LinuxCncCompTable> comp;       // per joint; empty when nothing is carried by tables
  std::vector<std::string> carried, not_carried;  // effect names
  std::vector<LinuxCncPrediction> predictions;
  std::vector<std::string> warnings;         // one line each
};

// Throws InputError (naming the model file) for a model of a family LinuxCNC
// has no kinematics for (genhexkins serves the 6-UPS).
void check_linuxcnc_family(const CalibrationModel& model);

// Also refuses (InputError) a model the controller's table check refuses.
LinuxCncExport linuxcnc_export(const CalibrationModel& model, const LinuxCncExportOptions& options = {});

// Writes the files into `dir` as one step: they are written to a fresh
// directory beside it and renamed into place, so `dir` is either absent, its
// old content, or the complete export. An existing `dir` is refused unless
// `overwrite` (then the old one is replaced whole). InputError on failure.
void write_export_directory(const std::map<std::string, std::string>& files, const std::string& dir, bool overwrite);
// The refusals of write_export_directory that need no files (an existing
// `dir` without `overwrite`, a missing parent), for a command to check before
// it works.
void check_export_directory(const std::string& dir, bool overwrite);

}  // namespace kincal::identify
