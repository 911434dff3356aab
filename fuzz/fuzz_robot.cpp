// libFuzzer target: robot description JSON (identify/robot.hpp parse_robot);
// an accepted robot must have a finite geometry and write itself back.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_check.hpp"
#include "kincal/identify/robot.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace ki = kincal::identify;
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string file = "robot.json";
  kincal::fuzz::run(
      [&] {
        const ki::Robot r = ki::parse_robot(text, file);
        if (r.is_stewart()) {
          kincal::fuzz::check_finite_all(r.stewart().base, "base");
          kincal::fuzz::check_finite_all(r.stewart().platform, "platform");
          kincal::fuzz::check_finite_all(r.stewart().min_length, "stroke");
          kincal::fuzz::check_finite_all(r.stewart().max_length, "stroke");
        } else {
          kincal::fuzz::check_finite_all(r.hybrid().base_joints, "base joints");
          kincal::fuzz::check_finite_all(r.hybrid().joint_offset, "joint offset");
        }
        (void)ki::parse_robot(ki::robot_to_json(r), "round trip");  // what it writes, it reads
      },
      file);
  return 0;
}
