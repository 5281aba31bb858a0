// The corridor merge over the rooms' boundary edges.
#include "core/rooms/refine/corridor_merge.h"

#include <algorithm>

namespace qsg::rooms::refine {

// ws->pairs holds one record per boundary edge at first: lower room slot << 40 | higher slot << 16 | open (0 or
// 1). Each round maps the records to the current merged rooms, sorts them and folds each pair's records into one
// (its open edges summed, saturating at 0xffff), so after the first round a round costs the number of room pairs,
// not of edges; it counts per room its distinct neighbours and merges the qualifying pair with the most open edges
// (ties: the lower pair). Slots are then renumbered densely.
Partition merge_corridors(const CorridorMergeConfig& config, const PlacesGraph& places, Partition rooms,
                          Workspace* ws, CorridorMergeStats* stats) {
  constexpr std::uint64_t kCountMask = 0xffffu;
  const auto lo_of = [](std::uint64_t x) { return static_cast<std::uint32_t>(x >> 40); };
  const auto hi_of = [](std::uint64_t x) { return static_cast<std::uint32_t>((x >> 16) & 0xffffffu); };
  const auto record = [](std::uint32_t a, std::uint32_t b, std::uint64_t count) {
    return (static_cast<std::uint64_t>(std::min(a, b)) << 40) | (static_cast<std::uint64_t>(std::max(a, b)) << 16) |
           count;
  };
  std::uint64_t* pairs = ws->pairs;
  std::uint32_t* neighbours = ws->room_scratch;
  const std::int32_t* room_of = rooms.room_of;
  std::size_t n = 0;
  for (std::size_t e = 0; e < places.num_edges; ++e) {
    const std::int32_t a = room_of[places.edges[e].a], b = room_of[places.edges[e].b];
    if (a < 0 || b < 0 || a == b) continue;
    pairs[n++] = record(static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b),
                        places.edges[e].closed() ? 0u : 1u);
  }
  for (std::size_t k = 0; k < rooms.num_rooms; ++k) ws->room_parent[k] = static_cast<std::uint32_t>(k);
  std::size_t merges = 0;
  for (;;) {
    std::size_t m = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const std::uint32_t a = ws->find_room(lo_of(pairs[k])), b = ws->find_room(hi_of(pairs[k]));
      if (a != b) pairs[m++] = record(a, b, pairs[k] & kCountMask);  // else inside one merged room now
    }
    std::sort(pairs, pairs + m);
    n = 0;
    for (std::size_t k = 0; k < m;) {
      std::uint64_t open = 0;
      std::size_t j = k;
      for (; j < m && (pairs[j] >> 16) == (pairs[k] >> 16); ++j) open += pairs[j] & kCountMask;
      pairs[n++] = (pairs[k] & ~kCountMask) | std::min(open, kCountMask);
      k = j;
    }
    std::fill(neighbours, neighbours + rooms.num_rooms, 0u);
    for (std::size_t k = 0; k < n; ++k) {
      ++neighbours[lo_of(pairs[k])];
      ++neighbours[hi_of(pairs[k])];
    }
    std::uint64_t best_open = 0;
    std::size_t best = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const std::uint64_t open = pairs[k] & kCountMask;
      if (open >= config.min_open_edges && open > best_open && neighbours[lo_of(pairs[k])] >= config.min_neighbours &&
          neighbours[hi_of(pairs[k])] >= config.min_neighbours) {
        best_open = open;
        best = k;
      }
    }
    if (best_open == 0) break;
    ws->room_parent[hi_of(pairs[best])] = lo_of(pairs[best]);  // the lower slot stays
    ++merges;
  }
  if (merges == 0) return rooms;
  stats->merges += merges;
  rooms.num_rooms = ws->renumber_merged_rooms(places, rooms.room_of, rooms.num_rooms);
  return rooms;
}

}  // namespace qsg::rooms::refine
