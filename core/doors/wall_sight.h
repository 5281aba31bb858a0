// Sight lines across the building's structural walls, for the room finder's visibility merge
// (Config::merge_visible): two adjacent rooms whose places mostly see each other past every long wall are one room
// that furniture or a false door cut in two.
//
// Built from the final door stage's slices (find_doors, one per storey): a slice's wall raster (cells whose surface
// spans DoorConfig::min_wall_height_m in the band) is thickened by DoorConfig::sight_wall_dilation_m, which bridges
// the small gaps of a wall the camera saw in pieces, and split into 8-connected components. A component whose
// bounding box spans at least DoorConfig::sight_min_wall_m (diagonal) is structure: the walls of a building are
// joined into long pieces, while furniture (chairs, a table with its chairs, a post) stands in short ones. A thick
// island (a ring of tables, a row of desks standing free: shorter than DoorConfig::sight_furniture_max_m and wider,
// on average, than sight_furniture_min_width_m) is furniture too, however long. Only structure blocks a sight
// line. Furniture pushed against a wall joins the wall and blocks too, which can only keep
// rooms apart, never merge them.
//
// Two forms: offline, one slice per storey on the heap (the final stage, at the end of a run); online, the door
// window's one slice in buffers carved at start-up (OnlineDoors, each pass). The queries are const and never
// allocate, so the room finder's update stays allocation-free with either.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/memory/arena.h"
#include "core/doors/door_detector.h"
#include "core/rooms/door_cues.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::rooms {

// The sight lines handed to the room finder (SightLines).
class WallSight : public SightLines {
 public:
  WallSight() = default;

  // Offline (find_doors): one slice per storey, on the heap.
  void clear();
  // Adds a slice at slice_z_m: wall[r x cols + c] is 1 for a wall cell of `raster` (before any dilation). False
  // (error set) when wall is null or the raster is empty or over config.max_cells. border_is_structure: a piece
  // that reaches the raster's edge is structure whatever its size inside (a window's raster, as set_window_slice).
  bool add_slice(const DoorRaster& raster, const std::uint8_t* wall, double slice_z_m, const DoorConfig& config,
                 std::string* error, bool border_is_structure = false);

  // Adds a slice whose structure mask (1: structure, raster.cells() of them) was built elsewhere: a copy of another
  // WallSight's slice (structure(i)), the online window's kept for later, say. Same errors as add_slice.
  // window: the slice is an online window's (window() says so, as for set_window_slice).
  bool add_structure(const DoorRaster& raster, const std::uint8_t* structure, double slice_z_m,
                     const DoorConfig& config, std::string* error, bool window = false);

  // Online (OnlineDoors): one slice, the door window's, in buffers carved at start-up for rasters of at most
  // `cells` cells. set_window_slice replaces it without allocating; there a piece that reaches the raster's edge
  // counts as structure, whatever its size inside (it may go on beyond the window). False when not carved, on a
  // raster beyond the buffers or a bad config; the slice is then empty.
  static memory::ArenaPlan plan(std::size_t cells);
  bool carve(memory::Arena& arena, std::size_t cells);
  bool set_window_slice(const DoorRaster& raster, const std::uint8_t* wall, double slice_z_m,
                        const DoorConfig& config);

  std::size_t slices() const override { return carved_ ? (window_set_ ? 1u : 0u) : slices_.size(); }
  // Whether the sight lines cover a window around the robot only (set_window_slice, or a copy of such a slice),
  // not the whole map of every storey.
  bool window() const override { return carved_ || copied_window_; }
  double slice_z(std::size_t i) const { return slice(i).z_m; }
  std::size_t structure_cells(std::size_t i) const { return slice(i).structure_cells; }
  std::size_t components(std::size_t i) const { return slice(i).components; }
  std::size_t structure_components(std::size_t i) const { return slice(i).structure_components; }
  // Pieces long enough to be walls that the thick-island rule left as furniture (DoorConfig::sight_furniture_*).
  std::size_t furniture_islands(std::size_t i) const { return slice(i).furniture_islands; }

  // The slice a point belongs to: the nearest one within max_dz_m of its height, or -1.
  int slice_of(const Eigen::Vector3d& p) const;
  // Whether the segment a-b, in plan, crosses no structure cell of the slice both ends belong to. False when the
  // ends belong to different slices or to none, lie outside the slice's raster (not mapped: unknown), or are not
  // finite.
  bool sees(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const override;
  // Whether the segment a-b, in plan, crosses a structure cell of the slice both ends belong to. False when they do
  // not belong to one slice (an edge between storeys is not judged) or an end lies outside its raster.
  bool crosses_structure(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const override;
  const DoorRaster& raster(std::size_t i) const { return slice(i).raster; }
  const std::uint8_t* structure(std::size_t i) const { return slice(i).structure(); }

  struct Slice {
    DoorRaster raster;
    double z_m = 0.0;
    std::vector<std::uint8_t> owned;        // offline: the structure mask (1: a cell of a long piece, dilated)
    const std::uint8_t* window = nullptr;   // online: the same, in the carved buffer
    std::size_t structure_cells = 0;
    std::size_t components = 0;
    std::size_t structure_components = 0;
    std::size_t furniture_islands = 0;
    const std::uint8_t* structure() const { return owned.empty() ? window : owned.data(); }
  };

 private:
  const Slice& slice(std::size_t i) const { return carved_ ? window_ : slices_[i]; }
  bool can_add(const DoorRaster& raster, const std::uint8_t* cells, double slice_z_m, const DoorConfig& config,
               std::string* error) const;
  bool line_hits(const Slice& s, const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;
  std::vector<Slice> slices_;
  double max_dz_m_ = 1.5;
  bool copied_window_ = false;
  // Online.
  bool carved_ = false;
  bool window_set_ = false;
  std::size_t capacity_cells_ = 0;
  Slice window_;
  std::uint8_t* grown_ = nullptr;
  std::uint8_t* scratch_ = nullptr;
  std::uint32_t* list_ = nullptr;
  std::uint8_t* structure_ = nullptr;
};

// Place-place edges that cross structure (WallSight::crosses_structure) get weight 0, closed as cut_place_edges
// closes a door's: an edge the places layer left through a wall (near the ceiling, over a wall's top, or between
// two free spaces that touch through a thin wall) is no passage, and the rooms on its two sides should not meet
// through it. Edges already closed are left as they are. Returns the edges closed.
std::size_t cut_edges_through_walls(const WallSight& sight, scene_graph::SceneGraph* graph);

}  // namespace qsg::rooms
