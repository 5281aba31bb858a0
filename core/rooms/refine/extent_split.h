// Extent split (our refinement, not the paper's): the places' clearance is capped near half the storey height by
// floor and ceiling, so every space wider than about 2.5 m looks alike to the filtration, and a room that meets a
// corridor through a wide opening (no constriction) merges with it. Each place whose clearance is at least
// saturation_m (bounded by floor and ceiling rather than walls) gets an extended clearance: its clearance plus its
// horizontal graph distance to the nearest place below that clearance, a horizontal distance to the walls inside
// the saturated sheet. Each room is then seeded again on the extended clearance over [min_extent_m, max_extent_m]
// with the persistence rule (min_persistence_m, min_component_size) through its own edges only; a room with two or
// more seeds is split and its other places flood-filled among them, again through its own edges. Rooms are never
// merged by it. Why it is on, and what it earned: core/rooms/README.md.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/memory/arena.h"
#include "core/rooms/partition.h"

namespace qsg::rooms::refine {

struct ExtentSplitConfig {
  double saturation_m = 1.0;     // rooms::Config::extent_saturation_m
  double min_extent_m = 1.0;     // split_min_extent_m
  double max_extent_m = 2.5;     // split_max_extent_m
  double min_persistence_m = 0.5;  // split_min_persistence_m
  std::uint32_t min_component_size = 6;  // split_min_component_size
};

struct ExtentSplitStats {
  std::size_t rooms_split = 0;        // rooms split in two or more
  std::size_t split_rooms_added = 0;  // rooms those splits added
  std::size_t seeds_dropped = 0;      // further seeds beyond the room capacity (their places stay in their room)
};

class ExtentSplit {
 public:
  static void plan(memory::ArenaPlan* p, std::size_t places, std::size_t rooms);
  bool carve(memory::Arena& arena, std::size_t places, std::size_t rooms);
  // The first seed of a split room keeps its slot, the others take new slots while rooms.max_rooms lasts.
  Partition run(const ExtentSplitConfig& config, const PlacesGraph& places, Partition rooms, Workspace* ws,
                ExtentSplitStats* stats);

 private:
  void compute_extent(const ExtentSplitConfig& config, const PlacesGraph& places, Workspace* ws);
  std::uint32_t seed(const ExtentSplitConfig& config, const PlacesGraph& places, const Partition& rooms,
                     Workspace* ws);
  double* extent_ = nullptr;             // per place: extended clearance
  std::uint32_t* sub_seeds_ = nullptr;   // per seed: its room, then its slot
  std::uint32_t* room_seeds_ = nullptr;  // per room slot: its seeds and flags
};

}  // namespace qsg::rooms::refine
