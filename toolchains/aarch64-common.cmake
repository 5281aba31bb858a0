# Shared part of the aarch64 Linux cross toolchain files (included by aarch64-linux-gnu.cmake and
# aarch64-linux-gnu-clang.cmake): target system, sysroot, find-root modes, pkg-config, qemu emulator.
#
# The sysroot comes from the CMAKE_SYSROOT cache variable (-DCMAKE_SYSROOT=... or a preset) or else from
# the QSG_SYSROOT environment variable; it is never hard-coded. Make one with toolchains/make_sysroot.sh,
# or copy a Jetson's root filesystem and fix it up with toolchains/fixup_sysroot.sh.
include_guard(GLOBAL)

set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
set(QSG_TARGET_TRIPLE aarch64-linux-gnu)

# --- sysroot -------------------------------------------------------------------------------------------
if(NOT CMAKE_SYSROOT AND NOT "$ENV{QSG_SYSROOT}" STREQUAL "")
  # Keep it in the cache so a later re-configure does not depend on the environment any more.
  set(CMAKE_SYSROOT "$ENV{QSG_SYSROOT}" CACHE PATH "arm64 sysroot (from QSG_SYSROOT)")
endif()
set(_qsg_sysroot_help
  "Make one with\n"
  "    toolchains/make_sysroot.sh bookworm build/sysroots/bookworm-arm64   (CI cross tests, GCC)\n"
  "    toolchains/make_sysroot.sh bullseye build/sysroots/bullseye-arm64   (Xavier / JetPack 5, clang)\n"
  "(or `toolchains/install_deps.sh --cross`, which builds both), or copy a Jetson's root filesystem and run\n"
  "    toolchains/fixup_sysroot.sh DIR\n"
  "then pass -DCMAKE_SYSROOT=DIR or set the environment variable QSG_SYSROOT=DIR.")
if(NOT CMAKE_SYSROOT)
  message(FATAL_ERROR "aarch64 toolchain: no sysroot given (CMAKE_SYSROOT / $QSG_SYSROOT are empty).\n"
                      ${_qsg_sysroot_help})
endif()
get_filename_component(_qsg_sysroot_abs "${CMAKE_SYSROOT}" ABSOLUTE)
if(NOT IS_DIRECTORY "${_qsg_sysroot_abs}/usr/include")
  message(FATAL_ERROR "aarch64 toolchain: sysroot '${CMAKE_SYSROOT}' does not exist or has no usr/include.\n"
                      ${_qsg_sysroot_help})
endif()
set(CMAKE_SYSROOT "${_qsg_sysroot_abs}")

# --- where to look ---------------------------------------------------------------------------------------
# Programs (code generators, pkg-config, qemu) come from the host; libraries, headers and CMake packages
# only from the sysroot (CMAKE_SYSROOT is the implicit first root path).
list(APPEND CMAKE_FIND_ROOT_PATH "${CMAKE_SYSROOT}")
list(REMOVE_DUPLICATES CMAKE_FIND_ROOT_PATH)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# pkg-config (libgpiod, libv4l2): the host's pkg-config, reading only the sysroot's .pc files, with the
# sysroot prefixed to the -I and -L paths it prints.
set(ENV{PKG_CONFIG_LIBDIR}
    "${CMAKE_SYSROOT}/usr/lib/${CMAKE_LIBRARY_ARCHITECTURE}/pkgconfig:${CMAKE_SYSROOT}/usr/lib/pkgconfig:${CMAKE_SYSROOT}/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_SYSROOT_DIR} "${CMAKE_SYSROOT}")
set(ENV{PKG_CONFIG_PATH} "")

# --- running target binaries on the host -------------------------------------------------------------
# qemu-user with -L <sysroot> runs the arm64 tests (ctest, gtest_discover_tests) and the sysroot's own
# dynamic loader and libraries, so no binfmt_misc registration is needed.
find_program(QSG_QEMU_AARCH64 NAMES qemu-aarch64 qemu-aarch64-static
             DOC "qemu-user emulator used to run arm64 binaries (tests) on the build host")
if(QSG_QEMU_AARCH64)
  set(CMAKE_CROSSCOMPILING_EMULATOR "${QSG_QEMU_AARCH64};-L;${CMAKE_SYSROOT}")
else()
  message(WARNING "aarch64 toolchain: qemu-aarch64 not found (apt-get install qemu-user): "
                  "the arm64 tests cannot run on this host.")
endif()

# try_compile projects re-read this file in a fresh cache: hand them the sysroot explicitly.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES CMAKE_SYSROOT QSG_QEMU_AARCH64)
list(REMOVE_DUPLICATES CMAKE_TRY_COMPILE_PLATFORM_VARIABLES)

# Helper for the compiler-specific files: find a host program or stop with an install hint.
macro(qsg_find_tool var hint)
  find_program(${var} NAMES ${ARGN})
  if(NOT ${var})
    message(FATAL_ERROR "aarch64 toolchain: none of '${ARGN}' found on PATH. ${hint}")
  endif()
endmacro()
