// The frontend on a rendered two-room world with furniture: places, objects and agents land in the scene graph
// with their inter-layer edges; an update split by a deadline ends in the same graph as one unlimited update;
// no heap allocation per update.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <memory>
#include <set>
#include <vector>

#include "core/frontend/frontend.h"
#include "core/scene_graph/scene_graph.h"
#include "tests/places/places_test_world.h"
#include "tests/support/allocation_counter.h"

namespace qsg::frontend {
namespace {

using places::testing::add_box;
using places::testing::camera_pose;
using places::testing::kPi;

// Two 4 m x 4 m rooms joined by a door, a chair and a table in each.
world::World furnished_world() {
  world::World w = places::testing::rooms_world({4.0, 4.0}, 4.0, /*doors=*/true);
  add_box(&w, {1.0, 1.0, 0.0}, {1.5, 1.5, 0.9}, semantics::kChair);
  add_box(&w, {2.5, 2.6, 0.0}, {3.3, 3.4, 0.75}, semantics::kTable);
  add_box(&w, {5.0, 1.0, 0.0}, {5.5, 1.5, 0.9}, semantics::kChair);
  add_box(&w, {6.5, 2.6, 0.0}, {7.3, 3.4, 0.75}, semantics::kTable);
  return w;
}

struct Rig {
  std::unique_ptr<render::Renderer> renderer = std::make_unique<render::Renderer>();
  std::unique_ptr<reconstruction::SemanticTsdf> tsdf = std::make_unique<reconstruction::SemanticTsdf>();
  std::unique_ptr<messages::RgbdFrame> frame = std::make_unique<messages::RgbdFrame>();
  std::unique_ptr<scene_graph::SceneGraph> graph = std::make_unique<scene_graph::SceneGraph>();
  std::unique_ptr<Frontend> frontend = std::make_unique<Frontend>();
  std::uint64_t seq = 0;
  std::uint64_t time_ns = 0;

  bool init(std::string* error, const Config& config = Config{}) {
    const reconstruction::Capacities caps = places::testing::small_tsdf_capacities();
    return renderer->init(render::Renderer::Config{}, furnished_world(), error) &&
           tsdf->init(reconstruction::Config{}, caps, reconstruction::SemanticTsdf::plan(caps).total_bytes(), error) &&
           graph->init(scene_graph::capacities_from_budget(), scene_graph::arena_bytes_from_budget(), error) &&
           frontend->init(config, error);
  }
  // A spin at a viewpoint: each frame a keyframe (agent node); the frontend runs after the spin.
  void spin(const Eigen::Vector3d& p) {
    const messages::CameraIntrinsics camera{160, 120, 100.0, 100.0, 79.5, 59.5};
    std::string error;
    for (double pitch : {-0.6, 0.0})
      for (int k = 0; k < 8; ++k) {
        const Eigen::Isometry3d T = camera_pose(p, 2 * kPi * k / 8, pitch);
        ASSERT_TRUE(renderer->render(T, camera, seq++, *frame, &error)) << error;
        ASSERT_TRUE(tsdf->process(*frame, T));
        frontend->observe(*tsdf, T);
        time_ns += 100000000;
        ASSERT_EQ(frontend->add_keyframe(graph.get(), time_ns, T), agents::AddResult::kAdded);
      }
  }
};

std::size_t count(const scene_graph::SceneGraph& g, scene_graph::NodeKind kind) { return g.num_nodes(kind); }

TEST(FrontendTest, PlacesObjectsAndAgentsWithTheirInterLayerEdges) {
  Rig rig;
  std::string error;
  ASSERT_TRUE(rig.init(&error)) << error;
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(2.0, 2.0, 1.0), Eigen::Vector3d(6.0, 2.0, 1.0)}) {
    rig.spin(p);
    const UpdateSummary s = rig.frontend->update(*rig.tsdf, p, rig.time_ns, rig.graph.get(), Deadline{});
    ASSERT_TRUE(s.places_complete) << "an unlimited update completes its cycle";
  }
  const scene_graph::SceneGraph& g = *rig.graph;
  EXPECT_GE(count(g, scene_graph::NodeKind::kPlace), 4u);
  EXPECT_EQ(count(g, scene_graph::NodeKind::kAgent), 32u);
  EXPECT_GE(count(g, scene_graph::NodeKind::kObject), 4u) << "two chairs and two tables";
  // Every object and every agent hangs below a place (its nearest active one).
  std::size_t objects = 0, agents = 0;
  g.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind != scene_graph::NodeKind::kObject && n.kind != scene_graph::NodeKind::kAgent) return;
    (n.kind == scene_graph::NodeKind::kObject ? objects : agents) += 1;
    ASSERT_NE(n.parent, scene_graph::kNoNode) << "node without a place";
    EXPECT_EQ(g.node(n.parent)->kind, scene_graph::NodeKind::kPlace);
  });
  EXPECT_EQ(agents, 32u);
  EXPECT_GE(objects, 4u);
  // The objects are where the furniture is, with its labels.
  std::map<semantics::Label, int> labels;
  g.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind == scene_graph::NodeKind::kObject) ++labels[static_cast<semantics::Label>(g.object(n.id)->semantic_label)];
  });
  EXPECT_EQ(labels[semantics::kChair], 2);
  EXPECT_EQ(labels[semantics::kTable], 2);
  EXPECT_EQ(rig.frontend->counters().interlayer_failed, 0u);
}

// Keyframes whose place a later cycle removes hang below a place again. With seeds at the TSDF's projective
// distances (as before the places measured their seeds from zero crossings), the second spin sees the first room
// again and removes places the first cycle made; without the reconnection 16 keyframes end without a place.
TEST(FrontendTest, KeyframesOfRemovedPlacesAreReconnected) {
  Config config;
  config.places.signed_surface_seeds = false;
  config.places.correct_projective_distance = false;
  Rig rig;
  std::string error;
  ASSERT_TRUE(rig.init(&error, config)) << error;
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(2.0, 2.0, 1.0), Eigen::Vector3d(6.0, 2.0, 1.0)}) {
    rig.spin(p);
    ASSERT_TRUE(rig.frontend->update(*rig.tsdf, p, rig.time_ns, rig.graph.get(), Deadline{}).places_complete);
  }
  ASSERT_GT(rig.frontend->counters().interlayer_reconnected, 0u) << "the scene no longer removes a place";
  std::size_t agents = 0;
  rig.graph->for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind != scene_graph::NodeKind::kAgent) return;
    ++agents;
    ASSERT_NE(n.parent, scene_graph::kNoNode) << "keyframe without a place";
    EXPECT_EQ(rig.graph->node(n.parent)->kind, scene_graph::NodeKind::kPlace);
  });
  EXPECT_EQ(agents, 32u);
}

TEST(FrontendTest, DeadlineSplitEndsInTheSameGraphWithoutAllocating) {
  Rig whole, split;
  std::string error;
  ASSERT_TRUE(whole.init(&error)) << error;
  ASSERT_TRUE(split.init(&error)) << error;
  const Eigen::Vector3d p(2.0, 2.0, 1.0);
  whole.spin(p);
  split.spin(p);
  ASSERT_TRUE(whole.frontend->update(*whole.tsdf, p, whole.time_ns, whole.graph.get(), Deadline{}).places_complete);
  Deadline small;
  small.max_work_units = 2000;
  int calls = 0;
  bool complete = false;
  EXPECT_NO_ALLOCATIONS({
    while (!complete && calls < 10000) {
      complete = split.frontend->update(*split.tsdf, p, split.time_ns, split.graph.get(), small).places_complete;
      ++calls;
    }
  });
  ASSERT_TRUE(complete);
  EXPECT_GT(calls, 3) << "the deadline must actually split the work";
  EXPECT_EQ(split.frontend->counters().deadline_stops, static_cast<std::uint64_t>(calls - 1));
  // Same places (ids, positions, clearance) and the same edges.
  const auto places_of = [](const scene_graph::SceneGraph& g) {
    std::map<scene_graph::NodeId, std::pair<Eigen::Vector3d, double>> out;
    g.for_each_node([&](const scene_graph::NodeRecord& n) {
      if (n.kind == scene_graph::NodeKind::kPlace)
        out[n.id] = {g.place(n.id)->position_m, g.place(n.id)->distance_m};
    });
    return out;
  };
  const auto a = places_of(*whole.graph), b = places_of(*split.graph);
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [id, value] : a) {
    ASSERT_TRUE(b.count(id)) << std::hex << id;
    EXPECT_TRUE(b.at(id).first.isApprox(value.first, 1e-9));
    EXPECT_DOUBLE_EQ(b.at(id).second, value.second);
  }
  EXPECT_EQ(whole.graph->num_edges(), split.graph->num_edges());
}

// An object out of the window whose parent place is wrong (as when it was first seen from afar, before its own
// room had places) gets the place of the whole graph whose free-space sphere is nearest at the next refresh;
// the per-cycle refresh only sees tracked objects and active places, so with the periodic one off it keeps the
// wrong parent.
TEST(FrontendTest, ObjectsOutOfTheWindowAreReparentedAmongAllPlaces) {
  const auto run = [](std::uint32_t every, std::size_t* wrong, std::size_t* untracked, std::uint64_t* reparented) {
    Config config;
    config.reparent_untracked_every = every;
    Rig rig;
    std::string error;
    ASSERT_TRUE(rig.init(&error, config)) << error;
    const Eigen::Vector3d room_a(2.0, 2.0, 1.0);
    rig.spin(room_a);
    ASSERT_TRUE(rig.frontend->update(*rig.tsdf, room_a, rig.time_ns, rig.graph.get(), Deadline{}).places_complete);
    // The robot goes 40 m away (frames of nothing): the mesh and the places of room A leave the window.
    const Eigen::Vector3d far(45.0, 2.0, 1.0);
    rig.spin(far);
    ASSERT_TRUE(rig.frontend->update(*rig.tsdf, far, rig.time_ns, rig.graph.get(), Deadline{}).places_complete);
    *untracked = 0;
    rig.frontend->objects().for_each_object([&](const objects::ObjectView& o) {
      if (o.node != scene_graph::kNoNode && o.num_tracked == 0) ++*untracked;
    });
    // Every object of room A now hangs from the place farthest from it.
    scene_graph::SceneGraph& g = *rig.graph;
    std::vector<scene_graph::NodeId> objects, places;
    g.for_each_node([&](const scene_graph::NodeRecord& n) {
      if (n.kind == scene_graph::NodeKind::kObject) objects.push_back(n.id);
      if (n.kind == scene_graph::NodeKind::kPlace) places.push_back(n.id);
    });
    ASSERT_FALSE(objects.empty());
    ASSERT_GE(places.size(), 4u);
    for (const scene_graph::NodeId o : objects) {
      const Eigen::Vector3d p = g.object(o)->position_m;
      const scene_graph::NodeId far_place = *std::max_element(places.begin(), places.end(), [&](auto a, auto b) {
        return (g.place(a)->position_m - p).norm() < (g.place(b)->position_m - p).norm();
      });
      if (g.parent(o) != scene_graph::kNoNode) g.remove_edge(o, g.parent(o));
      ASSERT_EQ(g.add_edge(o, far_place), scene_graph::Status::kOk);
    }
    // A few more cycles far away.
    for (int i = 0; i < 3; ++i)
      ASSERT_TRUE(rig.frontend->update(*rig.tsdf, far, rig.time_ns, rig.graph.get(), Deadline{}).places_complete);
    *reparented = rig.frontend->counters().objects_reparented;
    *wrong = 0;
    for (const scene_graph::NodeId o : objects) {
      const Eigen::Vector3d p = g.object(o)->position_m;
      // The parent's free-space sphere must be the nearest of all places' (what connect_to_nearest_places picks).
      double best = 1e9;
      for (const scene_graph::NodeId q : places)
        best = std::min(best, (g.place(q)->position_m - p).norm() - g.place(q)->distance_m);
      const scene_graph::NodeId parent = g.parent(o);
      const double gap = parent == scene_graph::kNoNode
                             ? 1e9
                             : (g.place(parent)->position_m - p).norm() - g.place(parent)->distance_m;
      *wrong += gap > best + 1e-9 ? 1 : 0;
    }
  };
  std::size_t wrong = 0, untracked = 0;
  std::uint64_t reparented = 0;
  run(1, &wrong, &untracked, &reparented);
  EXPECT_EQ(wrong, 0u);
  EXPECT_GE(untracked, 2u) << "room A's objects should have left the window";
  EXPECT_GE(reparented, untracked);
  run(0, &wrong, &untracked, &reparented);
  EXPECT_GT(wrong, 0u) << "off: the wrong parents stay";
  EXPECT_EQ(reparented, 0u);
}

TEST(FrontendTest, BadConfigIsRefusedByName) {
  Frontend f;
  Config c;
  c.places.voxel_factor = 7;
  std::string error;
  EXPECT_FALSE(f.init(c, &error));
  EXPECT_NE(error.find("places"), std::string::npos) << error;
}

}  // namespace
}  // namespace qsg::frontend
