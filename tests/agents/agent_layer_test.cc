// Agent layer: keyframe nodes with pose and time, odometry edges, rejected out-of-order time, bounded capacity.
#include "core/agents/agent_layer.h"

#include <gtest/gtest.h>

#include <algorithm>
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

// Sparsification off (every keyframe moved "far enough"), unless a test sets it.
AgentLayer make_layer(std::size_t keyframes = 100, char prefix = 'a') {
  AgentLayer layer;
  std::string error;
  Config c;
  c.prefix = prefix;
  c.min_translation_m = 0.0;
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

TEST(AgentLayerTest, KeyframesCloserThanThePolicyAreFoldedIntoTheNextNode) {
  auto graph = scene_graph::testing::make_graph();
  AgentLayer layer;
  std::string error;
  Config c;  // defaults: 0.25 m, 15 degrees, 10 s
  ASSERT_TRUE(layer.init(c, Capacities{100}, &error)) << error;
  ASSERT_EQ(layer.add_keyframe(graph.get(), 1, pose(0.0, 0.0)), AddResult::kAdded);
  EXPECT_EQ(layer.add_keyframe(graph.get(), 2, pose(0.1, 0.0)), AddResult::kSparsified);
  EXPECT_EQ(layer.add_keyframe(graph.get(), 3, pose(0.2, 0.0)), AddResult::kSparsified);
  EXPECT_EQ(layer.add_keyframe(graph.get(), 4, pose(0.3, 0.0)), AddResult::kAdded);   // moved 0.3 m
  EXPECT_EQ(layer.add_keyframe(graph.get(), 5, pose(0.3, 0.3)), AddResult::kAdded);   // turned 17 degrees
  const std::uint64_t s_ns = 1'000'000'000;
  EXPECT_EQ(layer.add_keyframe(graph.get(), 5 + 9 * s_ns, pose(0.3, 0.3)), AddResult::kSparsified);
  EXPECT_EQ(layer.add_keyframe(graph.get(), 5 + 11 * s_ns, pose(0.3, 0.3)), AddResult::kAdded);  // stood 11 s
  EXPECT_EQ(layer.counters().sparsified, 3u);
  EXPECT_EQ(layer.chain_size(), 4u);
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kAgent), 4u);
  EXPECT_TRUE(graph->has_edge(make_node_id('a', 0), make_node_id('a', 1))) << "the chain joins the kept nodes";
  EXPECT_NEAR(layer.chain(1).t_m.x(), 0.3, 1e-12);
}

// Each node keeps the odometric path from the first keyframe, over the folded keyframes too: a zig-zag between
// nodes counts in full (what a per-distance odometry noise model integrates).
TEST(AgentLayerTest, NodesKeepThePathTravelledThroughFoldedKeyframes) {
  auto graph = scene_graph::testing::make_graph();
  AgentLayer layer;
  std::string error;
  ASSERT_TRUE(layer.init(Config{}, Capacities{100}, &error)) << error;  // a node per 0.25 m
  ASSERT_EQ(layer.add_keyframe(graph.get(), 1, pose(0.0, 0.0)), AddResult::kAdded);
  EXPECT_EQ(layer.add_keyframe(graph.get(), 2, pose(0.2, 0.0)), AddResult::kSparsified);
  EXPECT_EQ(layer.add_keyframe(graph.get(), 3, pose(0.1, 0.0)), AddResult::kSparsified);
  EXPECT_EQ(layer.add_keyframe(graph.get(), 4, pose(0.3, 0.0)), AddResult::kAdded);
  ASSERT_EQ(layer.chain_size(), 2u);
  EXPECT_DOUBLE_EQ(layer.chain(0).path_m, 0.0);
  EXPECT_NEAR(layer.chain(1).path_m, 0.2 + 0.1 + 0.2, 1e-12) << "not the 0.3 m between the nodes";
  EXPECT_EQ(layer.add_keyframe(graph.get(), 5, pose(0.6, 0.0)), AddResult::kAdded);
  EXPECT_NEAR(layer.chain(2).path_m, 0.8, 1e-12);
}

// An 8-hour mission at 0.5 m/s adds far more nodes than any store holds: the chain folds its older half and never
// refuses, the graph's agent store never fills, and the chain stays one connected path.
TEST(AgentLayerTest, AFullChainFoldsItsOlderHalfAndNeverRefuses) {
  scene_graph::Capacities gc = scene_graph::testing::small_capacities();
  gc.agent_nodes = 64;
  auto graph = scene_graph::testing::make_graph(gc);
  AgentLayer layer = make_layer(64);
  Eigen::Matrix<double, 6, 1> variance = Eigen::Matrix<double, 6, 1>::Zero();
  std::size_t max_agents = 0;
  EXPECT_NO_ALLOCATIONS({
    for (int k = 0; k < 1000; ++k) {
      variance.setConstant(1e-4 * k);
      ASSERT_EQ(layer.add_keyframe(graph.get(), 100 + k, pose(0.5 * k, 0.0), 0, variance), AddResult::kAdded) << k;
      max_agents = std::max(max_agents, graph->num_nodes(scene_graph::NodeKind::kAgent));
    }
  });
  EXPECT_EQ(layer.counters().rejected_full, 0u);
  EXPECT_GT(layer.counters().fold_passes, 10u);
  EXPECT_LE(max_agents, 64u);
  EXPECT_EQ(layer.chain_stats().high_water, 64u * 9 / 10 + 1);
  // The first node anchors the map; the newest is the last; times increase along the chain; consecutive chain
  // nodes are joined in the graph and no folded node is left in it.
  ASSERT_GT(layer.chain_size(), 2u);
  EXPECT_EQ(layer.chain(0).id, make_node_id('a', 0));
  EXPECT_EQ(layer.chain(layer.chain_size() - 1).id, layer.last_node());
  for (std::size_t i = 1; i < layer.chain_size(); ++i) {
    EXPECT_LT(layer.chain(i - 1).time_ns, layer.chain(i).time_ns);
    EXPECT_TRUE(graph->has_edge(layer.chain(i - 1).id, layer.chain(i).id)) << i;
  }
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kAgent), layer.chain_size());
  EXPECT_EQ(graph->num_edges(), layer.chain_size() - 1);
  // The oldest part is the sparsest: spacing grows towards the start.
  EXPECT_GT(layer.chain(1).t_m.x() - layer.chain(0).t_m.x(),
            layer.chain(layer.chain_size() - 1).t_m.x() - layer.chain(layer.chain_size() - 2).t_m.x());
}

// A step of the odometry marks the next node added (not a sparsified keyframe), and survives the chain's folding.
TEST(AgentLayerTest, AnOdometryStepMarksTheNextNodeAndSurvivesFolding) {
  auto graph = scene_graph::testing::make_graph();
  AgentLayer layer;
  Config c;
  c.min_translation_m = 0.2;
  c.fold_at_fraction = 1.0;
  std::string error;
  ASSERT_TRUE(layer.init(c, Capacities{8}, &error)) << error;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const auto add = [&](double x, std::uint64_t t) {
    T.translation().x() = x;
    return layer.add_keyframe(graph.get(), t, T);
  };
  ASSERT_EQ(add(0.0, 1), AddResult::kAdded);
  ASSERT_EQ(add(0.5, 2), AddResult::kAdded);
  ASSERT_EQ(add(1.0, 3), AddResult::kAdded);
  layer.mark_odometry_step();
  ASSERT_EQ(add(1.05, 4), AddResult::kSparsified);  // not a node: the mark waits for the next one
  ASSERT_EQ(add(1.5, 5), AddResult::kAdded);
  ASSERT_EQ(add(2.0, 6), AddResult::kAdded);
  ASSERT_EQ(layer.chain_size(), 5u);
  EXPECT_FALSE(layer.chain(2).after_odometry_step);
  EXPECT_TRUE(layer.chain(3).after_odometry_step);
  EXPECT_FALSE(layer.chain(4).after_odometry_step);
  // Fill the chain until it folds its older half: node 3 (odd, in the older half) folds, and node 4 (t = 6), the
  // next one, now comes after the step.
  std::uint64_t t = 7;
  for (double x = 2.5; layer.counters().folded == 0; x += 0.5) ASSERT_EQ(add(x, t++), AddResult::kAdded);
  std::size_t marked = 0;
  for (std::size_t k = 0; k < layer.chain_size(); ++k) {
    marked += layer.chain(k).after_odometry_step ? 1 : 0;
    EXPECT_EQ(layer.chain(k).after_odometry_step, layer.chain(k).time_ns == 6) << "node " << k;
  }
  EXPECT_EQ(marked, 1u);
}

// LoopClosureConfig::map_in_corrected_frame: poses offered after set_frame_correction() include it. Each node keeps
// the correction it was mapped in, its odometric pose is the offered one without it, and the path counts the
// odometry's motion only (a change of correction is not travel).
TEST(AgentLayerTest, ANodeKeepsTheFrameCorrectionItWasMappedIn) {
  auto graph = scene_graph::testing::make_graph();
  AgentLayer layer = make_layer();
  ASSERT_EQ(layer.add_keyframe(graph.get(), 1, pose(0.0, 0.0)), AddResult::kAdded);
  ASSERT_EQ(layer.add_keyframe(graph.get(), 2, pose(0.5, 0.0)), AddResult::kAdded);
  Eigen::Isometry3d correction = Eigen::Isometry3d::Identity();
  correction.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  correction.translation() = Eigen::Vector3d(0.4, -0.3, 0.0);
  layer.set_frame_correction(correction);
  ASSERT_EQ(layer.add_keyframe(graph.get(), 3, correction * pose(1.0, 0.2)), AddResult::kAdded);
  ASSERT_EQ(layer.chain_size(), 3u);
  EXPECT_TRUE(layer.chain(1).frame_is_identity());
  EXPECT_FALSE(layer.chain(2).frame_is_identity());
  EXPECT_LT((odometric_pose(layer.chain(2)).matrix() - pose(1.0, 0.2).matrix()).norm(), 1e-12);
  EXPECT_LT((mapped_pose(layer.chain(2)).matrix() - (correction * pose(1.0, 0.2)).matrix()).norm(), 1e-12);
  EXPECT_NEAR(layer.chain(2).path_m, 1.0, 1e-12) << "the odometry moved 1 m; the correction is not path";
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
  c = Config{};
  c.fold_at_fraction = 0.2;
  EXPECT_FALSE(layer.init(c, Capacities{10}, &error));
  EXPECT_NE(error.find("fold_at_fraction"), std::string::npos) << error;
  c = Config{};
  c.min_translation_m = -1.0;
  EXPECT_FALSE(layer.init(c, Capacities{10}, &error));
  EXPECT_NE(error.find("min_translation_m"), std::string::npos) << error;
  auto graph = scene_graph::testing::make_graph();
  EXPECT_EQ(layer.add_keyframe(graph.get(), 1, pose(0, 0)), AddResult::kNotInitialized);
  EXPECT_GT(capacities_from_budget().keyframes, 0u);
}

}  // namespace
}  // namespace qsg::agents
