// Loop-closure decisions on a reduced agent graph (a refinement of DeformationConfig::decide_on_agents, switched by
// DeformationConfig::reduced_decisions): GNC-TLS runs over the closures' endpoint agents only (and the chain's first
// and last), the odometry between two consecutive kept agents composed into one edge with its covariance carried to
// first order (Barfoot & Furgale, "Associating uncertainty with 3D poses", TRO 2014: each step's covariance moved
// through the adjoint of the rest of the path, then summed). The decisions then hold while the whole chain is solved
// by plain least squares, from the reduced solution interpolated along the chain. A decision's cost then follows
// the number of closures, not the chain's length. Backend thread only: it allocates.
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/backend/pose_graph.h"

namespace qsg::backend {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

// An edge's covariance of [translation; rotation], both in its `to` frame (the convention of an edge with an
// information matrix; sigmas give the translation in the `from` frame, rotated here).
Matrix6d covariance_in_to_frame(const RelativePoseEdge& e);

// The adjoint of a_T_b on a perturbation [rho; phi] in b's frame (the right perturbation of this residual): the
// same perturbation seen in a's frame, [R, [t]x R; 0, R].
Matrix6d adjoint(const Pose3& a_T_b);

// The steps steps[0..n) (steps[k].to is steps[k + 1].from) as one edge from steps[0].from to steps[n - 1].to: their
// measurements composed, the covariance sum_k Ad(b_T_k) C_k Ad(b_T_k)^T with b_T_k the composed measurement from
// step k's `to` node to the last, C_k step k's covariance in its `to` frame. An information matrix, not a loop closure.
RelativePoseEdge compose_steps(const RelativePoseEdge* steps, std::size_t n);

// The agent graph reduced: the kept agents (in chain order) and the reduced edges, composed chain steps first.
struct ReducedAgentGraph {
  std::vector<std::uint32_t> kept;       // per reduced node, its agent
  std::vector<RelativePoseEdge> edges;   // K - 1 composed steps, then every other edge remapped, in input order
  std::vector<std::int64_t> edge_index;  // per input edge, its index in `edges`; -1 for a chain step
};

// Reduces `edges` over `num_agents` agents whose first `num_chain` edges are the chain (edge k joins k and k + 1):
// keeps agent 0, the last and every endpoint of another edge. False (and *out unspecified) when the first edges
// are not such a chain or num_chain is not num_agents - 1.
bool reduce_agent_graph(std::size_t num_agents, const std::vector<RelativePoseEdge>& edges, std::size_t num_chain,
                        ReducedAgentGraph* out);

// Every chain node's pose from the kept agents' solution: a kept agent takes its own; one between kept a and b
// takes its reference pose moved by a's and b's corrections (solved * reference^-1), interpolated along the
// reference path between them (translation linearly, rotation by slerp). end_reference (may be null: reference):
// each interval's end b as the interval sees it, when b was mapped in another frame correction than a
// (DeformationProblem::frame_changes).
std::vector<Pose3> expand_agents(const std::vector<Pose3>& reference, const std::vector<std::uint32_t>& kept,
                                 const std::vector<Pose3>& solved_kept,
                                 const std::vector<Pose3>* end_reference = nullptr);

// One decision on the reduced graph and the chain's solve with it.
struct ReducedDecision {
  ReducedAgentGraph graph;
  std::vector<Pose3> reduced;  // the reduced graph's solution
  // GNC-TLS over the reduced graph; edge_weight and edge_residual_sigma per *input* edge (a chain step: 1 and 0).
  PoseGraphResult decide;
  PoseGraphResult chain;  // least squares over the whole chain with the decided closures (chain_with_decisions)
};

// GNC over the reduced graph of (agents, edges), from the agents' poses; false when no edge is a loop closure (GNC
// is then one least-squares solve) or the graph is not reducible (reduce_agent_graph), and then nothing is solved.
bool decide_on_reduced_graph(const PoseGraphConfig& solver, const std::vector<Pose3>& agents,
                             const std::vector<RelativePoseEdge>& edges, std::size_t num_chain, ReducedDecision* d);

// The whole chain by plain least squares over the edges, a loop closure kept when d->decide weighs it over 0.5
// (then a plain edge), left out otherwise; *agents in: the poses decide_on_reduced_graph started from, out: the
// solution (started from the reduced solution interpolated along the chain). Fills d->chain; *agents untouched
// when it fails.
void chain_with_decisions(const PoseGraphConfig& solver, const std::vector<RelativePoseEdge>& edges,
                          ReducedDecision* d, std::vector<Pose3>* agents);

}  // namespace qsg::backend
