// The agent chain's pose graph: odometry edges from the chain's poses and covariances, loop closures, the solve.
#include "core/backend/agent_pose_graph.h"

#include <algorithm>
#include <cmath>

namespace qsg::backend {

void AgentGraphConfig::print(std::FILE* out) const {
  std::fprintf(out, "agent pose graph: odometry sigma floors %.3f m, %.4f rad\n", min_sigma_t_m, min_sigma_rot_rad);
  solver.print(out);
}

void AgentGraphResult::print(std::FILE* out) const {
  std::fprintf(out, "agent pose graph: %zu poses, %zu odometry edges, %zu loop closures; ", nodes, odometry_edges,
               loop_closures);
  solve.print(out);
}

RelativePoseEdge loop_closure_edge(const ChainLoopClosure& c) {
  RelativePoseEdge e;
  e.from = c.a;
  e.to = c.b;
  e.measured_from_T_to = c.a_T_b;
  e.sigma_t_m = c.sigma_t_m;
  e.sigma_rot_rad = c.sigma_rot_rad;
  e.is_loop_closure = true;
  return e;
}

std::vector<RelativePoseEdge> chain_odometry_edges(const agents::AgentLayer& agents, const AgentGraphConfig& config) {
  std::vector<RelativePoseEdge> edges;
  const std::size_t n = agents.chain_size();
  if (n < 2) return edges;
  edges.reserve(n - 1);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const agents::ChainNode& a = agents.chain(k);
    const agents::ChainNode& b = agents.chain(k + 1);
    RelativePoseEdge e;
    e.from = static_cast<std::uint32_t>(k);
    e.to = static_cast<std::uint32_t>(k + 1);
    e.measured_from_T_to = between(Pose3{a.t_m, a.q}, Pose3{b.t_m, b.q});
    // The odometry's covariance grows along the path: what it grew by between the two nodes is this edge's.
    const Eigen::Matrix<double, 6, 1> growth = (b.variance - a.variance).cwiseMax(0.0);
    for (int i = 0; i < 3; ++i) {
      e.sigma_t_m[i] = std::max(config.min_sigma_t_m, std::sqrt(growth[i]));
      e.sigma_rot_rad[i] = std::max(config.min_sigma_rot_rad, std::sqrt(growth[3 + i]));
    }
    edges.push_back(e);
  }
  return edges;
}

AgentGraphResult optimize_agent_chain(const agents::AgentLayer& agents, const std::vector<ChainLoopClosure>& loop_closures,
                                      const AgentGraphConfig& config, std::vector<Pose3>* optimized) {
  AgentGraphResult result;
  const std::size_t n = agents.chain_size();
  result.nodes = n;
  optimized->clear();
  optimized->reserve(n);
  for (std::size_t k = 0; k < n; ++k) optimized->push_back(Pose3{agents.chain(k).t_m, agents.chain(k).q});
  std::vector<RelativePoseEdge> edges = chain_odometry_edges(agents, config);
  result.odometry_edges = edges.size();
  for (const ChainLoopClosure& c : loop_closures) edges.push_back(loop_closure_edge(c));
  result.loop_closures = loop_closures.size();
  if (n < 2) {
    result.solve.status = PoseGraphStatus::kConverged;
    result.solve.message = "fewer than two poses: nothing to optimize";
    return result;
  }
  result.solve = optimize_pose_graph(config.solver, *optimized, edges);
  return result;
}

}  // namespace qsg::backend
