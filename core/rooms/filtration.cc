// The paper's step: the clearance filtration of the places graph, its Betti-0 curve, the alpha plateau rule and
// the components alive at the chosen dilation as room seeds (Seeding::kPlateau).
#include <algorithm>

#include "core/rooms/room_finder.h"

namespace qsg::rooms {

int choose_plateau(const std::uint32_t* betti, std::size_t samples, double alpha) {
  // Longest run of a non-zero value first, then the candidates.
  std::size_t longest = 0;
  for (std::size_t i = 0; i < samples;) {
    std::size_t j = i;
    while (j < samples && betti[j] == betti[i]) ++j;
    if (betti[i] != 0) longest = std::max(longest, j - i);
    i = j;
  }
  if (longest == 0) return -1;
  // "Longer than alpha x the longest": strictly, except that the longest itself always qualifies (alpha = 1).
  const double threshold = alpha * static_cast<double>(longest);
  int best = -1;
  std::size_t best_length = 0;
  std::uint32_t best_value = 0;
  for (std::size_t i = 0; i < samples;) {
    std::size_t j = i;
    while (j < samples && betti[j] == betti[i]) ++j;
    const std::size_t length = j - i;
    const bool candidate = betti[i] != 0 && (static_cast<double>(length) > threshold || length == longest);
    if (candidate && (best < 0 || betti[i] > best_value || (betti[i] == best_value && length > best_length))) {
      best = static_cast<int>(i);
      best_length = length;
      best_value = betti[i];
    }
    i = j;
  }
  return best;
}

// Superlevel filtration: lowering the dilation from d+ to d- adds places and edges in order of decreasing
// clearance; union-find keeps the number of components of at least min_component_size places.
void RoomFinder::compute_curve() {
  curve_size_ = config_.curve_samples();
  std::uint32_t* node_order = ws_.order;
  std::uint32_t* edge_order = ws_.order + num_places_;
  for (std::uint32_t i = 0; i < num_places_; ++i) node_order[i] = i;
  for (std::uint32_t e = 0; e < num_edges_; ++e) edge_order[e] = e;
  std::sort(node_order, node_order + num_places_, [&](std::uint32_t a, std::uint32_t b) {
    return clearance_[a] != clearance_[b] ? clearance_[a] > clearance_[b] : a < b;
  });
  std::sort(edge_order, edge_order + num_edges_, [&](std::uint32_t a, std::uint32_t b) {
    return edges_[a].clearance_m != edges_[b].clearance_m ? edges_[a].clearance_m > edges_[b].clearance_m : a < b;
  });
  const std::uint32_t m = config_.min_component_size;
  std::fill(ws_.parent, ws_.parent + num_places_, kNoIndex);
  std::size_t next_node = 0, next_edge = 0;
  std::uint32_t count = 0;
  for (std::size_t k = curve_size_; k-- > 0;) {
    const double delta = dilation_at(k) - kDilationTolerance;
    for (; next_node < num_places_ && clearance_[node_order[next_node]] >= delta; ++next_node) {
      const std::uint32_t i = node_order[next_node];
      ws_.parent[i] = i;
      ws_.size[i] = 1;
      if (m <= 1) ++count;
    }
    for (; next_edge < num_edges_ && edges_[edge_order[next_edge]].clearance_m >= delta; ++next_edge) {
      const PlaceEdge& e = edges_[edge_order[next_edge]];
      std::uint32_t ra = ws_.find(e.a), rb = ws_.find(e.b);
      if (ra == rb) continue;
      const bool big_a = ws_.size[ra] >= m, big_b = ws_.size[rb] >= m;
      if (ws_.size[ra] < ws_.size[rb]) std::swap(ra, rb);
      ws_.parent[rb] = ra;
      ws_.size[ra] += ws_.size[rb];
      count = count + (ws_.size[ra] >= m ? 1u : 0u) - (big_a ? 1u : 0u) - (big_b ? 1u : 0u);
    }
    curve_[k] = count;
  }
}

std::size_t RoomFinder::seed_rooms(double dilation_m, UpdateResult* r) {
  const double delta = dilation_m - kDilationTolerance;
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    ws_.parent[i] = clearance_[i] >= delta ? i : kNoIndex;
    ws_.size[i] = 1;
    room_of_[i] = -1;
    ws_.root_room[i] = kNoIndex;
  }
  for (std::size_t k = 0; k < num_edges_; ++k) {
    const PlaceEdge& e = edges_[k];
    if (e.clearance_m < delta) continue;
    std::uint32_t ra = ws_.find(e.a), rb = ws_.find(e.b);
    if (ra == rb) continue;
    if (ws_.size[ra] < ws_.size[rb]) std::swap(ra, rb);
    ws_.parent[rb] = ra;
    ws_.size[ra] += ws_.size[rb];
  }
  // Seed components, largest first when they do not all fit (ws_.order is free again).
  std::size_t seeds = 0;
  for (std::uint32_t i = 0; i < num_places_; ++i)
    if (ws_.parent[i] == i && ws_.size[i] >= config_.min_component_size) ws_.order[seeds++] = i;
  if (seeds > capacities_.rooms) {
    std::sort(ws_.order, ws_.order + seeds, [&](std::uint32_t a, std::uint32_t b) {
      return ws_.size[a] != ws_.size[b] ? ws_.size[a] > ws_.size[b] : a < b;
    });
    r->seeds_dropped = seeds - capacities_.rooms;
    seeds = capacities_.rooms;
    std::sort(ws_.order, ws_.order + seeds);  // slots in place order, as without the cut
  }
  r->seeds = seeds + r->seeds_dropped;
  for (std::size_t s = 0; s < seeds; ++s) ws_.root_room[ws_.order[s]] = static_cast<std::uint32_t>(s);
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    if (ws_.parent[i] == kNoIndex) continue;
    const std::uint32_t slot = ws_.root_room[ws_.find(i)];
    if (slot != kNoIndex) {
      room_of_[i] = static_cast<std::int32_t>(slot);
      ++r->seeded_places;
    }
  }
  return seeds;
}

}  // namespace qsg::rooms
