// Errors in user input (robot descriptions, CSV tables, parameter files,
// command-line values). Host side only: identify/ may throw; the kincal tool
// catches these at main and prints what() as one line, `FILE:LINE:COL: message`
// (GUIDE "Bars": bad input gets a clear one-line error naming where).
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

namespace kincal::identify {

class InputError : public std::runtime_error {
 public:
  // line / column are 1-based; 0 means "not known" and is left out of what().
  InputError(std::string file, std::size_t line, std::size_t column, std::string message);
  explicit InputError(std::string message) : InputError({}, 0, 0, std::move(message)) {}

  const std::string& file() const { return file_; }
  std::size_t line() const { return line_; }
  std::size_t column() const { return column_; }
  const std::string& message() const { return message_; }

 private:
  std::string file_;
  std::size_t line_;
  std::size_t column_;
  std::string message_;
};

// `s` on one line: control characters written as escapes (\n, \r, \t,
// \xNN), so a string from the input (an id, a parameter name, a file name)
// cannot break an error or warning into several lines or start a line that
// looks like the tool's own (issue #10 item 11). InputError's what() and the
// tool's warnings go through it.
std::string one_line(const std::string& s);

// "FILE:LINE:COL" with the unknown parts left out ("FILE:LINE", "FILE", "").
std::string format_location(const std::string& file, std::size_t line, std::size_t column);

struct TextPosition {
  std::size_t line = 1;    // 1-based
  std::size_t column = 1;  // 1-based, in bytes
};

// Line and column of byte `offset` (0-based) in `text`. Offsets past the end
// map to the position just after the last character.
TextPosition position_of(std::string_view text, std::size_t offset);

// Reads a whole input file (files.hpp read_input_file: a regular file of at
// most 256 MiB); throws InputError naming the file if it cannot be read.
std::string read_text_file(const std::string& path);

}  // namespace kincal::identify
