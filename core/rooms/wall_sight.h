// Sight lines across the building's structural walls, for the room finder's visibility merge
// (Config::merge_visible): two adjacent rooms whose places mostly see each other past every long wall are one room
// that furniture or a false door cut in two.
//
// Built from the final door stage's slices (find_doors, one per storey): a slice's wall raster (cells whose surface
// spans DoorConfig::min_wall_height_m in the band) is thickened by DoorConfig::sight_wall_dilation_m, which bridges
// the small gaps of a wall the camera saw in pieces, and split into 8-connected components. A component whose
// bounding box spans at least DoorConfig::sight_min_wall_m (diagonal) is structure: the walls of a building are
// joined into long pieces, while furniture (chairs, a table with its chairs, a post) stands in short ones. Only
// structure blocks a sight line. Furniture pushed against a wall joins the wall and blocks too, which can only keep
// rooms apart, never merge them.
//
// Offline (heap, at the end of a run); the queries are const and never allocate, so the room finder's update stays
// allocation-free with it.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/rooms/door_detector.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::rooms {

class WallSight {
 public:
  WallSight() = default;

  void clear();
  // Adds a slice at slice_z_m: wall[r x cols + c] is 1 for a wall cell of `raster` (before any dilation). False
  // (error set) when wall is null or the raster is empty or over config.max_cells.
  bool add_slice(const DoorRaster& raster, const std::uint8_t* wall, double slice_z_m, const DoorConfig& config,
                 std::string* error);

  std::size_t slices() const { return slices_.size(); }
  double slice_z(std::size_t i) const { return slices_[i].z_m; }
  std::size_t structure_cells(std::size_t i) const { return slices_[i].structure_cells; }
  std::size_t components(std::size_t i) const { return slices_[i].components; }
  std::size_t structure_components(std::size_t i) const { return slices_[i].structure_components; }

  // The slice a point belongs to: the nearest one within max_dz_m of its height, or -1.
  int slice_of(const Eigen::Vector3d& p) const;
  // Whether the segment a-b, in plan, crosses no structure cell of the slice both ends belong to. False when the
  // ends belong to different slices or to none, lie outside the slice's raster (not mapped: unknown), or are not
  // finite.
  bool sees(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;
  // Whether the segment a-b, in plan, crosses a structure cell of the slice both ends belong to. False when they do
  // not belong to one slice (an edge between storeys is not judged) or an end lies outside its raster.
  bool crosses_structure(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;
  // Whether cell (c, r) of slice i is structure (tests and pictures).
  bool structure_at(std::size_t i, int c, int r) const;
  const DoorRaster& raster(std::size_t i) const { return slices_[i].raster; }

 private:
  struct Slice {
    DoorRaster raster;
    double z_m = 0.0;
    std::vector<std::uint8_t> structure;  // 1: a cell of a long (structural) component, dilated
    std::size_t structure_cells = 0;
    std::size_t components = 0;
    std::size_t structure_components = 0;
  };
  bool line_hits(const Slice& s, const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;
  std::vector<Slice> slices_;
  double max_dz_m_ = 1.5;
};

// Place-place edges that cross structure (WallSight::crosses_structure) get weight 0, closed as cut_place_edges
// closes a door's: an edge the places layer left through a wall (near the ceiling, over a wall's top, or between
// two free spaces that touch through a thin wall) is no passage, and the rooms on its two sides should not meet
// through it. Edges already closed are left as they are. Returns the edges closed.
std::size_t cut_edges_through_walls(const WallSight& sight, scene_graph::SceneGraph* graph);

}  // namespace qsg::rooms
