// Agent layer: keyframe nodes with pose and time, odometry edges, rejected out-of-order time, bounded capacity.
#include "core/agents/agent_layer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/scene_graph/scene_graph.h"
#include "tests/scene_graph/test_graph.h"
#include "tests/support/allocation_counter.h"

namespace qsg::agents {
namespace {

using scene_graph::make_node_id;

Eigen::Isometry3d pose(double x, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, 0.5, 0.5);
  return T;
}

AgentLayer make_layer(std::size_t keyframes = 100, char prefix = 'a') {
  AgentLayer layer;
  std::string error;
  Config c;
  c.prefix = prefix;
  EXPECT_TRUE(layer.init(c, Capacities{keyframes}, &error)) << error;
  return layer;
}

TEST(AgentLayerTest, KeyframesBecomeNodesJoinedByOdometryEdges) {
  auto graph = scene_graph::testing::make_graph();
  AgentLayer layer = make_layer();
  for (int k = 0; k < 5; ++k)
    ASSERT_EQ(layer.add_keyframe(graph.get(), 1000 + 100 * k, pose(0.3 * k, 0.1 * k), 70 + k), AddResult::kAdded);
  EXPECT_EQ(layer.num_keyframes(), 5u);
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kAgent), 5u);
  EXPECT_EQ(graph->num_edges(), 4u);
  for (int k = 0; k < 5; ++k) {
    const scene_graph::NodeId id = make_node_id('a', k);
    const scene_graph::AgentAttributes* a = graph->agent(id);
    ASSERT_NE(a, nullptr);
    EXPECT_EQ(a->timestamp_ns, static_cast<std::uint64_t>(1000 + 100 * k));
    EXPECT_EQ(a->external_key, static_cast<std::uint64_t>(70 + k));
    EXPECT_TRUE(a->position_m.isApprox(Eigen::Vector3d(0.3 * k, 0.5, 0.5)));
    EXPECT_NEAR(a->world_R_body.angularDistance(Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * k, Eigen::Vector3d::UnitZ()))), 0.0,
                1e-9);
    EXPECT_EQ(graph->node(id)->layer.partition, 'a');
    if (k > 0) {
      EXPECT_TRUE(graph->has_edge(make_node_id('a', k - 1), id));
    }
  }
  EXPECT_FALSE(graph->has_edge(make_node_id('a', 0), make_node_id('a', 2))) << "only consecutive keyframes";
  EXPECT_EQ(layer.last_node(), make_node_id('a', 4));
}

TEST(AgentLayerTest, TimeGoingBackwardsOrStandingStillIsRejectedAndCounted) {
  auto graph = scene_graph::testing::make_graph();
  AgentLayer layer = make_layer();
  ASSERT_EQ(layer.add_keyframe(graph.get(), 2000, pose(0, 0)), AddResult::kAdded);
  EXPECT_EQ(layer.add_keyframe(graph.get(), 1999, pose(1, 0)), AddResult::kTimeNotIncreasing);
  EXPECT_EQ(layer.add_keyframe(graph.get(), 2000, pose(1, 0)), AddResult::kTimeNotIncreasing);
  EXPECT_EQ(layer.counters().rejected_time, 2u);
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kAgent), 1u);
  ASSERT_EQ(layer.add_keyframe(graph.get(), 2001, pose(1, 0)), AddResult::kAdded);
  EXPECT_TRUE(graph->has_edge(make_node_id('a', 0), make_node_id('a', 1))) << "the chain continues after a rejection";
  Eigen::Isometry3d bad = pose(0, 0);
  bad.translation().x() = std::nan("");
  EXPECT_EQ(layer.add_keyframe(graph.get(), 3000, bad), AddResult::kBadPose);
  EXPECT_EQ(layer.counters().rejected_pose, 1u);
  EXPECT_EQ(layer.counters().keyframes, 2u);
}

TEST(AgentLayerTest, CapacityIsBoundedAndAFullGraphIsNotFatal) {
  auto graph = scene_graph::testing::make_graph();
  AgentLayer layer = make_layer(3);
  for (int k = 0; k < 3; ++k) ASSERT_EQ(layer.add_keyframe(graph.get(), 10 + k, pose(k, 0)), AddResult::kAdded);
  EXPECT_EQ(layer.add_keyframe(graph.get(), 20, pose(4, 0)), AddResult::kFull);
  EXPECT_EQ(layer.counters().rejected_full, 1u);
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kAgent), 3u);

  scene_graph::Capacities gc = scene_graph::testing::small_capacities();
  gc.agent_nodes = 2;
  auto small = scene_graph::testing::make_graph(gc);
  AgentLayer layer2 = make_layer(100);
  EXPECT_EQ(layer2.add_keyframe(small.get(), 1, pose(0, 0)), AddResult::kAdded);
  EXPECT_EQ(layer2.add_keyframe(small.get(), 2, pose(1, 0)), AddResult::kAdded);
  EXPECT_EQ(layer2.add_keyframe(small.get(), 3, pose(2, 0)), AddResult::kFull);
  EXPECT_EQ(layer2.counters().rejected_full, 1u);
}

TEST(AgentLayerTest, AddingKeyframesDoesNotAllocate) {
  auto graph = scene_graph::testing::make_graph();
  AgentLayer layer = make_layer(100, 'b');
  ASSERT_EQ(layer.add_keyframe(graph.get(), 1, pose(0, 0)), AddResult::kAdded);
  EXPECT_NO_ALLOCATIONS(for (int k = 2; k < 50; ++k) layer.add_keyframe(graph.get(), k, pose(0.1 * k, 0)));
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kAgent), 49u);
  EXPECT_EQ(scene_graph::node_prefix(layer.last_node()), 'b');
}

TEST(AgentLayerTest, BadConfigIsRejectedClearly) {
  AgentLayer layer;
  std::string error;
  Config c;
  c.prefix = 'O';
  EXPECT_FALSE(layer.init(c, Capacities{10}, &error));
  EXPECT_NE(error.find("prefix"), std::string::npos) << error;
  c.prefix = 'p';
  EXPECT_FALSE(layer.init(c, Capacities{10}, &error));
  EXPECT_NE(error.find("places"), std::string::npos) << error;
  EXPECT_FALSE(layer.init(Config{}, Capacities{0}, &error));
  EXPECT_NE(error.find("keyframes"), std::string::npos) << error;
  auto graph = scene_graph::testing::make_graph();
  EXPECT_EQ(layer.add_keyframe(graph.get(), 1, pose(0, 0)), AddResult::kNotInitialized);
  EXPECT_GT(capacities_from_budget().keyframes, 0u);
}

}  // namespace
}  // namespace qsg::agents
