// The 6-RUS's part of a Robot (robot.hpp): its family name and its
// geometry, which is all it has.
#pragma once

#include "kincal/core/rus6.hpp"

namespace kincal::identify {

inline constexpr const char* kRus6Family = "rus6";

// The 6-RUS (rus6): its geometry is all it has.
struct Rus6Description {
  Rus6Geometry<double> geometry;
};

}  // namespace kincal::identify
