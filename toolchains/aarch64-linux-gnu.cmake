# CMake toolchain file: Debian's GCC cross compiler (aarch64-linux-gnu-g++) against an arm64 sysroot.
#
#   cmake -S . -B build/arm64 -G Ninja -DCMAKE_TOOLCHAIN_FILE=toolchains/aarch64-linux-gnu.cmake \
#         -DCMAKE_SYSROOT=build/sysroots/bookworm-arm64        (or: export QSG_SYSROOT=...)
#
# Use it with a bookworm sysroot (same glibc as the cross compiler); for the Xavier (glibc 2.31) use
# aarch64-linux-gnu-clang.cmake instead: GCC 12's cross toolchain links its own newer glibc first.
include(${CMAKE_CURRENT_LIST_DIR}/aarch64-common.cmake)

set(_qsg_hint "Install the cross compiler: apt-get install g++-aarch64-linux-gnu (or toolchains/install_deps.sh --cross).")
qsg_find_tool(QSG_AARCH64_GCC "${_qsg_hint}"
              aarch64-linux-gnu-gcc aarch64-linux-gnu-gcc-12 aarch64-linux-gnu-gcc-11 aarch64-linux-gnu-gcc-10)
qsg_find_tool(QSG_AARCH64_GXX "${_qsg_hint}"
              aarch64-linux-gnu-g++ aarch64-linux-gnu-g++-12 aarch64-linux-gnu-g++-11 aarch64-linux-gnu-g++-10)
set(CMAKE_C_COMPILER "${QSG_AARCH64_GCC}")
set(CMAKE_CXX_COMPILER "${QSG_AARCH64_GXX}")
