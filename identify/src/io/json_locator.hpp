// Private to identify/: where each value of an (already validated) JSON text
// starts, keyed by JSON-pointer-like paths ("/base_joints/2/0"). nlohmann/json
// gives no source positions for values, but schema errors must name the line
// and column (GUIDE "Bars"), so this walks the text once more.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace kincal::identify::detail {

struct JsonLocations {
  std::map<std::string, std::size_t> value;  // path → offset of the value's first byte
  std::map<std::string, std::size_t> key;    // path → offset of the key's opening quote
  struct Duplicate {
    std::string path;
    std::size_t offset;
  };
  std::vector<Duplicate> duplicates;  // repeated keys in one object

  // Offset of the value at `path`, or of its nearest recorded ancestor.
  std::size_t value_offset(std::string path) const;
  std::size_t key_offset(const std::string& path) const;
};

// `text` must be valid JSON (parse it with nlohmann first); on malformed input
// the result is incomplete but the walk stays in bounds.
JsonLocations locate_json(std::string_view text);

// Refuses JSON nested deeper than `max_depth` arrays / objects before any
// parser sees it (issue #10 item 8: a MODEL.json whose "robot" was nested
// ~3 000 deep overflowed the stack in json::dump()): InputError at the line and
// column of the first bracket too deep. Strings are skipped.
void check_json_depth(std::string_view text, const std::string& file, int max_depth = 64);

// The one way identify/ reads a JSON text (robot descriptions, MODEL.json):
// check_json_depth, then nlohmann's parser, every failure an InputError at
// the line and column where the text goes wrong — a syntax error where the
// parser stopped, a number that does not fit a double ("1e999": nlohmann
// gives no position) at the number itself.
nlohmann::json parse_json_text(const std::string& text, const std::string& file);

std::string child_path(const std::string& parent, const std::string& key);
std::string child_path(const std::string& parent, std::size_t index);

}  // namespace kincal::identify::detail
