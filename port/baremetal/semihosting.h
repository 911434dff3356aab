/* Arm semihosting for the bare-metal firmware tests (port/baremetal).
 *
 * Semihosting lets code on the target use the host's console and files through
 * the debugger or emulator: the target executes `bkpt 0xAB` with an operation
 * number in r0 and an argument in r1; qemu (-semihosting-config enable=on)
 * performs the operation and resumes.  It is the only I/O the firmware tests
 * use, so no UART driver is needed and a test's exit status reaches ctest.
 * Without a debugger/emulator attached, `bkpt` faults: never call these in a
 * production image.  Reference: Arm "Semihosting for AArch32 and AArch64" v2.0.
 */
#ifndef KINCAL_PORT_BAREMETAL_SEMIHOSTING_H
#define KINCAL_PORT_BAREMETAL_SEMIHOSTING_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Console (the emulator's stderr under qemu). */
void kincal_semihost_write(const char* text);
void kincal_semihost_write_int(long value);
void kincal_semihost_write_hex(unsigned long value); /* "0x" + 8 hex digits */

/* End the program.  status 0 makes qemu exit 0; any other value makes it exit
 * non-zero (the low 8 bits, or 1 if those are 0), so ctest sees the failure. */
void kincal_semihost_exit(int status) __attribute__((noreturn));

/* Host files (paths relative to the emulator's working directory, i.e. the
 * ctest working directory).  Modes are the semihosting SYS_OPEN modes. */
enum kincal_semihost_mode {
  KINCAL_SEMIHOST_READ = 1,   /* "rb" */
  KINCAL_SEMIHOST_WRITE = 5,  /* "wb": create or truncate */
  KINCAL_SEMIHOST_APPEND = 9  /* "ab" */
};
/* Returns a handle >= 0, or -1 on error. */
int kincal_semihost_open(const char* path, enum kincal_semihost_mode mode);
/* Returns the number of bytes written (== size on success). */
size_t kincal_semihost_write_file(int handle, const void* data, size_t size);
/* Returns the number of bytes read; 0 at end of file. */
size_t kincal_semihost_read_file(int handle, void* data, size_t size);
/* Returns 0 on success, -1 on error. */
int kincal_semihost_close(int handle);

/* The program's command line as the emulator has it (qemu: the -kernel file
 * name, then the -append text, or the -semihosting-config arg=... list),
 * NUL-terminated in buffer.  Returns 0, or -1 if the host cannot tell or the
 * line does not fit (SYS_GET_CMDLINE). */
int kincal_semihost_get_cmdline(char* buffer, size_t size);

#ifdef __cplusplus
}
#endif

#endif
