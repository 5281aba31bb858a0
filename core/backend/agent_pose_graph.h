// The agent layer's pose chain as a pose graph: one pose per chain node, an odometry edge between consecutive
// nodes (the odometric relative pose, its sigma from the growth of the odometry's covariance between them), plus
// loop-closure edges; solved by optimize_pose_graph. Runs on the backend thread (it allocates the solver's
// problem), never on the real-time path.
#pragma once

#include <cstdint>
#include <cstdio>
#include <vector>

#include "core/agents/agent_layer.h"
#include "core/backend/pose_graph.h"

namespace qsg::backend {

struct AgentGraphConfig {
  // Floors of an odometry edge's sigmas: the odometry's covariance may not grow between close nodes (or may be
  // unknown: zero), and a zero sigma would make the edge infinitely stiff.
  double min_sigma_t_m = 0.01;
  double min_sigma_rot_rad = 0.005;
  PoseGraphConfig solver;
  void print(std::FILE* out) const;
};

// A loop closure between chain nodes a and b (indices into the chain, a < b): b's pose in a's frame.
struct ChainLoopClosure {
  std::uint32_t a = 0;
  std::uint32_t b = 0;
  Pose3 a_T_b;
  Eigen::Vector3d sigma_t_m = Eigen::Vector3d::Constant(0.05);
  Eigen::Vector3d sigma_rot_rad = Eigen::Vector3d::Constant(0.01);
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

// The odometry edges of the chain (edge k joins node k and k + 1), for inspection and tests.
std::vector<RelativePoseEdge> chain_odometry_edges(const agents::AgentLayer& agents, const AgentGraphConfig& config);

// Optimizes the chain with the loop closures; `optimized` gets one world_T_agent per chain node, starting from the
// odometric poses. With no loop closure there is nothing to correct: the odometric poses come back unchanged.
AgentGraphResult optimize_agent_chain(const agents::AgentLayer& agents, const std::vector<ChainLoopClosure>& loop_closures,
                                      const AgentGraphConfig& config, std::vector<Pose3>* optimized);

}  // namespace qsg::backend
