# Cross-compiling SwerveMPC for 64-bit ARM Linux (Raspberry Pi 4, Jetson Orin) with Debian's
# g++-aarch64-linux-gnu; tests and the CLI run under qemu-aarch64. `make cross-arm64` uses it with
#   -DSWERVE_ARM64_SYSROOT=<dir>   the arm64 libraries unpacked by scripts/arm64-sysroot.sh
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)

if(NOT SWERVE_ARM64_SYSROOT)
  message(FATAL_ERROR "aarch64-linux-gnu.cmake: set -DSWERVE_ARM64_SYSROOT=<dir> (scripts/arm64-sysroot.sh)")
endif()
# Try-compiles see the same sysroot.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES SWERVE_ARM64_SYSROOT)

# arm64 libraries and their CMake packages from the unpacked sysroot only; headers and header-only
# packages (Eigen, ceres/jet.h, CLI11, nlohmann-json) also from the host; programs from the host.
set(CMAKE_FIND_ROOT_PATH ${SWERVE_ARM64_SYSROOT})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)

# The emulator: the cross toolchain's loader (-L) and its C and C++ runtimes first on the library
# path, then the sysroot's shared libraries. The runtimes must be the loader's own: with a
# multiarch libc6:arm64 of another build in /lib/aarch64-linux-gnu (apt installs one beside some
# :arm64 packages), ld.so and libc mismatched and every program that started a thread spun forever.
set(CMAKE_CROSSCOMPILING_EMULATOR
    qemu-aarch64 -L /usr/aarch64-linux-gnu
    -E LD_LIBRARY_PATH=/usr/aarch64-linux-gnu/lib:${SWERVE_ARM64_SYSROOT}/usr/lib/aarch64-linux-gnu)
