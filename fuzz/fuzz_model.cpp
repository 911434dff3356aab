// libFuzzer target: MODEL.json (identify/model.hpp parse_model); an accepted
// model must have finite parameters, and its calibration table (what
// `kincal table` and `kincal compensate` build) is either made or refused
// with the same one-line contract.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_check.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/model.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace ki = kincal::identify;
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string file = "model.json";
  kincal::fuzz::run(
      [&] {
        const ki::CalibrationModel m = ki::parse_model(text, file);
        for (const ki::ModelParameter& p : m.parameters) {
          kincal::fuzz::check_finite(p.value, "parameter value");
          kincal::fuzz::check_finite(p.standard_error, "standard error");
        }
        try {
          (void)ki::calibration_table(m);
        } catch (const ki::InputError& e) {
          kincal::fuzz::check_message(e, "");
        }
      },
      file);
  return 0;
}
