// The embedded deformation graph: build (agents, control points, places and their edges), solve, interpolate.
#include "core/backend/deformation_graph.h"

#include "core/backend/backend_params.h"
#include "core/backend/reduced_decisions.h"
#include "core/memory/prefault.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace qsg::backend {

std::string DeformationConfig::check() const {
  // Each field the app exposes within its declared range (backend_params.cc).
  if (std::string why = params::check(deformation_params_table(), *this); !why.empty()) return why;
  if (!(control_point_spacing_m >= 0.1 && control_point_spacing_m <= 20.0))
    return "control_point_spacing_m must be in [0.1, 20] m";
  if (!(control_edge_radius_m > 0.0 && control_edge_radius_m <= 50.0)) return "control_edge_radius_m must be in (0, 50] m";
  if (max_control_neighbours < 1 || max_control_neighbours > 64) return "max_control_neighbours must be in [1, 64]";
  if (!(place_control_radius_m >= 0.0 && place_control_radius_m <= 50.0)) return "place_control_radius_m must be in [0, 50] m";
  if (interpolation_neighbours < 1 || interpolation_neighbours > 16) return "interpolation_neighbours must be in [1, 16]";
  if (!(time_horizon_s > 0.0 && time_horizon_s <= 86400.0)) return "time_horizon_s must be in (0, 86400] s";
  if (!(whole_function_tolerance > 0.0 && whole_function_tolerance < 1.0))
    return "whole_function_tolerance must be in (0, 1)";
  if (!(agent_spacing_m >= 0.0 && agent_spacing_m <= 100.0)) return "agent_spacing_m must be in [0, 100] m";
  if (!(agent_turn_rad > 0.0 && agent_turn_rad <= 3.2)) return "agent_turn_rad must be in (0, 3.2] rad";
  return agents.check();
}

void DeformationConfig::print(std::FILE* out) const {
  std::fprintf(out,
               "deformation graph: control points every %.2f m, joined within %.2f m (<= %u), position sigma %.3f m, "
               "place to control point within %.2f m, %u nodes per interpolated point, time horizon %.0f s\n",
               control_point_spacing_m, control_edge_radius_m, max_control_neighbours, sigma_position_m,
               place_control_radius_m, interpolation_neighbours, time_horizon_s);
  if (agent_spacing_m > 0.0)
    std::fprintf(out, "deformation graph: an agent node every %.2f m of path (and at every loop closure)\n",
                 agent_spacing_m);
  if (settle_tolerance_m > 0.0 && decide_on_agents && hold_agents)
    std::fprintf(out,
                 "deformation graph: control points moved less than %.3f m since the last solve stay held (%u hops)\n",
                 settle_tolerance_m, settle_hops);
  if ((place_rotation_sigma_rad > 0.0 || control_rotation_sigma_rad > 0.0) && decide_on_agents)
    std::fprintf(out, "deformation graph: map rotations held to their start by priors, sigma %.3g rad (places), "
                 "%.3g rad (control points; 0: none)\n", place_rotation_sigma_rad, control_rotation_sigma_rad);
  if (incremental_decisions && decide_on_agents)
    std::fprintf(out, "deformation graph: a solve keeps the last one's decisions and decides its new closures\n");
  if (reduced_decisions && decide_on_agents)
    std::fprintf(out, "deformation graph: closures decided on the agent graph reduced to their agents\n");
  std::fprintf(out, "deformation graph: loop closures decided %s\n",
               !decide_on_agents ? "by GNC over the whole graph"
               : hold_agents     ? "by GNC on the agent layer, then the map by least squares around the agents, held"
                                 : "by GNC on the agent layer, then the whole graph by least squares");
  agents.print(out);
}

void DeformationResult::print(std::FILE* out) const {
  std::fprintf(out,
               "deformation graph: %zu agents (%zu solved), %zu control points, %zu places; edges aa %zu mm %zu pp %zu "
               "am %zu ap %zu mp %zu; %zu of %zu loop closures kept (%zu decisions carried%s); %zu control points held; ",
               agents, agents_solved, control_points, places, edges_aa, edges_mm, edges_pp, edges_am, edges_ap, edges_mp,
               loop_closures_kept, loop_closures, closures_carried, decided_again ? ", all decided again" : "",
               map_settled);
  solve.print(out);
  if (decide.iterations > 0) {
    std::fprintf(out, "deformation graph: decided on the agent layer: ");
    decide.print(out);
  }
  if (agents_decided > 0) {
    std::fprintf(out, "deformation graph: decided on %zu agents, then the agent layer solved with the decisions: ",
                 agents_decided);
    decide_chain.print(out);
  }
}

namespace {

std::uint64_t pack_cell(std::int64_t x, std::int64_t y, std::int64_t z) {
  const auto u = [](std::int64_t v) { return static_cast<std::uint64_t>(v + (1 << 20)) & 0x1FFFFF; };
  return u(x) | (u(y) << 21) | (u(z) << 42);
}

std::uint64_t cell_of(const Eigen::Vector3d& p, double spacing) {
  return pack_cell(static_cast<std::int64_t>(std::floor(p.x() / spacing)),
                   static_cast<std::int64_t>(std::floor(p.y() / spacing)),
                   static_cast<std::int64_t>(std::floor(p.z() / spacing)));
}

// A relative-position measurement from `from` to `to`: translation only (rotation information ~0).
RelativePoseEdge position_edge(std::uint32_t from, std::uint32_t to, const Pose3& from_pose, const Eigen::Vector3d& to_m,
                               double sigma_m) {
  RelativePoseEdge e;
  e.from = from;
  e.to = to;
  e.measured_from_T_to.t_m = from_pose.q.conjugate() * (to_m - from_pose.t_m);
  e.measured_from_T_to.q = from_pose.q.conjugate();  // the `to` node starts with identity rotation
  e.has_information = true;
  e.information.setZero();
  e.information.diagonal() << Eigen::Vector3d::Constant(1.0 / (sigma_m * sigma_m)), Eigen::Vector3d::Constant(1e-8);
  return e;
}

struct UnionFind {
  std::vector<std::uint32_t> parent;
  explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  std::uint32_t find(std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  bool unite(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return false;
    parent[a] = b;
    return true;
  }
};

}  // namespace

// ---------------------------------------------------------------------------------------------------------
// Control points

bool ControlPoints::init(std::size_t capacity, double spacing_m, std::string* error) {
  if (capacity == 0 || !(spacing_m >= 0.1 && spacing_m <= 20.0))
    return *error = "control points: capacity must be positive and the spacing in [0.1, 20] m", false;
  spacing_m_ = spacing_m;
  points_.clear();
  times_.clear();
  points_.reserve(capacity);
  times_.reserve(capacity);
  memory::prefault_capacity(&points_);
  memory::prefault_capacity(&times_);
  const std::size_t slots = decltype(cells_)::slots_for(capacity);
  cell_storage_.assign((decltype(cells_)::storage_bytes(slots) + 7) / 8, 0);
  cells_.bind(cell_storage_.data(), slots, capacity);
  refused_ = 0;
  return true;
}

void ControlPoints::clear() {
  points_.clear();
  times_.clear();
  cells_.clear();
  folds_ = folded_ = 0;
}

bool ControlPoints::offer(const Eigen::Vector3d& p_m, std::uint64_t time_ns) {
  if (!p_m.allFinite() || points_.capacity() == 0) return false;
  bool inserted = false;
  if (points_.size() == points_.capacity()) {
    const std::uint32_t* slot = cells_.find(cell_of(p_m, spacing_m_));
    if (slot != nullptr && time_ns <= times_[*slot] + horizon_ns_) return false;  // not needed
    fold_older_half();
  }
  const auto next = static_cast<std::uint32_t>(points_.size());
  std::uint32_t* slot = cells_.find_or_insert(cell_of(p_m, spacing_m_), next, &inserted);
  if (slot == nullptr) {
    ++refused_;
    return false;
  }
  if (!inserted) {
    if (time_ns <= times_[*slot] + horizon_ns_) return false;  // the cell's control point is recent enough
    *slot = next;  // a revisit: a new control point, the cell's newest
  }
  points_.push_back(p_m);
  times_.push_back(time_ns);
  return true;
}

// Drops every second point of the older half (the first of them included, so at least one goes), in place, and
// re-indexes the cells: each cell to its newest remaining point. No allocation.
void ControlPoints::fold_older_half() {
  const std::size_t n = points_.size(), half = std::max<std::size_t>(1, n / 2);
  std::size_t kept = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (i < half && i % 2 == 0) continue;
    points_[kept] = points_[i];
    times_[kept] = times_[i];
    ++kept;
  }
  folded_ += n - kept;
  ++folds_;
  points_.resize(kept);
  times_.resize(kept);
  cells_.clear();
  for (std::size_t i = 0; i < kept; ++i) {
    bool inserted = false;
    std::uint32_t* slot = cells_.find_or_insert(cell_of(points_[i], spacing_m_), static_cast<std::uint32_t>(i), &inserted);
    if (slot != nullptr) *slot = static_cast<std::uint32_t>(i);  // points in arrival order: the newest wins
  }
}

memory::ResourceStats ControlPoints::stats() const {
  memory::ResourceStats s;
  s.name = "backend.control_points";
  s.unit = "points";
  s.capacity = points_.capacity();
  s.in_use = points_.size();
  s.high_water = points_.size();
  s.failed = refused_;
  return s;
}

// ---------------------------------------------------------------------------------------------------------
// Build and solve

std::uint64_t DeformationGraph::cell_key(const Eigen::Vector3d& p) const {
  return cell_of(p, config_.control_point_spacing_m);
}

// The cached E_mm lists still describe this set of control points (append-only, in time order), or start again:
// how many leading points have theirs.
std::size_t DeformationGraph::reusable_control_edges(const ControlPointView& control, bool* in_order) const {
  const std::size_t C = control.size();
  std::size_t final_points = mm_begin_.empty() ? 0 : mm_begin_.size() - 1;
  *in_order = true;
  for (std::size_t i = 1; i < C && *in_order; ++i) *in_order = control.time_ns(i) >= control.time_ns(i - 1);
  if (!*in_order || final_points > C || (final_points > 0 && control.point(final_points - 1) != mm_last_point_)) {
    mm_neighbours_.clear();
    mm_begin_.clear();
    final_points = 0;
  }
  if (mm_begin_.empty()) mm_begin_.push_back(0);
  return final_points;
}

void DeformationGraph::keep_control_edges(const Eigen::Vector3d& point, const std::vector<std::uint32_t>& neighbours,
                                          std::size_t* final_points) const {
  mm_neighbours_.insert(mm_neighbours_.end(), neighbours.begin(), neighbours.end());
  mm_begin_.push_back(static_cast<std::uint32_t>(mm_neighbours_.size()));
  mm_last_point_ = point;
  ++*final_points;
}

namespace {

// Each closure's name; none when one is unnamed (all are then known by index).
std::vector<std::uint64_t> closure_ids(const std::vector<ChainLoopClosure>& closures) {
  std::vector<std::uint64_t> ids;
  if (!std::all_of(closures.begin(), closures.end(), [](const ChainLoopClosure& c) { return c.id != 0; })) return ids;
  for (const ChainLoopClosure& c : closures) ids.push_back(c.id);
  return ids;
}

// DeformationProblem::frame_changes of a chain, and its last node's frame (last_frame).
std::vector<std::uint32_t> frame_changes(const agents::ChainView& agents, Pose3* last_frame) {
  std::vector<std::uint32_t> out;
  const agents::ChainNode& last = agents.chain(agents.chain_size() - 1);
  *last_frame = Pose3{last.frame_t_m, last.frame_q};
  for (std::size_t k = 1; k < agents.chain_size(); ++k) {
    const agents::ChainNode &a = agents.chain(k - 1), &b = agents.chain(k);
    if (a.frame_t_m != b.frame_t_m || a.frame_q.coeffs() != b.frame_q.coeffs())
      out.push_back(static_cast<std::uint32_t>(k));
  }
  return out;
}
}  // namespace

DeformationProblem DeformationGraph::build(const agents::ChainView& agents,
                                           const std::vector<ChainLoopClosure>& loop_closures,
                                           const ControlPoints& control, const scene_graph::SceneGraph& graph) const {
  DeformationInputs in;
  in.copy(agents, control.view(), graph);
  return build(in, loop_closures);
}

DeformationProblem DeformationGraph::build(const DeformationInputs& in,
                                           const std::vector<ChainLoopClosure>& loop_closures) const {
  const agents::ChainView agents = in.chain_view();
  const ControlPointView control = in.control_view();
  DeformationProblem problem;
  DeformationResult& r = problem.result;
  const std::size_t A = agents.chain_size();
  const std::size_t C = control.size();
  r.agents = A;
  r.control_points = C;
  r.loop_closures = loop_closures.size();
  if (A < 2) {
    r.solve.status = PoseGraphStatus::kInvalidInput;
    r.solve.message = "fewer than two agent poses";
    return problem;
  }
  // Places: index them after the control points.
  std::unordered_map<scene_graph::NodeId, std::uint32_t> place_index;
  std::vector<scene_graph::NodeId>& place_ids = problem.place_ids;
  for (const DeformationInputs::Place& p : in.places) {
    place_index.emplace(p.id, static_cast<std::uint32_t>(A + C + place_ids.size()));
    place_ids.push_back(p.id);
  }
  r.places = place_ids.size();
  std::vector<Pose3>& poses = problem.poses;
  poses.reserve(A + C + place_ids.size());
  for (std::size_t k = 0; k < A; ++k) poses.push_back(Pose3{agents.chain(k).t_m, agents.chain(k).q});
  problem.agent_times_ns.reserve(A);
  for (std::size_t k = 0; k < A; ++k) problem.agent_times_ns.push_back(agents.chain(k).time_ns);
  problem.frame_changes = frame_changes(agents, &problem.last_frame);
  for (std::size_t i = 0; i < C; ++i) poses.push_back(Pose3{control.point(i), Eigen::Quaterniond::Identity()});
  for (const DeformationInputs::Place& p : in.places) poses.push_back(Pose3{p.position_m, Eigen::Quaterniond::Identity()});

  // E_aa: odometry along the chain, then the loop closures (GNC).
  std::vector<RelativePoseEdge>& edges = problem.edges;
  edges = chain_odometry_edges(agents, config_.agents);
  r.edges_aa = edges.size();
  problem.first_closure = edges.size();
  for (const ChainLoopClosure& c : loop_closures) edges.push_back(loop_closure_edge(c));
  problem.closure_ids = closure_ids(loop_closures);
  const double sigma = config_.sigma_position_m;
  // The chain node a time belongs to: the last one at or before it.
  const auto agent_at = [&](std::uint64_t t) {
    std::size_t lo = 0, hi = A;
    while (hi - lo > 1) {
      const std::size_t mid = (lo + hi) / 2;
      (agents.chain(mid).time_ns <= t ? lo : hi) = mid;
    }
    return static_cast<std::uint32_t>(lo);
  };
  // Control points by cell for the neighbour searches.
  std::unordered_multimap<std::uint64_t, std::uint32_t> cp_cells;
  cp_cells.reserve(C);
  for (std::size_t i = 0; i < C; ++i) cp_cells.emplace(cell_key(control.point(i)), static_cast<std::uint32_t>(i));
  const double spacing = config_.control_point_spacing_m;
  const auto horizon_ns = static_cast<std::uint64_t>(config_.time_horizon_s * 1e9);
  const auto within_horizon = [&](std::uint64_t a, std::uint64_t b) { return (a > b ? a - b : b - a) <= horizon_ns; };
  // Control points within `radius` of p seen within the time horizon of time_ns, nearest first.
  const auto near_control = [&](const Eigen::Vector3d& p, std::uint64_t time_ns, double radius,
                                std::vector<std::pair<double, std::uint32_t>>* out) {
    out->clear();
    const int reach = static_cast<int>(std::ceil(radius / spacing));
    const Eigen::Vector3d c = (p / spacing).array().floor();
    for (int dx = -reach; dx <= reach; ++dx)
      for (int dy = -reach; dy <= reach; ++dy)
        for (int dz = -reach; dz <= reach; ++dz) {
          const auto range = cp_cells.equal_range(pack_cell(static_cast<std::int64_t>(c.x()) + dx,
                                                            static_cast<std::int64_t>(c.y()) + dy,
                                                            static_cast<std::int64_t>(c.z()) + dz));
          for (auto it = range.first; it != range.second; ++it) {
            if (!within_horizon(control.time_ns(it->second), time_ns)) continue;
            const double d = (control.point(it->second) - p).norm();
            if (d <= radius) out->emplace_back(d, it->second);
          }
        }
    std::sort(out->begin(), out->end());
  };
  std::vector<std::pair<double, std::uint32_t>> near;
  bool in_order = true;
  std::size_t final_points = reusable_control_edges(control, &in_order);
  std::vector<std::uint32_t> fresh;  // a point's neighbours when searched now
  // E_am and E_mm.
  for (std::size_t i = 0; i < C; ++i) {
    const auto node = static_cast<std::uint32_t>(A + i);
    const std::uint32_t k = agent_at(control.time_ns(i));
    edges.push_back(position_edge(k, node, poses[k], control.point(i), sigma));
    ++r.edges_am;
    if (i < final_points) {
      fresh.assign(mm_neighbours_.begin() + mm_begin_[i], mm_neighbours_.begin() + mm_begin_[i + 1]);
    } else {
      near_control(control.point(i), control.time_ns(i), config_.control_edge_radius_m, &near);
      fresh.clear();
      for (const auto& [d, j] : near)
        if (j != i && fresh.size() < config_.max_control_neighbours) fresh.push_back(j);
      // Final once no control point to come can be within the horizon of it: the list is kept for the next build.
      if (in_order && i == final_points && control.time_ns(C - 1) > control.time_ns(i) + horizon_ns)
        keep_control_edges(control.point(i), fresh, &final_points);
    }
    for (const std::uint32_t j : fresh) {
      edges.push_back(position_edge(node, static_cast<std::uint32_t>(A + j), poses[node], control.point(j), sigma));
      ++r.edges_mm;
    }
  }
  // E_pp: a minimum spanning tree of the place-place edges (Kruskal); E_ap: agents to their places; E_mp.
  std::vector<std::pair<double, std::pair<std::uint32_t, std::uint32_t>>> place_edges;
  std::unordered_map<scene_graph::NodeId, std::uint32_t> agent_index;
  for (std::size_t k = 0; k < A; ++k) agent_index.emplace(agents.chain(k).id, static_cast<std::uint32_t>(k));
  for (const auto& [source, target] : in.edges) {
    const auto ps = place_index.find(source), pt = place_index.find(target);
    if (ps != place_index.end() && pt != place_index.end()) {
      place_edges.push_back({(poses[ps->second].t_m - poses[pt->second].t_m).norm(), {ps->second, pt->second}});
      continue;
    }
    const auto as = agent_index.find(source), at = agent_index.find(target);
    if (as != agent_index.end() && pt != place_index.end()) {
      edges.push_back(position_edge(as->second, pt->second, poses[as->second], poses[pt->second].t_m, sigma));
      ++r.edges_ap;
    } else if (at != agent_index.end() && ps != place_index.end()) {
      edges.push_back(position_edge(at->second, ps->second, poses[at->second], poses[ps->second].t_m, sigma));
      ++r.edges_ap;
    }
  }
  std::sort(place_edges.begin(), place_edges.end());
  UnionFind forest(poses.size());
  for (const auto& [length, ends] : place_edges) {
    if (!forest.unite(ends.first, ends.second)) continue;
    edges.push_back(position_edge(ends.first, ends.second, poses[ends.first], poses[ends.second].t_m, sigma));
    ++r.edges_pp;
  }
  for (std::size_t p = 0; p < place_ids.size(); ++p) {
    const auto node = static_cast<std::uint32_t>(A + C + p);
    near_control(in.places[p].basis_m, in.places[p].time_ns, config_.place_control_radius_m, &near);
    if (near.empty()) continue;
    edges.push_back(position_edge(node, static_cast<std::uint32_t>(A + near[0].second), poses[node],
                                  control.point(near[0].second), sigma));
    ++r.edges_mp;
  }

  problem.originals.reserve(C + place_ids.size());
  problem.times_ns.reserve(C + place_ids.size());
  for (std::size_t i = 0; i < C; ++i) {
    problem.originals.push_back(control.point(i));
    problem.times_ns.push_back(control.time_ns(i));
  }
  for (const DeformationInputs::Place& p : in.places) {
    problem.originals.push_back(p.position_m);
    problem.times_ns.push_back(p.time_ns);
  }
  return problem;
}

namespace {

void carry_map(const DeformationProblem& problem, const std::vector<Pose3>& agents, std::vector<Pose3>* poses);

// decide_on_agents, first step: GNC over the agents and the edges between them; the closures' weights in input
// order into *weights, the agents' solution into the first A poses, every other node carried along rigidly with the
// agent it hangs from (an E_am or E_ap edge, else its place's control point), as the start of the whole solve.
// reduced: GNC on the reduced agent graph, then the chain by least squares with its decisions (*chain: that solve).
PoseGraphResult decide_on_agents(const PoseGraphConfig& solver, const DeformationProblem& problem,
                                 std::vector<Pose3>* poses, std::vector<double>* weights, bool reduced,
                                 PoseGraphResult* chain, std::size_t* agents_decided) {
  const std::size_t A = problem.result.agents_solved;
  std::vector<Pose3> agents(poses->begin(), poses->begin() + static_cast<std::ptrdiff_t>(A));
  std::vector<RelativePoseEdge> edges;
  std::vector<std::size_t> closure_edge;  // per loop closure: its index in `edges`
  for (std::size_t k = 0; k < problem.edges.size(); ++k) {
    const RelativePoseEdge& e = problem.edges[k];
    if (e.from >= A || e.to >= A) continue;
    if (k >= problem.first_closure && k < problem.first_closure + problem.result.loop_closures)
      closure_edge.push_back(edges.size());
    edges.push_back(e);
  }
  PoseGraphResult r;
  ReducedDecision d;
  if (reduced && decide_on_reduced_graph(solver, agents, edges, problem.first_closure, &d)) {
    *agents_decided = d.graph.kept.size();
    if (d.decide.poses_updated()) {
      chain_with_decisions(solver, edges, &d, &agents);
      if (!d.chain.poses_updated()) return *chain = std::move(d.chain);
      *chain = std::move(d.chain);
    }
    r = std::move(d.decide);
  } else {
    r = optimize_pose_graph(solver, agents, edges);
  }
  if (!r.poses_updated()) return r;
  weights->clear();
  for (std::size_t i : closure_edge) weights->push_back(r.edge_weight.empty() ? 1.0 : r.edge_weight[i]);
  carry_map(problem, agents, poses);
  return r;
}

// Every map node carried rigidly with the agent it hangs from (an E_am or E_ap edge, else its place's control
// point), from the agents' poses in *poses (the odometric ones) to `agents`, which then replace them.
void carry_map(const DeformationProblem& problem, const std::vector<Pose3>& agents, std::vector<Pose3>* poses) {
  const std::size_t A = agents.size();
  std::vector<std::int64_t> anchor(poses->size(), -1);
  for (const RelativePoseEdge& e : problem.edges)
    if (e.from < A && e.to >= A && anchor[e.to] < 0) anchor[e.to] = e.from;
  for (const RelativePoseEdge& e : problem.edges)  // E_mp: a place without an agent edge follows its control point
    if (e.from >= A && e.to >= A && anchor[e.from] < 0 && anchor[e.to] >= 0) anchor[e.from] = anchor[e.to];
  for (std::size_t i = A; i < poses->size(); ++i) {
    if (anchor[i] < 0) continue;
    const Pose3& before = (*poses)[static_cast<std::size_t>(anchor[i])];
    const Pose3& after = agents[static_cast<std::size_t>(anchor[i])];
    const Eigen::Quaterniond dq = after.q * before.q.conjugate();
    (*poses)[i].t_m = after.t_m + dq * ((*poses)[i].t_m - before.t_m);
    (*poses)[i].q = (dq * (*poses)[i].q).normalized();
  }
  std::copy(agents.begin(), agents.end(), poses->begin());
}

// DeformationConfig::place_rotation_sigma_rad, control_rotation_sigma_rad: a prior per solved map node (original
// index i >= A, at where[i] in the solve, which holds the first num_held) towards its rotation at the solve's start.
std::vector<RotationPrior> map_rotation_priors(const DeformationConfig& config, std::size_t A, std::size_t C,
                                               const std::vector<Pose3>& start, const std::vector<std::uint32_t>& where,
                                               std::size_t num_held) {
  std::vector<RotationPrior> priors;
  if (!(config.place_rotation_sigma_rad > 0.0 || config.control_rotation_sigma_rad > 0.0)) return priors;
  for (std::size_t i = A; i < start.size(); ++i) {
    const double sigma = i < A + C ? config.control_rotation_sigma_rad : config.place_rotation_sigma_rad;
    if (sigma > 0.0 && where[i] >= num_held) priors.push_back(RotationPrior{where[i], start[i].q, sigma});
  }
  return priors;
}

// DeformationConfig::agent_spacing_m: the problem with one agent node per `spacing_m` of odometric path or
// `turn_rad` of rotation (plus the first, the last and every loop closure's two agents). The odometry edges
// between two kept agents compose into one, their covariances carried into its frame to first order (through the
// adjoint: a step's rotation noise moves the far end by its lever arm); an edge from or to a dropped agent moves to
// the kept agent before it, its measurement composed with the odometry between the two (the same geometry).
// *kept: the chain index of each kept agent.
DeformationProblem thin_agents(DeformationProblem in, double spacing_m, double turn_rad,
                               std::vector<std::uint32_t>* kept) {
  const std::size_t A = in.result.agents;
  std::vector<char> keep(A, 0);
  keep[0] = keep[A - 1] = 1;
  for (std::size_t c = 0; c < in.result.loop_closures; ++c) {
    const RelativePoseEdge& e = in.edges[in.first_closure + c];
    if (e.from < A) keep[e.from] = 1;
    if (e.to < A) keep[e.to] = 1;
  }
  std::vector<char> frame_change(A, 0);
  for (std::uint32_t k : in.frame_changes)
    if (k < A) keep[k] = frame_change[k] = 1;
  double since = 0.0;
  std::size_t last = 0;
  for (std::size_t k = 1; k < A; ++k) {
    since += (in.poses[k].t_m - in.poses[k - 1].t_m).norm();
    if (since >= spacing_m || in.poses[last].q.angularDistance(in.poses[k].q) >= turn_rad) keep[k] = 1;
    if (keep[k]) {
      since = 0.0;
      last = k;
    }
  }
  kept->clear();
  std::vector<std::uint32_t> owner(A);  // chain node -> the reduced index of the kept agent at or before it
  for (std::size_t k = 0; k < A; ++k) {
    if (keep[k]) kept->push_back(static_cast<std::uint32_t>(k));
    owner[k] = static_cast<std::uint32_t>(kept->size() - 1);
  }
  const std::size_t K = kept->size();
  const auto shift = static_cast<std::uint32_t>(A - K);
  const auto remap = [&](std::uint32_t i) { return i < A ? owner[i] : i - shift; };
  DeformationProblem out;
  out.result = in.result;
  out.result.agents_solved = K;
  out.poses.reserve(in.poses.size() - (A - K));
  for (std::uint32_t k : *kept) out.poses.push_back(in.poses[k]);
  out.poses.insert(out.poses.end(), in.poses.begin() + static_cast<std::ptrdiff_t>(A), in.poses.end());
  // Odometry: the chain's edges k -> k + 1 come first, in order.
  const std::size_t odometry = in.first_closure;  // edges_aa is not kept by every writer of a problem
  for (std::size_t j = 0; j + 1 < K; ++j) {
    const std::uint32_t a = (*kept)[j], b = (*kept)[j + 1];
    // The poses of a..b in a's frame correction: b's, when it was mapped in another one (kept then, so only b can
    // be), from the odometry edge into it.
    Pose3 pose_b = in.poses[b];
    if (frame_change[b] && b - 1 < odometry) pose_b = in.poses[b - 1] * in.edges[b - 1].measured_from_T_to;
    const auto pose_at = [&](std::uint32_t k) -> const Pose3& { return k == b ? pose_b : in.poses[k]; };
    RelativePoseEdge e;
    e.from = static_cast<std::uint32_t>(j);
    e.to = static_cast<std::uint32_t>(j + 1);
    e.measured_from_T_to = between(in.poses[a], pose_b);
    // Each step's noise, a perturbation in its `to` frame k + 1, seen in b's frame through the adjoint of b_T_(k+1)
    // (first order): rotation noise moves b by its lever arm too.
    Matrix6d cov = Matrix6d::Zero();
    for (std::uint32_t k = a; k < b && k < odometry; ++k) {
      const Matrix6d ad = adjoint(between(pose_b, pose_at(k + 1)));
      cov += ad * covariance_in_to_frame(in.edges[k]) * ad.transpose();
    }
    e.has_information = true;
    const Matrix6d info = cov.inverse();
    e.information = 0.5 * (info + info.transpose());
    out.edges.push_back(e);
  }
  out.result.edges_aa = out.edges.size();
  out.first_closure = out.edges.size();
  for (std::size_t k = odometry; k < in.edges.size(); ++k) {
    RelativePoseEdge e = in.edges[k];
    if (e.from < A && !keep[e.from]) {  // a position edge from a dropped agent: from the kept one before it
      const std::uint32_t a = (*kept)[owner[e.from]];
      e.measured_from_T_to = between(in.poses[a], in.poses[e.from]) * e.measured_from_T_to;
    }
    if (e.to < A && !keep[e.to]) {
      const std::uint32_t a = (*kept)[owner[e.to]];
      e.measured_from_T_to = e.measured_from_T_to * between(in.poses[e.to], in.poses[a]);
    }
    e.from = remap(e.from);
    e.to = remap(e.to);
    out.edges.push_back(e);
  }
  out.originals = std::move(in.originals);
  out.times_ns = std::move(in.times_ns);
  out.place_ids = std::move(in.place_ids);
  out.frame_changes = std::move(in.frame_changes);  // chain indices, as agent_times_ns
  return out;
}

}  // namespace

DeformationResult DeformationGraph::solve(DeformationProblem problem) {
  if (problem.poses.empty()) return problem.result;
  problem.result.agents_solved = problem.result.agents;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> ends;  // each closure's chain nodes (before any thinning)
  for (std::size_t c = 0; c < problem.result.loop_closures; ++c)
    ends.emplace_back(problem.edges[problem.first_closure + c].from, problem.edges[problem.first_closure + c].to);
  std::vector<std::uint32_t> kept;
  const std::vector<std::uint64_t> chain_times = problem.agent_times_ns;  // before any thinning
  std::vector<std::uint64_t> ids = problem.closure_ids;
  if (ids.size() != problem.result.loop_closures) ids.clear();
  const Pose3 last_frame = problem.last_frame;
  std::vector<Pose3> odometric;  // the chain's poses, when the solved graph thins them
  std::vector<Pose3> as_ended;   // ... with each frame change's node in the frame before it (expand_agents)
  if (config_.agent_spacing_m > 0.0 && problem.result.agents > 2) {
    odometric.assign(problem.poses.begin(), problem.poses.begin() + static_cast<std::ptrdiff_t>(problem.result.agents));
    if (!problem.frame_changes.empty()) {  // a node mapped in a new frame correction, as the interval before sees it
      as_ended = odometric;
      for (std::uint32_t k : problem.frame_changes)
        if (k < odometric.size() && k - 1 < problem.first_closure)
          as_ended[k] = odometric[k - 1] * problem.edges[k - 1].measured_from_T_to;
    }
    problem = thin_agents(std::move(problem), config_.agent_spacing_m, config_.agent_turn_rad, &kept);
  }
  DeformationResult r = problem.result;
  const std::size_t A = r.agents_solved, nodes = problem.originals.size();
  std::vector<Pose3> solved = problem.poses;
  if (config_.decide_on_agents && r.loop_closures > 0) {
    if (!(config_.incremental_decisions && decide_incrementally(problem, kept, ends, chain_times, ids, &solved, &r)))
      r.decide = decide_on_agents(config_.agents.solver, problem, &solved, &r.loop_closure_weight,
                                  config_.reduced_decisions, &r.decide_chain, &r.agents_decided);
    if (!r.decide.poses_updated()) {
      r.solve = r.decide;
      r.loop_closure_weight.clear();
      return r;
    }
    // The whole graph by least squares over the closures kept. Held first (hold_agents): the agents, then the map
    // nodes that settled at the last solve (settle_tolerance_m); the solve moves the rest.
    const bool hold = config_.hold_agents;
    std::vector<char> held;
    if (hold) r.map_settled = settle(problem, kept, chain_times, &solved, &held);
    const std::size_t num_held = hold ? A + r.map_settled : 0;
    std::vector<std::uint32_t> where(solved.size());  // a node's index in the solve
    std::iota(where.begin(), where.end(), 0u);
    if (r.map_settled > 0) {
      auto next_held = static_cast<std::uint32_t>(A), next_free = static_cast<std::uint32_t>(num_held);
      for (std::size_t i = A; i < solved.size(); ++i) where[i] = held[i] ? next_held++ : next_free++;
    }
    std::vector<Pose3> ordered(solved.size());
    for (std::size_t i = 0; i < solved.size(); ++i) ordered[where[i]] = solved[i];
    std::vector<RelativePoseEdge> edges;
    edges.reserve(problem.edges.size());
    for (std::size_t k = 0; k < problem.edges.size(); ++k) {
      RelativePoseEdge e = problem.edges[k];
      e.from = where[e.from];
      e.to = where[e.to];
      if (e.from < num_held && e.to < num_held) continue;  // between held nodes: nothing to solve
      const bool closure = k >= problem.first_closure && k < problem.first_closure + r.loop_closures;
      if (!closure || r.loop_closure_weight[k - problem.first_closure] > 0.5) edges.push_back(e);
    }
    PoseGraphConfig whole = config_.agents.solver;
    whole.hold_first_poses = num_held;
    whole.loop_closure_loss = RobustLoss::kNone;
    whole.function_tolerance = config_.whole_function_tolerance;
    r.solve = optimize_pose_graph(whole, ordered, edges,
                                  map_rotation_priors(config_, A, r.control_points, solved, where, num_held));
    if (!r.solve.poses_updated()) {
      r.loop_closure_weight.clear();
      return r;
    }
    for (std::size_t i = 0; i < solved.size(); ++i) solved[i] = ordered[where[i]];
  } else {
    r.solve = optimize_pose_graph(config_.agents.solver, solved, problem.edges);
    if (!r.solve.poses_updated()) return r;
    for (std::size_t c = 0; c < r.loop_closures; ++c)
      r.loop_closure_weight.push_back(r.solve.edge_weight.empty() ? 1.0
                                                                  : r.solve.edge_weight[problem.first_closure + c]);
  }
  for (double w : r.loop_closure_weight) r.loop_closures_kept += w > 0.5 ? 1 : 0;
  agent_poses_.assign(solved.begin(), solved.begin() + static_cast<std::ptrdiff_t>(A));
  if (!kept.empty())
    agent_poses_ = expand_agents(odometric, kept, agent_poses_, as_ended.empty() ? nullptr : &as_ended);
  agent_times_ = chain_times.size() == agent_poses_.size() ? chain_times : std::vector<std::uint64_t>{};
  closure_ends_ = std::move(ends);
  closure_weights_ = r.loop_closure_weight;
  closure_by_id_.clear();
  if (ids.size() == closure_weights_.size()) {
    for (std::size_t k = 0; k < ids.size(); ++k) closure_by_id_.emplace_back(ids[k], static_cast<std::uint32_t>(k));
    std::sort(closure_by_id_.begin(), closure_by_id_.end());
  }
  tail_correction_ = agent_poses_.back() * (kept.empty() ? problem.poses[A - 1] : odometric.back()).inverse();
  tail_frame_ = last_frame;
  nodes_.clear();
  nodes_.reserve(nodes);
  control_points_ = r.control_points;
  for (std::size_t i = 0; i < nodes; ++i) nodes_.push_back(Node{problem.originals[i], problem.times_ns[i], solved[A + i]});
  place_node_.clear();
  for (std::size_t p = 0; p < problem.place_ids.size(); ++p)
    place_node_.emplace(problem.place_ids[p], static_cast<std::uint32_t>(r.control_points + p));
  index_nodes();
  solved_ = true;
  return r;
}

std::int64_t DeformationGraph::last_agent(const std::vector<std::uint64_t>& chain_times, std::size_t k) const {
  if (chain_times.empty() || agent_times_.empty())
    return k < agent_poses_.size() ? static_cast<std::int64_t>(k) : -1;
  if (k >= chain_times.size()) return -1;
  const auto it = std::lower_bound(agent_times_.begin(), agent_times_.end(), chain_times[k]);
  return it != agent_times_.end() && *it == chain_times[k] ? it - agent_times_.begin() : -1;
}

std::int64_t DeformationGraph::last_closure(const std::vector<std::uint64_t>& ids, std::size_t c) const {
  if (ids.empty() || closure_by_id_.empty()) return c < closure_weights_.size() ? static_cast<std::int64_t>(c) : -1;
  const auto it = std::lower_bound(closure_by_id_.begin(), closure_by_id_.end(), std::make_pair(ids[c], 0u));
  return it != closure_by_id_.end() && it->first == ids[c] ? static_cast<std::int64_t>(it->second) : -1;
}

bool DeformationGraph::closure_weight(std::uint64_t id, double* weight) const {
  const auto it = std::lower_bound(closure_by_id_.begin(), closure_by_id_.end(), std::make_pair(id, 0u));
  if (!solved_ || it == closure_by_id_.end() || it->first != id || it->second >= closure_weights_.size()) return false;
  *weight = closure_weights_[it->second];
  return true;
}

bool DeformationGraph::agent_pose_at(std::uint64_t time_ns, Pose3* out) const {
  const auto it = std::lower_bound(agent_times_.begin(), agent_times_.end(), time_ns);
  if (!solved_ || it == agent_times_.end() || *it != time_ns) return false;
  *out = agent_poses_[static_cast<std::size_t>(it - agent_times_.begin())];
  return true;
}

bool DeformationGraph::decide_incrementally(const DeformationProblem& problem, const std::vector<std::uint32_t>& kept,
                                            const std::vector<std::pair<std::uint32_t, std::uint32_t>>& ends,
                                            const std::vector<std::uint64_t>& chain_times,
                                            const std::vector<std::uint64_t>& ids, std::vector<Pose3>* solved,
                                            DeformationResult* r) const {
  const std::size_t A = problem.result.agents_solved, L = r->loop_closures;
  if (!solved_ || closure_ends_.empty() || agent_poses_.empty()) return false;
  // The agent layer's edges; a closure the last solve decided (same closure, same chain nodes) keeps its decision.
  std::vector<RelativePoseEdge> edges;
  std::vector<std::int64_t> closure_edge(L, -1);  // its index in `edges`, when in
  std::vector<char> carried(L, 0);
  std::vector<double> last_weight(L, 0.0);  // a carried closure's weight in the last solve
  std::size_t num_carried = 0;
  for (std::size_t k = 0; k < problem.edges.size(); ++k) {
    RelativePoseEdge e = problem.edges[k];
    if (e.from >= A || e.to >= A) continue;
    if (k >= problem.first_closure && k < problem.first_closure + L) {
      const std::size_t c = k - problem.first_closure;
      // The same closure (by its id: a fold of the closure store shifts the indices) on the same chain nodes (by
      // time: a fold of the chain does).
      const std::int64_t o = last_closure(ids, c);
      const std::int64_t a = last_agent(chain_times, ends[c].first), b = last_agent(chain_times, ends[c].second);
      if (o >= 0 && static_cast<std::size_t>(o) < closure_ends_.size() && a >= 0 && b >= 0 &&
          closure_ends_[static_cast<std::size_t>(o)] ==
              std::make_pair(static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b))) {
        carried[c] = 1;
        last_weight[c] = closure_weights_[static_cast<std::size_t>(o)];
        ++num_carried;
        if (last_weight[c] <= 0.5) continue;       // an outlier stays out
        e.is_loop_closure = false;                 // an inlier stays in, as a plain edge
      }
      closure_edge[c] = static_cast<std::int64_t>(edges.size());
    }
    edges.push_back(e);
  }
  if (num_carried == 0) return false;
  // From the last solution; chain nodes after it follow its last node's correction.
  // A node mapped in a frame correction that changed after the last solve (the frontend following that solve's
  // correction) has it already: it starts where it was mapped.
  std::vector<Pose3> agents(A);
  bool corrected_since = false;
  std::size_t next_change = 0;
  for (std::size_t j = 0; j < A; ++j) {
    const std::size_t chain_j = kept.empty() ? j : kept[j];
    const std::int64_t last = last_agent(chain_times, chain_j);
    while (next_change < problem.frame_changes.size() && problem.frame_changes[next_change] <= chain_j) {
      if (last < 0) corrected_since = true;
      ++next_change;
    }
    agents[j] = last >= 0 ? agent_poses_[static_cast<std::size_t>(last)]
                          : (corrected_since ? problem.poses[j] : tail_correction_ * problem.poses[j]);
  }
  // reduced_decisions: GNC on the reduced agent graph; the chain is solved once the decisions stand.
  ReducedDecision d;
  const bool reduced = config_.reduced_decisions &&
                       decide_on_reduced_graph(config_.agents.solver, agents, edges, problem.first_closure, &d);
  PoseGraphResult pr = reduced ? std::move(d.decide) : optimize_pose_graph(config_.agents.solver, agents, edges);
  if (!pr.poses_updated()) return false;
  const double threshold = config_.agents.solver.loop_closure_loss_scale_sigma;
  for (std::size_t c = 0; c < L; ++c)
    if (carried[c] && closure_edge[c] >= 0 &&
        pr.edge_residual_sigma[static_cast<std::size_t>(closure_edge[c])] > threshold) {
      r->decided_again = true;  // the new closures contradict an old decision: decide them all again
      return false;
    }
  r->loop_closure_weight.assign(L, 0.0);
  for (std::size_t c = 0; c < L; ++c) {
    if (carried[c])
      r->loop_closure_weight[c] = last_weight[c] > 0.5 ? 1.0 : 0.0;
    else if (closure_edge[c] >= 0)
      r->loop_closure_weight[c] =
          pr.edge_weight.empty() ? 1.0 : pr.edge_weight[static_cast<std::size_t>(closure_edge[c])];
  }
  if (reduced) {
    d.decide.edge_weight = pr.edge_weight;
    chain_with_decisions(config_.agents.solver, edges, &d, &agents);
    if (!d.chain.poses_updated()) return false;
    r->agents_decided = d.graph.kept.size();
    r->decide_chain = std::move(d.chain);
  }
  r->closures_carried = num_carried;
  r->decide = std::move(pr);
  carry_map(problem, agents, solved);
  return true;
}

// A map node settles when the last solve had it (same odometric position, same time seen) and each agent it hangs
// from (its E_am and E_ap edges) carries it, rigidly, to within settle_tolerance_m of where that agent's last
// solution carried it; a node without an agent edge follows its neighbours. Then the unsettled spread settle_hops
// map edges (E_mm, E_pp, E_mp), so the boundary between moved and held map can bend. Only control points are held.
std::size_t DeformationGraph::settle(const DeformationProblem& problem, const std::vector<std::uint32_t>& kept,
                                     const std::vector<std::uint64_t>& chain_times, std::vector<Pose3>* solved,
                                     std::vector<char>* held) const {
  const std::size_t A = problem.result.agents_solved, N = problem.poses.size(), C = problem.result.control_points;
  held->assign(N, 0);
  if (!solved_ || config_.settle_tolerance_m <= 0.0 || problem.originals.size() + A != N) return 0;
  std::vector<std::int64_t> last(N, -1);  // the node's index in nodes_
  std::vector<char> moves(N, 0);
  for (std::size_t m = 0; m + A < N; ++m) {
    std::int64_t j = -1;
    if (m < C) {
      if (m < control_points_) j = static_cast<std::int64_t>(m);
    } else if (m - C < problem.place_ids.size()) {
      const auto it = place_node_.find(problem.place_ids[m - C]);
      if (it != place_node_.end()) j = it->second;
    }
    const bool same = j >= 0 && nodes_[static_cast<std::size_t>(j)].original == problem.originals[m] &&
                      nodes_[static_cast<std::size_t>(j)].time_ns == problem.times_ns[m];
    last[A + m] = same ? j : -1;
    moves[A + m] = same ? 0 : 1;
  }
  for (const RelativePoseEdge& e : problem.edges) {
    if (e.from >= A || e.to < A || moves[e.to]) continue;
    const std::int64_t agent = last_agent(chain_times, kept.empty() ? e.from : kept[e.from]);
    if (agent < 0) {  // an agent the last solve did not have
      moves[e.to] = 1;
      continue;
    }
    const Pose3& odometric = problem.poses[e.from];
    const Eigen::Vector3d local = odometric.q.conjugate() * (problem.originals[e.to - A] - odometric.t_m);
    const Pose3& now = (*solved)[e.from];
    const Pose3& before = agent_poses_[static_cast<std::size_t>(agent)];
    const double moved = ((now.q * local + now.t_m) - (before.q * local + before.t_m)).norm();
    if (!(moved <= config_.settle_tolerance_m)) moves[e.to] = 1;
  }
  for (std::uint32_t hop = 0; hop < config_.settle_hops; ++hop) {
    std::vector<char> grown = moves;
    for (const RelativePoseEdge& e : problem.edges)
      if (e.from >= A && e.to >= A && (moves[e.from] || moves[e.to])) grown[e.from] = grown[e.to] = 1;
    moves.swap(grown);
  }
  // Places are always solved: few (they do not grow with the path), and a place held where its tree of places
  // moved bends the most (bench/results/loop_closure.md).
  std::size_t settled = 0;
  for (std::size_t i = A; i < A + C && i < N; ++i) {
    if (moves[i]) continue;
    (*held)[i] = 1;
    (*solved)[i] = nodes_[static_cast<std::size_t>(last[i])].optimized;
    ++settled;
  }
  return settled;
}

void DeformationGraph::index_nodes() {
  cells_.clear();
  cells_.reserve(nodes_.size());
  for (std::size_t i = 0; i < nodes_.size(); ++i) cells_.emplace_back(cell_key(nodes_[i].original), static_cast<std::uint32_t>(i));
  std::sort(cells_.begin(), cells_.end());
}

bool DeformationGraph::place_position(scene_graph::NodeId id, Eigen::Vector3d* out) const {
  const auto it = place_node_.find(id);
  if (it == place_node_.end()) return false;
  *out = nodes_[it->second].optimized.t_m;
  return true;
}

// Embedded deformation (Sumner et al. 2007): p' = sum_j w_j (R_j (p - g_j) + g_j'), over the k nearest nodes with
// w_j = (1 - d_j / d_max)^2, d_max the distance of the (k+1)-th nearest. Searches 1, then 2, then 4 cells out.
Eigen::Vector3d DeformationGraph::deform(const Eigen::Vector3d& p, std::uint64_t time_ns) const {
  if (!solved_ || nodes_.empty()) return p;
  constexpr std::size_t kMax = 17;
  std::pair<double, std::uint32_t> best[kMax];
  const std::size_t want = std::min<std::size_t>(config_.interpolation_neighbours + 1, kMax);
  std::size_t found = 0;
  const double spacing = config_.control_point_spacing_m;
  const Eigen::Vector3d c = (p / spacing).array().floor();
  const auto horizon_ns = static_cast<std::uint64_t>(config_.time_horizon_s * 1e9);
  // First the nodes within the time horizon of the point, then (none found) any.
  for (int pass = time_ns == 0 ? 1 : 0; pass < 2 && found == 0; ++pass)
  for (int reach = 1; reach <= 4 && found < want; reach *= 2) {
    found = 0;
    for (int dx = -reach; dx <= reach; ++dx)
      for (int dy = -reach; dy <= reach; ++dy)
        for (int dz = -reach; dz <= reach; ++dz) {
          const std::uint64_t key = pack_cell(static_cast<std::int64_t>(c.x()) + dx, static_cast<std::int64_t>(c.y()) + dy,
                                              static_cast<std::int64_t>(c.z()) + dz);
          auto it = std::lower_bound(cells_.begin(), cells_.end(), std::make_pair(key, std::uint32_t{0}));
          for (; it != cells_.end() && it->first == key; ++it) {
            const std::uint64_t t = nodes_[it->second].time_ns;
            if (pass == 0 && (t > time_ns ? t - time_ns : time_ns - t) > horizon_ns) continue;
            const double d = (nodes_[it->second].original - p).norm();
            if (found < want) {
              best[found++] = {d, it->second};
              std::push_heap(best, best + found);
            } else if (d < best[0].first) {
              std::pop_heap(best, best + found);
              best[found - 1] = {d, it->second};
              std::push_heap(best, best + found);
            }
          }
        }
  }
  if (found == 0) return p;  // nothing within reach: no node bends this point
  std::sort_heap(best, best + found);
  const std::size_t k = found == want ? found - 1 : found;
  const double d_max = found == want ? best[found - 1].first : best[found - 1].first + spacing;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double sw = 0.0;
  for (std::size_t j = 0; j < k; ++j) {
    const Node& n = nodes_[best[j].second];
    const double w = d_max > 0.0 ? std::pow(std::max(0.0, 1.0 - best[j].first / d_max), 2.0) : 1.0;
    sum += w * (n.optimized.q * (p - n.original) + n.optimized.t_m);
    sw += w;
  }
  if (sw <= 0.0) {
    const Node& n = nodes_[best[0].second];
    return n.optimized.q * (p - n.original) + n.optimized.t_m;
  }
  return sum / sw;
}

}  // namespace qsg::backend
