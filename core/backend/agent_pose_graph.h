// The agent layer's pose chain as a pose graph: one pose per chain node, an odometry edge between consecutive
// nodes (the odometric relative pose, its sigma from the growth of the odometry's covariance between them), plus
// loop-closure edges; solved by optimize_pose_graph. Runs on the backend thread (it allocates the solver's
// problem), never on the real-time path.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "core/agents/agent_layer.h"
#include "core/backend/pose_graph.h"

namespace qsg::backend {

// How an odometry edge between two chain nodes is weighted.
enum class OdometryWeighting : std::uint8_t {
  // Sigmas from the growth of the odometry's reported covariance diagonal between the two nodes, floored. The
  // reported covariance is absolute and in the world frame: its position part grows with the yaw error times the
  // distance from the start (not noise of this edge), and its rotation part is about the world axes while the edge's
  // rotation residual is about the node's own axes (a camera's optical axis is not the vertical).
  kCovarianceGrowth,
  // A random walk per metre travelled, the odometry's own noise model (drivers/sim/drifting_odometry.h; a VIO's
  // specification): translation sigma_t^2 d (isotropic), rotation sigma_yaw^2 d about the world vertical and
  // sigma_tilt^2 d about the horizontal axes, expressed in the node's frame; d the odometric path between the nodes;
  // plus the floors (squared) so that nodes added without motion (turning in place, waiting) stay finite.
  kPerDistance,
};
const char* to_string(OdometryWeighting w);
bool parse_odometry_weighting(const std::string& name, OdometryWeighting* out);

struct AgentGraphConfig {
  // Floors of an odometry edge's sigmas (kCovarianceGrowth: the odometry's covariance may not grow between close
  // nodes, or may be unknown: zero, and a zero sigma would make the edge infinitely stiff).
  double min_sigma_t_m = 0.01;
  double min_sigma_rot_rad = 0.005;
  // kPerDistance by default, with the local-map closures within each tour (why, measured:
  // bench/results/loop_closure.md, "Session of 2026-12-03 (2)"). Set the walks below to the robot's odometry (the
  // simulator's drifting odometry states its own).
  OdometryWeighting odometry_weighting = OdometryWeighting::kPerDistance;
  // kPerDistance: the odometry's random walks per sqrt(metre) (defaults: the simulator's "sim" level), and the
  // floors added in quadrature.
  double sigma_t_m_per_sqrt_m = 0.02;
  double sigma_yaw_rad_per_sqrt_m = 0.003;
  double sigma_tilt_rad_per_sqrt_m = 0.0005;
  double floor_t_m = 0.001;
  double floor_rot_rad = 0.0005;
  // The edge into a node after an odometry step (ChainNode::after_odometry_step) measures the step, not motion: at
  // least these sigmas, loose against the loop closures' centimetres (which then place the two sides), finite so a
  // stretch without closures stays determined.
  double step_sigma_t_m = 2.0;
  double step_sigma_rot_rad = 0.5;
  PoseGraphConfig solver;
  std::string check() const;
  void print(std::FILE* out) const;
};

// A loop closure between chain nodes a and b (indices into the chain, a < b): b's pose in a's frame.
struct ChainLoopClosure {
  std::uint32_t a = 0;
  std::uint32_t b = 0;
  Pose3 a_T_b;
  Eigen::Vector3d sigma_t_m = Eigen::Vector3d::Constant(0.05);
  Eigen::Vector3d sigma_rot_rad = Eigen::Vector3d::Constant(0.01);
  // Which closure this is, kept from one solve to the next (the backend uses the query agent's time; 0: unnamed,
  // then a closure is known by its index). The deformation graph carries a decision by it when the closure store
  // folded since (which shifts the indices).
  std::uint64_t id = 0;
};

struct AgentGraphResult {
  std::size_t nodes = 0;
  std::size_t odometry_edges = 0;
  std::size_t loop_closures = 0;
  PoseGraphResult solve;  // initial_cost 0 and no change when there are no loop closures: odometry is consistent
  void print(std::FILE* out) const;
};

// A loop closure as a robust edge of the pose graph.
RelativePoseEdge loop_closure_edge(const ChainLoopClosure& c);

// The odometry edge from world_T_a to world_T_b (odometric poses), d_m of odometric path apart, weighted per the
// configuration's kPerDistance model (a full information matrix: rotation about the vertical in b's frame).
RelativePoseEdge per_distance_odometry_edge(std::uint32_t a, std::uint32_t b, const Pose3& world_T_a,
                                            const Pose3& world_T_b, double d_m, const AgentGraphConfig& config);

// The odometry edges of the chain (edge k joins node k and k + 1), for inspection and tests.
std::vector<RelativePoseEdge> chain_odometry_edges(const agents::ChainView& agents, const AgentGraphConfig& config);

// Optimizes the chain with the loop closures; `optimized` gets one world_T_agent per chain node, starting from the
// odometric poses. With no loop closure there is nothing to correct: the odometric poses come back unchanged.
AgentGraphResult optimize_agent_chain(const agents::AgentLayer& agents, const std::vector<ChainLoopClosure>& loop_closures,
                                      const AgentGraphConfig& config, std::vector<Pose3>* optimized);

}  // namespace qsg::backend
