// The scene graph as an embedded deformation graph (the paper's section "3D Scene Graph Optimization", after
// Sumner et al. 2007 and Kimera-PGMO): one pose per agent of the pose chain, per mesh control point and per place;
// edges for odometry and loop closures between agents (E_aa), between control points closer than a radius (E_mm),
// along a minimum spanning tree of the places (E_pp), from an agent to the control points first seen from it (E_am)
// and to its nearest places (E_ap), and from a place to the control point of its nearest basis point (E_mp).
// Relative-position edges weigh only translation (the paper's diag[0 0 0 w_t]); odometry edges carry the chain's
// covariances; loop closures go through graduated non-convexity with a truncated least-squares loss, so wrong ones
// switch themselves off. The solved graph then deforms any point of the odometric map by its nearest nodes
// (interpolation), and gives agents and places their optimized poses.
//
// Control points are kept incrementally (ControlPoints): the first mesh vertex seen in a cell of the spatial hash,
// with the time it was seen; fixed capacity, refusals counted. Building and solving the graph runs on the backend
// thread and allocates there (Ceres); nothing here is on the real-time path.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <cstdio>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/agents/agent_layer.h"
#include "core/backend/agent_pose_graph.h"
#include "core/backend/deformation_inputs.h"
#include "core/memory/fixed_hash_map.h"
#include "core/memory/resource_stats.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::backend {

struct DeformationConfig {
  double control_point_spacing_m = 1.0;  // spatial-hash cell of the mesh control points
  double control_edge_radius_m = 2.5;    // E_mm: control points closer than this (the paper's 2.5 m)
  std::uint32_t max_control_neighbours = 8;  // ... the nearest ones only
  // Relative-position edges: w_t = 1 / sigma^2, how much the map may bend. Stiffer, and the mesh (built from the
  // drifted odometry) holds the drift against the loop closures, which GNC then rejects.
  double sigma_position_m = 0.2;
  double place_control_radius_m = 2.0;   // E_mp: a place's nearest control point within this
  // Control points, places and points to interpolate are tied only to nodes seen within this time of them: a
  // revisit's mesh (drifted by what the loop closure corrects) must not be held to, or moved by, the first visit's.
  double time_horizon_s = 30.0;
  std::uint32_t interpolation_neighbours = 4;  // nodes that move a point (Sumner's k)
  // How the loop closures are decided. true: graduated non-convexity over the agent layer alone (the chain's
  // odometry and the loop closures, the only edges an outlier can be in), then the whole graph solved once by least
  // squares with the closures kept, starting from the agents' solution; false: GNC over the whole graph, as the
  // paper states it (every weighted solve then carries every control point and place). Same decisions where the
  // mesh is not what makes a closure inconsistent; bench/results/loop_closure.md has both.
  bool decide_on_agents = true;
  // decide_on_agents: the whole graph's solve starts from the agents' solution, close to its optimum; it stops at
  // this relative cost change (the agents' solve keeps the solver's own tolerance).
  double whole_function_tolerance = 1e-4;
  // decide_on_agents: the whole solve holds the agents at the agent layer's solution and moves the map (control
  // points and places) around them, the trajectory-first two-step of Whelan et al. 2016 (which the paper cites);
  // false: every node moves together, as the paper's problem states it. Held, the odometric map no longer pulls
  // the trajectory back towards its drift, and the solve is 2-4x cheaper (bench/results/loop_closure.md).
  bool hold_agents = true;
  // Agent nodes of the solved graph: one per this much odometric path (and every loop closure's two agents, the
  // first and the last); the chain nodes between two of them follow the pair's correction, interpolated along
  // the path. 0: every chain node (one per keyframe) is a node, as the graph grows by ~7 nodes a metre.
  double agent_spacing_m = 0.0;
  // ... or this much rotation since the last agent node (a quadruped turning on the spot moves no path, but the
  // map seen while it turns hangs from those nodes).
  double agent_turn_rad = 0.2;
  // Bounded solve (a refinement; with decide_on_agents and hold_agents only): a control point already in the last
  // solve, whose agents' corrections moved it less than this since then, keeps that solve's pose, held; the others,
  // those within settle_hops map edges of a moved node, and every place are solved. The solve's cost then follows
  // what the new closures moved, not the whole map (bench/results/loop_closure.md). 0: every map node is solved
  // every time.
  double settle_tolerance_m = 0.01;
  std::uint32_t settle_hops = 2;
  // Incremental decisions (a refinement; with decide_on_agents only): a solve after the first keeps the last solve's
  // decision on each of its closures (inliers become plain edges, outliers are left out) and starts the agent layer
  // from the last solution; GNC decides the new closures only. If an inlier kept so no longer fits (its residual
  // beyond the TLS threshold), the solve decides every closure again, from odometry, as without this.
  bool incremental_decisions = true;
  // Reduced decisions (a refinement; with decide_on_agents only, reduced_decisions.h): GNC decides the closures
  // (all of them, or the new ones with incremental_decisions) on the agent graph reduced to the closures' agents,
  // the odometry between them composed with its covariance; the whole chain is then solved by least squares with
  // those decisions. A decision's cost then follows the closures, not the chain's length; the same decisions on
  // the 1,010 m mission (bench/results/loop_closure.md, session (5)).
  bool reduced_decisions = true;
  // Rotation priors on the map nodes (a refinement; with decide_on_agents only): position-only edges hold a place's
  // or control point's rotation little, so where it lands depends on where the solve starts and when it stops. A
  // residual 2 vec(q_start^-1 q) / sigma pulls each solved map node towards the rotation the whole solve starts it
  // with: the correction of the agent it hangs from, carried. (GNC over the whole graph starts the map at identity,
  // the paper's initial value, where a prior would hold the map against the closures' rotation.) 0: none, as the
  // paper's problem states it. On for places: they then land where a tighter stopping rule lands them, nearer the
  // GVD, at half the solve's CPU; control points need none once the places are held (bench/results/loop_closure.md,
  // session of 2026-12-04).
  double place_rotation_sigma_rad = 0.3;
  double control_rotation_sigma_rad = 0.0;
  AgentGraphConfig agents;               // odometry sigma floors and the solver (loop closures under GNC-TLS)

  DeformationConfig() {
    agents.solver.loop_closure_loss = RobustLoss::kGncTls;
    agents.solver.max_iterations = 30;
    agents.solver.gnc_inner_iterations = 5;
  }
  std::string check() const;
  void print(std::FILE* out) const;
};

// Mesh control points: one per occupied cell of a spatial hash, at the first vertex seen there (odometric frame).
// offer() runs on the loop thread: fixed storage, no allocation after init. A revisit after the time horizon makes
// new ones, so on a long mission the store fills; when it is full, every second point of its older half (by
// arrival, which is time order) is dropped (a fold, counted): the oldest visits keep a coarser deformation, memory
// stays fixed, and nothing new is refused.
class ControlPoints {
 public:
  bool init(std::size_t capacity, double spacing_m, std::string* error);
  // Keeps p as a control point unless its cell has one; time_ns: when it was seen (ties it to an agent).
  // A cell seen again more than `horizon_ns` after its control point was made gets a new one (a revisit).
  bool offer(const Eigen::Vector3d& p_m, std::uint64_t time_ns);
  void set_horizon_ns(std::uint64_t horizon_ns) { horizon_ns_ = horizon_ns; }
  std::size_t size() const { return points_.size(); }
  const Eigen::Vector3d& point(std::size_t i) const { return points_[i]; }
  std::uint64_t time_ns(std::size_t i) const { return times_[i]; }
  ControlPointView view() const { return {points_.data(), times_.data(), points_.size()}; }
  double spacing_m() const { return spacing_m_; }
  memory::ResourceStats stats() const;
  std::uint64_t folds() const { return folds_; }
  std::uint64_t folded() const { return folded_; }  // points dropped by folds
  void clear();

 private:
  void fold_older_half();
  double spacing_m_ = 1.0;
  std::uint64_t horizon_ns_ = 30'000'000'000ull;
  std::vector<Eigen::Vector3d> points_;
  std::vector<std::uint64_t> times_;
  std::vector<std::uint64_t> cell_storage_;  // the hash map's slots (8-byte aligned)
  memory::FixedHashMap<std::uint64_t, std::uint32_t, memory::U64Hash> cells_{"backend.control_cells",
                                                                             memory::OverflowPolicy::kRefuse};
  std::uint64_t refused_ = 0;
  std::uint64_t folds_ = 0, folded_ = 0;
};

struct DeformationResult {
  std::size_t agents = 0, control_points = 0, places = 0;
  std::size_t agents_solved = 0;  // agent nodes in the solved graph (agent_spacing_m thins the chain's `agents`)
  std::size_t map_settled = 0;    // settle_tolerance_m: control points held at the last solve's pose (places never)
  // incremental_decisions: closures carried over decided, and whether GNC had to decide every closure again.
  std::size_t closures_carried = 0;
  bool decided_again = false;
  std::size_t edges_aa = 0, edges_mm = 0, edges_pp = 0, edges_am = 0, edges_ap = 0, edges_mp = 0;
  std::size_t loop_closures = 0;
  std::size_t loop_closures_kept = 0;  // GNC weight above 0.5 after the solve
  std::vector<double> loop_closure_weight;  // per loop closure, in input order
  PoseGraphResult solve;   // the whole graph's solve (with decide_on_agents: least squares with the kept closures)
  PoseGraphResult decide;  // decide_on_agents: GNC over the agent layer (its edge weights decide the closures)
  // reduced_decisions: the agents GNC decided on (the reduced graph; 0 when it ran on the whole layer), and the
  // whole agent layer's least-squares solve with those decisions.
  std::size_t agents_decided = 0;
  PoseGraphResult decide_chain;
  void print(std::FILE* out) const;
};

// The graph to solve, built from the scene graph (which it no longer needs): the caller can build it under the
// scene graph's lock and solve it without.
struct DeformationProblem {
  DeformationResult result;  // sizes; the solve fills the rest
  std::vector<Pose3> poses;  // agents [0, A), control points [A, A + C), places after
  std::vector<RelativePoseEdge> edges;
  std::size_t first_closure = 0;
  std::vector<Eigen::Vector3d> originals;      // control points and places: their odometric positions
  std::vector<std::uint64_t> times_ns;         // ... and when they were seen
  std::vector<scene_graph::NodeId> place_ids;
  // The chain nodes' times (strictly increasing), so the next solve finds its agents in this one after the chain
  // folded (which shifts their indices). Empty for a problem read from a file: indices are then taken as they are.
  std::vector<std::uint64_t> agent_times_ns;
  std::vector<std::uint64_t> closure_ids;  // each closure's ChainLoopClosure::id (empty for a problem from a file)
  // Chain nodes mapped in another frame correction than the node before them (agents::ChainNode::frame_t_m; the
  // frontend following the backend's correction): their poses jump by the change, their odometry edges do not.
  // Thinning keeps them, and composes the odometry into them from the edges. Empty in the odometry frame.
  std::vector<std::uint32_t> frame_changes;
  // The last chain node's frame correction (identity in the odometry frame): DeformationGraph::map_T_odom().
  Pose3 last_frame;
};

class DeformationGraph {
 public:
  explicit DeformationGraph(const DeformationConfig& config = {}) : config_(config) {}
  // Builds the graph from the chain, its loop closures, the control points and the graph's places (and the agents'
  // place edges).
  DeformationProblem build(const agents::ChainView& agents, const std::vector<ChainLoopClosure>& loop_closures,
                           const ControlPoints& control, const scene_graph::SceneGraph& graph) const;
  // The same from a copy of the chain, the control points and the graph's places (DeformationInputs::copy).
  DeformationProblem build(const DeformationInputs& inputs, const std::vector<ChainLoopClosure>& loop_closures) const;
  // Solves it and, on success, makes it the deformation in use; on failure the previous one (or none) stays.
  DeformationResult solve(DeformationProblem problem);
  // build() then solve().
  DeformationResult optimize(const agents::ChainView& agents, const std::vector<ChainLoopClosure>& loop_closures,
                             const ControlPoints& control, const scene_graph::SceneGraph& graph) {
    return solve(build(agents, loop_closures, control, graph));
  }

  bool solved() const { return solved_; }
  // An odometric point seen at time_ns moved by its nearest deformation nodes seen within the time horizon of it
  // (any time when none is, or when time_ns is 0); identity before any solve.
  Eigen::Vector3d deform(const Eigen::Vector3d& p_m, std::uint64_t time_ns = 0) const;
  // The optimized pose of chain node k (the odometric one before any solve, or beyond the solved chain).
  Pose3 agent_pose(std::size_t k) const { return k < agent_poses_.size() ? agent_poses_[k] : Pose3{}; }
  // The optimized pose of the chain node seen at time_ns, found by its time (the chain may have folded since the
  // solve); false when the solve did not have it (a node added since: tail_correction() * its odometric pose).
  bool agent_pose_at(std::uint64_t time_ns, Pose3* out) const;
  // The last solved chain node's correction (optimized * odometric^-1), for the nodes added since.
  const Pose3& tail_correction() const { return tail_correction_; }
  // The odometry frame onto the last solution, at the last solved chain node (optimized * odometric^-1): where
  // the frontend maps the keyframes that follow (LoopClosureConfig::map_in_corrected_frame), and the correction of
  // a node added since.
  Pose3 map_T_odom() const { return tail_correction_ * tail_frame_; }
  std::size_t num_agent_poses() const { return agent_poses_.size(); }
  // The last solve's weight of the closure named `id` (ChainLoopClosure::id; above 0.5: kept), or false when it had
  // no closure of that name.
  bool closure_weight(std::uint64_t id, double* weight) const;
  // A place's optimized position, or false when the place was not in the solved graph.
  bool place_position(scene_graph::NodeId id, Eigen::Vector3d* out) const;
  const DeformationConfig& config() const { return config_; }
  // The solved map nodes: the control points [0, C) then the places, in the solved problem's order.
  std::size_t num_map_nodes() const { return nodes_.size(); }
  const Pose3& map_node_pose(std::size_t i) const { return nodes_[i].optimized; }

 private:
  struct Node {
    Eigen::Vector3d original = Eigen::Vector3d::Zero();
    std::uint64_t time_ns = 0;
    Pose3 optimized;
  };
  std::uint64_t cell_key(const Eigen::Vector3d& p) const;
  void index_nodes();
  // settle_tolerance_m: marks in *held the map nodes that keep the last solve's pose (and sets it in *solved);
  // `kept` maps solved agents to chain nodes (empty: one to one). Returns how many.
  std::size_t settle(const DeformationProblem& problem, const std::vector<std::uint32_t>& kept,
                     const std::vector<std::uint64_t>& chain_times, std::vector<Pose3>* solved,
                     std::vector<char>* held) const;
  // The last solve's index of this problem's chain node k (chain_times: the problem's agent_times_ns), found by
  // time; -1 when the last solve did not have it. Without times on either side, k itself when in range.
  std::int64_t last_agent(const std::vector<std::uint64_t>& chain_times, std::size_t k) const;
  // The last solve's index of this problem's closure c (ids: the problem's closure_ids), found by its id; without ids
  // on either side, c itself. -1 when the last solve did not have it.
  std::int64_t last_closure(const std::vector<std::uint64_t>& ids, std::size_t c) const;
  // incremental_decisions: the agent layer with the last solve's decisions, GNC over the new closures; false (and
  // *r untouched) when there is nothing to carry over or a carried inlier no longer fits.
  bool decide_incrementally(const DeformationProblem& problem, const std::vector<std::uint32_t>& kept,
                            const std::vector<std::pair<std::uint32_t, std::uint32_t>>& ends,
                            const std::vector<std::uint64_t>& chain_times, const std::vector<std::uint64_t>& ids,
                            std::vector<Pose3>* solved, DeformationResult* r) const;

  DeformationConfig config_;
  bool solved_ = false;
  std::vector<Pose3> agent_poses_;
  std::vector<std::uint64_t> agent_times_;  // agent_poses_' chain node times (empty: unknown)
  std::vector<Node> nodes_;  // control points then places: what interpolation reads
  std::size_t control_points_ = 0;  // of nodes_, the control points
  // The last solve's closures (their chain nodes) and weights, and the correction of its last chain node.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> closure_ends_;
  std::vector<double> closure_weights_;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> closure_by_id_;  // sorted (id, index); empty: by index
  Pose3 tail_correction_;
  Pose3 tail_frame_;  // the last solved chain node's frame correction (DeformationProblem::last_frame)
  std::unordered_map<scene_graph::NodeId, std::uint32_t> place_node_;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> cells_;  // sorted (cell, node)
  // build(): the E_mm neighbours of the control points that can gain none any more (seen more than the time horizon
  // before the newest, control points coming in time order), kept from one build to the next. Their search was most
  // of a build's time (bench/results/loop_closure.md). build() is not reentrant.
  std::size_t reusable_control_edges(const ControlPointView& control, bool* in_order) const;
  void keep_control_edges(const Eigen::Vector3d& point, const std::vector<std::uint32_t>& neighbours,
                          std::size_t* final_points) const;
  mutable std::vector<std::uint32_t> mm_neighbours_;  // control point indices, each final point's in turn ...
  mutable std::vector<std::uint32_t> mm_begin_;       // ... point i's from mm_begin_[i] to mm_begin_[i + 1]
  mutable Eigen::Vector3d mm_last_point_ = Eigen::Vector3d::Zero();  // the last final point (a changed set: cleared)
};

}  // namespace qsg::backend
