// BM_scene_graph_*: inserting places with their graph edges and room parents, as the frontend does per update.
#include <benchmark/benchmark.h>

#include "core/scene_graph/scene_graph.h"

namespace {

using namespace qsg::scene_graph;

// A 2D lattice of places (side x side), 4-connected, parented to one room per 10 x 10 block.
void insert_lattice(SceneGraph& g, int side) {
  for (int y = 0; y < side; ++y) {
    for (int x = 0; x < side; ++x) {
      PlaceAttributes p;
      p.position_m = {0.5 * x, 0.5 * y, 1.0};
      p.distance_m = 0.8;
      const NodeId id = make_node_id(kPlacePrefix, static_cast<std::uint64_t>(y * side + x));
      g.add_place(id, p);
      if (x > 0) g.add_edge(id - 1, id, {0.8, true});
      if (y > 0) g.add_edge(id - side, id, {0.8, true});
      const NodeId room = make_node_id(kRoomPrefix, static_cast<std::uint64_t>((y / 10) * 100 + x / 10));
      if (!g.has_node(room)) g.add_room(room, RoomAttributes{});
      g.add_edge(room, id);
    }
  }
}

void BM_scene_graph_insert_places(benchmark::State& state) {
  const int side = static_cast<int>(state.range(0));
  SceneGraph g;
  g.init(capacities_from_budget(), arena_bytes_from_budget(), nullptr);
  for (auto _ : state) {
    state.PauseTiming();
    g.clear();
    state.ResumeTiming();
    insert_lattice(g, side);
  }
  state.SetItemsProcessed(state.iterations() * side * side);
  state.counters["nodes"] = static_cast<double>(g.num_nodes());
  state.counters["edges"] = static_cast<double>(g.num_edges());
}

void BM_scene_graph_neighbors(benchmark::State& state) {
  const int side = static_cast<int>(state.range(0));
  SceneGraph g;
  g.init(capacities_from_budget(), arena_bytes_from_budget(), nullptr);
  insert_lattice(g, side);
  double sum = 0.0;
  for (auto _ : state) {
    for (int i = 0; i < side * side; ++i)
      g.for_each_neighbor(make_node_id(kPlacePrefix, static_cast<std::uint64_t>(i)),
                          [&](NodeId, const EdgeRecord& e) { sum += e.info.weight; });
  }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(state.iterations() * side * side);
}

BENCHMARK(BM_scene_graph_insert_places)->Arg(32)->Arg(128)->ArgName("side")->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_scene_graph_neighbors)->Arg(128)->ArgName("side")->Unit(benchmark::kMicrosecond);

}  // namespace
