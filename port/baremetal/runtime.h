/* Bare-metal run-time entry points shared by startup.c and cxx_runtime.cpp. */
#ifndef KINCAL_PORT_BAREMETAL_RUNTIME_H
#define KINCAL_PORT_BAREMETAL_RUNTIME_H

#ifdef __cplusplus
extern "C" {
#endif

/* Reports the stack high-water mark, then ends the program through semihosting
 * with `status` (0 = pass).  Used after main() returns and by _exit/abort/assert. */
void kincal_firmware_exit(int status) __attribute__((noreturn));

#ifdef __cplusplus
}
#endif

#endif
