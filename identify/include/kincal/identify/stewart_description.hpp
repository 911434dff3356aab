// The 6-UPS's part of a Robot (robot.hpp): its family name and what only
// it has — core's geometry and whether the leg offsets are modelled.
#pragma once

#include "kincal/core/stewart.hpp"

namespace kincal::identify {

inline constexpr const char* kStewartFamily = "stewart-6ups";

// The 6-UPS (stewart-6ups).
struct StewartDescription {
  StewartGeometry<double> geometry;
  // The optional description key `leg_offset_sq` (mm², six: the squared
  // distance of each leg's prismatic line from its U centre,
  // core/stewart.hpp). Given, even as zeros, the identification also fits
  // the six (dsq1..dsq6, after seed 001's 42); absent, they are not modelled.
  bool models_leg_offsets = false;
};

}  // namespace kincal::identify
