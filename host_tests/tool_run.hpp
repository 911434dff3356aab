// Running the built kincal tool from a test (app_kincal_test.cpp,
// identify_table_bounds_test.cpp): the binary KINCAL_TOOL with arguments,
// stdout and stderr captured in per-test files under `dir` (ctest runs test
// cases as parallel processes), bounded so that a hang fails the test (exit
// status 124) instead of stalling the suite.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/input_error.hpp"  // read_text_file

namespace kincal_test {

struct ToolRun {
  int code = -1;
  std::string out, err;
};

inline std::string test_name() { return ::testing::UnitTest::GetInstance()->current_test_info()->name(); }

inline ToolRun run_tool_in(const std::string& dir, const std::string& args) {
  std::filesystem::create_directories(dir);
  const std::string out = dir + "/" + test_name() + ".stdout", err = dir + "/" + test_name() + ".stderr";
  const std::string cmd =
      std::string("timeout 300 \"") + KINCAL_TOOL + "\" " + args + " >\"" + out + "\" 2>\"" + err + "\"";
  const int status = std::system(cmd.c_str());
  ToolRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = kincal::identify::read_text_file(out);
  r.err = kincal::identify::read_text_file(err);
  return r;
}

// `text` written as `dir`/`name`; returns the path.
inline std::string write_in(const std::string& dir, const std::string& name, const std::string& text) {
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

}  // namespace kincal_test
