// BM_neural_tree_*: room labels for a frozen synthetic building (H-tree, message passing, LR head, blend), and the
// H-tree alone.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>

#include "core/neural_tree/room_classifier.h"
#include "core/neural_tree/synthetic_building.h"

namespace {

using namespace qsg::neural_tree;

// Per-iteration wall time so the max is reported beside the mean (a real-time stage's figure of merit).
template <typename F>
void timed_loop(benchmark::State& state, F&& body) {
  double max_us = 0.0, sum_us = 0.0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    body();
    const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
    max_us = std::max(max_us, us);
    sum_us += us;
  }
  state.counters["max_us"] = max_us;
  state.counters["mean_us"] = state.iterations() ? sum_us / static_cast<double>(state.iterations()) : 0.0;
}

void BM_neural_tree_classify(benchmark::State& state) {
  const int rooms = static_cast<int>(state.range(0));
  const int objects = static_cast<int>(state.range(1));
  RoomClassifier classifier;
  std::string error;
  if (!classifier.init(&error)) {
    state.SkipWithError(error.c_str());
    return;
  }
  ObjectRoomGraph graph;
  make_synthetic_building(rooms, objects / std::max(rooms, 1), 3, classifier, &graph);
  bool ok = true;
  timed_loop(state, [&] { ok = classifier.classify(graph, &error) && ok; });
  if (!ok) state.SkipWithError(error.c_str());
  state.counters["htree_nodes"] = classifier.stats().last_htree_nodes;
  state.counters["htree_width"] = classifier.stats().last_width;
  state.counters["graph_nodes"] = static_cast<double>(graph.nodes.size());
}

void BM_neural_tree_h_tree(benchmark::State& state) {
  const int rooms = static_cast<int>(state.range(0));
  const int objects = static_cast<int>(state.range(1));
  RoomClassifier classifier;  // only for word indices; labels do not change the tree
  ObjectRoomGraph graph;
  make_synthetic_building(rooms, objects / std::max(rooms, 1), 3, classifier, &graph);
  LayeredGraph layered;
  for (const auto& n : graph.nodes) layered.layers.push_back(n.layer);
  for (int v = 0; v < static_cast<int>(graph.nodes.size()); ++v) {
    if (graph.nodes[v].layer == NodeLayer::kObject) {
      layered.edge_a.push_back(v);
      layered.edge_b.push_back(graph.nodes[v].room);
    } else if (graph.nodes[v].layer == NodeLayer::kRoom) {
      layered.edge_a.push_back(v);
      layered.edge_b.push_back(0);  // the building
    }
  }
  for (std::size_t e = 0; e < graph.edge_a.size(); ++e) {
    layered.edge_a.push_back(graph.edge_a[e]);
    layered.edge_b.push_back(graph.edge_b[e]);
  }
  HTreeBuilder builder;
  HTree h;
  std::string error;
  timed_loop(state, [&] { benchmark::DoNotOptimize(builder.build(layered, &h, &error)); });
  state.counters["htree_nodes"] = h.num_nodes();
  state.counters["htree_width"] = h.width;
}

BENCHMARK(BM_neural_tree_classify)->Args({30, 300})->Args({10, 100})->Args({60, 600})->ArgNames({"rooms", "objects"})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_neural_tree_h_tree)->Args({30, 300})->ArgNames({"rooms", "objects"})->Unit(benchmark::kMicrosecond);

}  // namespace
