// Doors and openings from the robot's own surface: the cue that separates a room from its corridor where the
// places' clearance cannot (a corridor about as wide as its doors, a wide opening under the storey's clearance cap).
//
// One horizontal slice of the reconstructed surface at a given height becomes a wall raster: a cell is wall when
// the surface inside it spans at least min_wall_height_m vertically within the slice's band, so floors and ceilings
// (flat, one layer) do not count and walls, jambs and furniture sides do. The free space is the non-wall cells
// near the places (the space the robot mapped). Its Euclidean distance transform and medial axis (Zhang-Suen
// thinning) give the classical critical points of a free-space Voronoi diagram (Thrun's "critical lines"): a
// medial-axis cell whose clearance is a local minimum along the axis, whose two nearest walls lie on opposite sides
// (the jambs), and from which the clearance rises by at least min_rise_m within rise_reach_m on both sides of the
// jamb-to-jamb line. That line is the door. Place-place edges that cross a door (in plan, and within max_dz_m of the
// slice) are the ones a room should not grow through; cut_place_edges() gives them weight 0, which the room finder
// reads as a closed passage.
//
// Slices: one per storey the robot walked on (the modes of its poses' heights), slice_above_robot_m above the
// robot's height there: with the camera 0.5 m above the floor, 1.2 m above the floor, above most furniture and
// below the lintels. find_doors() reads the places and the robot's poses (agent nodes) from the scene graph and
// runs every slice.
//
// Not on the per-frame path: the detector works on heap buffers sized by the slice (the app runs it once when a
// run finishes; bench/rooms/rooms_eval once per explored plan).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <vector>

#include "core/scene_graph/scene_graph.h"

namespace qsg::rooms {

struct DoorConfig {
  double cell_m = 0.05;               // raster resolution
  double slice_half_band_m = 0.4;     // surface within +-this of the slice height is read
  double min_wall_height_m = 0.3;     // vertical extent of the surface in a cell (inside the band) to be wall
  double mapped_radius_m = 2.0;       // free cells within this (in plan) of a place are mapped free space
  double place_band_m = 1.5;          // places within +-this of the slice height mark mapped space
  double min_width_m = 0.5;           // door widths (jamb to jamb) considered
  double max_width_m = 2.5;
  double min_rise_m = 0.1;            // clearance rise on both sides of the door line
  double rise_reach_m = 1.0;          // ... within this distance of it
  double max_off_centre = 0.35;       // |d1 - d2| / (d1 + d2) of the jambs' distances from the axis cell
  double suppression_m = 0.4;         // of two critical cells closer than this, the narrower stays
  // The raster's size limit, about 19 bytes a cell while a slice is worked on: 4 Mi cells (a 100 m x 100 m storey
  // at 0.05 m) is about 80 MB. A surface beyond it (or a stray vertex far away) is an error, not an allocation.
  std::size_t max_cells = 4u << 20;
  // Storeys and slices.
  double slice_above_robot_m = 0.7;   // the slice's height above the robot's (camera's) height on a storey
  double storey_bin_m = 0.1;          // robot heights are binned this finely ...
  double storey_min_share = 0.05;     // ... and a bin holding this share of the poses, a local maximum, is a storey
  double storey_separation_m = 2.0;   // of two storeys closer than this, the one with more poses stays
  // Closing edges.
  double cut_extension_m = 0.3;       // door lines lengthened by this at both ends (into the jambs)
  double cut_max_dz_m = 1.5;          // edges whose ends lie within this of the slice's height
  bool validate(std::string* error) const;
};

struct Door {
  Eigen::Vector2d a = Eigen::Vector2d::Zero();  // jamb to jamb, in plan
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  double z_m = 0.0;                              // the slice's height
  double width_m() const { return (b - a).norm(); }
};

struct DoorStats {
  std::size_t slices = 0;  // find_doors: storeys sliced
  std::size_t cols = 0, rows = 0, wall_cells = 0, free_cells = 0, axis_cells = 0, candidates = 0;  // summed
};

// The slice heights for the robot's pose heights: one per storey (see DoorConfig), ascending.
std::vector<double> door_slice_heights(const std::vector<double>& robot_z_m, const DoorConfig& config);

// Doors in the slice at slice_z_m of the surface (mesh vertices); place positions mark the mapped space (and the
// raster's extent). False with *error set on a bad config or a raster beyond max_cells; no surface or no places near
// the slice gives no doors.
bool detect_doors(const std::vector<Eigen::Vector3f>& surface, const std::vector<Eigen::Vector3d>& places,
                  double slice_z_m, const DoorConfig& config, std::vector<Door>* doors, DoorStats* stats,
                  std::string* error);

// Every slice of the robot's storeys (agent nodes' heights), with the graph's places as the mapped space.
bool find_doors(const std::vector<Eigen::Vector3f>& surface, const scene_graph::SceneGraph& graph,
                const DoorConfig& config, std::vector<Door>* doors, DoorStats* stats, std::string* error);

// Every place-place edge whose plan projection crosses a door (its line lengthened by cut_extension_m at both ends,
// into the jambs, so that no edge squeezes past a jamb's corner), with both ends within cut_max_dz_m of the door's
// height, gets weight 0: a closed passage for the room finder (Config::seed_closed_regions). Returns the number of
// edges closed.
std::size_t cut_place_edges(const std::vector<Door>& doors, const DoorConfig& config,
                            scene_graph::SceneGraph* graph);

}  // namespace qsg::rooms
