// Semantic TSDF integration + mesh update per frame (integration on one or two threads), on frames rendered once from a generated
// building along its exploration tour; reports ms/frame and the active window's bytes (TSDF + semantics).
#include <benchmark/benchmark.h>

#include <memory>
#include <string>
#include <vector>

#include "bench/frozen_frames.h"
#include "core/reconstruction/semantic_tsdf.h"

namespace {

using namespace qsg;

// Frozen frames, rendered once per resolution.
const bench::FrozenFrames& frames(int width, int height) {
  static std::unique_ptr<bench::FrozenFrames> cache[2];
  std::unique_ptr<bench::FrozenFrames>& slot = cache[width == 640 ? 0 : 1];
  if (!slot) slot = bench::render_frozen_frames(width, height);
  return *slot;
}

void BM_IntegrateAndMesh(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const double voxel = static_cast<double>(state.range(1)) / 100.0;
  const bench::FrozenFrames& data = frames(width, width * 3 / 4);
  if (data.frames.empty()) {
    state.SkipWithError("no frames rendered");
    return;
  }
  reconstruction::Config config;
  config.voxel_size_m = voxel;
  config.integration_threads = static_cast<int>(state.range(2));
  reconstruction::Capacities caps = reconstruction::capacities_from_budget();
  if (voxel < 0.1) caps.max_blocks *= 4;  // a finer grid needs more blocks for the same window
  reconstruction::SemanticTsdf tsdf;
  std::string error;
  if (!tsdf.init(config, caps, reconstruction::SemanticTsdf::plan(caps).total_bytes(), &error)) {
    state.SkipWithError(error.c_str());
    return;
  }
  std::size_t k = 0;
  for (auto _ : state) {
    tsdf.process(*data.frames[k], data.poses[k]);
    k = (k + 1) % data.frames.size();
  }
  // The Time column is the per-frame time (integration + mesh update + window), in ms.
  state.counters["window_bytes"] = static_cast<double>(tsdf.window_bytes());
  state.counters["active_blocks"] = static_cast<double>(tsdf.active_blocks());
  state.counters["blocks_evicted"] = static_cast<double>(tsdf.counters().blocks_evicted);
}
BENCHMARK(BM_IntegrateAndMesh)
    ->ArgNames({"width", "voxel_cm", "threads"})
    ->ArgsProduct({{640, 320}, {10, 5}, {1, 2}})
    ->UseRealTime()  // wall time per frame: the worker thread's time is not the caller's CPU time
    ->Unit(benchmark::kMillisecond);

}  // namespace
