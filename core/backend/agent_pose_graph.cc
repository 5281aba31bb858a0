// The agent chain's pose graph: odometry edges from the chain's poses and covariances, loop closures, the solve.
#include "core/backend/agent_pose_graph.h"

#include "core/backend/backend_params.h"

#include <algorithm>
#include <cmath>

namespace qsg::backend {

const char* to_string(OdometryWeighting w) {
  return w == OdometryWeighting::kPerDistance ? "per_distance" : "covariance_growth";
}

bool parse_odometry_weighting(const std::string& name, OdometryWeighting* out) {
  if (name == "per_distance") *out = OdometryWeighting::kPerDistance;
  else if (name == "covariance_growth") *out = OdometryWeighting::kCovarianceGrowth;
  else return false;
  return true;
}

std::string AgentGraphConfig::check() const {
  // Each field the app exposes within its declared range (backend_params.cc).
  if (std::string why = params::check(agent_graph_params_table(), *this); !why.empty()) return why;
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0 && v <= 10.0; };
  if (!positive(min_sigma_t_m) || !positive(min_sigma_rot_rad)) return "odometry sigma floors must be in (0, 10]";
  if (!positive(floor_t_m) || !positive(floor_rot_rad)) return "odometry floors must be in (0, 10]";
  if (!positive(step_sigma_t_m) || !positive(step_sigma_rot_rad)) return "odometry step sigmas must be in (0, 10]";
  if (std::string why = solver.check(); !why.empty()) return "solver: " + why;
  return "";
}

void AgentGraphConfig::print(std::FILE* out) const {
  if (odometry_weighting == OdometryWeighting::kPerDistance)
    std::fprintf(out,
                 "agent pose graph: odometry edges per distance: %.4f m, yaw %.5f rad, tilt %.5f rad per sqrt(m), "
                 "floors %.4f m, %.5f rad\n",
                 sigma_t_m_per_sqrt_m, sigma_yaw_rad_per_sqrt_m, sigma_tilt_rad_per_sqrt_m, floor_t_m, floor_rot_rad);
  else
    std::fprintf(out, "agent pose graph: odometry edges from the covariance's growth, sigma floors %.3f m, %.4f rad\n",
                 min_sigma_t_m, min_sigma_rot_rad);
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

RelativePoseEdge per_distance_odometry_edge(std::uint32_t a, std::uint32_t b, const Pose3& world_T_a,
                                            const Pose3& world_T_b, double d_m, const AgentGraphConfig& config) {
  RelativePoseEdge e;
  e.from = a;
  e.to = b;
  e.measured_from_T_to = between(world_T_a, world_T_b);
  const double d = std::max(0.0, d_m);
  const double ft = config.floor_t_m * config.floor_t_m, fr = config.floor_rot_rad * config.floor_rot_rad;
  const double var_t = config.sigma_t_m_per_sqrt_m * config.sigma_t_m_per_sqrt_m * d + ft;
  // Rotation noise about the world axes, then in b's frame (the residual's rotation part is in the `to` frame).
  const Eigen::Vector3d world_var(config.sigma_tilt_rad_per_sqrt_m * config.sigma_tilt_rad_per_sqrt_m * d + fr,
                                  config.sigma_tilt_rad_per_sqrt_m * config.sigma_tilt_rad_per_sqrt_m * d + fr,
                                  config.sigma_yaw_rad_per_sqrt_m * config.sigma_yaw_rad_per_sqrt_m * d + fr);
  const Eigen::Matrix3d r_b = world_T_b.q.normalized().toRotationMatrix();
  const Eigen::Matrix3d cov_rot = r_b.transpose() * world_var.asDiagonal() * r_b;
  e.has_information = true;
  e.information.setZero();
  e.information.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() / var_t;  // isotropic: any frame
  Eigen::Matrix3d info_rot = cov_rot.inverse();
  e.information.bottomRightCorner<3, 3>() = 0.5 * (info_rot + info_rot.transpose());
  e.sigma_t_m.setConstant(std::sqrt(var_t));
  e.sigma_rot_rad = world_var.cwiseSqrt();
  return e;
}

namespace {
Pose3 odometric(const agents::ChainNode& n) {
  if (n.frame_is_identity()) return Pose3{n.t_m, n.q};
  return Pose3{n.frame_t_m, n.frame_q}.inverse() * Pose3{n.t_m, n.q};
}
}  // namespace

std::vector<RelativePoseEdge> chain_odometry_edges(const agents::ChainView& agents, const AgentGraphConfig& config) {
  std::vector<RelativePoseEdge> edges;
  const std::size_t n = agents.chain_size();
  if (n < 2) return edges;
  edges.reserve(n - 1);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const agents::ChainNode& a = agents.chain(k);
    const agents::ChainNode& b = agents.chain(k + 1);
    // The odometry's own poses: a node mapped in a corrected frame carries the correction, which is not motion.
    const Pose3 pa = odometric(a), pb = odometric(b);
    RelativePoseEdge e;
    if (config.odometry_weighting == OdometryWeighting::kPerDistance) {
      e = per_distance_odometry_edge(static_cast<std::uint32_t>(k), static_cast<std::uint32_t>(k + 1), pa, pb,
                                     b.path_m - a.path_m, config);
    } else {
      e.from = static_cast<std::uint32_t>(k);
      e.to = static_cast<std::uint32_t>(k + 1);
      e.measured_from_T_to = between(pa, pb);
      // The odometry's covariance grows along the path: what it grew by between the two nodes is this edge's.
      const Eigen::Matrix<double, 6, 1> growth = (b.variance - a.variance).cwiseMax(0.0);
      for (int i = 0; i < 3; ++i) {
        e.sigma_t_m[i] = std::max(config.min_sigma_t_m, std::sqrt(growth[i]));
        e.sigma_rot_rad[i] = std::max(config.min_sigma_rot_rad, std::sqrt(growth[3 + i]));
      }
    }
    if (b.after_odometry_step) {  // the step, not motion: loose, by sigmas alone
      e.has_information = false;
      e.sigma_t_m = e.sigma_t_m.cwiseMax(config.step_sigma_t_m);
      e.sigma_rot_rad = e.sigma_rot_rad.cwiseMax(config.step_sigma_rot_rad);
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
