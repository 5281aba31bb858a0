// The backend stage driven on its own, as the app and the evaluations drive it: rooms and labels in one call, its
// stores and counters, loop closure off and on, and a clear error when its stores exceed their arena.
#include "core/backend/backend_stage.h"

#include <gtest/gtest.h>

#include <memory>
#include <set>
#include <string>

#include "budgets/budget_table.h"
#include "tests/rooms/synthetic_places.h"

namespace qsg::backend {
namespace {

namespace sg = scene_graph;

sg::Capacities graph_capacities() {
  sg::Capacities c;
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

std::unique_ptr<sg::SceneGraph> make_graph() {
  auto g = std::make_unique<sg::SceneGraph>();
  std::string error;
  EXPECT_TRUE(g->init(graph_capacities(), sg::SceneGraph::plan(graph_capacities()).total_bytes(), &error)) << error;
  return g;
}

// Two rooms joined by a door, with an object hanging from a place of each.
std::unique_ptr<sg::SceneGraph> two_rooms_with_objects(rooms::testing::SyntheticPlaces* s) {
  rooms::testing::two_rooms_plan().add_to(s, 1.0);
  auto g = make_graph();
  EXPECT_TRUE(s->write(g.get()));
  const sg::NodeId first = s->places.front().id, last = s->places.back().id;
  std::uint64_t k = 0;
  for (const auto& [place, label] : {std::pair{first, semantics::kBed}, std::pair{last, semantics::kToilet}}) {
    sg::ObjectAttributes o;
    o.semantic_label = label;
    o.position_m = g->place(place)->position_m;
    o.bounding_box = sg::BoundingBox::aabb(o.position_m - Eigen::Vector3d::Constant(0.4),
                                           o.position_m + Eigen::Vector3d::Constant(0.4));
    const sg::NodeId id = sg::make_node_id(sg::kObjectPrefix, k++);
    EXPECT_EQ(g->add_object(id, o), sg::Status::kOk);
    EXPECT_EQ(g->add_edge(place, id), sg::Status::kOk);
  }
  return g;
}

std::set<std::string> store_names(const BackendStage& stage, bool with_door_set = true) {
  std::set<std::string> names;
  stage.for_each_resource([&](const memory::ResourceStats& s) { names.insert(s.name); }, with_door_set);
  return names;
}

TEST(BackendStageTest, RoomsAndTheirLabelsInOneUpdate) {
  rooms::testing::SyntheticPlaces s;
  auto g = two_rooms_with_objects(&s);
  BackendStage stage;
  BackendStage::Config c;
  c.doors_online = false;
  std::string error, warning;
  ASSERT_TRUE(stage.init(c, graph_capacities(), 0, 0, &error, &warning)) << error;
  EXPECT_TRUE(warning.empty()) << warning;  // the shipped weights load
  const rooms::UpdateResult r = stage.update_rooms(g.get(), 1'000'000'000);
  ASSERT_EQ(r.outcome, rooms::Outcome::kOk) << rooms::to_string(r.outcome);
  EXPECT_EQ(r.rooms, 2u);
  EXPECT_EQ(stage.counters().updates.load(), 1u);
  EXPECT_EQ(stage.counters().rooms.load(), 2u);
  // Each room holds one informative object: both get a label, and the stage says so.
  std::size_t labelled = 0;
  g->for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind != sg::NodeKind::kRoom) return;
    const sg::RoomAttributes* a = g->room(n.id);
    labelled += a->semantic_label != semantics::kRoomUnknown ? 1 : 0;
    EXPECT_FALSE(a->class_probabilities.empty());
  });
  EXPECT_EQ(labelled, 2u);
  EXPECT_EQ(stage.counters().rooms_labelled.load(), 2u);
  // Loop closure off: no loop-closure store, and nothing to solve or correct.
  const std::set<std::string> names = store_names(stage);
  EXPECT_EQ(names.count("loop_closure.closures"), 0u);
  EXPECT_FALSE(stage.solve_due(1'000'000'000));
  EXPECT_FALSE(stage.solved());
}

TEST(BackendStageTest, MissingWeightsAreAWarningAndRoomsStayUnknown) {
  rooms::testing::SyntheticPlaces s;
  auto g = two_rooms_with_objects(&s);
  BackendStage stage;
  BackendStage::Config c;
  c.doors_online = false;
  c.room_weights_path = "/nonexistent/room_classifier.json";
  std::string error, warning;
  ASSERT_TRUE(stage.init(c, graph_capacities(), 0, 0, &error, &warning)) << error;
  EXPECT_NE(warning.find("room labels off"), std::string::npos) << warning;
  EXPECT_EQ(stage.update_rooms(g.get(), 0).rooms, 2u);
  EXPECT_EQ(stage.counters().rooms_labelled.load(), 0u);
}

TEST(BackendStageTest, LoopClosureStoresAreCarvedAndReported) {
  BackendStage stage;
  BackendStage::Config c;
  c.loop_closure.enabled = true;
  std::string error, warning;
  ASSERT_TRUE(stage.init(c, graph_capacities(), 64, 0, &error, &warning)) << error;
  const std::set<std::string> names = store_names(stage);
  EXPECT_EQ(names.count("loop_closure.closures"), 1u);
  EXPECT_EQ(names.count(stage.control_points().stats().name), 1u);
  // The door set is left out for a reader on another thread; the online doors' arena is still reported.
  EXPECT_LT(store_names(stage, false).size(), names.size());
  // No agents yet: nothing described, nothing detected, nothing to solve.
  auto g = make_graph();
  agents::AgentLayer agents;
  EXPECT_FALSE(stage.detect_loop_closures(*g, agents, 100'000'000'000ull));
  EXPECT_FALSE(stage.solve_due(100'000'000'000ull));
  EXPECT_EQ(stage.counters().agents_described.load(), 0u);
}

TEST(BackendStageTest, StoresOverTheirArenaAreAClearError) {
  BackendStage stage;
  BackendStage::Config c;
  c.loop_closure.enabled = true;
  std::string error, warning;
  EXPECT_FALSE(stage.init(c, graph_capacities(), 0, budgets::active::loop_closure::kArenaBytes + 1, &error, &warning));
  EXPECT_NE(error.find("loop_closure"), std::string::npos) << error;
}

}  // namespace
}  // namespace qsg::backend
