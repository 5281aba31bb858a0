// The agent chain's pose graph: odometry edges from the chain (sigmas from the covariance's growth), no change
// without loop closures, and a true loop closure pulling a drifted square loop back towards the truth.
#include "core/backend/agent_pose_graph.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/scene_graph/scene_graph.h"
#include "tests/backend/planar_pose.h"
#include "tests/scene_graph/test_graph.h"

namespace qsg::backend {
namespace {

using testing::planar;

// A 4 m square walked once, 0.5 m steps, ending where it started; the odometry's yaw drifts 0.5 degree per step.
struct SquareLoop {
  std::vector<Eigen::Isometry3d> truth, odometry;
};
SquareLoop square_loop() {
  SquareLoop s;
  Eigen::Isometry3d est = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d prev = Eigen::Isometry3d::Identity();
  for (int side = 0; side < 4; ++side)
    for (int k = 0; k < 8; ++k) {
      const double yaw = side * M_PI / 2;
      const Eigen::Vector3d corner[4] = {{0, 0, 0}, {4, 0, 0}, {4, 4, 0}, {0, 4, 0}};
      const Eigen::Vector3d dir = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::Vector3d::UnitX();
      const Eigen::Vector3d p = corner[side] + 0.5 * k * dir;
      const Eigen::Isometry3d t = planar(p.x(), p.y(), yaw);
      if (!s.truth.empty()) {
        Eigen::Isometry3d step = prev.inverse() * t;
        step.linear() = Eigen::AngleAxisd(0.5 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() * step.linear();
        est = est * step;
      }
      prev = t;
      s.truth.push_back(t);
      s.odometry.push_back(est);
    }
  return s;
}

double position_rmse(const std::vector<Pose3>& poses, const std::vector<Eigen::Isometry3d>& truth) {
  double sum = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) sum += (poses[i].t_m - truth[i].translation()).squaredNorm();
  return std::sqrt(sum / static_cast<double>(poses.size()));
}

TEST(AgentPoseGraphTest, OdometryEdgesComeFromTheChainAndALoopClosureCorrectsTheDrift) {
  const SquareLoop loop = square_loop();
  auto graph = scene_graph::testing::make_graph();
  agents::AgentLayer layer;
  agents::Config c;
  c.min_translation_m = 0.0;
  std::string error;
  ASSERT_TRUE(layer.init(c, agents::Capacities{100}, &error)) << error;
  for (std::size_t i = 0; i < loop.odometry.size(); ++i) {
    Eigen::Matrix<double, 6, 1> variance;
    variance << 1e-4 * i, 1e-4 * i, 1e-6 * i, 1e-7 * i, 1e-7 * i, 1e-5 * i;  // grows along the path
    ASSERT_EQ(layer.add_keyframe(graph.get(), 1000 + i, loop.odometry[i], 0, variance), agents::AddResult::kAdded);
  }
  AgentGraphConfig config;
  const std::vector<RelativePoseEdge> edges = chain_odometry_edges(layer, config);
  ASSERT_EQ(edges.size(), loop.odometry.size() - 1);
  EXPECT_NEAR(edges[3].sigma_t_m.x(), 0.01, 1e-12);              // sqrt(1e-4): the growth over one step
  EXPECT_NEAR(edges[3].sigma_t_m.z(), config.min_sigma_t_m, 1e-12);  // sqrt(1e-6) is below the floor
  EXPECT_NEAR(edges[3].measured_from_T_to.t_m.norm(), 0.5, 1e-9);

  // Without loop closures the odometry is already optimal: nothing moves.
  std::vector<Pose3> optimized;
  AgentGraphResult r = optimize_agent_chain(layer, {}, config, &optimized);
  ASSERT_TRUE(r.solve.poses_updated()) << r.solve.message;
  EXPECT_LT(r.solve.final_cost, 1e-12);
  const double drifted = position_rmse(optimized, loop.truth);
  EXPECT_GT(drifted, 0.3) << "the test needs visible drift";

  // The last pose seen again from the first (the true relative pose): the loop closes, the error shrinks.
  ChainLoopClosure closure;
  closure.a = 0;
  closure.b = static_cast<std::uint32_t>(loop.truth.size() - 1);
  const Eigen::Isometry3d a_T_b = loop.truth.front().inverse() * loop.truth.back();
  closure.a_T_b = Pose3{a_T_b.translation(), Eigen::Quaterniond(a_T_b.linear())};
  r = optimize_agent_chain(layer, {closure}, config, &optimized);
  ASSERT_TRUE(r.solve.poses_updated()) << r.solve.message;
  EXPECT_EQ(r.loop_closures, 1u);
  EXPECT_LT(position_rmse(optimized, loop.truth), 0.3 * drifted);
}

}  // namespace
}  // namespace qsg::backend
