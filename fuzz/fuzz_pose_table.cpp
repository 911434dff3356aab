// libFuzzer target: the measurement / poses CSV reader (identify/csv.hpp
// parse_pose_table, as identify, diagnose, simulate and compensate call it).
// FUZZ_POSES: the poses-file view (same reader; the fuzzer's seeds differ).
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz_check.hpp"
#include "kincal/identify/csv.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace ki = kincal::identify;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const std::string file = "fuzz.csv";
  kincal::fuzz::run(
      [&] {
        ki::PoseTableOptions options;
        options.warn = [](const std::string& w) {
          if (w.find('\n') != std::string::npos) kincal::fuzz::broken("warning not one line", w);
        };
        const ki::PoseTable t = ki::parse_pose_table(text, file, options);
        for (const ki::PoseRow& r : t.rows) {
          kincal::fuzz::check_finite_all(r.commanded, "commanded pose");
          if (r.measured) kincal::fuzz::check_finite_all(*r.measured, "measured pose");
          if (r.targets) kincal::fuzz::check_finite_all(*r.targets, "targets");
          if (r.q) kincal::fuzz::check_finite_all(*r.q, "q");
          if (r.temp) kincal::fuzz::check_finite(*r.temp, "temp");
          if (r.time) kincal::fuzz::check_finite(*r.time, "time");
          if (r.dir)
            for (Eigen::Index k = 0; k < r.dir->size(); ++k)
              if ((*r.dir)(k) != 1 && (*r.dir)(k) != -1) kincal::fuzz::broken("direction not +-1", r.id);
        }
      },
      file);
  return 0;
}
