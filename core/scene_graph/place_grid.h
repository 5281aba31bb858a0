// A spatial hash of the scene graph's closed places (inactive, with a parent), and per room the sums of its closed
// children, so that the room finder's window and the online door pass find the places near the robot, and a long
// room's far part, without visiting the building (issue 37).
//
// The graph files a place when its open-places iteration drops it (inactive, with a parent) and unfiles it when it
// opens again (SceneGraph::mark_open: a writable access, its parent edge going, its removal). A filed place is not
// written while filed (every writer reaches it through the writable access, which unfiles it first), so its cell
// and its share of its room's sums stay those of its attributes. Cells are hashed by integer index, as voxel blocks
// are; each holds an intrusive list of its places. Capacity: one cell per place at most, so filing never fails.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/memory/arena.h"
#include "core/memory/fixed_hash_map.h"
#include "core/memory/resource_stats.h"
#include "core/scene_graph/attributes.h"

namespace qsg::scene_graph {

// Cell side: a few places' spacing (0.3-0.5 m) on each side, so a window's box is some tens of cells.
inline constexpr double kPlaceGridCellM = 2.0;
// The rooms' sums are exact integers (fixed point, 2^-24 m), so subtracting a part gives what adding the rest would.
inline constexpr double kChildSumUnitsPerM = 16777216.0;

// A room's closed children: count, position sums in fixed point, and the box of their free-space spheres (radius:
// clearance), which only grows while the room has closed children (a box does not subtract).
struct ChildSums {
  std::int64_t sum[3];
  double min[3];
  double max[3];
  std::uint32_t count;
  void reset();
};

// A place's position in the sums' fixed point (non-finite: 0; clamped to +-1e9 m).
std::int64_t child_sum_units(double position_m);
// A place's free-space radius as the rooms use it (non-finite or negative clearance: 0).
inline double free_space_radius_m(const PlaceAttributes& a) {
  return std::isfinite(a.distance_m) && a.distance_m > 0.0 ? a.distance_m : 0.0;
}

class PlaceGrid {
 public:
  PlaceGrid() = default;
  PlaceGrid(const PlaceGrid&) = delete;
  PlaceGrid& operator=(const PlaceGrid&) = delete;

  static void plan(memory::ArenaPlan& plan, std::size_t places, std::size_t rooms);
  bool carve(memory::Arena& arena, std::size_t places, std::size_t rooms);
  void clear();

  // place (not filed): its handle in the places pool; node: its slot in the node table; room: its parent's handle
  // in the rooms pool.
  void file(std::uint32_t place, std::uint32_t node, std::uint32_t room, const PlaceAttributes& a);
  // Undoes file() with the same attributes (a filed place is not written: see the top of the file).
  void unfile(std::uint32_t place, const PlaceAttributes& a);
  bool filed(std::uint32_t place) const { return room_[place] != memory::kInvalidHandle; }
  const ChildSums& sums(std::uint32_t room) const { return sums_[room]; }

  // fn(node slot) for every filed place in a cell the box [lo, hi] touches (a superset of the box's places; the
  // caller tests positions). A box of more cells than the grid holds (or not finite) visits every cell.
  template <typename Fn>
  void for_each_in_box(const double* lo, const double* hi, Fn&& fn) const;

  std::size_t filed_places() const { return filed_; }
  memory::ResourceStats stats() const { return cells_.stats(); }

 private:
  static std::int32_t cell_of(double x) {
    const double c = std::floor(x / kPlaceGridCellM);  // infinities clamp; NaN is cell 0
    return std::isnan(c) ? 0 : static_cast<std::int32_t>(std::max(-1e9, std::min(1e9, c)));
  }
  template <typename Fn>
  void walk(std::uint32_t head, Fn&& fn) const {
    for (std::uint32_t p = head; p != memory::kInvalidHandle; p = next_[p]) fn(node_[p]);
  }

  memory::FixedHashMap<memory::Index3, std::uint32_t, memory::Index3Hash> cells_{"scene_graph.place_grid"};
  std::uint32_t* next_ = nullptr;  // per place handle: the cell's list
  std::uint32_t* prev_ = nullptr;
  std::uint32_t* node_ = nullptr;
  std::uint32_t* room_ = nullptr;  // the parent's room handle while filed, else kInvalidHandle
  memory::Index3* cell_ = nullptr;
  ChildSums* sums_ = nullptr;      // per room handle
  std::size_t places_ = 0;
  std::size_t rooms_ = 0;
  std::size_t filed_ = 0;
  std::int32_t bounds_lo_[3] = {0, 0, 0};  // the cells ever filed since clear() (lo > hi: none)
  std::int32_t bounds_hi_[3] = {-1, -1, -1};
};

template <typename Fn>
void PlaceGrid::for_each_in_box(const double* lo, const double* hi, Fn&& fn) const {
  if (filed_ == 0) return;
  // The box's cells, cut to the cells ever filed (a window's margin reaches above and below a storey's places).
  std::int32_t a[3] = {0, 0, 0}, b[3] = {0, 0, 0};
  double cells = 1.0;
  for (int d = 0; d < 3; ++d) {
    if (std::isnan(lo[d]) || std::isnan(hi[d])) {  // not a box: every cell (a superset is what was asked for)
      cells = HUGE_VAL;
      break;
    }
    a[d] = std::max(cell_of(lo[d]), bounds_lo_[d]);
    b[d] = std::min(cell_of(hi[d]), bounds_hi_[d]);
    if (hi[d] < lo[d] || b[d] < a[d]) return;  // empty
    cells *= static_cast<double>(b[d]) - static_cast<double>(a[d]) + 1.0;
  }
  // A probe of an empty cell costs less than a visit of a place: probe unless the cells outnumber the places.
  if (cells > static_cast<double>(filed_)) {
    cells_.for_each([&](const memory::Index3&, std::uint32_t head) { walk(head, fn); });
    return;
  }
  for (std::int32_t z = a[2]; z <= b[2]; ++z)
    for (std::int32_t y = a[1]; y <= b[1]; ++y)
      for (std::int32_t x = a[0]; x <= b[0]; ++x)
        if (const std::uint32_t* head = cells_.find(memory::Index3{x, y, z})) walk(*head, fn);
}

}  // namespace qsg::scene_graph
