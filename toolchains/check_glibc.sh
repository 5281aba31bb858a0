#!/usr/bin/env bash
# Checks that every ELF executable and shared library a build produced can start on a Xavier (JetPack 5,
# Ubuntu 20.04: glibc 2.31, libstdc++ of GCC 9/10): prints per binary the highest GLIBC_ and GLIBCXX_
# symbol versions it requires (objdump -T) and fails if any is newer than the limits.
#
#   toolchains/check_glibc.sh BUILD_DIR
#
# Limits: QSG_MAX_GLIBC (default 2.31) and QSG_MAX_GLIBCXX (default 3.4.28). objdump: $OBJDUMP, else
# aarch64-linux-gnu-objdump, objdump, llvm-objdump. CMake's own probe binaries (CMakeFiles/<version>/,
# CMakeFiles/CMakeTmp, CMakeScratch) are skipped. Exits 1 on a violation, 2 if it found no binary.
set -euo pipefail

build_dir=${1:?usage: check_glibc.sh BUILD_DIR}
max_glibc=${QSG_MAX_GLIBC:-2.31}
max_glibcxx=${QSG_MAX_GLIBCXX:-3.4.28}
[[ -d "$build_dir" ]] || { echo "check_glibc: '$build_dir' is not a directory" >&2; exit 2; }

objdump=${OBJDUMP:-}
if [[ -z "$objdump" ]]; then
  for cand in aarch64-linux-gnu-objdump objdump llvm-objdump llvm-objdump-16 llvm-objdump-15 llvm-objdump-14; do
    if command -v "$cand" > /dev/null; then objdump=$cand; break; fi
  done
fi
[[ -n "$objdump" ]] || { echo "check_glibc: no objdump found (apt-get install binutils-aarch64-linux-gnu)" >&2; exit 2; }

# version_gt A B: true if version A is strictly newer than B.
version_gt() { [[ "$1" != "$2" && "$(printf '%s\n%s\n' "$1" "$2" | sort -V | tail -n 1)" == "$1" ]]; }
# highest PREFIX_x.y.z version named in the text on stdin ("-" if none).
max_version() { { grep -oE "\\b$1_[0-9]+(\\.[0-9]+)*\\b" || true; } | sed "s/^$1_//" | sort -uV | tail -n 1; }

# ELF executables (ET_EXEC, ET_DYN: PIE executables and shared libraries), not objects or CMake probes.
binaries=()
while IFS= read -r -d '' f; do
  [[ "$(head -c 4 "$f" | od -An -c | tr -d ' ')" == '177ELF' ]] || continue
  e_type=$(od -An -tu1 -j16 -N1 "$f" | tr -d ' ')
  [[ "$e_type" == 2 || "$e_type" == 3 ]] || continue
  binaries+=("$f")
done < <(find "$build_dir" \( -path '*/CMakeFiles/[0-9]*' -o -path '*/CMakeFiles/CMakeTmp' \
                              -o -path '*/CMakeFiles/CMakeScratch' -o -path '*/CMakeFiles/pkgRedirects' \) -prune \
                           -o -type f ! -name '*.o' ! -name '*.a' ! -name '*.cmake' ! -name '*.txt' -size +1k -print0 \
         | sort -z)
if (( ${#binaries[@]} == 0 )); then
  echo "check_glibc: FAIL no ELF executable or shared library found under $build_dir (not built yet?)" >&2
  exit 2
fi

echo "check_glibc: ${#binaries[@]} binaries under $build_dir (limits GLIBC_$max_glibc, GLIBCXX_$max_glibcxx; $objdump)"
failures=0
overall_glibc=0 overall_glibcxx=0
for f in "${binaries[@]}"; do
  if ! symbols=$("$objdump" -T "$f" 2>&1); then
    echo "check_glibc: FAIL cannot read $f with $objdump: $symbols" >&2
    failures=$((failures + 1))
    continue
  fi
  glibc=$(max_version GLIBC <<< "$symbols")
  glibcxx=$(max_version GLIBCXX <<< "$symbols")
  printf '  %-60s GLIBC_%-6s GLIBCXX_%s\n' "${f#"$build_dir"/}" "${glibc:--}" "${glibcxx:--}"
  if [[ -n "$glibc" ]] && version_gt "$glibc" "$max_glibc"; then
    echo "check_glibc: FAIL $f needs GLIBC_$glibc (limit GLIBC_$max_glibc): it will not start on the target" >&2
    failures=$((failures + 1))
  fi
  if [[ -n "$glibcxx" ]] && version_gt "$glibcxx" "$max_glibcxx"; then
    echo "check_glibc: FAIL $f needs GLIBCXX_$glibcxx (limit GLIBCXX_$max_glibcxx): it will not start on the target" >&2
    failures=$((failures + 1))
  fi
  if [[ -n "$glibc" ]] && version_gt "$glibc" "$overall_glibc"; then overall_glibc=$glibc; fi
  if [[ -n "$glibcxx" ]] && version_gt "$glibcxx" "$overall_glibcxx"; then overall_glibcxx=$glibcxx; fi
done
echo "check_glibc: highest overall GLIBC_$overall_glibc, GLIBCXX_$overall_glibcxx"
if (( failures > 0 )); then
  echo "check_glibc: FAIL $failures problem(s) in $build_dir" >&2
  exit 1
fi
echo "check_glibc: OK"
