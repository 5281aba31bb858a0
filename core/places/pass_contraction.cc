// Repair pass: edge contraction (Config::contract_removed, contract_search_places). Removing a place never cuts
// an inactive place off the active graph: it is joined to the removed place's nearest other neighbour.
#include "core/places/places_internal.h"

namespace qsg::places {

// Whether an inactive place still reaches an active place (other than `removed`) within contract_search_places
// graph nodes. Bounded breadth-first search on a fixed array: no allocation.
bool Places::anchored(const scene_graph::SceneGraph& graph, scene_graph::NodeId start, scene_graph::NodeId removed,
                      const scene_graph::NodeId* removing, std::size_t num_removing) const {
  scene_graph::NodeId queue[kMaxContractSearch];
  const int limit = config_.contract_search_places;
  int num = 0;
  queue[num++] = start;
  bool found = false, overflow = false;
  for (int i = 0; i < num && !found && !overflow; ++i) {
    graph.for_each_neighbor(queue[i], [&](scene_graph::NodeId m, const scene_graph::EdgeRecord&) {
      if (found || overflow || m == removed || scene_graph::node_prefix(m) != scene_graph::kPlacePrefix) return;
      const scene_graph::PlaceAttributes* pm = graph.place(m);
      if (pm == nullptr || std::binary_search(removing, removing + num_removing, m)) return;  // going: no anchor
      if (pm->is_active) {
        found = true;
        return;
      }
      for (int j = 0; j < num; ++j)
        if (queue[j] == m) return;
      if (num == limit) {
        overflow = true;  // undecided: contract (one edge too many is cheaper than a cut graph)
        return;
      }
      queue[num++] = m;
    });
  }
  return found;
}

// Before a place node is removed: each inactive neighbour that only reached the active graph through it is joined
// to the removed place's nearest other neighbour (preferring active ones), with the weaker of the two edge weights.
void Places::contract_around(scene_graph::SceneGraph* graph, scene_graph::NodeId removed,
                             const scene_graph::NodeId* removing, std::size_t num_removing, SyncResult* r) {
  constexpr int kMaxNeighbours = 32;
  scene_graph::NodeId nbr[kMaxNeighbours];
  Eigen::Vector3d pos[kMaxNeighbours];
  double weight[kMaxNeighbours];
  bool active[kMaxNeighbours];
  std::uint8_t rank[kMaxNeighbours];  // as a target: 0 active, 1 inactive, 2 removed later in this sync
  int n = 0;
  graph->for_each_neighbor(removed, [&](scene_graph::NodeId m, const scene_graph::EdgeRecord& e) {
    if (n == kMaxNeighbours || scene_graph::node_prefix(m) != scene_graph::kPlacePrefix) return;
    const scene_graph::PlaceAttributes* pm = graph->place(m);
    if (pm == nullptr) return;
    nbr[n] = m;
    pos[n] = pm->position_m;
    weight[n] = e.info.weighted ? e.info.weight : pm->distance_m;
    active[n] = pm->is_active;
    // A place removed later in this sync is the last resort: its own removal then contracts again.
    rank[n] = std::binary_search(removing, removing + num_removing, m) ? 2 : (pm->is_active ? 0 : 1);
    ++n;
  });
  for (int i = 0; i < n; ++i) {
    if (active[i] || anchored(*graph, nbr[i], removed, removing, num_removing)) continue;
    int best = -1;
    double best_d2 = std::numeric_limits<double>::max();
    for (int pass = 0; pass < 3 && best < 0; ++pass)
      for (int j = 0; j < n; ++j) {
        if (j == i || rank[j] != pass) continue;
        const double d2 = (pos[j] - pos[i]).squaredNorm();
        if (d2 < best_d2) {
          best = j;
          best_d2 = d2;
        }
      }
    if (best < 0 || graph->edge_info(nbr[i], nbr[best]) != nullptr) continue;
    if (add_repair_edge(graph, nbr[i], nbr[best], std::min(weight[i], weight[best]), "a contraction edge", r))
      ++counters_.contracted;
  }
}

}  // namespace qsg::places
