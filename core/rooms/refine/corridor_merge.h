// Corridor merge (our refinement, not the paper's): a corridor is the space that connects many rooms, and the
// seeding cuts it into pieces wherever it widens or narrows, a loss of recall that no door cue recovers (it has no
// door there). Two adjacent rooms that both touch at least min_neighbours other rooms (through any place edge, open
// or closed by a door stage) and meet through at least min_open_edges open place edges (a wide opening, not a door)
// are one room; pairs are merged most open edges first, the neighbour counts taken again after each merge. A room
// off a corridor touches one or two rooms, so it is left alone. What it earned: core/rooms/README.md.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/rooms/partition.h"

namespace qsg::rooms::refine {

struct CorridorMergeConfig {
  std::uint32_t min_neighbours = 3;   // rooms::Config::corridor_min_neighbours
  std::uint32_t min_open_edges = 20;  // corridor_min_open_edges
};

struct CorridorMergeStats {
  std::size_t merges = 0;  // rooms merged into an adjacent corridor piece
};

// Room slots are packed 24 bits a side (rooms::Capacities::check keeps rooms below 2^24). Needs no scratch of its
// own (the Workspace's pairs and room slots).
Partition merge_corridors(const CorridorMergeConfig& config, const PlacesGraph& places, Partition rooms,
                          Workspace* ws, CorridorMergeStats* stats);

}  // namespace qsg::rooms::refine
