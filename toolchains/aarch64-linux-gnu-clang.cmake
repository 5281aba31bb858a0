# CMake toolchain file for the Xavier / JetPack 5 deploy build: clang --target=aarch64-linux-gnu with lld,
# against an arm64 sysroot with an older glibc, using the sysroot's own GCC libstdc++ and libgcc.
#
#   cmake -S . -B build/xavier-deploy -G Ninja -DCMAKE_TOOLCHAIN_FILE=toolchains/aarch64-linux-gnu-clang.cmake \
#         -DCMAKE_SYSROOT=build/sysroots/bullseye-arm64    (glibc 2.31, GCC 10's libstdc++)
#   ... or -DCMAKE_SYSROOT=/path/to/jetson-rootfs          (copied from the board, see toolchains/README.md)
#
# Unlike Debian's GCC 12 cross compiler, clang carries no glibc or libstdc++ of its own, so the binaries
# only need what the sysroot provides (check with toolchains/check_glibc.sh).
include(${CMAKE_CURRENT_LIST_DIR}/aarch64-common.cmake)

set(_qsg_hint "Install clang and lld: apt-get install clang lld (or toolchains/install_deps.sh --cross).")
qsg_find_tool(QSG_CLANG "${_qsg_hint}" clang clang-16 clang-15 clang-14)
qsg_find_tool(QSG_CLANGXX "${_qsg_hint}" clang++ clang++-16 clang++-15 clang++-14)
qsg_find_tool(QSG_LLD "${_qsg_hint}" ld.lld ld.lld-16 ld.lld-15 ld.lld-14)
set(CMAKE_C_COMPILER "${QSG_CLANG}")
set(CMAKE_CXX_COMPILER "${QSG_CLANGXX}")
set(CMAKE_C_COMPILER_TARGET ${QSG_TARGET_TRIPLE})
set(CMAKE_CXX_COMPILER_TARGET ${QSG_TARGET_TRIPLE})
set(CMAKE_ASM_COMPILER_TARGET ${QSG_TARGET_TRIPLE})

# libstdc++, libgcc and the crt files must come from the GCC inside the sysroot (GCC 10 on bullseye, GCC 9
# on a JetPack 5 rootfs), never from the host's gcc-cross: point clang's GCC detection at <sysroot>/usr.
file(GLOB _qsg_sysroot_gcc LIST_DIRECTORIES true "${CMAKE_SYSROOT}/usr/lib/gcc/${QSG_TARGET_TRIPLE}/*")
if(NOT _qsg_sysroot_gcc)
  message(FATAL_ERROR "aarch64 clang toolchain: '${CMAKE_SYSROOT}' has no usr/lib/gcc/${QSG_TARGET_TRIPLE}/<version>: "
                      "the sysroot needs GCC's libstdc++ and libgcc (libstdc++-<N>-dev, e.g. libstdc++-10-dev on "
                      "bullseye, libstdc++-9-dev on JetPack 5).")
endif()
set(CMAKE_C_COMPILER_EXTERNAL_TOOLCHAIN "${CMAKE_SYSROOT}/usr")
set(CMAKE_CXX_COMPILER_EXTERNAL_TOOLCHAIN "${CMAKE_SYSROOT}/usr")

# Link with lld (the sysroot's linker scripts and symlinks are resolved inside the sysroot).
foreach(_kind EXE SHARED MODULE)
  set(CMAKE_${_kind}_LINKER_FLAGS_INIT "-fuse-ld=lld")
endforeach()

# Archiver: LLVM's (reads aarch64 objects whatever the host), else the GNU cross binutils.
find_program(QSG_LLVM_AR NAMES llvm-ar llvm-ar-16 llvm-ar-15 llvm-ar-14 aarch64-linux-gnu-ar
             PATHS /usr/lib/llvm-16/bin /usr/lib/llvm-15/bin /usr/lib/llvm-14/bin)
find_program(QSG_LLVM_RANLIB NAMES llvm-ranlib llvm-ranlib-16 llvm-ranlib-15 llvm-ranlib-14 aarch64-linux-gnu-ranlib
             PATHS /usr/lib/llvm-16/bin /usr/lib/llvm-15/bin /usr/lib/llvm-14/bin)
if(QSG_LLVM_AR AND QSG_LLVM_RANLIB)
  set(CMAKE_AR "${QSG_LLVM_AR}" CACHE FILEPATH "Archiver")
  set(CMAKE_RANLIB "${QSG_LLVM_RANLIB}" CACHE FILEPATH "Ranlib")
endif()
