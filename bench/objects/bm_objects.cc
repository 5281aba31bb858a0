// Object-layer benchmarks: the per-keyframe update (+ scene-graph sync) on frozen frames of a generated building,
// and clustering alone on random point sets; both report the max beside the mean (a real-time stage).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "bench/frozen_frames.h"
#include "budgets/budget_table.h"
#include "core/objects/object_layer.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/scene_graph/scene_graph.h"

namespace {

using namespace qsg;

const bench::FrozenFrames& frames() {
  static std::unique_ptr<bench::FrozenFrames> cache;
  if (!cache) cache = bench::render_frozen_frames(320, 240, 120);
  return *cache;
}

// One iteration = the object layer's update and sync after one more frame was integrated (integration untimed).
void BM_ObjectsUpdate(benchmark::State& state) {
  const bench::FrozenFrames& data = frames();
  if (data.frames.empty()) {
    state.SkipWithError("no frames rendered");
    return;
  }
  std::string error;
  auto tsdf = std::make_unique<reconstruction::SemanticTsdf>();
  auto layer = std::make_unique<objects::ObjectLayer>();
  auto graph = std::make_unique<scene_graph::SceneGraph>();
  if (!tsdf->init(reconstruction::Config{}, reconstruction::capacities_from_budget(),
                  budgets::active::reconstruction::kArenaBytes, &error) ||
      !layer->init(objects::Config{}, objects::capacities_from_budget(), budgets::active::objects::kArenaBytes, &error) ||
      !graph->init(scene_graph::capacities_from_budget(), scene_graph::arena_bytes_from_budget(), &error)) {
    state.SkipWithError(error.c_str());
    return;
  }
  std::size_t k = 0;
  double max_ms = 0.0;
  for (auto _ : state) {
    state.PauseTiming();
    tsdf->process(*data.frames[k], data.poses[k]);
    k = (k + 1) % data.frames.size();
    state.ResumeTiming();
    const auto t0 = std::chrono::steady_clock::now();
    layer->update(*tsdf, k);
    layer->sync(graph.get());
    max_ms = std::max(max_ms, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  state.counters["max_ms"] = max_ms;
  state.counters["objects"] = static_cast<double>(layer->num_objects());
  state.counters["tracked_vertices"] = static_cast<double>(layer->num_tracked_vertices());
}
BENCHMARK(BM_ObjectsUpdate)->Unit(benchmark::kMillisecond)->Iterations(120);

// Clustering alone: n new vertices of 4 labels in a 6 x 6 x 1.5 m volume, clustered in one update of a fresh layer.
void BM_ObjectsClusterRandom(benchmark::State& state) {
  const std::size_t n = static_cast<std::size_t>(state.range(0));
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> uxy(0.0f, 6.0f), uz(0.0f, 1.5f);
  const semantics::Label labels[4] = {semantics::kChair, semantics::kTable, semantics::kSofa, semantics::kPlant};
  std::vector<objects::InputVertex> pts(n);
  for (std::size_t i = 0; i < n; ++i) {
    pts[i] = objects::InputVertex{i + 1, uxy(rng), uxy(rng), uz(rng), labels[i % 4]};
  }
  std::string error;
  double max_ms = 0.0;
  std::size_t num_objects = 0;
  for (auto _ : state) {
    state.PauseTiming();  // a fresh layer each time (init is start-up work, not timed)
    auto layer = std::make_unique<objects::ObjectLayer>();
    if (!layer->init(objects::Config{}, objects::capacities_from_budget(), budgets::active::objects::kArenaBytes,
                     &error)) {
      state.SkipWithError(error.c_str());
      return;
    }
    state.ResumeTiming();
    const auto t0 = std::chrono::steady_clock::now();
    layer->begin_update(1);
    layer->begin_block({0, 0, 0});  // the block of each vertex does not matter for the clustering itself
    for (const objects::InputVertex& v : pts) layer->add_vertex(v);
    layer->end_update();
    max_ms = std::max(max_ms, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    num_objects = layer->num_objects();
  }
  state.counters["max_ms"] = max_ms;
  state.counters["objects"] = static_cast<double>(num_objects);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(n));
}
BENCHMARK(BM_ObjectsClusterRandom)->Arg(5000)->Arg(20000)->Arg(60000)->Unit(benchmark::kMillisecond);

}  // namespace
