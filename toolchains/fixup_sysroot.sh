#!/usr/bin/env bash
# Fixes up an arm64 root filesystem so a cross compiler, CMake and qemu-aarch64 can use it as a sysroot.
#
#   toolchains/fixup_sysroot.sh DIR
#
# Called by make_sysroot.sh on the trees it extracts; run it yourself on a root filesystem copied from a
# Jetson (see toolchains/README.md). Idempotent (a stamp records the fix-up version); safe to re-run.
set -euo pipefail

dir=${1:?usage: fixup_sysroot.sh DIR}
[[ -d "$dir/usr/include" ]] || { echo "fixup_sysroot: '$dir' is not a root filesystem (no usr/include)" >&2; exit 2; }
dir=$(realpath "$dir")   # physical path: DIR may be a symlink to the real tree
version="fixup v6"
stamp="$dir/.sysroot-fixup-stamp"
if [[ -f "$stamp" && "$(cat "$stamp")" == "$version" ]]; then
  echo "fixup_sysroot: $dir already fixed up"
  exit 0
fi
libdir="$dir/usr/lib/aarch64-linux-gnu"

# (1) merged /usr: qemu-aarch64 -L and the linker must not fall back to host paths.
for d in lib bin sbin; do
  if [[ -d "$dir/$d" && ! -L "$dir/$d" ]]; then
    mkdir -p "$dir/usr/$d"
    cp -a "$dir/$d/." "$dir/usr/$d/"
    rm -rf "${dir:?}/$d"
    ln -s "usr/$d" "$dir/$d"
  fi
done
# (2) update-alternatives never ran in an extract-only tree: recreate the BLAS/LAPACK links.
for lib in libblas.so.3 liblapack.so.3 libblas.so liblapack.so; do
  if [[ ! -e "$libdir/$lib" ]]; then
    cand=$(find "$libdir" -mindepth 2 -path "*/$lib" \( -type f -o -type l \) 2>/dev/null | sort | head -n 1)
    if [[ -n "$cand" ]]; then ln -sfn "${cand#"$libdir/"}" "$libdir/$lib"; fi
  fi
done
# (3) absolute symlinks point into the host: make them relative inside the sysroot. Computed lexically
# (realpath -s): following a not-yet-fixed absolute link (/etc/alternatives/...) would leave the sysroot.
while IFS= read -r -d '' link; do
  target=$(readlink "$link")
  if [[ "$target" == /* ]]; then
    ln -sfn "$(realpath -m -s --relative-to="$(dirname "$link")" "$dir$target")" "$link"
  fi
done < <(find "$dir" -path "$dir/proc" -prune -o -path "$dir/sys" -prune -o -path "$dir/dev" -prune \
              -o -type l -print0)
# (4) CMake package files that name host paths: Ceres 2.x's exported targets list /usr/lib/<triple>/lib{lapack,
#     blas,f77blas,atlas}.so, Ceres 1.14's config pins Eigen3_DIR, glog_DIR and gflags_DIR (and lives under
#     usr/lib/cmake/Ceres), bullseye's yaml-cpp 0.6 imports /usr/lib/<triple>/libyaml-cpp.so.0.6.3 and its
#     benchmark 1.5 links /usr/lib/<triple>/librt.so. Prefix ${CMAKE_SYSROOT} to every such path in the
#     sysroot's CMake package files (not in a cmake-3.x module tree). Lines naming `_realOrig` (CMake's
#     "/usr move" check) stay as they are: re-rooted, that check would reset the prefix to the host's /usr.
#     The substitution only matches a path right after a quote, '(', ';' or blank, so a second run
#     changes nothing.
pattern='([";([:space:]])/usr/(lib|include|share)/'
while IFS= read -r -d '' f; do
  if grep -E "$pattern" "$f" | grep -qv _realOrig; then
    sed -i -E "/_realOrig/!s#$pattern#\\1\${CMAKE_SYSROOT}/usr/\\2/#g" "$f"
    echo "fixup_sysroot: re-rooted host paths in ${f#"$dir/"}"
  fi
done < <(find "$dir/usr/lib" "$dir/usr/share" -path '*/cmake-[0-9]*' -prune -o \
              -path '*/cmake/*' -name '*.cmake' -type f -print0 2>/dev/null)

echo "$version" > "$stamp"
echo "fixup_sysroot: $dir fixed up"
