// Our refinements of the paper's rooms, in the one place that orders them: each pass takes the partition the
// previous one returned (the first gets the finder's flood fill) and returns one. Their scratch is carved from the
// room finder's arena at start-up; a pass never allocates. Each pass's settings come from the rooms::Config fields
// named in its own config (extent_split.h, corridor_merge.h, visibility_merge.h).
#pragma once

#include <cstddef>

#include "core/memory/arena.h"
#include "core/rooms/config.h"
#include "core/rooms/door_cues.h"
#include "core/rooms/partition.h"
#include "core/rooms/refine/corridor_merge.h"
#include "core/rooms/refine/extent_split.h"
#include "core/rooms/refine/visibility_merge.h"

namespace qsg::rooms {
struct UpdateResult;  // core/rooms/room_finder.h
}

namespace qsg::rooms::refine {

ExtentSplitConfig extent_split_config(const Config& config);
CorridorMergeConfig corridor_merge_config(const Config& config);
VisibilityMergeConfig visibility_merge_config(const Config& config);

class Refinements {
 public:
  static void plan(memory::ArenaPlan* p, const Capacities& capacities);
  bool carve(memory::Arena& arena, const Capacities& capacities);

  // In order: the extent split (Config::split_by_extent), the corridor merge (merge_corridors), the visibility
  // merge (merge_visible, with whole-map sight lines only: `sight` null, empty or a window's skips it). Their
  // counts go to *result.
  Partition run(const Config& config, const PlacesGraph& places, const SightLines* sight, Partition rooms,
                Workspace* ws, UpdateResult* result);

 private:
  ExtentSplit extent_split_;
  VisibilityMerge visibility_merge_;
};

}  // namespace qsg::rooms::refine
