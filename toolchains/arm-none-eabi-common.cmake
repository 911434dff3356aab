# Shared part of the bare-metal Arm toolchain files (cortex-m7.cmake, cortex-m4f.cmake).
# The including file sets, before include():
#   KINCAL_ARM_CPU_FLAGS     -mcpu/-mfpu/-mfloat-abi/-mthumb for the core
#   KINCAL_QEMU_MACHINE      qemu-system-arm -M value (an mps2 board)
#   KINCAL_QEMU_CPU          qemu-system-arm -cpu value
#   KINCAL_FIRMWARE_BOARD / KINCAL_FIRMWARE_SCALARS as cache variables
# CMake reads a toolchain file several times (once per try_compile too), so this
# file only sets variables and never has side effects.

# "Generic" = no operating system: CMake assumes no shared libraries, no rpath.
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)

# A bare-metal compiler cannot link a test program without our startup and linker
# script, so CMake's compiler checks build a static library instead.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

set(KINCAL_ARM_TRIPLE arm-none-eabi)
find_program(CMAKE_C_COMPILER   ${KINCAL_ARM_TRIPLE}-gcc REQUIRED)
find_program(CMAKE_CXX_COMPILER ${KINCAL_ARM_TRIPLE}-g++ REQUIRED)
set(CMAKE_ASM_COMPILER ${CMAKE_C_COMPILER})
# CMake finds objcopy/objdump/nm itself from the compiler prefix, but not size.
find_program(CMAKE_SIZE ${KINCAL_ARM_TRIPLE}-size REQUIRED)

# -Os is the default optimisation: the firmware bars (flash/RAM/stack) are stated at -Os.
# A build type adds its own flags after these (e.g. Release's -O3 wins over -Os).
# Sections per function/object let --gc-sections drop everything unreferenced.
# newlib-nano (--specs=nano.specs) is smaller and is what bare-metal parts ship;
# it must be given to compile and link alike (it selects newlib-nano's headers and
# libraries).
# -fno-math-errno: core never reads errno, and without it sqrt() drags in
# newlib's reentrancy data (~100 B of .data) to set errno on negative input.
set(_kincal_common_flags "${KINCAL_ARM_CPU_FLAGS} --specs=nano.specs -Os -fno-math-errno -ffunction-sections -fdata-sections")
set(CMAKE_C_FLAGS_INIT   "${_kincal_common_flags}")
set(CMAKE_ASM_FLAGS_INIT "${KINCAL_ARM_CPU_FLAGS}")
# core/ uses no exceptions/RTTI; function-local statics need no guard (single thread,
# and the guards would pull in __cxa_guard_*); static destructors never run on a
# controller, -fno-use-cxa-atexit avoids __cxa_atexit/__dso_handle.
set(CMAKE_CXX_FLAGS_INIT "${_kincal_common_flags} -fno-exceptions -fno-rtti -fno-threadsafe-statics -fno-use-cxa-atexit")
# CMake's link line repeats the compile flags (so -mcpu/--specs reach the link too:
# giving --specs twice is an error in GCC 12).
set(CMAKE_EXE_LINKER_FLAGS_INIT "-Wl,--gc-sections")

# Libraries and headers for the target come from the cross toolchain only; programs
# (qemu, size) from the host.  Packages: both, because Eigen is header-only and its
# CMake config lives on the host (/usr/share/eigen3/cmake).
get_filename_component(_kincal_gcc_bin "${CMAKE_C_COMPILER}" DIRECTORY)
set(CMAKE_FIND_ROOT_PATH "${_kincal_gcc_bin}/../lib/${KINCAL_ARM_TRIPLE}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
if(NOT DEFINED Eigen3_DIR AND EXISTS /usr/share/eigen3/cmake/Eigen3Config.cmake)
  set(Eigen3_DIR /usr/share/eigen3/cmake CACHE PATH "Eigen3 CMake config (host copy; header-only)")
endif()

# ctest runs every firmware test ELF as: <emulator...> <elf>.  The ELF goes right
# after -kernel.  -serial none/-monitor none: all I/O is semihosting, so nothing
# else may claim stdio; target=native: semihosting file calls reach the host files
# (relative to the test's working directory).
find_program(KINCAL_QEMU_SYSTEM_ARM qemu-system-arm)
if(KINCAL_QEMU_SYSTEM_ARM)
  set(CMAKE_CROSSCOMPILING_EMULATOR
    ${KINCAL_QEMU_SYSTEM_ARM} -M ${KINCAL_QEMU_MACHINE} -cpu ${KINCAL_QEMU_CPU}
    -nographic -monitor none -serial none
    -semihosting-config enable=on,target=native
    -kernel)
endif()
