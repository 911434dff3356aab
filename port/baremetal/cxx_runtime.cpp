// C++ run-time pieces for the firmware (port/baremetal).
//
// operator new is deliberately NOT defined: every form is --wrap'ed in the link
// (CMakeLists.txt), so any reference to it fails to link (see heap_probe.cpp).
//
// operator delete, however, is referenced by every class with a virtual
// destructor (the compiler emits a "deleting destructor" whether or not the class
// is ever heap-allocated).  libsupc++'s operator delete calls free(), which is
// also wrapped, so without these stubs a harmless virtual destructor would look
// like heap use.  Since nothing can be allocated with new, none of these can be
// reached; if one is, the program stops with a message.
#include <cstddef>

#include "runtime.h"
#include "semihosting.h"

namespace {
[[noreturn]] void delete_reached() {
  kincal_semihost_write("\n*** kincal firmware: operator delete called (no heap exists)\n");
  kincal_firmware_exit(2);
}
}  // namespace

void operator delete(void*) noexcept { delete_reached(); }
void operator delete[](void*) noexcept { delete_reached(); }
void operator delete(void*, std::size_t) noexcept { delete_reached(); }
void operator delete[](void*, std::size_t) noexcept { delete_reached(); }
