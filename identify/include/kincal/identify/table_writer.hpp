// `kincal table`: a calibration model (MODEL.json) as a constexpr C++ header
// for the firmware (issue #5 item 3; docs/firmware.md "Generated tables").
//
// The header holds, for double and float:
//   - the calibration table (identify/calibration_table.hpp: the numbers
//     `kincal compensate` runs on), as core's canonical value list
//     (core/calibration_table.hpp) with full round-trip precision (17
//     significant digits: every double comes back bit for bit), its format
//     version and its CRC-32, checked at compile time by
//     static_assert(table_crc(...) == crc) and static_assert(validate_table(...) == Ok);
//   - the nominal table of the same machine (no identified errors, no
//     effects, default bounds): the controller's fallback when the
//     calibration table fails its start-up check.
// A "generated from <model> by kincal <version>" banner names its source
// (libopencm3 / modm style), and the header does not compile against a core
// of another table format version.
#pragma once

#include <string>

#include "kincal/identify/model.hpp"

namespace kincal::identify {

// The header text. `model_name` is how the banner names the model (the path
// as the user gave it); nothing else in the text depends on it being a file.
// Throws InputError if the model cannot become a valid table
// (identify/calibration_table.hpp).
std::string calibration_table_header(const CalibrationModel& model, const std::string& model_name);

// Reads MODEL.json and writes the header to `out_path` atomically
// (files.hpp; the output is never read). Throws InputError on a bad model, an
// unwritable path, or an output that is the model file itself.
void write_calibration_table_header(const std::string& model_path, const std::string& out_path);

}  // namespace kincal::identify
