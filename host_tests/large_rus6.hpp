// A 6-RUS of another size than rus6-ref, read from a description file (the
// custom-machine path): base radius 420 mm, motor pairs ±20° (not ±25°),
// cranks 150 mm with motor 4's 156 mm, rods 620 mm, platform spheres on a
// 260 mm circle at ±32° about the pairs (not at the motors' azimuths), a
// 50:1 gearbox (cyclic period 2π/50), joint limits −75°…+65°. Home is the
// height where the first leg's crank is horizontal; the other legs close
// near it (motor 4's longer crank turns it a little). `extra_keys` is
// spliced into the description (e.g. "\"max_correction\": 0.05,").
#pragma once

#include <cmath>
#include <string>

#include "kincal/identify/robot.hpp"

namespace kincal_test {

inline kincal::identify::Robot large_rus6(const std::string& extra_keys = "") {
  const double deg = M_PI / 180, base_r = 420, crank = 150, rod = 620, platform_r = 260;
  const double motor_spread = 20 * deg, sphere_spread = 32 * deg;
  std::string motors, zero, spheres;
  auto triple = [](double x, double y, double z) {
    return "[" + std::to_string(x) + ", " + std::to_string(y) + ", " + std::to_string(z) + "]";
  };
  for (int i = 0; i < 6; ++i) {
    const double sign = i % 2 == 0 ? -1 : 1, pair = (i / 2) * 120 * deg;
    const double am = pair + sign * motor_spread, as = pair + sign * sphere_spread;
    const std::string sep = i ? ", " : "";
    // Radial shaft a = sign·r̂, crank zero z = −sign·t̂ … as rus6-ref: a × z = +z.
    motors += sep + "{\"point\": " + triple(base_r * std::cos(am), base_r * std::sin(am), 0) +
              ", \"axis\": " + triple(sign * std::cos(am), sign * std::sin(am), 0) + "}";
    zero += sep + triple(-sign * std::sin(am), sign * std::cos(am), 0);
    spheres += sep + triple(platform_r * std::cos(as), platform_r * std::sin(as), 0);
  }
  // Leg 1's crank horizontal: its tip, then the rod's horizontal run to its sphere.
  const double am = -motor_spread, as = -sphere_spread;
  const double tip_x = base_r * std::cos(am) + crank * std::sin(am), tip_y = base_r * std::sin(am) - crank * std::cos(am);
  const double run_x = platform_r * std::cos(as) - tip_x, run_y = platform_r * std::sin(as) - tip_y;
  const double home_z = std::sqrt(rod * rod - run_x * run_x - run_y * run_y);
  const std::string json = R"({"format": "kincal-robot", "version": 1, "family": "rus6", "name": "large-rus6",
    "units": {"length": "mm", "angle": "rad"}, )" + extra_keys +
                           R"( "motor_axes": [)" + motors + R"(], "crank_zero": [)" + zero +
                           R"(], "crank_length": [150, 150, 150, 156, 150, 150], "rod_length": 620, "platform_joints": [)" +
                           spheres + R"(], "joint_limits": {"min": [)" + std::string(5, ' ') +
                           "-1.309, -1.309, -1.309, -1.309, -1.309, -1.309], \"max\": [1.1345, 1.1345, 1.1345, 1.1345, "
                           "1.1345, 1.1345]}, \"screw_lead\": 0.12566370614359174, \"home\": {\"x\": 0, \"y\": 0, \"z\": " +
                           std::to_string(home_z) + ", \"rx\": 0, \"ry\": 0, \"rz\": 0}}";
  return kincal::identify::parse_robot(json, "large-rus6.json");
}

}  // namespace kincal_test
