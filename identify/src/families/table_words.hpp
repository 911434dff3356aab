// How the table check says what it refused (io/calibration_table.cpp and the
// families' machine_limit_violation): numbers to six digits, the robot
// description key that raises a bound, the first array value above its cap.
// Private to identify/.
#pragma once

#include <cmath>
#include <cstddef>
#include <sstream>
#include <string>

namespace kincal::identify::detail {

inline std::string table_number(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

// Where the user raises a bound a message names: every bound of the table
// check is a robot description key (GUIDE "Bounds, per machine").
inline std::string key_note(const char* key) { return std::string(" (robot description key '") + key + "')"; }

// The first value of `values` (named `name`, less `base` if given) whose
// magnitude is above the cap of the robot description key `key`.
template <std::size_t N>
std::string first_above(const char* name, const double (&values)[N], double cap, const char* key,
                        const double* base = nullptr) {
  for (std::size_t k = 0; k < N; ++k) {
    const double v = values[k] - (base != nullptr ? base[k] : 0.0);
    if (!(std::abs(v) <= cap))
      return std::string(name) + "[" + std::to_string(k) + "] = " + table_number(v) + " above " + key + " " +
             table_number(cap) + key_note(key);
  }
  return {};
}

}  // namespace kincal::identify::detail
