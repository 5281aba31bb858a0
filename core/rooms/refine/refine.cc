// The refinement passes in order, and each pass's settings from rooms::Config.
#include "core/rooms/refine/refine.h"

#include "core/rooms/room_finder.h"

namespace qsg::rooms::refine {

ExtentSplitConfig extent_split_config(const Config& c) {
  ExtentSplitConfig s;
  s.saturation_m = c.extent_saturation_m;
  s.min_extent_m = c.split_min_extent_m;
  s.max_extent_m = c.split_max_extent_m;
  s.min_persistence_m = c.split_min_persistence_m;
  s.min_component_size = c.split_min_component_size;
  return s;
}

CorridorMergeConfig corridor_merge_config(const Config& c) {
  CorridorMergeConfig s;
  s.min_neighbours = c.corridor_min_neighbours;
  s.min_open_edges = c.corridor_min_open_edges;
  return s;
}

VisibilityMergeConfig visibility_merge_config(const Config& c) {
  VisibilityMergeConfig s;
  s.min_share = c.visible_min_share;
  s.samples = c.visible_samples;
  s.max_rounds = c.visible_max_rounds;
  s.local_radius_m = c.visible_local_radius_m;
  s.local_min_share = c.visible_local_min_share;
  s.local_min_places = c.visible_local_min_places;
  s.touching = c.visible_touching;
  s.touch_max_clearance_m = c.visible_touch_max_clearance_m;
  return s;
}

void Refinements::plan(memory::ArenaPlan* p, const Capacities& c) {
  ExtentSplit::plan(p, c.places, c.rooms);
  VisibilityMerge::plan(p, c.places, c.rooms);
}

bool Refinements::carve(memory::Arena& arena, const Capacities& c) {
  const bool split = extent_split_.carve(arena, c.places, c.rooms);
  const bool visible = visibility_merge_.carve(arena, c.places, c.rooms);
  return split && visible;
}

Partition Refinements::run(const Config& config, const PlacesGraph& places, const SightLines* sight,
                           Partition rooms, Workspace* ws, UpdateResult* r) {
  if (config.split_by_extent) {
    ExtentSplitStats s;
    rooms = extent_split_.run(extent_split_config(config), places, rooms, ws, &s);
    r->rooms_split += s.rooms_split;
    r->split_rooms_added += s.split_rooms_added;
    r->seeds_dropped += s.seeds_dropped;
  }
  if (config.merge_corridors) {
    CorridorMergeStats s;
    rooms = merge_corridors(corridor_merge_config(config), places, rooms, ws, &s);
    r->corridor_merges += s.merges;
  }
  if (config.merge_visible && sight != nullptr && sight->slices() > 0 && !sight->window()) {
    VisibilityMergeStats s;
    rooms = visibility_merge_.run(visibility_merge_config(config), places, *sight, rooms, ws, &s);
    r->visible_merges += s.merges;
    r->visible_pairs += s.pairs;
    r->visible_near_merges += s.near_merges;
    r->visible_touching_pairs += s.touching_pairs;
    r->visible_touching_dropped += s.touching_dropped;
  }
  return rooms;
}

}  // namespace qsg::rooms::refine
