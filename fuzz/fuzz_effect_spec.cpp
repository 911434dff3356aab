// libFuzzer target: `--effect NAME:PARAM=VALUE[,PARAM=VALUE...]`
// (identify/parameters.hpp parse_effect_options) and setting it on both built-in robots, as simulate does.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_check.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/robot.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace ki = kincal::identify;
  static const ki::Robot stewart = ki::builtin_robot("stewart-seed001");
  static const ki::Robot hybrid = ki::builtin_robot("hybrid-seed000");
  const std::string text(reinterpret_cast<const char*>(data), size);
  kincal::fuzz::run(
      [&] {
        for (const ki::EffectSetting& s : ki::parse_effect_options(text)) {
          kincal::fuzz::check_finite(s.value, "effect value");
          for (const ki::Robot* r : {&stewart, &hybrid}) {
            ki::EffectValues v;
            try {
              v.set(*r, s.effect, s.parameter, s.value);
            } catch (const ki::InputError& e) {
              kincal::fuzz::check_message(e, "");
            }
          }
        }
      },
      "");
  return 0;
}
