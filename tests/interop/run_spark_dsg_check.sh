#!/usr/bin/env bash
# Loads the app's scene graph with the real Spark-DSG 1.1.3 and compares every node, edge and typed attribute with
# this project's own reading; reads back what Spark-DSG saves; checks the graph Spark-DSG wrote itself (the shared
# fixture) both ways (tests/interop/spark_dsg_check.cc).
#
#   tests/interop/run_spark_dsg_check.sh [APP_GRAPH.json [APP_MESH.ply]]
#
# Without a graph it runs qsg_app on a short simulated mission (4 rooms; build/default's qsg_app, built first if
# missing) and checks its scene_graph.json and mesh.ply (embedded in the graph as Spark-DSG does). Spark-DSG is built once from ../shared/peers/spark_dsg (Debian packages
# only: nlohmann-json3-dev, libeigen3-dev; its own LTO makes that 2-4 minutes on two cores) into build/spark_dsg-*,
# and rebuilt only when the tarball changes. Test-only: the product never links it. Exit status 0 when every
# reading agrees.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
cd "$root"
jobs=${QSG_JOBS:-2}
peer=../shared/peers/spark_dsg
fixtures=../shared/data/scene_graphs/spark_dsg_1.1.3
tarball=$(ls "$peer"/spark_dsg-1.1.3-*.tar.gz 2> /dev/null | head -1 || true)
[[ -n "$tarball" ]] || { echo "run_spark_dsg_check: no Spark-DSG tarball in $peer" >&2; exit 1; }

# 1. Spark-DSG, cached under build/ and keyed by the tarball's checksum.
prefix=build/spark_dsg-install stamp=build/spark_dsg-install/.source_sha256
sum=$(sha256sum "$tarball" | cut -d' ' -f1)
if [[ ! -f "$stamp" || "$(cat "$stamp")" != "$sum" ]]; then
  start=$SECONDS
  rm -rf build/spark_dsg build/spark_dsg-build "$prefix"
  mkdir -p build/spark_dsg
  tar -xzf "$tarball" -C build/spark_dsg
  cmake -S build/spark_dsg -B build/spark_dsg-build -DCMAKE_BUILD_TYPE=Release -DSPARK_DSG_BUILD_ZMQ=OFF \
        -DSPARK_DSG_BUILD_PYTHON=OFF -DSPARK_DSG_BUILD_EXAMPLES=OFF -DBUILD_TESTING=OFF > build/spark_dsg-configure.log 2>&1
  cmake --build build/spark_dsg-build -j"$jobs" > build/spark_dsg-build.log 2>&1 ||
    { tail -30 build/spark_dsg-build.log >&2; exit 1; }
  cmake --install build/spark_dsg-build --prefix "$prefix" > /dev/null
  echo "$sum" > "$stamp"
  echo "run_spark_dsg_check: built Spark-DSG 1.1.3 in $((SECONDS - start)) s"
else
  echo "run_spark_dsg_check: Spark-DSG 1.1.3 already built ($prefix)"
fi

# 2. The checker, in a build folder of its own (only its target and our scene-graph library are built).
cmake -S . -B build/interop -G Ninja -DCMAKE_BUILD_TYPE=Release -DQSG_BOARD=host_sim -DQSG_BUILD_TESTS=OFF \
      -DQSG_BUILD_BENCH=OFF -DQSG_SPARK_DSG_CHECK=ON -Dspark_dsg_DIR="$root/$prefix/lib/cmake/spark_dsg" > build/interop-configure.log
cmake --build build/interop --target spark_dsg_check -j"$jobs" > build/interop-build.log ||
  { tail -30 build/interop-build.log >&2; exit 1; }

# 3. The graph to check: the given one, or a short simulated mission's.
graph=${1:-} mesh=${2:-}
if [[ -z "$graph" ]]; then
  app=build/default/firmware_app/qsg_app
  if [[ ! -x "$app" ]]; then
    cmake --preset default > /dev/null
    cmake --build build/default --target qsg_app -j"$jobs"
  fi
  out=build/interop/app_output
  rm -rf "$out"
  start=$SECONDS
  "$app" --rooms 4 --seed 3 --quiet --output "$out" > build/interop/app_run.log
  echo "run_spark_dsg_check: qsg_app mapped 4 rooms in $((SECONDS - start)) s ($(grep -m1 '^outputs:' build/interop/app_run.log | cut -c1-100)...)"
  graph=$out/scene_graph.json mesh=$out/mesh.ply
fi

# 4. The comparisons.
build/interop/tests/interop/spark_dsg_check "$graph" "$fixtures" build/interop/check ${mesh:+"$mesh"}
