// Joint limits on the identification side (issue #11 item 1). A robot file's
// limits bound what the controller may command (compensate, table, firmware);
// they never make identification reject a measured row: the machine was
// there, so the measurement is a fact about it (GUIDE "Command-line
// contract"). Identification, residuals and diagnosis therefore model
// measured rows on a copy of the robot whose limits are opened, and the tool
// warns once per row and joint that lies outside the file's limits.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal::identify {

// The geometry with its joint (and, for the hybrid, UP-extension) limits
// opened to ±1e9 (hybrid.hpp's own "no limit" value; the extension keeps its
// physical floor of 0). Everything else is unchanged.
StewartGeometry<double> without_limits(StewartGeometry<double> g);
HybridGeometry<double> without_limits(HybridGeometry<double> g);
// The 6-RUS's limits also pick the IK branch (core/rus6.hpp): opened to the
// one-turn window about their middle, where the home branch decides.
Rus6Geometry<double> without_limits(Rus6Geometry<double> g);
// The robot for modelling measured rows. MODEL.json and the tables keep the
// robot as the file gives it.
Robot without_limits(Robot robot);

// One warning per row and joint whose joint command (q1..q6, or the nominal
// IK of the commanded pose) lies outside the robot's limits, by how much:
//   FILE:LINE: warning: row 'n028': q3 = 286.6 mm is 3.36 mm above its limit
//   283.24 mm (used: limits bound the controller, not the measurement)
// and, for the hybrid, the UP extension likewise. Rows whose nominal IK fails
// even without limits are left to the identification's own message.
std::vector<std::string> joint_limit_warnings(const Robot& robot, const PoseTable& data);

}  // namespace kincal::identify
