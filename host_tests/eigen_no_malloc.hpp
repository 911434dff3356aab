// "No malloc" enforced, not promised (Eigen's test/nomalloc.cpp): with
// EIGEN_RUNTIME_NO_MALLOC every Eigen heap allocation checks a flag
// (Eigen::internal::set_is_malloc_allowed), and eigen_assert is routed to
// abort() so the trap also fires in Release builds (where NDEBUG disables
// assert). Include this first, before anything that includes Eigen.
#pragma once

#include <cstdio>
#include <cstdlib>

#define EIGEN_RUNTIME_NO_MALLOC
#define eigen_assert(x)                                      \
  do {                                                       \
    if (!(x)) {                                              \
      std::fprintf(stderr, "eigen_assert failed: %s\n", #x); \
      std::abort();                                          \
    }                                                        \
  } while (false)
