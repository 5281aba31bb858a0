// Small scene graphs for tests.
#pragma once

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "core/scene_graph/scene_graph.h"

namespace qsg::scene_graph::testing {

inline Capacities small_capacities() {
  Capacities c;
  c.object_nodes = 64;
  c.agent_nodes = 256;
  c.place_nodes = 512;
  c.room_nodes = 16;
  c.building_nodes = 2;
  c.edges = 4096;
  c.adjacency_chunks = 1024;
  c.mesh_connections = 1 << 16;
  return c;
}

inline std::unique_ptr<SceneGraph> make_graph(const Capacities& c = small_capacities()) {
  auto g = std::make_unique<SceneGraph>();
  std::string error;
  EXPECT_TRUE(g->init(c, SceneGraph::plan(c).total_bytes(), &error)) << error;
  return g;
}

inline PlaceAttributes place_at(double x, double y, double clearance) {
  PlaceAttributes p;
  p.position_m = {x, y, 1.0};
  p.distance_m = clearance;
  return p;
}

}  // namespace qsg::scene_graph::testing
