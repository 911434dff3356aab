# Cortex-M7 with the double-precision FPU (FPv5-D16): the reference controller target.
# Usage: cmake -S . -B build-m7 -DCMAKE_TOOLCHAIN_FILE=toolchains/cortex-m7.cmake
# Tests run on qemu's mps2-an500 board (Cortex-M7, see docs/firmware.md).
set(KINCAL_ARM_CPU_FLAGS "-mcpu=cortex-m7 -mfpu=fpv5-d16 -mfloat-abi=hard -mthumb")
set(KINCAL_QEMU_MACHINE mps2-an500)
set(KINCAL_QEMU_CPU cortex-m7)
set(KINCAL_FIRMWARE_BOARD "mps2-an500" CACHE STRING "Board the firmware tests are linked for and run on")
# The FPU does double in hardware, so the core is tested in both scalars.
set(KINCAL_FIRMWARE_SCALARS "double;float" CACHE STRING "Scalar types the firmware tests instantiate")
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi-common.cmake)
