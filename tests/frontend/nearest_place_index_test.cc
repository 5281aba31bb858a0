// Nearest-place k-d tree against brute force, without allocating; object and agent parent edges to places.
#include "core/frontend/nearest_place_index.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "core/scene_graph/scene_graph.h"
#include "tests/scene_graph/test_graph.h"
#include "tests/support/allocation_counter.h"

namespace qsg::frontend {
namespace {

using scene_graph::make_node_id;
using scene_graph::NodeId;

std::unique_ptr<NearestPlaceIndex> make_index(std::size_t capacity) {
  auto index = std::make_unique<NearestPlaceIndex>();
  std::string error;
  const NearestPlaceCapacities c{capacity};
  EXPECT_TRUE(index->init(c, NearestPlaceIndex::plan(c).total_bytes(), &error)) << error;
  return index;
}

TEST(NearestPlaceIndexTest, NearestKEqualsBruteForceOnRandomSets) {
  std::mt19937 rng(11);
  auto index = make_index(2000);
  for (const std::size_t n : {1u, 7u, 9u, 100u, 2000u}) {
    std::uniform_real_distribution<double> u(-10.0, 10.0);
    std::vector<Eigen::Vector3d> pts(n);
    std::vector<NodeId> ids(n);
    for (std::size_t i = 0; i < n; ++i) {
      pts[i] = Eigen::Vector3d(u(rng), u(rng), 0.1 * u(rng));
      ids[i] = make_node_id('p', 1000 + i);
    }
    ASSERT_EQ(index->rebuild(pts.data(), ids.data(), n), n);
    for (int q = 0; q < 200; ++q) {
      const Eigen::Vector3d query(u(rng) * 1.2, u(rng) * 1.2, u(rng) * 0.2);
      const std::size_t k = 1 + static_cast<std::size_t>(q % 16);
      std::vector<std::pair<double, NodeId>> ref;
      for (std::size_t i = 0; i < n; ++i) ref.push_back({(pts[i] - query).norm(), ids[i]});
      std::sort(ref.begin(), ref.end());
      PlaceNeighbor out[NearestPlaceIndex::kMaxK];
      const std::size_t got = index->nearest(query, k, out);
      ASSERT_EQ(got, std::min(k, n));
      for (std::size_t j = 0; j < got; ++j) {
        EXPECT_DOUBLE_EQ(out[j].distance_m, ref[j].first) << "n=" << n << " k=" << k << " rank " << j;
        EXPECT_EQ(out[j].id, ref[j].second) << "n=" << n << " rank " << j;
      }
    }
  }
}

TEST(NearestPlaceIndexTest, RebuildAndQueryDoNotAllocateAndCapacityIsBounded) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 20.0);
  std::vector<Eigen::Vector3d> pts(600);
  for (auto& p : pts) p = Eigen::Vector3d(u(rng), u(rng), 1.0);
  auto index = make_index(500);
  std::size_t built = 0;
  EXPECT_NO_ALLOCATIONS(built = index->rebuild(pts.data(), nullptr, pts.size()));
  EXPECT_EQ(built, 500u);
  EXPECT_EQ(index->dropped(), 100u);
  memory::ResourceStats st = index->stats();
  EXPECT_EQ(st.capacity, 500u);
  EXPECT_EQ(st.in_use, 500u);
  EXPECT_EQ(st.high_water, 500u);
  EXPECT_EQ(st.failed, 100u);
  PlaceNeighbor out[4];
  std::size_t got = 0;
  EXPECT_NO_ALLOCATIONS(for (int i = 0; i < 100; ++i) got += index->nearest(Eigen::Vector3d(u(rng), u(rng), 1.0), 4, out));
  EXPECT_EQ(got, 400u);
  EXPECT_EQ(index->nearest(Eigen::Vector3d(1, 1, 1), 0, out), 0u);
  // From a scene graph: only active places.
  auto graph = scene_graph::testing::make_graph();
  for (int i = 0; i < 50; ++i) {
    scene_graph::PlaceAttributes p = scene_graph::testing::place_at(i, 0, 1);
    p.is_active = i % 2 == 0;
    graph->add_place(make_node_id('p', i), p);
  }
  EXPECT_NO_ALLOCATIONS(built = index->rebuild(*graph));
  EXPECT_EQ(built, 25u);
  st = index->stats();
  EXPECT_EQ(st.in_use, 25u);
  EXPECT_EQ(st.high_water, 500u) << "the high-water mark stays";
  ASSERT_EQ(index->nearest(Eigen::Vector3d(3.1, 0, 1), 1, out), 1u);
  EXPECT_EQ(out[0].id, make_node_id('p', 4)) << "p3 is inactive";
  EXPECT_EQ(index->rebuild(*graph, false), 50u);
}

// Places of equal clearance: the nearest sphere is the nearest place.
TEST(NearestPlaceIndexTest, ObjectsAndAgentsGetTheirNearestPlaceAsParent) {
  auto graph = scene_graph::testing::make_graph();
  for (int i = 0; i < 5; ++i) {
    scene_graph::PlaceAttributes p = scene_graph::testing::place_at(2.0 * i, 0, 1);
    p.is_active = true;
    ASSERT_EQ(graph->add_place(make_node_id('p', i), p), scene_graph::Status::kOk);
  }
  scene_graph::ObjectAttributes o;
  o.position_m = Eigen::Vector3d(4.2, 0.5, 0.4);
  const NodeId obj = make_node_id('O', 0);
  ASSERT_EQ(graph->add_object(obj, o), scene_graph::Status::kOk);
  scene_graph::AgentAttributes a;
  a.position_m = Eigen::Vector3d(0.7, 0, 0.5);
  const NodeId agent = make_node_id('a', 0);
  ASSERT_EQ(graph->add_agent(agent, 'a', a), scene_graph::Status::kOk);
  auto index = make_index(64);
  index->rebuild(*graph);
  const NodeId nodes[] = {obj, agent, make_node_id('O', 99), make_node_id('p', 0)};
  ConnectStats s = connect_to_nearest_places(graph.get(), *index, nodes, 4);
  EXPECT_EQ(s.connected, 2u);
  EXPECT_EQ(s.no_place, 2u) << "a missing node and a place are skipped";
  EXPECT_EQ(graph->parent(obj), make_node_id('p', 2));
  EXPECT_EQ(graph->parent(agent), make_node_id('p', 0));
  s = connect_to_nearest_places(graph.get(), *index, nodes, 2);
  EXPECT_EQ(s.unchanged, 2u);
  // The object moves: its edge is replaced, not duplicated.
  graph->object(obj)->position_m = Eigen::Vector3d(7.9, 0, 0.4);
  EXPECT_NO_ALLOCATIONS(s = connect_to_nearest_places(graph.get(), *index, nodes, 2));
  EXPECT_EQ(s.connected, 1u);
  EXPECT_EQ(graph->parent(obj), make_node_id('p', 4));
  EXPECT_FALSE(graph->has_edge(obj, make_node_id('p', 2)));
  EXPECT_EQ(graph->num_layer_edges(true), 2u);
  // An empty index connects nothing.
  auto empty = make_index(4);
  s = connect_to_nearest_places(graph.get(), *empty, nodes, 2);
  EXPECT_EQ(s.no_place, 2u);
}

// A bed against a wall: the place just behind the wall (0.9 m from the bed's centre, in the corridor, 0.4 m of
// clearance) is nearer than the bedroom's (1.4 m away, 1.3 m of clearance). The bedroom place's free-space sphere
// reaches to 0.1 m of the bed; the corridor's stops 0.5 m short, at the wall. The parent is the bedroom's place.
TEST(NearestPlaceIndexTest, TheParentIsThePlaceWhoseFreeSphereIsNearest) {
  auto graph = scene_graph::testing::make_graph();
  const NodeId corridor = make_node_id('p', 0), bedroom = make_node_id('p', 1);
  scene_graph::PlaceAttributes behind_wall = scene_graph::testing::place_at(-0.9, 0, 0.4);
  scene_graph::PlaceAttributes in_room = scene_graph::testing::place_at(1.4, 0, 1.3);
  behind_wall.is_active = in_room.is_active = true;
  ASSERT_EQ(graph->add_place(corridor, behind_wall), scene_graph::Status::kOk);
  ASSERT_EQ(graph->add_place(bedroom, in_room), scene_graph::Status::kOk);
  scene_graph::ObjectAttributes bed;
  bed.position_m = Eigen::Vector3d(0, 0, 1.0);
  const NodeId obj = make_node_id('O', 0);
  ASSERT_EQ(graph->add_object(obj, bed), scene_graph::Status::kOk);
  auto index = make_index(8);
  index->rebuild(*graph);
  PlaceNeighbor nearest;
  ASSERT_EQ(index->nearest(bed.position_m, 1, &nearest), 1u);
  ASSERT_EQ(nearest.id, corridor) << "the scene must put the corridor's place nearer (else it tests nothing)";
  EXPECT_EQ(connect_to_nearest_places(graph.get(), *index, &obj, 1).connected, 1u);
  EXPECT_EQ(graph->parent(obj), bedroom);
}

TEST(NearestPlaceIndexTest, AFullEdgeStoreIsCountedNotFatal) {
  scene_graph::Capacities gc = scene_graph::testing::small_capacities();
  gc.edges = 1;
  auto graph = scene_graph::testing::make_graph(gc);
  scene_graph::PlaceAttributes p = scene_graph::testing::place_at(0, 0, 1);
  p.is_active = true;
  graph->add_place(make_node_id('p', 0), p);
  graph->add_object(make_node_id('O', 0), scene_graph::ObjectAttributes{});
  graph->add_object(make_node_id('O', 1), scene_graph::ObjectAttributes{});
  auto index = make_index(4);
  index->rebuild(*graph);
  const NodeId nodes[] = {make_node_id('O', 0), make_node_id('O', 1)};
  const ConnectStats s = connect_to_nearest_places(graph.get(), *index, nodes, 2);
  EXPECT_EQ(s.connected, 1u);
  EXPECT_EQ(s.failed, 1u);
}

TEST(NearestPlaceIndexTest, BadCapacitiesAreRejectedClearly) {
  NearestPlaceIndex index;
  std::string error;
  EXPECT_FALSE(index.init(NearestPlaceCapacities{0}, 1 << 20, &error));
  EXPECT_NE(error.find("capacities.places"), std::string::npos) << error;
  EXPECT_FALSE(index.init(NearestPlaceCapacities{1000}, 100, &error));
  EXPECT_FALSE(error.empty());
  PlaceNeighbor out[1];
  EXPECT_EQ(index.nearest(Eigen::Vector3d::Zero(), 1, out), 0u);
  EXPECT_GT(nearest_place_capacities_from_budget().places, 0u);
}

}  // namespace
}  // namespace qsg::frontend
