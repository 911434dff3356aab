// A hexapod of another size than seed 001's (issue #11): base radius 330 mm,
// platform radius 190 mm, legs 600–1100 mm, home at z = 800 mm — the machine
// of the issue's large-error report. `extra_keys` is spliced into the
// description (e.g. "\"max_correction\": 20,").
#pragma once

#include <cmath>
#include <string>

#include "kincal/identify/robot.hpp"

namespace kincal_test {

inline kincal::identify::Robot large_hexapod(const std::string& extra_keys = "") {
  std::string base, platform;
  for (int i = 0; i < 6; ++i) {
    const double pair = (i / 2) * 2 * M_PI / 3, side = (i % 2 == 0 ? -1 : 1);
    const double ab = pair + side * 12 * M_PI / 180, ap = pair + M_PI / 3 + side * (-48) * M_PI / 180;
    base += std::string(i ? ", " : "") + "[" + std::to_string(330 * std::cos(ab)) + ", " +
            std::to_string(330 * std::sin(ab)) + ", 0.0]";
    platform += std::string(i ? ", " : "") + "[" + std::to_string(190 * std::cos(ap)) + ", " +
                std::to_string(190 * std::sin(ap)) + ", 0.0]";
  }
  const std::string json = R"({"format": "kincal-robot", "version": 1, "family": "stewart-6ups", "name": "large-hexapod",
    "units": {"length": "mm", "angle": "rad"}, )" + extra_keys + R"( "base_joints": [)" + base +
                           R"(], "platform_joints": [)" + platform +
                           R"(], "stroke": {"min": [600, 600, 600, 600, 600, 600], "max": [1100, 1100, 1100, 1100, 1100, 1100]},
    "length_offset": [0, 0, 0, 0, 0, 0], "home": {"x": 0, "y": 0, "z": 800, "rx": 0, "ry": 0, "rz": 0}})";
  return kincal::identify::parse_robot(json, "large-hexapod.json");
}

}  // namespace kincal_test
