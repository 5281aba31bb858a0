#!/usr/bin/env bash
# Installs every build and test dependency of quadsg on a Debian 12 (bookworm) machine. Idempotent: when
# everything is already there it does not touch apt at all (no root needed).
#
#   toolchains/install_deps.sh [--native] [--sanitize] [--cross]
#
#   --native  (default) compiler, CMake, Ninja and the -dev packages of the host build (Eigen, OpenCV, Ceres,
#             libgpiod, libv4l, nanoflann, yaml-cpp, nlohmann-json, GoogleTest, Google Benchmark), ccache;
#             three.js (libjs-three, inlined into the app's scene_graph.html) and headless Chromium (its test).
#   --sanitize  also clang and its sanitizer and libFuzzer runtimes (the asan preset: tests and fuzz/ targets).
#   --cross   also the aarch64 tools (GCC cross compiler, lld, qemu-user, mmdebstrap; qemu-system-arm, kmod and
#             cpio for the VM stage; what --sanitize installs) and both arm64 sysroots under build/sysroots/:
#             bookworm-arm64 (the arm64 preset) and bullseye-arm64 (the xavier-deploy preset, CI's arm64 stage),
#             built by toolchains/make_sysroot.sh (itself a no-op when a sysroot is up to date).
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(dirname "$here")

cross=0
sanitize=0
for arg in "$@"; do
  case "$arg" in
    --native) ;;  # always: the cross build needs the host tools too (CMake, Ninja, pkg-config)
    --sanitize) sanitize=1 ;;
    --cross) cross=1 sanitize=1 ;;
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
    *) echo "install_deps: unknown option '$arg' (--native, --sanitize, --cross)" >&2; exit 2 ;;
  esac
done

packages=(cmake ninja-build g++ git pkg-config ccache
          libeigen3-dev libopencv-dev libceres-dev libgpiod-dev libv4l-dev libnanoflann-dev libyaml-cpp-dev
          nlohmann-json3-dev libgtest-dev libbenchmark-dev
          libjs-three chromium fonts-dejavu-core)
if (( sanitize )); then
  # clang with libFuzzer and its sanitizer runtimes (the asan preset, fuzz/run_fuzzers.sh).
  packages+=(clang libclang-rt-14-dev)
fi
if (( cross )); then
  packages+=(g++-aarch64-linux-gnu binutils-aarch64-linux-gnu qemu-user mmdebstrap lld)
  # The VM stage (toolchains/vm/): qemu-system-arm boots Debian's arm64 kernel, depmod (kmod) resolves the
  # modules vivid needs, cpio packs the initramfs. The arm64 kernel and busybox are .debs that
  # toolchains/vm/fetch_kernel.sh downloads through its own apt state, so the host needs no arm64 dpkg
  # architecture (an arm64 busybox-static installed on the host would replace /bin/busybox).
  packages+=(qemu-system-arm kmod cpio)
fi
# Installed without their recommends: qemu-system-arm's (GUI, EFI firmware, block backends) are about 60
# packages that a headless -kernel boot never uses.
# chromium's (a desktop's worth of fonts, icons and plugins) are not needed to render the viewer headless.
no_recommends=" qemu-system-arm chromium "

missing=()
for p in "${packages[@]}"; do
  if [[ "$(dpkg-query -W -f='${db:Status-Status}' "$p" 2> /dev/null)" != installed ]]; then
    missing+=("$p")
  fi
done

if (( ${#missing[@]} == 0 )); then
  echo "install_deps: all ${#packages[@]} packages already installed, apt not needed"
else
  echo "install_deps: installing ${#missing[@]} missing package(s): ${missing[*]}"
  sudo=()
  if (( EUID != 0 )); then
    if command -v sudo > /dev/null; then sudo=(sudo); else
      echo "install_deps: must run as root (or with sudo available) to install packages" >&2; exit 1
    fi
  fi
  apt_opts=(-o DPkg::Lock::Timeout=600 -o Acquire::Retries=3)
  start=$SECONDS
  "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get "${apt_opts[@]}" update -q
  with=() without=()
  for p in "${missing[@]}"; do
    if [[ "$no_recommends" == *" $p "* ]]; then without+=("$p"); else with+=("$p"); fi
  done
  if (( ${#with[@]} )); then
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get "${apt_opts[@]}" install -y -q "${with[@]}"
  fi
  if (( ${#without[@]} )); then
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get "${apt_opts[@]}" install -y -q --no-install-recommends \
      "${without[@]}"
  fi
  echo "install_deps: apt-get update + install took $((SECONDS - start)) s"
fi

if (( cross )); then
  # Both sysroots in parallel: each is mostly download and unpacking (about 1-2 min).
  mkdir -p "$root/build/sysroots"
  start=$SECONDS
  pids=()
  for suite in bookworm bullseye; do
    "$here/make_sysroot.sh" "$suite" "$root/build/sysroots/$suite-arm64" > "$root/build/sysroots/$suite-arm64.log" 2>&1 &
    pids+=($!)
  done
  failed=0
  for i in 0 1; do
    suite=$([[ $i == 0 ]] && echo bookworm || echo bullseye)
    if wait "${pids[$i]}"; then
      grep '^make_sysroot\|^fixup_sysroot' "$root/build/sysroots/$suite-arm64.log" | sed 's/^/install_deps: /'
    else
      echo "install_deps: building the $suite sysroot failed; its log:" >&2
      tail -n 40 "$root/build/sysroots/$suite-arm64.log" >&2
      failed=1
    fi
  done
  (( failed == 0 )) || exit 1
  echo "install_deps: sysroots ready in build/sysroots/ ($((SECONDS - start)) s)"
fi
echo "install_deps: done"
