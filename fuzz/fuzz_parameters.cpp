// libFuzzer target: PARAMS.csv (identify/parameters.hpp parse_parameters) for
// both built-in robots (the first input byte chooses), then applied to the
// robot as simulate does.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz_check.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/robot.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace ki = kincal::identify;
  if (size == 0) return 0;
  static const ki::Robot stewart = ki::builtin_robot("stewart-seed001");
  static const ki::Robot hybrid = ki::builtin_robot("hybrid-seed000");
  const ki::Robot& robot = (data[0] & 1) ? hybrid : stewart;
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  const std::string file = "params.csv";
  kincal::fuzz::run(
      [&] {
        const ki::ParameterSet set = ki::parse_parameters(text, file, robot, [](const std::string& w) {
          if (w.find('\n') != std::string::npos) kincal::fuzz::broken("warning not one line", w);
        });
        for (const auto& v : set.values) kincal::fuzz::check_finite(v.value, "parameter value");
        (void)ki::apply_parameters(robot, set);
      },
      file);
  return 0;
}
