/* Bare-metal start-up for the qemu mps2 boards (Cortex-M4F / Cortex-M7).
 *
 * Owns everything between reset and main():
 *   vector table -> Reset_Handler: FPU on, .data copied, .bss zeroed, stack
 *   painted, C++ constructors run -> main() -> exit through semihosting with
 *   main's return value.
 * and everything that must end a test instead of hanging it: every fault and
 * unexpected exception, abort(), assert(), stack overflow.
 *
 * Exit statuses seen by ctest: main's value; 2 = abort/assert; 3 = fault or
 * unexpected exception; 4 = stack overflow detected at exit.
 * Written in C (no assembler file) so the top-level project needs no ASM language.
 */
#include <stdint.h>

#include "runtime.h"
#include "semihosting.h"

/* Symbols defined by mps2.ld; only their addresses are meaningful. */
extern uint32_t __stack_bottom[];
extern uint32_t __stack_top[];
extern uint32_t __data_load[];
extern uint32_t __data_start[];
extern uint32_t __data_end[];
extern uint32_t __bss_start[];
extern uint32_t __bss_end[];
extern uint32_t __ram_start[];
extern uint32_t __ram_end[];
typedef void (*kincal_init_fn)(void);
extern kincal_init_fn __preinit_array_start[];
extern kincal_init_fn __preinit_array_end[];
extern kincal_init_fn __init_array_start[];
extern kincal_init_fn __init_array_end[];

int main(void);

/* System control block registers (Armv7-M ARM, B3.2). */
#define KINCAL_REG(addr) (*(volatile uint32_t*)(addr))
#define SCB_VTOR KINCAL_REG(0xE000ED08u)
#define SCB_CCR KINCAL_REG(0xE000ED14u)
#define SCB_CFSR KINCAL_REG(0xE000ED28u)
#define SCB_HFSR KINCAL_REG(0xE000ED2Cu)
#define SCB_MMFAR KINCAL_REG(0xE000ED34u)
#define SCB_BFAR KINCAL_REG(0xE000ED38u)
#define SCB_CPACR KINCAL_REG(0xE000ED88u)

/* Fill pattern for the stack high-water mark. */
#define KINCAL_STACK_PAINT 0xC5AC5AC5u

void Reset_Handler(void) __attribute__((noreturn));
/* Not declared noreturn: the weak aliases below would then need it too. */
void Default_Handler(void);

/* Every exception the application does not define ends the test (see below).
 * Weak, so a firmware example can provide e.g. its own SysTick_Handler. */
#define KINCAL_WEAK_DEFAULT __attribute__((weak, alias("Default_Handler")))
void NMI_Handler(void) KINCAL_WEAK_DEFAULT;
void HardFault_Handler(void) KINCAL_WEAK_DEFAULT;
void MemManage_Handler(void) KINCAL_WEAK_DEFAULT;
void BusFault_Handler(void) KINCAL_WEAK_DEFAULT;
void UsageFault_Handler(void) KINCAL_WEAK_DEFAULT;
void SVC_Handler(void) KINCAL_WEAK_DEFAULT;
void DebugMon_Handler(void) KINCAL_WEAK_DEFAULT;
void PendSV_Handler(void) KINCAL_WEAK_DEFAULT;
void SysTick_Handler(void) KINCAL_WEAK_DEFAULT;

/* Entry 0 is the initial stack pointer, not a handler: a union avoids casting
 * between object and function pointers (not ISO C). */
typedef union {
  void (*handler)(void);
  uint32_t* stack;
} kincal_vector;

/* Both mps2 images (AN386, AN500) wire 32 external interrupts.  None is enabled,
 * but a complete table means a stray one lands in Default_Handler rather than at
 * whatever follows the table. */
#define KINCAL_SYSTEM_VECTORS 16
#define KINCAL_EXTERNAL_IRQS 32
#define KINCAL_IRQ1 {.handler = Default_Handler}
#define KINCAL_IRQ8 KINCAL_IRQ1, KINCAL_IRQ1, KINCAL_IRQ1, KINCAL_IRQ1, \
                    KINCAL_IRQ1, KINCAL_IRQ1, KINCAL_IRQ1, KINCAL_IRQ1

__attribute__((section(".isr_vector"), used))
const kincal_vector kincal_vector_table[KINCAL_SYSTEM_VECTORS + KINCAL_EXTERNAL_IRQS] = {
    [0] = {.stack = __stack_top},
    [1] = {.handler = Reset_Handler},
    [2] = {.handler = NMI_Handler},
    [3] = {.handler = HardFault_Handler},
    [4] = {.handler = MemManage_Handler},
    [5] = {.handler = BusFault_Handler},
    [6] = {.handler = UsageFault_Handler},
    [11] = {.handler = SVC_Handler},
    [12] = {.handler = DebugMon_Handler},
    [14] = {.handler = PendSV_Handler},
    [15] = {.handler = SysTick_Handler},
    /* Entries 16..47: external interrupts 0..31 (a range designator would be a
     * GNU extension, hence the spelled-out list). */
    KINCAL_IRQ8, KINCAL_IRQ8, KINCAL_IRQ8, KINCAL_IRQ8,
};

/* Reset_Handler runs before the FPU is enabled, so it must not touch a floating-
 * point register: general-regs-only makes the compiler guarantee that (it could
 * otherwise use VFP registers to copy memory). */
__attribute__((target("general-regs-only"))) void Reset_Handler(void) {
  /* CP10/CP11 full access: without it the first VFP instruction is a UsageFault
   * (NOCP).  DSB/ISB so the next instruction sees the enabled FPU. */
  SCB_CPACR |= (0xFu << 20);
  __asm__ volatile("dsb\n\tisb" ::: "memory");

  /* qemu starts at VTOR = 0 where the table is; a real board with a boot loader
   * may not, so point VTOR at our table explicitly. */
  SCB_VTOR = (uint32_t)(uintptr_t)kincal_vector_table;
  /* Integer division by zero traps instead of silently giving 0. */
  SCB_CCR |= (1u << 4);

  /* .data: initial values live in code memory (LMA), variables in RAM (VMA). */
  for (uint32_t *src = __data_load, *dst = __data_start; dst < __data_end;) *dst++ = *src++;
  for (uint32_t* dst = __bss_start; dst < __bss_end;) *dst++ = 0u;

  /* Paint the unused part of the stack so kincal_firmware_exit can report the
   * high-water mark and detect an overflow into the bottom word. */
  uint32_t* sp;
  __asm__ volatile("mov %0, sp" : "=r"(sp));
  for (uint32_t* p = __stack_bottom; p < sp - 16;) *p++ = KINCAL_STACK_PAINT;

  /* C++ static constructors (and C __attribute__((constructor))). */
  for (kincal_init_fn* f = __preinit_array_start; f < __preinit_array_end; ++f) (*f)();
  for (kincal_init_fn* f = __init_array_start; f < __init_array_end; ++f) (*f)();

  kincal_firmware_exit(main());
}

/* Every way out of the program ends here: report the stack high-water mark, then
 * leave through semihosting so qemu exits with the status. */
void kincal_firmware_exit(int status) {
  const uint32_t* p = __stack_bottom;
  while (p < __stack_top && *p == KINCAL_STACK_PAINT) ++p;
  const long used = (long)((__stack_top - p) * (long)sizeof(uint32_t));
  const long size = (long)((__stack_top - __stack_bottom) * (long)sizeof(uint32_t));
  kincal_semihost_write("kincal firmware: stack used ");
  kincal_semihost_write_int(used);
  kincal_semihost_write(" of ");
  kincal_semihost_write_int(size);
  kincal_semihost_write(" bytes\n");
  if (p == __stack_bottom) {
    kincal_semihost_write("kincal firmware: STACK OVERFLOW (bottom word overwritten)\n");
    if (status == 0) status = 4;
  }
  kincal_semihost_exit(status);
}

static const char* exception_name(uint32_t number) {
  switch (number) {
    case 2: return "NMI";
    case 3: return "HardFault";
    case 4: return "MemManage fault";
    case 5: return "BusFault";
    case 6: return "UsageFault";
    case 11: return "SVCall";
    case 12: return "DebugMonitor";
    case 14: return "PendSV";
    case 15: return "SysTick";
    default: return "external interrupt";
  }
}

/* Called by Default_Handler with the exception frame (r0..r3, r12, lr, pc, xPSR),
 * or NULL if the stack pointer was unusable. */
void kincal_fault_report(const uint32_t* frame) __attribute__((noreturn, used));
void kincal_fault_report(const uint32_t* frame) {
  uint32_t ipsr;
  __asm__ volatile("mrs %0, ipsr" : "=r"(ipsr));
  const uint32_t number = ipsr & 0x1FFu;
  kincal_semihost_write("\n*** kincal firmware: ");
  kincal_semihost_write(exception_name(number));
  kincal_semihost_write(" (exception ");
  kincal_semihost_write_int((long)number);
  kincal_semihost_write(")\n");
  const uintptr_t f = (uintptr_t)frame;
  if (frame != 0 && (f & 3u) == 0u && f >= (uintptr_t)__ram_start && f + 32u <= (uintptr_t)__ram_end) {
    kincal_semihost_write("    pc ");
    kincal_semihost_write_hex(frame[6]);
    kincal_semihost_write("  lr ");
    kincal_semihost_write_hex(frame[5]);
    kincal_semihost_write("\n");
  } else {
    kincal_semihost_write("    stack pointer unusable (stack overflow?)\n");
  }
  kincal_semihost_write("    CFSR ");
  kincal_semihost_write_hex(SCB_CFSR);
  kincal_semihost_write("  HFSR ");
  kincal_semihost_write_hex(SCB_HFSR);
  kincal_semihost_write("  MMFAR ");
  kincal_semihost_write_hex(SCB_MMFAR);
  kincal_semihost_write("  BFAR ");
  kincal_semihost_write_hex(SCB_BFAR);
  kincal_semihost_write("\n    (addr2line -e <elf> <pc> names the faulting line)\n");
  kincal_semihost_exit(3);
}

/* Naked: no prologue may push onto a stack that might be the cause of the fault.
 * Hands kincal_fault_report the exception frame; if the stack pointer is within
 * 256 bytes of the stack bottom (or below it), the report runs on a fresh stack
 * from the top instead, since nothing returns from here anyway. */
__attribute__((naked)) void Default_Handler(void) {
  __asm__ volatile(
      "tst lr, #4\n\t"
      "ite eq\n\t"
      "mrseq r0, msp\n\t"
      "mrsne r0, psp\n\t"
      "movw r1, #:lower16:__stack_bottom\n\t"
      "movt r1, #:upper16:__stack_bottom\n\t"
      "add r1, r1, #256\n\t"
      "cmp r0, r1\n\t"
      "bhs 1f\n\t"
      "movw r1, #:lower16:__stack_top\n\t"
      "movt r1, #:upper16:__stack_top\n\t"
      "msr msp, r1\n\t"
      "movs r0, #0\n"
      "1:\n\t"
      "b kincal_fault_report\n");
}

/* --- C library hooks: route the few newlib exits to semihosting. ------------ */

/* exit() ends in _exit(); newlib has no default for it on bare metal. */
void _exit(int status) __attribute__((noreturn));
void _exit(int status) { kincal_firmware_exit(status); }

/* newlib's abort() raises SIGABRT through _kill/_getpid, which do not exist here. */
void abort(void) __attribute__((noreturn));
void abort(void) {
  kincal_semihost_write("\n*** kincal firmware: abort()\n");
  kincal_firmware_exit(2);
}

/* assert() failures (also Eigen's eigen_assert): newlib's version formats with
 * fiprintf, which drags in stdio and the heap.  This one needs neither. */
void __assert_func(const char* file, int line, const char* func, const char* expr)
    __attribute__((noreturn));
void __assert_func(const char* file, int line, const char* func, const char* expr) {
  kincal_semihost_write("\n*** kincal firmware: assertion failed: ");
  kincal_semihost_write(expr != 0 ? expr : "?");
  kincal_semihost_write("\n    at ");
  kincal_semihost_write(file != 0 ? file : "?");
  kincal_semihost_write(":");
  kincal_semihost_write_int(line);
  if (func != 0) {
    kincal_semihost_write(" in ");
    kincal_semihost_write(func);
  }
  kincal_semihost_write("\n");
  kincal_firmware_exit(2);
}

/* -fno-use-cxa-atexit registers static destructors with atexit().  A controller
 * never runs them, and newlib's atexit would reserve a 32-slot table in RAM. */
int atexit(void (*function)(void));
int atexit(void (*function)(void)) {
  (void)function;
  return 0;
}

/* Reached only through a call of a pure virtual function from a constructor or
 * destructor; libsupc++'s version would pull in std::terminate and exceptions. */
void __cxa_pure_virtual(void) __attribute__((noreturn));
void __cxa_pure_virtual(void) {
  kincal_semihost_write("\n*** kincal firmware: pure virtual function called\n");
  kincal_firmware_exit(2);
}
