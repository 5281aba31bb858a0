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

// The merge search with many objects in the layer: n objects seen earlier (square rings of chair vertices, 0.8 m
// a side, on a 3 m grid), then one update per iteration that presents a patch at the centre of one ring (farther
// than the tolerance from it, inside its box: merged by the centre-in-box rule) and syncs. Public API only, so the
// same benchmark runs against any version of the layer; the cost should not follow n.
void BM_ObjectsMergeManyObjects(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  std::string error;
  auto layer = std::make_unique<objects::ObjectLayer>();
  auto graph = std::make_unique<scene_graph::SceneGraph>();
  if (!layer->init(objects::Config{}, objects::capacities_from_budget(), budgets::active::objects::kArenaBytes,
                   &error) ||
      !graph->init(scene_graph::capacities_from_budget(), scene_graph::arena_bytes_from_budget(), &error)) {
    state.SkipWithError(error.c_str());
    return;
  }
  const int per_row = 60;
  const auto origin = [&](int i, float* x, float* y) {
    *x = 3.0f * static_cast<float>(i % per_row);
    *y = 3.0f * static_cast<float>(i / per_row);
  };
  std::uint64_t key = 1;
  for (int first = 0; first < n; first += 1000) {  // in parts: one update clusters at most cluster_vertices
    layer->begin_update(static_cast<std::uint64_t>(first + 1));
    for (int i = first; i < std::min(n, first + 1000); ++i) {
      float x0 = 0, y0 = 0;
      origin(i, &x0, &y0);
      layer->begin_block({i / 10, -1, 0});  // ten rings a block, never presented again
      for (int k = 0; k < 8; ++k) {
        const float t = 0.1f * static_cast<float>(k);
        const float ring[4][2] = {{x0 + t, y0}, {x0 + 0.8f, y0 + t}, {x0 + 0.8f - t, y0 + 0.8f}, {x0, y0 + 0.8f - t}};
        for (const auto& p : ring) layer->add_vertex(objects::InputVertex{key++, p[0], p[1], 0.0f, semantics::kChair});
      }
    }
    layer->end_update();
    layer->sync(graph.get());
  }
  if (layer->num_objects() != static_cast<std::size_t>(n)) {
    state.SkipWithError("the rings did not become one object each");
    return;
  }
  int i = 0;
  double max_ms = 0.0;
  for (auto _ : state) {
    float x0 = 0, y0 = 0;
    origin(i % n, &x0, &y0);
    const auto t0 = std::chrono::steady_clock::now();
    layer->begin_update(static_cast<std::uint64_t>(n + i));
    layer->begin_block({i, 1, 0});
    for (int a = 0; a < 5; ++a)
      for (int b = 0; b < 5; ++b)
        layer->add_vertex(objects::InputVertex{key++, x0 + 0.3f + 0.05f * static_cast<float>(a),
                                               y0 + 0.3f + 0.05f * static_cast<float>(b), 0.0f, semantics::kChair});
    layer->end_update();
    layer->sync(graph.get());
    max_ms = std::max(max_ms, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    ++i;
  }
  state.counters["max_ms"] = max_ms;
  state.counters["objects"] = static_cast<double>(layer->num_objects());
}
BENCHMARK(BM_ObjectsMergeManyObjects)->Arg(500)->Arg(1500)->Arg(3000)->Iterations(500)->Unit(benchmark::kMicrosecond);

}  // namespace
