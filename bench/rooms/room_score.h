// Room segmentations scored as the benchmark scores them (rooms_eval's metric, shared with drift/drift_baseline):
// estimated rooms become pixel sets on a 2D raster of free cells by a wavefront from the places, then max-overlap
// precision and recall against the ground-truth rooms (see rooms_eval.cc's file comment for the definitions).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <map>
#include <utility>
#include <vector>

#include "core/scene_graph/scene_graph.h"
#include "drivers/world/building_generator.h"
#include "bench/rooms/floor_plan_rooms.h"
#include "drivers/world/world.h"
#include "drivers/world/world_query.h"

namespace qsg::bench {

// A 2D raster: which cells are free, the ground-truth room of each (0: none) and the estimated one (0: none).
struct Raster {
  int cols = 0, rows = 0;
  double res_m = 0.05;
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();  // world x-y of cell (0, rows - 1)'s lower-left corner
  std::vector<std::uint8_t> free;
  std::vector<std::int32_t> truth;
  std::vector<std::int32_t> estimate;
  std::size_t idx(int c, int r) const { return static_cast<std::size_t>(r) * static_cast<std::size_t>(cols) + c; }
  // Image convention (row 0 at the top, +y up), as the floor-plan importer.
  bool cell_of(const Eigen::Vector3d& p, int* c, int* r) const {
    *c = static_cast<int>(std::floor((p.x() - origin_m.x()) / res_m));
    *r = rows - 1 - static_cast<int>(std::floor((p.y() - origin_m.y()) / res_m));
    return *c >= 0 && *r >= 0 && *c < cols && *r < rows;
  }
  Eigen::Vector2d center_of(int c, int r) const {
    return origin_m + res_m * Eigen::Vector2d(c + 0.5, rows - r - 0.5);
  }
};

// The ground-truth room of cell (c, r), or of the nearest cell within 3 cells that has one (a place on a wall cell
// after rasterization); 0: none.
inline std::int32_t truth_near(const Raster& ras, int c, int r) {
  for (int d = 0; d <= 3; ++d)
    for (int dr = -d; dr <= d; ++dr)
      for (int dc = -d; dc <= d; ++dc) {
        const int cc = c + dc, rr = r + dr;
        if (cc >= 0 && rr >= 0 && cc < ras.cols && rr < ras.rows && ras.truth[ras.idx(cc, rr)] > 0)
          return ras.truth[ras.idx(cc, rr)];
      }
  return 0;
}

// Labels free cells with the room of the geodesically nearest place (multi-source BFS from the places' cells).
// oracle: every place (with a room or not) takes the ground-truth room of its cell instead (the nearest within 3
// cells when its cell has none), so the score is the bound any room finder could reach on these places: what the
// tour observed and the rasterization keep, with a perfect assignment of places to rooms.
inline void label_from_places(const scene_graph::SceneGraph& g, double z_min_m, double z_max_m, double max_reach_m,
                              Raster* ras, bool oracle = false) {
  ras->estimate.assign(ras->free.size(), 0);
  std::vector<int> dist(ras->free.size(), -1);
  std::deque<std::pair<int, int>> queue;
  std::map<scene_graph::NodeId, std::int32_t> room_label;
  // Seeds in the order of the places' ids (a cell two places share, and ties in the search, go to the lower id), so
  // the score depends on the graph's content only, not on the order its storage visits nodes in.
  std::vector<std::pair<scene_graph::NodeId, scene_graph::NodeId>> places;  // (place, room)
  g.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind == scene_graph::NodeKind::kPlace && (oracle || n.parent != scene_graph::kNoNode))
      places.emplace_back(n.id, n.parent);
  });
  std::sort(places.begin(), places.end());
  for (const auto& [id, parent] : places) {
    const Eigen::Vector3d& p = g.place(id)->position_m;
    if (p.z() < z_min_m || p.z() >= z_max_m) continue;
    int c, r;
    if (!ras->cell_of(p, &c, &r)) continue;
    std::int32_t label = 0;
    if (oracle) {
      label = truth_near(*ras, c, r);
      if (label <= 0) continue;
    } else {
      auto it = room_label.find(parent);
      if (it == room_label.end())
        it = room_label.emplace(parent, static_cast<std::int32_t>(room_label.size() + 1)).first;
      label = it->second;
    }
    // A place on a wall cell (rasterization): the nearest free cell within 2 cells.
    int best_c = -1, best_r = -1;
    for (int d = 0; d <= 2 && best_c < 0; ++d)
      for (int dr = -d; dr <= d && best_c < 0; ++dr)
        for (int dc = -d; dc <= d && best_c < 0; ++dc) {
          const int cc = c + dc, rr = r + dr;
          if (cc >= 0 && rr >= 0 && cc < ras->cols && rr < ras->rows && ras->free[ras->idx(cc, rr)]) {
            best_c = cc;
            best_r = rr;
          }
        }
    if (best_c < 0 || dist[ras->idx(best_c, best_r)] == 0) continue;
    dist[ras->idx(best_c, best_r)] = 0;
    ras->estimate[ras->idx(best_c, best_r)] = label;
    queue.emplace_back(best_c, best_r);
  }
  const int max_steps = static_cast<int>(std::lround(max_reach_m / ras->res_m));
  while (!queue.empty()) {
    const auto [c, r] = queue.front();
    queue.pop_front();
    const int d = dist[ras->idx(c, r)];
    if (d >= max_steps) continue;
    for (int dr = -1; dr <= 1; ++dr)
      for (int dc = -1; dc <= 1; ++dc) {
        const int cc = c + dc, rr = r + dr;
        if ((dc == 0 && dr == 0) || cc < 0 || rr < 0 || cc >= ras->cols || rr >= ras->rows) continue;
        const std::size_t k = ras->idx(cc, rr);
        if (!ras->free[k] || dist[k] >= 0) continue;
        dist[k] = d + 1;
        ras->estimate[k] = ras->estimate[ras->idx(c, r)];
        queue.emplace_back(cc, rr);
      }
  }
}

// The benchmark's max-overlap precision and recall over the cells that are free and inside a ground-truth room.
inline bench::RoomSegmentationScore score(const Raster& ras) {
  return bench::score_room_segmentation(ras.free, ras.truth, ras.estimate);
}

// One raster per floor of a generated building over its footprint (0.05 m): room interiors are free, labelled by
// room id + 1; with the z range of the places that floor's rooms are estimated from (from its floor up to the next
// floor's: stair places go with the floor below).
struct FloorRaster {
  Raster raster;
  std::int32_t floor_index = 0;
  double z_min_m = 0.0, z_max_m = 0.0;
};
inline std::vector<FloorRaster> generated_floor_rasters(const world::World& w, const world::BuildingConfig& bc) {
  const world::Aabb box = world::world_bounds(w);
  std::map<std::int32_t, double> floors;  // floor index -> floor z
  for (const world::Room& room : w.rooms) floors[room.floor_index] = room.floor_z_m;
  std::vector<FloorRaster> out;
  for (const auto& [floor, z] : floors) {
    Raster ras;
    ras.res_m = 0.05;
    ras.origin_m = box.min_m.head<2>();
    ras.cols = static_cast<int>(std::ceil((box.max_m.x() - box.min_m.x()) / ras.res_m));
    ras.rows = static_cast<int>(std::ceil((box.max_m.y() - box.min_m.y()) / ras.res_m));
    ras.free.assign(static_cast<std::size_t>(ras.cols) * static_cast<std::size_t>(ras.rows), 0);
    ras.truth.assign(ras.free.size(), 0);
    for (const world::Room& room : w.rooms) {
      if (room.floor_index != floor) continue;
      for (int r = 0; r < ras.rows; ++r)
        for (int c = 0; c < ras.cols; ++c) {
          const Eigen::Vector2d p = ras.center_of(c, r);
          for (const world::Polygon2& poly : room.footprint_m)
            if (world::point_in_polygon(poly, p)) {
              ras.free[ras.idx(c, r)] = 1;
              ras.truth[ras.idx(c, r)] = room.id + 1;
            }
        }
    }
    out.push_back({std::move(ras), floor, z - 0.3, z + bc.ceiling_height_m - 0.3 + bc.slab_thickness_m});
  }
  return out;
}

// The estimated rooms of a generated building scored over its floors (oracle: each place given its ground-truth
// room instead, the bound exploration and rasterization allow).
inline bench::RoomSegmentationScore score_generated_rooms(const scene_graph::SceneGraph& g,
                                                          std::vector<FloorRaster>* floors, double max_reach_m,
                                                          bool oracle = false) {
  bench::RoomSegmentationScore total;
  for (FloorRaster& f : *floors) {
    label_from_places(g, f.z_min_m, f.z_max_m, max_reach_m, &f.raster, oracle);
    total.add(score(f.raster));
  }
  return total;
}

}  // namespace qsg::bench
