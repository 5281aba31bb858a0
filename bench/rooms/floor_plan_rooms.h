// Room segmentation on a 2D floor-plan raster: the room segmentation benchmark's score (max-overlap precision and
// recall), and two classical segmentations that see the complete plan, the peers our robot's room finder (which
// sees only what its camera saw, in 3D) is measured against in the same run.
//
// Rasters are row-major, cols x rows cells; `free` is 1 for free cells, labels are 0 for "no room".
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "drivers/world/floor_plan_import.h"

namespace qsg::bench {

// A benchmark plan as the score sees it: free cells of the occupancy image (>= config.free_threshold), and each
// cell's ground-truth room: the 8-connected white regions (> config.gt_room_threshold) of the ground-truth image
// with at least config.min_room_area_px cells, numbered by OpenCV's labelling (0: none).
struct PlanRaster {
  int cols = 0, rows = 0;
  std::vector<std::uint8_t> free;
  std::vector<std::int32_t> truth;
};

// False with *error set when an image cannot be read or their sizes differ.
bool read_plan_raster(const std::string& occupancy_path, const std::string& gt_path,
                      const world::FloorPlanConfig& config, PlanRaster* out, std::string* error);

// The benchmark's score of an estimated segmentation against the ground truth, over the cells that are free and
// inside a ground-truth room. An estimated room's precision is its largest overlap with one ground-truth room over
// its size there; a ground-truth room's recall is its largest overlap with one estimated room over its size (its
// unlabelled cells count, so unexplored space lowers recall). The mean form averages over rooms, the area form pools
// cells; both are kept because the mean form hides merged rooms. The sums let scores pool over maps (add()).
struct RoomSegmentationScore {
  double precision_mean = 0.0, recall_mean = 0.0;
  double precision_area = 0.0, recall_area = 0.0;
  std::size_t rooms_found = 0, rooms_truth = 0;
  double p_sum = 0.0, r_sum = 0.0, p_overlap = 0.0, p_size = 0.0, r_overlap = 0.0, r_size = 0.0;
  void add(const RoomSegmentationScore& o);
  void finish();
};

// Sizes must agree (a mismatch scores nothing: all zeros).
RoomSegmentationScore score_room_segmentation(const std::vector<std::uint8_t>& free,
                                              const std::vector<std::int32_t>& truth,
                                              const std::vector<std::int32_t>& estimate);

// Distance-transform room segmentation (Bormann et al., "Room Segmentation: Survey, Implementation, and Analysis",
// ICRA 2016, its "distance" method): the Euclidean distance transform of the free space is thresholded at every
// level in turn; at each level the connected regions whose area lies in [min_room_area_m2, max_room_area_m2] are
// counted, and the level with the most such regions (the lowest on ties) gives the seeds; a wavefront from the seeds
// then gives every reachable free cell the room of its geodesically nearest seed. The defaults are the areas the
// benchmark's authors use for this method.
//
// Level::kPlateau picks the level from the same counts by persistent homology instead: the curve of room-sized
// regions over the levels is a Betti-0 curve, and the paper's alpha plateau rule (rooms::choose_plateau: among the
// flat runs longer than alpha x the longest, the one with the most regions) gives one threshold per map, the kind of
// per-map persistent-homology threshold the 2D anchor uses. As in the room finder, the curve spans
// [plateau_min_level_m, plateau_max_level_m] (rooms::Config's d- and d+): over all levels the top run of one region
// (the largest room alone) is the longest and the rule picks it.
struct DistanceSegmentationConfig {
  enum class Level { kMostRooms, kPlateau };
  double resolution_m = 0.05;     // cell size
  double min_room_area_m2 = 0.35;
  double max_room_area_m2 = 163.0;
  double step_m = 0.05;           // threshold increment
  Level level = Level::kMostRooms;
  double plateau_alpha = 0.5;     // kPlateau only, in [0, 1]
  double plateau_min_level_m = 0.5;
  double plateau_max_level_m = 1.2;
};

struct PlanSegmentation {
  std::vector<std::int32_t> labels;  // 1..rooms per free cell reached from a seed, 0 elsewhere
  double level_m = 0.0;              // distance transform: the chosen threshold; erosion: the deepest erosion used
  int rooms = 0;
};

// Returns false with *error set on bad input (sizes, non-positive resolution or step, an empty area range, an alpha
// outside [0, 1], an empty plateau range).
bool segment_by_distance_transform(const std::vector<std::uint8_t>& free, int cols, int rows,
                                   const DistanceSegmentationConfig& config, PlanSegmentation* out,
                                   const char** error);

// Morphological room segmentation (the same paper's "morphological" method): the free space is eroded one cell at a
// time; after each erosion every connected region whose area lies in [min_room_area_m2, max_room_area_m2] becomes a
// room seed and is removed from further erosion; when nothing is left, a wavefront from the seeds fills the free
// space as above. The defaults are the authors' areas for this method.
struct MorphologicalSegmentationConfig {
  double resolution_m = 0.05;
  double min_room_area_m2 = 0.8;
  double max_room_area_m2 = 47.0;
};

bool segment_by_erosion(const std::vector<std::uint8_t>& free, int cols, int rows,
                        const MorphologicalSegmentationConfig& config, PlanSegmentation* out, const char** error);

}  // namespace qsg::bench
