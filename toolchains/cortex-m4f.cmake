# Cortex-M4F, single-precision FPU (FPv4-SP-D16).
# Usage: cmake -S . -B build-m4f -DCMAKE_TOOLCHAIN_FILE=toolchains/cortex-m4f.cmake
# Tests run on qemu's mps2-an386 board (Cortex-M4 with FPU, see docs/firmware.md).
set(KINCAL_ARM_CPU_FLAGS "-mcpu=cortex-m4 -mfpu=fpv4-sp-d16 -mfloat-abi=hard -mthumb")
set(KINCAL_QEMU_MACHINE mps2-an386)
set(KINCAL_QEMU_CPU cortex-m4)
set(KINCAL_FIRMWARE_BOARD "mps2-an386" CACHE STRING "Board the firmware tests are linked for and run on")
# double would be software-emulated here (slow, large): the core runs in float only.
set(KINCAL_FIRMWARE_SCALARS "float" CACHE STRING "Scalar types the firmware tests instantiate")
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi-common.cmake)
