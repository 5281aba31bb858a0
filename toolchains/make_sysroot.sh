#!/usr/bin/env bash
# Builds an arm64 Debian sysroot (headers and libraries only) from the host's own apt sources.
#
#   toolchains/make_sysroot.sh SUITE DIR      SUITE = bookworm (CI cross tests) | bullseye (Xavier / JetPack 5)
#
# No emulation is needed: mmdebstrap only extracts packages. The tree is then fixed up so a cross
# compiler, CMake and qemu-aarch64 can all use it (see toolchains/README.md). Idempotent: an existing
# sysroot with a matching stamp is left alone. The fix-ups live in fixup_sysroot.sh (also used on a
# root filesystem copied from a Jetson).
set -euo pipefail

suite=${1:?usage: make_sysroot.sh SUITE DIR}
dir=${2:?usage: make_sysroot.sh SUITE DIR}

case "$suite" in
  bookworm) stdcxx=libstdc++-12-dev ;;
  # bullseye's GTest package config also declares GTest::gmock, so libgmock.a must be there.
  bullseye) stdcxx=libstdc++-10-dev,libgmock-dev ;;
  *) echo "make_sysroot: unsupported suite '$suite' (bookworm or bullseye)" >&2; exit 2 ;;
esac
packages="libc6-dev,$stdcxx,libeigen3-dev,libopencv-dev,libceres-dev,libgpiod-dev,libv4l-dev,libnanoflann-dev,libyaml-cpp-dev,nlohmann-json3-dev,libgtest-dev,libbenchmark-dev"
stamp="$dir/.sysroot-stamp"
want="$suite $packages v3"
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
if [[ -f "$stamp" && "$(cat "$stamp")" == "$want" ]]; then
  echo "make_sysroot: $dir is up to date ($suite)"
  "$here/fixup_sysroot.sh" "$dir"   # no-op unless the fix-ups changed since the tree was made
  exit 0
fi

# The Debian archive the host already uses (deb822 or one-line format), never a host name of ours.
mirror=""
if [[ -f /etc/apt/sources.list.d/debian.sources ]]; then
  mirror=$(awk '/^URIs:/ && $2 !~ /security/ {print $2; exit}' /etc/apt/sources.list.d/debian.sources)
fi
if [[ -z "$mirror" && -f /etc/apt/sources.list ]]; then
  mirror=$(awk '$1 == "deb" && $0 !~ /security/ {for (i = 2; i <= NF; ++i) if ($i ~ /^[a-z]+:\/\//) {print $i; exit}}' /etc/apt/sources.list)
fi
if [[ -z "$mirror" ]]; then
  echo "make_sysroot: no Debian archive found in the host's apt sources" >&2
  exit 1
fi
echo "make_sysroot: $suite arm64 from $mirror into $dir"

rm -rf "$dir"
mkdir -p "$(dirname "$dir")"
mmdebstrap --arch=arm64 --variant=extract --include="$packages" \
  --aptopt='Acquire::Check-Valid-Until "false"' \
  --dpkgopt='path-exclude=/usr/share/doc/*' --dpkgopt='path-exclude=/usr/share/man/*' \
  --dpkgopt='path-exclude=/usr/share/locale/*' \
  "$suite" "$dir" "deb $mirror $suite main"

"$here/fixup_sysroot.sh" "$dir"

echo "$want" > "$stamp"
echo "make_sysroot: done ($(du -sh "$dir" | cut -f1))"
