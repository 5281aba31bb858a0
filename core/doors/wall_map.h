// The robot's surface kept for the online door stage: per plan cell (DoorConfig::cell_m), one bit per cell_m of
// height that says whether a mesh vertex lies there. Tiles of 32 x 32 cells x 32 height bins (one 32-bit word a
// cell, 4 KB a tile) come from a fixed pool through a fixed spatial hash, so memory is set by the budget table and
// a building larger than the pool is a counted degradation (its new surface is not painted), never an allocation.
//
// The loop repaints a voxel block whenever marching cubes re-ran on it: clear_box() forgets the block's volume,
// add() paints its vertices. Archived blocks stay painted. slice() turns the bits into the wall raster of a slice,
// as the offline detector does from vertices: a cell is wall when its occupied bins within the band span at least
// min_wall_height_m.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>

#include "core/memory/arena.h"
#include "core/memory/fixed_hash_map.h"
#include "core/memory/resource_stats.h"
#include "core/doors/door_detector.h"

namespace qsg::rooms {

class WallMap {
 public:
  static constexpr int kTileSide = 32;  // cells per tile side
  static constexpr int kTileBins = 32;  // height bins per tile: one 32-bit word per cell
  struct Tile {
    std::uint32_t bits[kTileSide * kTileSide];
  };

  WallMap() = default;
  WallMap(const WallMap&) = delete;
  WallMap& operator=(const WallMap&) = delete;

  static memory::ArenaPlan plan(std::size_t tiles);
  bool carve(memory::Arena& arena, std::size_t tiles, double cell_m);

  // Forgets the surface in the box (cells and bins whose centres lie in [min_m, max_m)). Tiles are not freed.
  void clear_box(const Eigen::Vector3d& min_m, const Eigen::Vector3d& max_m);
  // Paints a vertex; false when its tile is new and the pool is full (counted), or the vertex is not finite.
  bool add(float x, float y, float z);
  // The wall raster of the slice at z_m (raster.lo a multiple of cell_m): wall[r x cols + c] is 1 when the
  // occupied bins within [z_m - half_band_m, z_m + half_band_m] span at least min_wall_height_m, else 0. The band
  // must hold fewer than 32 bins.
  void slice(const DoorRaster& raster, double z_m, double half_band_m, double min_wall_height_m,
             std::uint8_t* wall) const;
  void clear();

  // Repaints every block of `tsdf` (core/reconstruction's SemanticTsdf, or anything with its block interface)
  // whose marching cubes ran since it was last painted: its volume cleared, its vertices added. stamps and blocks
  // (tsdf.block_slots() entries each, zeroed at start-up) remember what each block slot last painted. Returns the
  // blocks painted. Allocation-free.
  template <typename Tsdf>
  std::size_t repaint(const Tsdf& tsdf, std::uint32_t* stamps, memory::Index3* blocks, std::size_t slots);

  double cell_m() const { return cell_m_; }
  memory::ResourceStats tile_stats() const { return counter_.stats(); }
  memory::ResourceStats index_stats() const { return index_.stats(); }
  std::uint64_t dropped_vertices() const { return dropped_; }

 private:
  const Tile* find(std::int32_t tx, std::int32_t ty, std::int32_t tz) const;
  double cell_m_ = 0.05;
  memory::FixedHashMap<memory::Index3, std::uint32_t, memory::Index3Hash> index_{"wall_tiles_index",
                                                                               memory::OverflowPolicy::kRefuse};
  Tile* tiles_ = nullptr;
  std::size_t used_ = 0;
  std::uint64_t dropped_ = 0;
  memory::UsageCounter counter_{"wall_tiles", "tiles", 0, memory::OverflowPolicy::kRefuse};
};

template <typename Tsdf>
std::size_t WallMap::repaint(const Tsdf& tsdf, std::uint32_t* stamps, memory::Index3* blocks, std::size_t slots) {
  const double side = tsdf.block_size_m();
  std::size_t painted = 0;
  tsdf.for_each_block([&](std::uint32_t h, const typename Tsdf::BlockView& view) {
    if (h >= slots || view.meshed_stamp == 0 || (stamps[h] == view.meshed_stamp && blocks[h] == view.index)) return;
    stamps[h] = view.meshed_stamp;
    blocks[h] = view.index;
    const Eigen::Vector3d lo(view.index.x * side, view.index.y * side, view.index.z * side);
    clear_box(lo, lo + Eigen::Vector3d::Constant(side));
    typename Tsdf::VertexCursor cursor;
    typename Tsdf::Vertex v;
    std::uint64_t key = 0;
    while (tsdf.next_block_vertex(h, &cursor, &v, &key)) add(v.x, v.y, v.z);
    ++painted;
  });
  return painted;
}

}  // namespace qsg::rooms
