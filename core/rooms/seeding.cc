// Our seeds, in place of the paper's plateau (Seeding::kPersistence): per component on the filtration's merge tree;
// and every region the door stage's closed edges cut off, holding no seed, a seed of its own
// (Config::seed_closed_regions).
#include <algorithm>

#include "core/rooms/room_finder.h"

namespace qsg::rooms {

// Merge tree of the clearance filtration (ws_.order still holds compute_curve()'s sorted places and edges): places
// enter at their clearance (capped at d+), edges join components at their clearance, down to d-. When two
// components meet and both are seed-worthy (big and persistent enough, or already holding seeds), the ones not yet
// seeded become seeds with every place they hold; the merged component holds seeds from then on, so later places
// that reach it only through it are left to the flood fill. At d- every remaining component of the minimum size
// becomes a seed whatever its persistence: nothing joins it above d-, so it is a region of its own (a narrow
// corridor peaks not far above d-, yet is a room).
std::size_t RoomFinder::seed_by_persistence(UpdateResult* r) {
  const std::uint32_t* node_order = ws_.order;
  const std::uint32_t* edge_order = ws_.order + num_places_;
  const double d_min = config_.min_dilation_m - kDilationTolerance;
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    ws_.parent[i] = kNoIndex;
    room_of_[i] = -1;
  }
  const auto worthy = [&](std::uint32_t root, double at_m) {
    return ws_.flag[root] != 0 ||
           (ws_.size[root] >= config_.min_component_size && ws_.birth[root] - at_m >= config_.min_persistence_m - 1e-9);
  };
  // A place enters the filtration as a component of its own, born at its clearance (capped at d+).
  const auto enter = [&](std::uint32_t i) {
    ws_.parent[i] = i;
    ws_.size[i] = 1;
    ws_.birth[i] = std::min(clearance_[i], config_.max_dilation_m);
    ws_.member_next[i] = kNoIndex;
    ws_.member_tail[i] = i;
    ws_.flag[i] = 0;
  };
  std::size_t seeds = 0;
  std::size_t next_node = 0;
  for (std::size_t k = 0; k < num_edges_; ++k) {
    const PlaceEdge& e = edges_[edge_order[k]];
    if (e.clearance_m < d_min) break;
    // Places at least as clear as this edge enter first (an edge's clearance never exceeds its ends').
    for (; next_node < num_places_ && clearance_[node_order[next_node]] >= e.clearance_m; ++next_node)
      enter(node_order[next_node]);
    std::uint32_t ra = ws_.find(e.a), rb = ws_.find(e.b);
    if (ra == rb) continue;
    std::uint8_t split = ws_.flag[ra] | ws_.flag[rb];
    if (e.clearance_m <= config_.max_door_clearance_m + 1e-9 && worthy(ra, e.clearance_m) &&
        worthy(rb, e.clearance_m)) {
      if (ws_.flag[ra] == 0) emit_seed(ra, &seeds, r);
      if (ws_.flag[rb] == 0) emit_seed(rb, &seeds, r);
      split = 1;
    }
    ws_.join(ra, rb, split);
  }
  // Places above d- that no edge above d- reached are components of their own.
  for (; next_node < num_places_ && clearance_[node_order[next_node]] >= d_min; ++next_node)
    enter(node_order[next_node]);
  for (std::size_t n = 0; n < next_node; ++n) {
    const std::uint32_t i = node_order[n];
    if (ws_.parent[i] == i && ws_.flag[i] == 0 && ws_.size[i] >= config_.min_component_size) emit_seed(i, &seeds, r);
  }
  r->seeds = seeds + r->seeds_dropped;
  return seeds;
}

// Closed-off regions (Config::seed_closed_regions): the components of the places graph without its closed edges;
// each that holds no seed and has at least min_component_size places becomes a seed with all its places (while the
// room capacity lasts; beyond it, counted as dropped). Returns the new number of seeds.
std::size_t RoomFinder::seed_closed_regions(std::size_t seeds, UpdateResult* r) {
  if (r->closed_edges == 0) return seeds;
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    ws_.parent[i] = i;
    ws_.size[i] = 1;
    ws_.flag[i] = 0;  // per root: holds a seed (or is refused)
    ws_.root_room[i] = kNoIndex;
  }
  for (std::size_t k = 0; k < num_edges_; ++k) {
    const PlaceEdge& e = edges_[k];
    if (e.closed()) continue;
    std::uint32_t ra = ws_.find(e.a), rb = ws_.find(e.b);
    if (ra == rb) continue;
    if (ws_.size[ra] < ws_.size[rb]) std::swap(ra, rb);
    ws_.parent[rb] = ra;
    ws_.size[ra] += ws_.size[rb];
  }
  for (std::uint32_t i = 0; i < num_places_; ++i)
    if (room_of_[i] >= 0) ws_.flag[ws_.find(i)] = 1;
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    const std::uint32_t root = ws_.find(i);
    if (ws_.flag[root] != 0 || ws_.size[root] < config_.min_component_size) continue;
    if (ws_.root_room[root] == kNoIndex) {
      if (seeds == capacities_.rooms) {
        ws_.flag[root] = 1;
        ++r->seeds_dropped;
        continue;
      }
      ws_.root_room[root] = static_cast<std::uint32_t>(seeds++);
      ++r->closed_region_rooms;
      ++r->seeds;
    }
    room_of_[i] = static_cast<std::int32_t>(ws_.root_room[root]);
    ++r->seeded_places;
  }
  return seeds;
}

void RoomFinder::emit_seed(std::uint32_t root, std::size_t* seeds, UpdateResult* r) {
  ws_.flag[root] = 1;
  if (*seeds == capacities_.rooms) {
    ++r->seeds_dropped;
    return;
  }
  const std::int32_t slot = static_cast<std::int32_t>((*seeds)++);
  for (std::uint32_t i = root; i != kNoIndex; i = ws_.member_next[i]) {
    room_of_[i] = slot;
    ++r->seeded_places;
  }
}

}  // namespace qsg::rooms
