// Shared by the libFuzzer targets (fuzz/*.cpp): the contract every reader
// keeps on any input (issue #10, "Real fuzzing"): it parses, or it throws the
// project's InputError whose message is ONE line naming the file; never a
// crash, a hang, another exception, or a non-finite number accepted.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "kincal/identify/input_error.hpp"

namespace kincal::fuzz {

[[noreturn]] inline void broken(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz contract broken: %s: %s\n", what, detail.c_str());
  std::abort();
}

// The error contract: one line, naming `file` first ("" for inputs without a file).
inline void check_message(const identify::InputError& e, const std::string& file) {
  const std::string m = e.what();
  if (m.empty()) broken("empty message", m);
  if (m.find('\n') != std::string::npos || m.find('\r') != std::string::npos) broken("message not one line", m);
  if (!file.empty() && m.rfind(file, 0) != 0) broken("message does not name the file", m);
}

inline void check_finite(double v, const char* what) {
  if (!std::isfinite(v)) broken("non-finite value accepted", what);
}

template <class M> void check_finite_all(const M& m, const char* what) {
  for (Eigen::Index i = 0; i < m.size(); ++i) check_finite(m.data()[i], what);
}

// Runs `parse`; InputError must keep the contract; anything else thrown is a bug.
template <class F> void run(F&& parse, const std::string& file) {
  try {
    parse();
  } catch (const identify::InputError& e) {
    check_message(e, file);
  } catch (const std::exception& e) {
    broken("unexpected exception", e.what());
  }
}

}  // namespace kincal::fuzz
