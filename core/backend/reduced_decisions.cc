// Loop-closure decisions on the agent graph reduced to the closures' agents, then the whole chain solved with them.
#include "core/backend/reduced_decisions.h"

#include <algorithm>

namespace qsg::backend {

Matrix6d covariance_in_to_frame(const RelativePoseEdge& e) {
  Matrix6d cov = Matrix6d::Zero();
  if (e.has_information) {
    cov = e.information.inverse();
  } else {  // sigmas: translation in the `from` frame, rotation in the `to` frame
    const Eigen::Matrix3d to_R_from = e.measured_from_T_to.q.conjugate().toRotationMatrix();
    cov.topLeftCorner<3, 3>() = to_R_from * e.sigma_t_m.cwiseAbs2().asDiagonal() * to_R_from.transpose();
    cov.bottomRightCorner<3, 3>() = e.sigma_rot_rad.cwiseAbs2().asDiagonal();
  }
  return cov;
}

Matrix6d adjoint(const Pose3& a_T_b) {
  const Eigen::Matrix3d r = a_T_b.q.normalized().toRotationMatrix();
  const Eigen::Vector3d& t = a_T_b.t_m;
  Eigen::Matrix3d skew;
  skew << 0.0, -t.z(), t.y(), t.z(), 0.0, -t.x(), -t.y(), t.x(), 0.0;
  Matrix6d ad = Matrix6d::Zero();
  ad.topLeftCorner<3, 3>() = ad.bottomRightCorner<3, 3>() = r;
  ad.topRightCorner<3, 3>() = skew * r;
  return ad;
}

// Step k's noise is a right perturbation of its relative pose, in its `to` frame; composed, T_ab = T_0 .. T_{n-1}
// with T_k -> T_k Exp(x_k) moves T_ab by Exp(sum_k Ad(b_T_(k+1)) x_k) to first order: the steps after k carry it.
RelativePoseEdge compose_steps(const RelativePoseEdge* steps, std::size_t n) {
  RelativePoseEdge e;
  if (n == 0) return e;
  e.from = steps[0].from;
  e.to = steps[n - 1].to;
  Pose3 rest;  // the composed measurement from step k's `to` node to the last node
  Matrix6d cov = Matrix6d::Zero();
  for (std::size_t k = n; k-- > 0;) {
    const Matrix6d ad = adjoint(rest.inverse());
    cov += ad * covariance_in_to_frame(steps[k]) * ad.transpose();
    Pose3 step = steps[k].measured_from_T_to;
    step.q.normalize();
    rest = step * rest;
  }
  rest.q.normalize();
  e.measured_from_T_to = rest;
  e.has_information = true;
  const Matrix6d info = cov.inverse();
  e.information = 0.5 * (info + info.transpose());
  return e;
}

bool reduce_agent_graph(std::size_t num_agents, const std::vector<RelativePoseEdge>& edges, std::size_t num_chain,
                        ReducedAgentGraph* out) {
  if (num_agents < 2 || num_chain + 1 != num_agents || edges.size() < num_chain) return false;
  for (std::size_t k = 0; k < num_chain; ++k)
    if (edges[k].from != k || edges[k].to != k + 1 || edges[k].is_loop_closure) return false;
  std::vector<char> keep(num_agents, 0);
  keep.front() = keep.back() = 1;
  for (std::size_t k = num_chain; k < edges.size(); ++k) {
    if (edges[k].from >= num_agents || edges[k].to >= num_agents) return false;
    keep[edges[k].from] = keep[edges[k].to] = 1;
  }
  out->kept.clear();
  std::vector<std::uint32_t> index(num_agents, 0);
  for (std::size_t k = 0; k < num_agents; ++k)
    if (keep[k]) {
      index[k] = static_cast<std::uint32_t>(out->kept.size());
      out->kept.push_back(static_cast<std::uint32_t>(k));
    }
  out->edges.clear();
  out->edges.reserve(out->kept.size() - 1 + edges.size() - num_chain);
  for (std::size_t j = 0; j + 1 < out->kept.size(); ++j) {
    RelativePoseEdge e = compose_steps(&edges[out->kept[j]], out->kept[j + 1] - out->kept[j]);
    e.from = static_cast<std::uint32_t>(j);
    e.to = static_cast<std::uint32_t>(j + 1);
    out->edges.push_back(e);
  }
  out->edge_index.assign(edges.size(), -1);
  for (std::size_t k = num_chain; k < edges.size(); ++k) {
    RelativePoseEdge e = edges[k];
    e.from = index[e.from];
    e.to = index[e.to];
    out->edge_index[k] = static_cast<std::int64_t>(out->edges.size());
    out->edges.push_back(e);
  }
  return true;
}

std::vector<Pose3> expand_agents(const std::vector<Pose3>& reference, const std::vector<std::uint32_t>& kept,
                                 const std::vector<Pose3>& solved_kept, const std::vector<Pose3>* end_reference) {
  std::vector<Pose3> out(reference.size());
  for (std::size_t j = 0; j < kept.size(); ++j) {
    out[kept[j]] = solved_kept[j];
    if (j + 1 == kept.size()) break;
    const std::uint32_t a = kept[j], b = kept[j + 1];
    // b as the interval sees it: in a's frame correction (end_reference), when b was mapped in another one.
    const Pose3& end = end_reference != nullptr ? (*end_reference)[b] : reference[b];
    const Pose3 ca = solved_kept[j] * reference[a].inverse(), cb = solved_kept[j + 1] * end.inverse();
    double total = 0.0;
    for (std::uint32_t k = a; k < b; ++k)
      total += ((k + 1 == b ? end : reference[k + 1]).t_m - reference[k].t_m).norm();
    double along = 0.0;
    for (std::uint32_t k = a + 1; k < b; ++k) {
      along += (reference[k].t_m - reference[k - 1].t_m).norm();
      const double f = total > 0.0 ? along / total : static_cast<double>(k - a) / static_cast<double>(b - a);
      const Pose3 c{(1.0 - f) * ca.t_m + f * cb.t_m, ca.q.slerp(f, cb.q).normalized()};
      out[k] = c * reference[k];
    }
  }
  return out;
}

bool decide_on_reduced_graph(const PoseGraphConfig& solver, const std::vector<Pose3>& agents,
                             const std::vector<RelativePoseEdge>& edges, std::size_t num_chain, ReducedDecision* d) {
  // Without a closure to decide (every one carried as a plain edge) GNC is one least-squares solve: nothing to gain.
  if (std::none_of(edges.begin(), edges.end(), [](const RelativePoseEdge& e) { return e.is_loop_closure; }))
    return false;
  if (!reduce_agent_graph(agents.size(), edges, num_chain, &d->graph)) return false;
  d->reduced.clear();
  d->reduced.reserve(d->graph.kept.size());
  for (std::uint32_t k : d->graph.kept) d->reduced.push_back(agents[k]);
  PoseGraphResult r = optimize_pose_graph(solver, d->reduced, d->graph.edges);
  // Weights and residuals per input edge, as a solve over the whole chain reports them.
  if (r.poses_updated()) {
    std::vector<double> weight(edges.size(), 1.0), residual(edges.size(), 0.0);
    for (std::size_t k = 0; k < edges.size(); ++k) {
      const std::int64_t j = d->graph.edge_index[k];
      if (j < 0) continue;
      if (!r.edge_weight.empty()) weight[k] = r.edge_weight[static_cast<std::size_t>(j)];
      residual[k] = r.edge_residual_sigma[static_cast<std::size_t>(j)];
    }
    r.edge_weight.swap(weight);
    r.edge_residual_sigma.swap(residual);
  }
  d->decide = std::move(r);
  d->chain = PoseGraphResult{};
  return true;
}

void chain_with_decisions(const PoseGraphConfig& solver, const std::vector<RelativePoseEdge>& edges,
                          ReducedDecision* d, std::vector<Pose3>* agents) {
  std::vector<RelativePoseEdge> kept;
  kept.reserve(edges.size());
  for (std::size_t k = 0; k < edges.size(); ++k) {
    if (!edges[k].is_loop_closure) {
      kept.push_back(edges[k]);
    } else if (d->decide.edge_weight.empty() || d->decide.edge_weight[k] > 0.5) {
      kept.push_back(edges[k]);
      kept.back().is_loop_closure = false;  // decided: a plain edge
    }
  }
  std::vector<Pose3> start = expand_agents(*agents, d->graph.kept, d->reduced);
  PoseGraphConfig plain = solver;
  plain.loop_closure_loss = RobustLoss::kNone;
  plain.prefilter_pairwise_consistency = false;
  d->chain = optimize_pose_graph(plain, start, kept);
  if (d->chain.poses_updated()) agents->swap(start);
}

}  // namespace qsg::backend
