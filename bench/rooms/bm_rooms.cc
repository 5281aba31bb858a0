// BM_rooms_update: one room update (Betti curve, plateau or merge-tree seeds, flood fill, room and building nodes
// rewritten; the second argument picks the seeding: 0 the paper's plateau, 1 persistence, the default; the third
// turns the extent split off or on, the default, so its cost shows beside the same update without it)
// over a frozen synthetic places graph: a corridor with 4 m rooms on both sides at 0.5 m place spacing, in a scene
// graph and a finder sized by the board's budget table. Reports the median and max per update as well as the mean.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <vector>

#include "core/rooms/room_finder.h"
#include "core/scene_graph/scene_graph.h"
#include "tests/rooms/synthetic_places.h"

namespace {

using namespace qsg;

void BM_rooms_update(benchmark::State& state) {
  const int rooms_per_side = static_cast<int>(state.range(0));
  rooms::Config config = state.range(1) == 0 ? rooms::Config::paper() : rooms::Config{};
  config.split_by_extent = state.range(2) != 0;
  rooms::testing::SyntheticPlaces places;
  rooms::testing::corridor_plan(rooms_per_side, 0.5).add_to(&places, 0.5);
  auto graph = std::make_unique<scene_graph::SceneGraph>();
  auto finder = std::make_unique<rooms::RoomFinder>();
  std::string error;
  const scene_graph::Capacities caps = scene_graph::capacities_from_budget();
  if (!graph->init(caps, scene_graph::arena_bytes_from_budget(), &error) || !places.write(graph.get()) ||
      !finder->init(config, rooms::Capacities::from_scene_graph(caps), 0, &error)) {
    state.SkipWithError(error.empty() ? "setup failed" : error.c_str());
    return;
  }
  std::vector<double> ms;
  ms.reserve(1 << 16);
  rooms::UpdateResult r;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    r = finder->update(graph.get());
    const auto t1 = std::chrono::steady_clock::now();
    if (ms.size() < ms.capacity()) ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    benchmark::DoNotOptimize(r);
  }
  std::sort(ms.begin(), ms.end());
  state.counters["places"] = static_cast<double>(r.places);
  state.counters["place_edges"] = static_cast<double>(r.place_edges);
  state.counters["rooms"] = static_cast<double>(r.rooms);
  state.counters["expected_rooms"] = 2.0 * rooms_per_side + 1.0;
  state.counters["median_ms"] = ms.empty() ? 0.0 : ms[ms.size() / 2];
  state.counters["max_ms"] = ms.empty() ? 0.0 : ms.back();
  std::size_t arena = 0;
  finder->for_each_resource([&](const memory::ResourceStats& s) {
    if (arena == 0) arena = s.capacity;  // the first resource is the arena
  });
  state.counters["arena_MB"] = static_cast<double>(arena) / (1 << 20);
}

// 6 rooms per side: ~1,000 places (the target size); 24: ~4,000.
BENCHMARK(BM_rooms_update)
    ->ArgsProduct({{6, 24}, {0, 1}, {0, 1}})
    ->ArgNames({"rooms_per_side", "persistence", "extent_split"})
    ->Unit(benchmark::kMillisecond);

}  // namespace
