// BM_rooms_update: one room update (Betti curve, plateau or merge-tree seeds, flood fill, room and building nodes
// rewritten; the second argument picks the seeding: 0 the paper's plateau, 1 persistence, the default; the third
// turns the extent split off or on, the default, so its cost shows beside the same update without it; the fourth
// likewise the corridor merge)
// over a frozen synthetic places graph: a corridor with 4 m rooms on both sides at 0.5 m place spacing, in a scene
// graph and a finder sized by the board's budget table. Reports the median and max per update as well as the mean.
//
// BM_rooms_visible_merge: the same update over the corridor plan with every room cut in two by a false door (its
// place edges across the room's middle closed) and the plan's walls as sight lines (rooms::WallSight); the second
// argument turns the visibility merge off or on, so the merge's cost shows beside the same update without it.
//
// BM_online_door_pass: one online door pass (rooms::OnlineDoors, the budget table's "doors" capacities: the window
// around the robot, its places and place edges from a scene graph, the wall raster from the painted wall map, the
// detection, the bypass check of every found door and the door set's update) over the same corridor plan extruded
// into a surface (its walls as columns of vertices 0.05 m apart, 2.5 m tall) with the robot in the middle of the
// corridor; the second argument turns the bypass check off or on, the default. Reports the doors found against the
// plan's doors in the window, the median and max per pass.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <vector>

#include "budgets/budget_table.h"
#include "core/doors/online_doors.h"
#include "core/rooms/room_finder.h"
#include "core/doors/wall_sight.h"
#include "core/scene_graph/scene_graph.h"
#include "tests/rooms/synthetic_places.h"

namespace {

using namespace qsg;

// Times finder->update over the places in a scene graph and a finder sized by the board's budget table; writes the
// counters both update benchmarks share. Returns the last update (outcome kNotInitialized when setup failed).
rooms::UpdateResult time_updates(benchmark::State& state, const rooms::Config& config,
                                 const rooms::testing::SyntheticPlaces& places, int rooms_per_side,
                                 const rooms::WallSight* sight = nullptr) {
  auto graph = std::make_unique<scene_graph::SceneGraph>();
  auto finder = std::make_unique<rooms::RoomFinder>();
  std::string error;
  const scene_graph::Capacities caps = scene_graph::capacities_from_budget();
  rooms::UpdateResult r;
  if (!graph->init(caps, scene_graph::arena_bytes_from_budget(), &error) || !places.write(graph.get()) ||
      !finder->init(config, rooms::Capacities::from_scene_graph(caps), 0, &error)) {
    state.SkipWithError(error.empty() ? "setup failed" : error.c_str());
    return r;
  }
  std::vector<double> ms;
  ms.reserve(1 << 16);
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    r = finder->update(graph.get(), 0, nullptr, sight);
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
  finder->for_each_resource([&](const memory::ResourceStats& st) {
    if (arena == 0) arena = st.capacity;  // the first resource is the arena
  });
  state.counters["arena_MB"] = static_cast<double>(arena) / (1 << 20);
  return r;
}

void BM_rooms_update(benchmark::State& state) {
  const int rooms_per_side = static_cast<int>(state.range(0));
  rooms::Config config = state.range(1) == 0 ? rooms::Config::paper() : rooms::Config{};
  config.split_by_extent = state.range(2) != 0;
  config.merge_corridors = state.range(3) != 0;
  rooms::testing::SyntheticPlaces places;
  rooms::testing::corridor_plan(rooms_per_side, 0.5).add_to(&places, 0.5);
  time_updates(state, config, places, rooms_per_side);
}

// 6 rooms per side: ~1,000 places (the target size); 24: ~4,000.
BENCHMARK(BM_rooms_update)
    ->ArgsProduct({{6, 24}, {0, 1}, {0, 1}, {0, 1}})
    ->ArgNames({"rooms_per_side", "persistence", "extent_split", "corridor_merge"})
    ->Unit(benchmark::kMillisecond);

// BM_rooms_corridor_merge: the same update over a corridor the seeding cuts into pieces at its pinches
// (rooms::testing::pinched_corridor_plan at 0.5 m, one pinch every second room: 12 rooms a side give 6 pieces), so
// the merge has pieces to join; the second argument turns it off or on. The synthetic graph has one layer of places,
// so the open edges through a 1 m pinch are few: the merge asks for one (the neighbour rule still keeps the rooms).
void BM_rooms_corridor_merge(benchmark::State& state) {
  const int rooms_per_side = static_cast<int>(state.range(0));
  rooms::Config config;
  config.merge_corridors = state.range(1) != 0;
  config.corridor_min_open_edges = 1;
  rooms::testing::SyntheticPlaces places;
  rooms::testing::pinched_corridor_plan(rooms_per_side, 0.5).add_to(&places, 1.0, Eigen::Vector2d::Zero(), 1.25);
  const rooms::UpdateResult r = time_updates(state, config, places, rooms_per_side);
  state.counters["corridor_merges"] = static_cast<double>(r.corridor_merges);
}

BENCHMARK(BM_rooms_corridor_merge)
    ->ArgsProduct({{12, 48}, {0, 1}})
    ->ArgNames({"rooms_per_side", "corridor_merge"})
    ->Unit(benchmark::kMillisecond);

void BM_rooms_visible_merge(benchmark::State& state) {
  const int rooms_per_side = static_cast<int>(state.range(0));
  rooms::Config config;
  config.merge_visible = state.range(1) != 0;
  const rooms::testing::GridPlan plan = rooms::testing::corridor_plan(rooms_per_side, 0.5);
  rooms::testing::SyntheticPlaces places;
  plan.add_to(&places, 1.0, Eigen::Vector2d::Zero(), 1.25);
  // The false doors: edges between two places of one room whose ends lie on both sides of its middle.
  const double cell = plan.cell_m(), room_m = 4.0 + cell;  // a room and its wall
  for (rooms::testing::SyntheticEdge& e : places.edges) {
    const rooms::testing::SyntheticPlace &a = places.places[e.a], &b = places.places[e.b];
    if (a.room < 1 || a.room != b.room) continue;
    const double middle = cell + room_m * std::floor((a.position_m.x() - cell) / room_m) + 2.0;
    if ((a.position_m.x() < middle) != (b.position_m.x() < middle)) e.weight_m = 0.0;
  }
  // The sight lines: the plan's occupied cells at 0.05 m, one slice at 1.2 m.
  Eigen::Vector2d hi = Eigen::Vector2d::Zero();
  for (const rooms::testing::SyntheticPlace& p : places.places) hi = hi.cwiseMax(p.position_m.head<2>());
  rooms::DoorRaster raster;
  raster.cell_m = 0.05;
  raster.cols = static_cast<int>(std::ceil((hi.x() + cell) / raster.cell_m));
  raster.rows = static_cast<int>(std::ceil((hi.y() + cell) / raster.cell_m));
  std::vector<std::uint8_t> wall(raster.cells(), 0);
  for (int r = 0; r < raster.rows; ++r)
    for (int c = 0; c < raster.cols; ++c) {
      const Eigen::Vector2d p = raster.centre_of(c, r);
      wall[static_cast<std::size_t>(r) * raster.cols + c] =
          plan.free(static_cast<int>(p.x() / cell), static_cast<int>(p.y() / cell)) ? 0 : 1;
    }
  rooms::WallSight sight;
  std::string error;
  if (!sight.add_slice(raster, wall.data(), 1.2, rooms::DoorConfig{}, &error)) {
    state.SkipWithError(error.c_str());
    return;
  }
  const rooms::UpdateResult r = time_updates(state, config, places, rooms_per_side, &sight);
  state.counters["visible_merges"] = static_cast<double>(r.visible_merges);
  state.counters["room_pairs_tested"] = static_cast<double>(r.visible_pairs);
}

BENCHMARK(BM_rooms_visible_merge)
    ->ArgsProduct({{6, 24}, {0, 1}})
    ->ArgNames({"rooms_per_side", "visible_merge"})
    ->Unit(benchmark::kMillisecond);

void BM_online_door_pass(benchmark::State& state) {
  const int rooms_per_side = static_cast<int>(state.range(0));
  rooms::DoorConfig config;
  if (state.range(1) == 0) config.bypass_max_m = 0.0;  // the bypass check off: the same pass without it
  const rooms::testing::GridPlan plan = rooms::testing::corridor_plan(rooms_per_side, 0.25);
  rooms::testing::SyntheticPlaces places;
  plan.add_to(&places, 1.0);
  auto online = std::make_unique<rooms::OnlineDoors>();
  auto graph = std::make_unique<scene_graph::SceneGraph>();
  std::string error;
  if (!online->init(config, rooms::OnlineDoorCapacities::from_budget(),
                    budgets::active::doors::kArenaBytes, &error) ||
      !graph->init(scene_graph::capacities_from_budget(), scene_graph::arena_bytes_from_budget(), &error) ||
      !places.write(graph.get())) {
    state.SkipWithError(error.empty() ? "the places do not fit the scene graph" : error.c_str());
    return;
  }
  // Walls: the sides of every occupied cell that face a free one, as vertex columns.
  const double cell = plan.cell_m();
  Eigen::Vector2d hi = Eigen::Vector2d::Zero();
  for (int y = -1; y < 200; ++y)
    for (int x = -1; x < 1000; ++x) {
      if (plan.free(x, y)) {
        hi = hi.cwiseMax(Eigen::Vector2d((x + 1) * cell, (y + 1) * cell));
        continue;
      }
      const int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
      for (int k = 0; k < 4; ++k) {
        if (!plan.free(x + dx[k], y + dy[k])) continue;
        // The shared side, from one corner to the other.
        const Eigen::Vector2d centre((x + 0.5) * cell, (y + 0.5) * cell);
        const Eigen::Vector2d normal(dx[k], dy[k]), along(-dy[k], dx[k]);
        for (double t = -0.5 * cell; t <= 0.5 * cell + 1e-9; t += 0.05) {
          const Eigen::Vector2d p = centre + 0.5 * cell * normal + t * along;
          for (double z = 0.0; z <= 2.5 + 1e-9; z += 0.1)
            online->wall_map().add(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(z));
        }
      }
    }
  const Eigen::Vector3d robot(0.5 * hi.x(), 0.5 * hi.y(), 0.5);  // mid-corridor: the slice is 1.2 m
  std::vector<double> ms;
  ms.reserve(1 << 16);
  rooms::PassResult r;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    online->begin_pass(robot);
    online->add_places(*graph);  // the places and their edges: the bypass check runs on them
    online->rasterize();
    r = online->detect();
    const auto t1 = std::chrono::steady_clock::now();
    if (ms.size() < ms.capacity()) ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    benchmark::DoNotOptimize(r);
  }
  if (!r.ran) {
    state.SkipWithError("the pass did not run");
    return;
  }
  // The plan's doors whose centres lie in the window's interior (the window less the mapped radius).
  const rooms::DoorRaster& w = online->window();
  const double margin = rooms::DoorConfig{}.mapped_radius_m;
  const int room = 16;
  int expected = 0;
  for (int i = 0; i < rooms_per_side; ++i) {
    const double x = (1 + i * (room + 1) + room / 2) * cell;
    if (x >= w.lo.x() + margin && x < w.lo.x() + w.cols * w.cell_m - margin) expected += 2;
  }
  std::sort(ms.begin(), ms.end());
  state.counters["window_cells"] = static_cast<double>(w.cells());
  state.counters["places_in_window"] = static_cast<double>(r.places);
  state.counters["doors"] = static_cast<double>(r.found);
  state.counters["doors_gone_round"] = static_cast<double>(r.bypassed);
  state.counters["expected_doors"] = expected;
  state.counters["median_ms"] = ms.empty() ? 0.0 : ms[ms.size() / 2];
  state.counters["max_ms"] = ms.empty() ? 0.0 : ms.back();
  state.counters["arena_MB"] = static_cast<double>(online->arena().capacity_bytes()) / (1 << 20);
}

// 6 rooms per side: a 24 m corridor, wider than the window; 3: all of it inside.
BENCHMARK(BM_online_door_pass)
    ->ArgsProduct({{3, 6}, {0, 1}})
    ->ArgNames({"rooms_per_side", "bypass_check"})
    ->Unit(benchmark::kMillisecond);

}  // namespace
