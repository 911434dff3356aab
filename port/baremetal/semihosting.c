/* Arm semihosting calls, see semihosting.h. */
#include "semihosting.h"

#include <stdint.h>

/* Operation numbers (Arm semihosting specification v2.0, table 5-1). */
enum {
  SYS_OPEN = 0x01,
  SYS_CLOSE = 0x02,
  SYS_WRITE0 = 0x04,
  SYS_WRITE = 0x05,
  SYS_READ = 0x06,
  SYS_GET_CMDLINE = 0x15,
  SYS_EXIT = 0x18,
  SYS_EXIT_EXTENDED = 0x20
};
/* SYS_EXIT reason codes. */
enum {
  ADP_Stopped_RunTimeErrorUnknown = 0x20023,
  ADP_Stopped_ApplicationExit = 0x20026
};

/* One semihosting call.  The "memory" clobber matters: the host reads and writes
 * the buffers r1 points to, which the compiler cannot see. */
static intptr_t semihost_call(uintptr_t op, const void* arg) {
  register uintptr_t r0 __asm__("r0") = op;
  register const void* r1 __asm__("r1") = arg;
  __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
  return (intptr_t)r0;
}

void kincal_semihost_write(const char* text) { (void)semihost_call(SYS_WRITE0, text); }

void kincal_semihost_write_int(long value) {
  char buf[24];
  char* p = buf + sizeof buf;
  /* Work in unsigned so LONG_MIN does not overflow when negated. */
  unsigned long magnitude = value < 0 ? 0UL - (unsigned long)value : (unsigned long)value;
  *--p = '\0';
  do {
    *--p = (char)('0' + magnitude % 10UL);
    magnitude /= 10UL;
  } while (magnitude != 0UL);
  if (value < 0) *--p = '-';
  kincal_semihost_write(p);
}

void kincal_semihost_write_hex(unsigned long value) {
  static const char digits[] = "0123456789abcdef";
  char buf[11];
  buf[0] = '0';
  buf[1] = 'x';
  for (int i = 0; i < 8; ++i) buf[2 + i] = digits[(value >> (28 - 4 * i)) & 0xFUL];
  buf[10] = '\0';
  kincal_semihost_write(buf);
}

void kincal_semihost_exit(int status) {
  if (status == 0) {
    /* AArch32 SYS_EXIT takes the reason code itself in r1 (not a block);
     * qemu exits 0 for ApplicationExit. */
    (void)semihost_call(SYS_EXIT, (const void*)(uintptr_t)ADP_Stopped_ApplicationExit);
  } else {
    /* SYS_EXIT_EXTENDED carries an exit code; qemu passes it to exit(), which
     * keeps the low 8 bits, so never let a failure become 0. */
    int code = status & 0xFF;
    const uintptr_t block[2] = {ADP_Stopped_ApplicationExit, (uintptr_t)(code != 0 ? code : 1)};
    (void)semihost_call(SYS_EXIT_EXTENDED, block);
    /* A host without SYS_EXIT_EXTENDED returns: any reason other than
     * ApplicationExit still means "failed" (qemu: exit status 1). */
    (void)semihost_call(SYS_EXIT, (const void*)(uintptr_t)ADP_Stopped_RunTimeErrorUnknown);
  }
  for (;;) {
    /* No host attached: nothing sensible left to do. */
  }
}

static size_t string_length(const char* s) {
  size_t n = 0;
  while (s[n] != '\0') ++n;
  return n;
}

int kincal_semihost_open(const char* path, enum kincal_semihost_mode mode) {
  const uintptr_t block[3] = {(uintptr_t)path, (uintptr_t)mode, (uintptr_t)string_length(path)};
  return (int)semihost_call(SYS_OPEN, block);
}

size_t kincal_semihost_write_file(int handle, const void* data, size_t size) {
  const uintptr_t block[3] = {(uintptr_t)handle, (uintptr_t)data, (uintptr_t)size};
  /* The host returns the number of bytes NOT written. */
  intptr_t not_written = semihost_call(SYS_WRITE, block);
  if (not_written < 0 || (size_t)not_written > size) return 0;
  return size - (size_t)not_written;
}

size_t kincal_semihost_read_file(int handle, void* data, size_t size) {
  const uintptr_t block[3] = {(uintptr_t)handle, (uintptr_t)data, (uintptr_t)size};
  /* The host returns the number of bytes NOT read (size at end of file). */
  intptr_t not_read = semihost_call(SYS_READ, block);
  if (not_read < 0 || (size_t)not_read > size) return 0;
  return size - (size_t)not_read;
}

int kincal_semihost_close(int handle) {
  const uintptr_t block[1] = {(uintptr_t)handle};
  return semihost_call(SYS_CLOSE, block) == 0 ? 0 : -1;
}

int kincal_semihost_get_cmdline(char* buffer, size_t size) {
  if (size == 0) return -1;
  /* The host writes the line and its length back into the block. */
  uintptr_t block[2] = {(uintptr_t)buffer, (uintptr_t)size};
  if (semihost_call(SYS_GET_CMDLINE, block) != 0) return -1;
  if (block[1] >= size) return -1;
  buffer[block[1]] = '\0';
  return 0;
}
