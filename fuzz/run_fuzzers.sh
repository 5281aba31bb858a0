#!/usr/bin/env bash
# Runs every fuzz target of a QSG_FUZZ build for a bounded time each, from the committed seed corpora (plus the
# source tree's example world and app configs), under the build's ASan and UBSan. Exits non-zero on the first finding: the crashing
# input is left in BUILD/fuzz_artifacts/ (reproduce: BUILD/fuzz/fuzz_<name> FILE).
#   fuzz/run_fuzzers.sh [BUILD_DIR (build/asan)] [SECONDS_EACH (45)] [TARGET ...]
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
build=${1:-build/asan}
seconds=${2:-45}
shift $(( $# > 2 ? 2 : $# ))
targets=("$@")
if (( ${#targets[@]} == 0 )); then
  targets=(spark_dsg world_file app_config tum floor_plan pose_message classifier_weights)
fi
artifacts=$build/fuzz_artifacts
mkdir -p "$artifacts"
for name in "${targets[@]}"; do
  binary=$build/fuzz/fuzz_$name
  [[ -x $binary ]] || { echo "fuzz: $binary not built (cmake --preset asan && cmake --build --preset asan)" >&2; exit 1; }
  corpus=$build/fuzz_corpus/$name
  mkdir -p "$corpus"
  cp -n fuzz/corpus/"$name"/* "$corpus"/ 2> /dev/null || true
  case $name in  # fixtures the tree already holds
    world_file) cp -n tests/data/worlds/*.json "$corpus"/ ;;
    app_config) cp -n firmware_app/config/*.json "$corpus"/ ;;
  esac
  echo "=== fuzz: $name for ${seconds} s"
  # -max_len: every seed fits whole (the classifier weights' seed is the real file trimmed: the real one, 300 KB,
  # makes each run 30 times slower).
  status=0
  "$binary" "$corpus" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2560 -max_len=65536 \
    -artifact_prefix="$artifacts/${name}_" -print_final_stats=1 > "$build/fuzz_$name.log" 2>&1 || status=$?
  if (( status != 0 )); then
    grep -A40 -m1 -E '==ERROR|runtime error|deadly signal|Timeout|out-of-memory' "$build/fuzz_$name.log" >&2 || tail -n 40 "$build/fuzz_$name.log" >&2
    echo "=== fuzz: $name FOUND A FAULT (status $status); its input is in $artifacts/, the log $build/fuzz_$name.log" >&2
    exit "$status"
  fi
  grep -E '^(Done|stat::(number_of_executed_units|average_exec_per_sec|new_units_added|peak_rss_mb))' "$build/fuzz_$name.log"
done
echo "=== fuzz: ${#targets[@]} targets, no finding"
