// Set-up shared by the places tests: small stores, a scene graph for places, running a cycle to its end, and the
// number of connected components of the places graph.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "core/places/places.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::places::testing {

inline Capacities small_capacities() {
  Capacities c;
  c.max_blocks = 160;
  c.place_nodes = 1024;
  c.inactive_cells = 1024;
  c.observed_blocks = 4096;
  c.pending_relinks = 512;
  return c;
}

inline std::unique_ptr<Places> make_places(const Config& config = Config{},
                                           const Capacities& caps = small_capacities()) {
  auto p = std::make_unique<Places>();
  std::string error;
  EXPECT_TRUE(p->init(config, caps, Places::plan(caps).total_bytes(), &error)) << error;
  return p;
}

inline std::unique_ptr<scene_graph::SceneGraph> make_graph(std::size_t place_nodes = 2048) {
  scene_graph::Capacities c;
  c.object_nodes = 4;
  c.agent_nodes = 4;
  c.place_nodes = place_nodes;
  c.room_nodes = 4;
  c.building_nodes = 1;
  c.edges = 8192;
  c.adjacency_chunks = 4096;
  c.mesh_connections = 16;
  auto g = std::make_unique<scene_graph::SceneGraph>();
  std::string error;
  EXPECT_TRUE(g->init(c, scene_graph::SceneGraph::plan(c).total_bytes(), &error)) << error;
  return g;
}

// Calls update() under `deadline` until a cycle completes (a tight deadline needs many calls).
inline void run_to_completion(Places* p, const reconstruction::SemanticTsdf& tsdf, const Eigen::Vector3d& robot,
                              const Deadline& deadline = Deadline::unlimited()) {
  for (int i = 0; i < 1000000; ++i)
    if (p->update(tsdf, robot, deadline).complete) return;
  ADD_FAILURE() << "update() did not complete";
}

inline std::size_t place_components(const scene_graph::SceneGraph& g) {
  std::vector<scene_graph::NodeId> ids;
  g.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind == scene_graph::NodeKind::kPlace) ids.push_back(n.id);
  });
  std::set<scene_graph::NodeId> seen;
  std::size_t components = 0;
  for (scene_graph::NodeId start : ids) {
    if (!seen.insert(start).second) continue;
    ++components;
    std::vector<scene_graph::NodeId> stack{start};
    while (!stack.empty()) {
      const scene_graph::NodeId id = stack.back();
      stack.pop_back();
      g.for_each_neighbor(id, [&](scene_graph::NodeId m, const scene_graph::EdgeRecord&) {
        if (scene_graph::node_prefix(m) == scene_graph::kPlacePrefix && seen.insert(m).second) stack.push_back(m);
      });
    }
  }
  return components;
}

}  // namespace qsg::places::testing
