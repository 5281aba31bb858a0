// Test scenes for the door stage: walls as vertical columns of vertices (0.05 m along, 0.1 m up, one storey
// tall), flat floor and ceiling slabs that must not count as walls, and places on a grid as the mapped space.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "core/scene_graph/scene_graph.h"
#include "tests/scene_graph/test_graph.h"

namespace qsg::rooms::testing {

constexpr double kStoreyM = 2.5;

struct Scene {
  std::vector<Eigen::Vector3f> surface;
  std::vector<Eigen::Vector3d> places;

  // A wall from (x0, y0) to (x1, y1): vertices every 0.05 m along it and every 0.1 m from floor to ceiling.
  void wall(double x0, double y0, double x1, double y1, double floor_z = 0.0) {
    const double len = std::hypot(x1 - x0, y1 - y0);
    const int n = std::max(1, static_cast<int>(std::ceil(len / 0.05)));
    for (int i = 0; i <= n; ++i) {
      const double t = static_cast<double>(i) / n;
      for (double z = 0.0; z <= kStoreyM + 1e-9; z += 0.1)
        surface.emplace_back(static_cast<float>(x0 + t * (x1 - x0)), static_cast<float>(y0 + t * (y1 - y0)),
                             static_cast<float>(floor_z + z));
    }
  }
  // Floor and ceiling over [x0, x1] x [y0, y1]: flat, they must not count as walls.
  void slabs(double x0, double y0, double x1, double y1, double floor_z = 0.0) {
    for (double x = x0; x <= x1 + 1e-9; x += 0.1)
      for (double y = y0; y <= y1 + 1e-9; y += 0.1)
        for (const double z : {floor_z, floor_z + kStoreyM})
          surface.emplace_back(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
  }
  // Places every 0.5 m over [x0, x1] x [y0, y1] at z, as the mapped space.
  void place_grid(double x0, double y0, double x1, double y1, double z = 1.0) {
    for (double x = x0; x <= x1 + 1e-9; x += 0.5)
      for (double y = y0; y <= y1 + 1e-9; y += 0.5) places.emplace_back(x, y, z);
  }
};

// Two 4 x 4 m rooms side by side; the wall between them at x = 4 has an opening over y in [y0, y1].
inline Scene two_rooms(double y0, double y1) {
  Scene s;
  s.wall(0, 0, 8, 0);
  s.wall(8, 0, 8, 4);
  s.wall(8, 4, 0, 4);
  s.wall(0, 4, 0, 0);
  s.wall(4, 0, 4, y0);
  s.wall(4, y1, 4, 4);
  s.slabs(0, 0, 8, 4);
  s.place_grid(0.25, 0.25, 7.75, 3.75);
  return s;
}

// The scene's places in a scene graph (clearance 0.25 m) with 4-neighbour edges of weight 0.25; an edge across the
// wall at x = wall_x only where its y lies in (y0, y1), the opening, or everywhere (through_wall: a places layer
// that links through the wall).
inline std::unique_ptr<scene_graph::SceneGraph> places_graph(const Scene& s, double wall_x, double y0, double y1,
                                                             bool through_wall = false) {
  namespace sg = scene_graph;
  auto graph = sg::testing::make_graph();
  std::vector<sg::NodeId> ids;
  for (std::size_t i = 0; i < s.places.size(); ++i) {
    sg::PlaceAttributes a;
    a.position_m = s.places[i];
    a.distance_m = 0.25;
    ids.push_back(sg::make_node_id(sg::kPlacePrefix, i));
    EXPECT_EQ(graph->add_place(ids.back(), a), sg::Status::kOk);
  }
  for (std::size_t i = 0; i < s.places.size(); ++i)
    for (std::size_t j = i + 1; j < s.places.size(); ++j) {
      if (std::abs((s.places[j] - s.places[i]).norm() - 0.5) > 1e-6) continue;
      const bool crosses = (s.places[i].x() < wall_x) != (s.places[j].x() < wall_x);
      const double y = s.places[i].y();
      if (crosses && !through_wall && !(y > y0 && y < y1)) continue;
      sg::EdgeAttributes info;
      info.weighted = true;
      info.weight = 0.25;
      EXPECT_EQ(graph->add_edge(ids[i], ids[j], info), sg::Status::kOk);
    }
  return graph;
}

}  // namespace qsg::rooms::testing
