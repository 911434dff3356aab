/* Deliberately faults: the test firmware_fault_exits checks that a HardFault
 * ends the qemu run with a report and a failure status instead of hanging ctest. */
#include <stdint.h>

int main(void) {
  /* 0x30000000 is not decoded on the mps2 boards (between the 0x2xxxxxxx RAMs and
   * the 0x4xxxxxxx peripherals): the store is a BusFault, escalated to HardFault. */
  *(volatile uint32_t*)0x30000000u = 0xDEADBEEFu;
  return 0; /* not reached: 0 here would make the test fail */
}
