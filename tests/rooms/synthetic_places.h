// Synthetic places graphs with known rooms for the room tests and the room benchmark: free cells of a 2D grid
// plan become places (clearance = distance to the nearest occupied cell), 8-neighbours become weighted edges.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "core/scene_graph/scene_graph.h"

namespace qsg::rooms::testing {

// A scene graph sized for the synthetic place graphs of the room, window and backend-stage tests.
inline scene_graph::Capacities small_graph_capacities() {
  scene_graph::Capacities c;
  c.object_nodes = 16;
  c.agent_nodes = 16;
  c.place_nodes = 4096;
  c.room_nodes = 64;
  c.building_nodes = 2;
  c.edges = 32768;
  c.adjacency_chunks = 16384;
  c.mesh_connections = 16;
  return c;
}

struct SyntheticPlace {
  scene_graph::NodeId id = scene_graph::kNoNode;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  double clearance_m = 0.0;
  int room = -1;  // ground-truth room tag of the plan (-1: doorway or unlabelled)
};

struct SyntheticEdge {
  std::size_t a = 0;  // indices into SyntheticPlaces::places
  std::size_t b = 0;
  double weight_m = 0.0;
};

struct SyntheticPlaces {
  std::vector<SyntheticPlace> places;
  std::vector<SyntheticEdge> edges;

  std::size_t add_place(const Eigen::Vector3d& p, double clearance_m, int room = -1) {
    SyntheticPlace s;
    s.id = scene_graph::make_node_id(scene_graph::kPlacePrefix, places.size());
    s.position_m = p;
    s.clearance_m = clearance_m;
    s.room = room;
    places.push_back(s);
    return places.size() - 1;
  }
  void add_edge(std::size_t a, std::size_t b, double weight_m) { edges.push_back({a, b, weight_m}); }

  // Writes the places and their edges (weighted) into the graph; false on the first refusal.
  bool write(scene_graph::SceneGraph* graph) const {
    for (const SyntheticPlace& p : places) {
      scene_graph::PlaceAttributes a;
      a.position_m = p.position_m;
      a.distance_m = p.clearance_m;
      a.is_active = true;
      if (graph->add_place(p.id, a) != scene_graph::Status::kOk) return false;
    }
    for (const SyntheticEdge& e : edges) {
      scene_graph::EdgeAttributes info;
      info.weight = e.weight_m;
      info.weighted = true;
      if (graph->add_edge(places[e.a].id, places[e.b].id, info) != scene_graph::Status::kOk) return false;
    }
    return true;
  }
};

// A 2D plan of square cells: everything starts occupied; rooms and doors are carved free. A room's cells carry
// its tag (the ground truth), door cells carry -1.
class GridPlan {
 public:
  static constexpr int kWall = -1000;  // carve(..., kWall) fills cells back in
  GridPlan(int width, int height, double cell_m) : width_(width), height_(height), cell_m_(cell_m),
                                                    tag_(static_cast<std::size_t>(width * height), kWall) {}

  // Cells [x0, x1) x [y0, y1) become free with tag `room` (-1 for a doorway).
  void carve(int x0, int y0, int x1, int y1, int room) {
    for (int y = std::max(0, y0); y < std::min(height_, y1); ++y)
      for (int x = std::max(0, x0); x < std::min(width_, x1); ++x) tag_[index(x, y)] = room;
  }
  bool free(int x, int y) const { return x >= 0 && y >= 0 && x < width_ && y < height_ && tag_[index(x, y)] != kWall; }

  // Places at the free cells' centres (z = z_m), clearance to the nearest occupied cell (or the plan's border),
  // edges between free 8-neighbours weighted with the smaller clearance. Returns the index of the first place.
  // max_clearance_m caps every clearance, as floor and ceiling cap a real place's (half the storey height).
  std::size_t add_to(SyntheticPlaces* out, double z_m, const Eigen::Vector2d& origin_m = Eigen::Vector2d::Zero(),
                     double max_clearance_m = HUGE_VAL) const {
    const std::size_t first = out->places.size();
    std::vector<std::size_t> place_of(tag_.size(), SIZE_MAX);
    for (int y = 0; y < height_; ++y)
      for (int x = 0; x < width_; ++x) {
        if (!free(x, y)) continue;
        const Eigen::Vector2d c = origin_m + cell_m_ * Eigen::Vector2d(x + 0.5, y + 0.5);
        place_of[index(x, y)] = out->add_place(Eigen::Vector3d(c.x(), c.y(), z_m),
                                               std::min(clearance(x, y), max_clearance_m), tag_[index(x, y)]);
      }
    for (int y = 0; y < height_; ++y)
      for (int x = 0; x < width_; ++x) {
        if (!free(x, y)) continue;
        const std::size_t a = place_of[index(x, y)];
        const int dx[4] = {1, 0, 1, -1}, dy[4] = {0, 1, 1, 1};
        for (int k = 0; k < 4; ++k) {
          if (!free(x + dx[k], y + dy[k])) continue;
          const std::size_t b = place_of[index(x + dx[k], y + dy[k])];
          out->add_edge(a, b, std::min(out->places[a].clearance_m, out->places[b].clearance_m));
        }
      }
    return first;
  }

  double cell_m() const { return cell_m_; }

 private:
  std::size_t index(int x, int y) const { return static_cast<std::size_t>(y * width_ + x); }
  double clearance(int x, int y) const {
    // Distance from the cell centre to the nearest occupied cell (a square), or to the plan's border.
    double best = cell_m_ * std::min(std::min(x + 0.5, width_ - x - 0.5), std::min(y + 0.5, height_ - y - 0.5));
    for (int oy = 0; oy < height_; ++oy)
      for (int ox = 0; ox < width_; ++ox) {
        if (free(ox, oy)) continue;
        const double ex = std::max(0.0, std::abs(ox - x) - 0.5), ey = std::max(0.0, std::abs(oy - y) - 0.5);
        best = std::min(best, cell_m_ * std::hypot(ex, ey));
      }
    return best;
  }

  int width_, height_;
  double cell_m_;
  std::vector<int> tag_;
};

constexpr double kCellM = 0.25;

// Two 4 m x 4 m rooms side by side, walls one cell thick, joined by a door three cells (0.75 m) wide.
inline GridPlan two_rooms_plan() {
  GridPlan plan(35, 18, kCellM);
  plan.carve(1, 1, 17, 17, 0);
  plan.carve(18, 1, 34, 17, 1);
  plan.carve(17, 7, 18, 10, -1);
  return plan;
}

// A corridor 2 m wide and rooms_per_side x 4 m long, with a row of 4 m x 4 m rooms on each side, each with a
// door (0.75 m) to the corridor. Room tags: corridor 0, then 1, 2, ...
inline GridPlan corridor_plan(int rooms_per_side, double cell_m = kCellM) {
  const int room = static_cast<int>(std::lround(4.0 / cell_m));
  const int corridor = static_cast<int>(std::lround(2.0 / cell_m));
  const int door = std::max(1, static_cast<int>(std::lround(0.75 / cell_m)));
  const int width = rooms_per_side * (room + 1) + 1;
  const int height = 2 * room + corridor + 4;
  GridPlan plan(width, height, cell_m);
  const int cy0 = room + 2, cy1 = cy0 + corridor;
  plan.carve(1, cy0, width - 1, cy1, 0);
  int tag = 1;
  for (int i = 0; i < rooms_per_side; ++i) {
    const int x0 = 1 + i * (room + 1), x1 = x0 + room;
    const int dx0 = x0 + room / 2 - door / 2;
    plan.carve(x0, 1, x1, 1 + room, tag++);          // south room
    plan.carve(dx0, 1 + room, dx0 + door, cy0, -1);  // its door
    plan.carve(x0, cy1 + 1, x1, cy1 + 1 + room, tag++);  // north room
    plan.carve(dx0, cy1, dx0 + door, cy1 + 1, -1);
  }
  return plan;
}

// corridor_plan's layout with a corridor 3 m wide that narrows to 1.5 m for 1 m at every second wall between
// rooms: (rooms_per_side - 1) / 2 pinches (rooms_per_side >= 3 for one), no door at any of them. The persistence
// seeding cuts the corridor at each (clearance 1.25 m, the storey's cap, on both sides against 0.75 m at the
// pinch), the corridor merge joins the pieces again. Tags: corridor 0, then the rooms 1, 2, ... (south and north
// in turn).
inline GridPlan pinched_corridor_plan(int rooms_per_side, double cell_m = kCellM) {
  const int room = static_cast<int>(std::lround(4.0 / cell_m));
  const int corridor = static_cast<int>(std::lround(3.0 / cell_m));
  const int door = std::max(1, static_cast<int>(std::lround(0.75 / cell_m)));
  const int inset = std::max(1, static_cast<int>(std::lround(0.75 / cell_m)));
  const int pinch = std::max(1, static_cast<int>(std::lround(1.0 / cell_m)));
  const int width = rooms_per_side * (room + 1) + 1, height = 2 * room + corridor + 4;
  GridPlan plan(width, height, cell_m);
  const int cy0 = room + 2, cy1 = cy0 + corridor;
  plan.carve(1, cy0, width - 1, cy1, 0);
  int tag = 1;
  for (int i = 0; i < rooms_per_side; ++i) {
    const int x0 = 1 + i * (room + 1), dx0 = x0 + room / 2 - door / 2;
    plan.carve(x0, 1, x0 + room, 1 + room, tag++);          // south room
    plan.carve(dx0, 1 + room, dx0 + door, cy0, -1);  // its door
    plan.carve(x0, cy1 + 1, x0 + room, cy1 + 1 + room, tag++);  // north room
    plan.carve(dx0, cy1, dx0 + door, cy1 + 1, -1);
  }
  // The pinches: the corridor's sides filled back in (walls) around the walls between rooms 2k and 2k + 1.
  const auto fill = [&](int x0, int y0, int x1, int y1) { plan.carve(x0, y0, x1, y1, GridPlan::kWall); };
  for (int i = 2; i < rooms_per_side; i += 2) {
    const int wall_x = i * (room + 1), x0 = wall_x - pinch / 2, x1 = x0 + pinch;
    fill(x0, cy0, x1, cy0 + inset);
    fill(x0, cy1 - inset, x1, cy1);
  }
  return plan;
}

// Ground-truth room tag -> the room nodes its places were given (tags >= 0 only).
inline std::map<int, std::set<scene_graph::NodeId>> rooms_by_tag(const scene_graph::SceneGraph& g,
                                                                   const SyntheticPlaces& s) {
  std::map<int, std::set<scene_graph::NodeId>> out;
  for (const auto& p : s.places)
    if (p.room >= 0) out[p.room].insert(g.parent(p.id));
  return out;
}

}  // namespace qsg::rooms::testing
