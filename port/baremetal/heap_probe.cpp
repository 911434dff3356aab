// Must NOT link: proves that heap use in firmware is a link error.
// Built only by the ctest test firmware_heap_use_fails_to_link, which expects the
// link to fail on the undefined __wrap_malloc and __wrap__Znwj (CMakeLists.txt).
// If this file ever links, the no-heap guarantee is gone.
#include <cstdlib>

// volatile: stops the compiler from eliding the matched allocate/free pairs,
// which C++14 allows and GCC does at -Os.
static void* volatile g_sink;

int main() {
  g_sink = std::malloc(16);
  std::free(g_sink);
  int* p = new int(42);
  g_sink = p;
  delete p;
  return 0;
}
