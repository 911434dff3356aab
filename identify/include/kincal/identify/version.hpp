// Version of the kincal tools. Keep in step with project(kincal VERSION ...)
// in the top-level CMakeLists.txt.
#pragma once

namespace kincal::identify {
inline constexpr const char* kVersion = "0.1.0";
}  // namespace kincal::identify
