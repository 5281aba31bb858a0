// The agent chain's pose graph: odometry edges from the chain (sigmas from the covariance's growth, or a random walk
// per metre in the node's frame), no change without loop closures, and a true loop closure pulling a drifted square
// loop back towards the truth; the per-distance weighting spreads a yaw drift's correction along the whole loop.
#include "core/backend/agent_pose_graph.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
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
  config.odometry_weighting = OdometryWeighting::kCovarianceGrowth;
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

// The odometry steps 1.2 m sideways after node 16 and keeps the step (a relocalizing VIO), on a loop without drift.
// Marked (AgentLayer::mark_odometry_step), the edge into node 17 is loose and true loop closures across the step put
// the two halves back together under GNC; unmarked, the tight edge holds the step against them.
TEST(AgentPoseGraphTest, AnEdgeAcrossAnOdometryStepIsLooseSoClosuresPlaceTheTwoSides) {
  const SquareLoop loop = square_loop();
  const auto chain = [&](bool mark, agents::AgentLayer* layer, std::unique_ptr<scene_graph::SceneGraph>* graph) {
    *graph = scene_graph::testing::make_graph();
    agents::Config c;
    c.min_translation_m = 0.0;
    std::string error;
    ASSERT_TRUE(layer->init(c, agents::Capacities{100}, &error)) << error;
    for (std::size_t i = 0; i < loop.truth.size(); ++i) {
      Eigen::Isometry3d odom = loop.truth[i];
      if (i > 16) odom.translation() += Eigen::Vector3d(0.0, 1.2, 0.0);
      if (i == 17 && mark) layer->mark_odometry_step();
      ASSERT_EQ(layer->add_keyframe(graph->get(), 1000 + i, odom), agents::AddResult::kAdded);
    }
  };
  const auto closure = [&](std::uint32_t a, std::uint32_t b) {
    ChainLoopClosure c;
    c.a = a;
    c.b = b;
    const Eigen::Isometry3d a_T_b = loop.truth[a].inverse() * loop.truth[b];
    c.a_T_b = Pose3{a_T_b.translation(), Eigen::Quaterniond(a_T_b.linear())};
    return c;
  };
  // The last side comes back along x = 0 to the start: closures from it to the first nodes, across the step.
  const std::vector<ChainLoopClosure> closures = {closure(0, 31), closure(1, 31), closure(0, 30), closure(2, 31)};
  AgentGraphConfig config;
  config.solver.loop_closure_loss = RobustLoss::kGncTls;
  double error_m[2] = {0.0, 0.0};
  std::size_t kept[2] = {0, 0};
  for (int mark = 0; mark < 2; ++mark) {
    agents::AgentLayer layer;
    std::unique_ptr<scene_graph::SceneGraph> graph;
    chain(mark == 1, &layer, &graph);
    const std::vector<RelativePoseEdge> edges = chain_odometry_edges(layer, config);
    ASSERT_EQ(layer.chain(17).after_odometry_step, mark == 1);
    EXPECT_EQ(edges[16].sigma_t_m.x() >= config.step_sigma_t_m, mark == 1);
    std::vector<Pose3> optimized;
    const AgentGraphResult r = optimize_agent_chain(layer, closures, config, &optimized);
    ASSERT_TRUE(r.solve.poses_updated()) << r.solve.message;
    // Aligned at the start (pose 0 is held): the error of the second half.
    for (std::size_t i = 17; i < optimized.size(); ++i)
      error_m[mark] = std::max(error_m[mark], (optimized[i].t_m - loop.truth[i].translation()).norm());
    for (std::size_t e = edges.size(); e < r.solve.edge_weight.size(); ++e) kept[mark] += r.solve.edge_weight[e] > 0.5;
  }
  EXPECT_GT(error_m[0], 0.5) << "unmarked, the step stays";
  EXPECT_LT(error_m[1], 0.05) << "marked, the closures place the second half";
  EXPECT_EQ(kept[1], closures.size());
}

// The per-distance model in the node's own frame: for a camera looking along the world x axis (optical frame: z
// forward, y down), the yaw noise is about its y axis, roll and pitch's about x and z; translation is isotropic.
TEST(AgentPoseGraphTest, PerDistanceEdgesWeighYawAboutTheVerticalInTheNodesFrame) {
  AgentGraphConfig c;
  c.sigma_t_m_per_sqrt_m = 0.02;
  c.sigma_yaw_rad_per_sqrt_m = 0.003;
  c.sigma_tilt_rad_per_sqrt_m = 0.0005;
  Eigen::Matrix3d world_R_optical;
  world_R_optical.col(0) = -Eigen::Vector3d::UnitY();  // right
  world_R_optical.col(1) = -Eigen::Vector3d::UnitZ();  // down
  world_R_optical.col(2) = Eigen::Vector3d::UnitX();   // forward
  const Eigen::Quaterniond q(world_R_optical);
  const Pose3 a{Eigen::Vector3d(1, 2, 0.5), q}, b{Eigen::Vector3d(1.25, 2, 0.5), q};
  const RelativePoseEdge e = per_distance_odometry_edge(3, 4, a, b, 0.25, c);
  EXPECT_EQ(e.from, 3u);
  EXPECT_EQ(e.to, 4u);
  ASSERT_TRUE(e.has_information);
  EXPECT_NEAR(e.measured_from_T_to.t_m.z(), 0.25, 1e-12) << "0.25 m forward";
  const double ft = c.floor_t_m * c.floor_t_m, fr = c.floor_rot_rad * c.floor_rot_rad;
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(e.information(i, i), 1.0 / (0.02 * 0.02 * 0.25 + ft), 1e-6);
  EXPECT_NEAR(e.information(4, 4), 1.0 / (0.003 * 0.003 * 0.25 + fr), 1e-3) << "yaw: about the camera's y axis";
  EXPECT_NEAR(e.information(3, 3), 1.0 / (0.0005 * 0.0005 * 0.25 + fr), 1e-2);
  EXPECT_NEAR(e.information(5, 5), 1.0 / (0.0005 * 0.0005 * 0.25 + fr), 1e-2) << "the optical axis is horizontal";
  EXPECT_NEAR(e.information(3, 4), 0.0, 1e-6);
  // No motion: the floors alone, finite.
  const RelativePoseEdge still = per_distance_odometry_edge(0, 1, a, a, 0.0, c);
  EXPECT_NEAR(still.information(0, 0), 1.0 / ft, 1e-3);
  EXPECT_NEAR(still.information(4, 4), 1.0 / fr, 1e-1);
  EXPECT_TRUE(still.information.allFinite());
  AgentGraphConfig bad = c;
  bad.sigma_yaw_rad_per_sqrt_m = 0.0;
  EXPECT_FALSE(bad.check().empty());
  OdometryWeighting w = OdometryWeighting::kCovarianceGrowth;
  EXPECT_TRUE(parse_odometry_weighting(to_string(OdometryWeighting::kPerDistance), &w));
  EXPECT_EQ(w, OdometryWeighting::kPerDistance);
  EXPECT_FALSE(parse_odometry_weighting("sideways", &w));
}

// The square loop with a steady yaw drift, and the covariance the simulator's drifting odometry would report
// (first-order propagation in the world frame, drivers/sim/drifting_odometry.cc). Closed once at the end, both
// weightings bring the loop back near the truth: per-distance weights spread the correction evenly along the path,
// as the drift happened.
TEST(AgentPoseGraphTest, PerDistanceWeightingSpreadsALoopsCorrectionAsTheDriftHappened) {
  const SquareLoop loop = square_loop();
  auto graph = scene_graph::testing::make_graph();
  agents::AgentLayer layer;
  agents::Config ac;
  ac.min_translation_m = 0.0;
  std::string error;
  ASSERT_TRUE(layer.init(ac, agents::Capacities{100}, &error)) << error;
  const double sigma_t = 0.02, sigma_yaw = 0.003;
  Eigen::Matrix4d cov = Eigen::Matrix4d::Zero();  // [position; yaw] error
  for (std::size_t i = 0; i < loop.odometry.size(); ++i) {
    if (i > 0) {
      const Eigen::Vector3d step = loop.truth[i].translation() - loop.truth[i - 1].translation();
      Eigen::Matrix4d f = Eigen::Matrix4d::Identity();
      f(0, 3) = -step.y();
      f(1, 3) = step.x();
      cov = f * cov * f.transpose();
      cov.diagonal() += Eigen::Vector4d(1, 1, 1, 0).cwiseProduct(Eigen::Vector4d::Constant(sigma_t * sigma_t * step.norm())) +
                        Eigen::Vector4d(0, 0, 0, sigma_yaw * sigma_yaw * step.norm());
    }
    Eigen::Matrix<double, 6, 1> variance;
    variance << cov(0, 0), cov(1, 1), cov(2, 2), 1e-6, 1e-6, cov(3, 3) + 1e-6;
    ASSERT_EQ(layer.add_keyframe(graph.get(), 1000 + i, loop.odometry[i], 0, variance), agents::AddResult::kAdded);
  }
  ChainLoopClosure closure;
  closure.a = 0;
  closure.b = static_cast<std::uint32_t>(loop.truth.size() - 1);
  const Eigen::Isometry3d a_T_b = loop.truth.front().inverse() * loop.truth.back();
  closure.a_T_b = Pose3{a_T_b.translation(), Eigen::Quaterniond(a_T_b.linear())};
  closure.sigma_t_m.setConstant(0.005);
  closure.sigma_rot_rad.setConstant(0.001);
  AgentGraphConfig config;
  EXPECT_EQ(config.odometry_weighting, OdometryWeighting::kPerDistance) << "the measured default";
  config.sigma_t_m_per_sqrt_m = sigma_t;
  config.sigma_yaw_rad_per_sqrt_m = sigma_yaw;
  config.solver.loop_closure_loss = RobustLoss::kNone;
  std::vector<Pose3> per_distance, growth;
  config.odometry_weighting = OdometryWeighting::kPerDistance;
  ASSERT_TRUE(optimize_agent_chain(layer, {closure}, config, &per_distance).solve.poses_updated());
  config.odometry_weighting = OdometryWeighting::kCovarianceGrowth;
  ASSERT_TRUE(optimize_agent_chain(layer, {closure}, config, &growth).solve.poses_updated());
  std::vector<Pose3> odometry;
  for (const Eigen::Isometry3d& t : loop.odometry) odometry.push_back(Pose3{t.translation(), Eigen::Quaterniond(t.linear())});
  const double before = position_rmse(odometry, loop.truth);
  const double e_per_distance = position_rmse(per_distance, loop.truth), e_growth = position_rmse(growth, loop.truth);
  EXPECT_GT(before, 0.3);
  EXPECT_LT(e_per_distance, 0.05 * before) << "a steady drift, spread evenly: nearly the truth";
  EXPECT_LT(e_growth, 0.05 * before);
}

}  // namespace
}  // namespace qsg::backend
