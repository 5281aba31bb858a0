// The backend stage: doors, rooms, labels and the persistent scene graph (backend_stage.h).
#include "core/backend/backend_stage.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include "budgets/budget_table.h"
#include "core/backend/backend_stage_params.h"
#include "core/memory/prefault.h"

namespace qsg::backend {

namespace {

// The chain node with the time closest to t (the chain is ordered in time; folding may have removed the exact one).
std::size_t chain_index_at(const agents::ChainView& agents, std::uint64_t t) {
  std::size_t lo = 0, hi = agents.chain_size();
  while (hi - lo > 1) {
    const std::size_t mid = (lo + hi) / 2;
    (agents.chain(mid).time_ns <= t ? lo : hi) = mid;
  }
  if (lo + 1 < agents.chain_size() && agents.chain(lo + 1).time_ns - t < t - agents.chain(lo).time_ns) ++lo;
  return lo;
}

Eigen::Isometry3d isometry(const Eigen::Vector3d& t, const Eigen::Quaterniond& q) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = t;
  return T;
}

void store_max(std::atomic<std::uint64_t>& m, std::uint64_t v) {
  if (v > m.load()) m.store(v);
}

}  // namespace

std::string LoopClosureConfig::check() const {
  // Each field the app exposes within its declared range (backend_stage_params.cc; then each part's other fields).
  if (std::string why = params::check(loop_closure_params_table(), *this); !why.empty()) return why;
  if (const std::string d = descriptor.check(); !d.empty()) return d;
  if (const std::string d = detector.check(); !d.empty()) return d;
  return deformation.check();
}

bool BackendStage::init(const Config& config, const scene_graph::Capacities& gc, std::size_t tsdf_block_slots,
                        std::size_t frame_bytes, std::string* error, std::string* warning) {
  config_ = config;
  if (!rooms_.init(config_.rooms, rooms::Capacities::from_scene_graph(gc), budgets::active::rooms::kArenaBytes,
                   error))
    return false;
  neural_tree::RoomClassifier::Config cc;
  if (!config_.room_weights_path.empty()) cc.weights_path = config_.room_weights_path;
  cc.perceived_labels = config_.perceived_labels;
  classifier_ = std::make_unique<neural_tree::RoomClassifier>(cc);
  std::string why;
  if (!classifier_->init(&why) && warning != nullptr) *warning = "room labels off: " + why + " (rooms stay \"unknown\")";
  // The classifier's input holds every room, object and building node the graph can (room-room edges at most one
  // per pair of rooms), so labelling never grows it.
  room_graph_.reserve(static_cast<int>(gc.room_nodes + gc.object_nodes + gc.building_nodes),
                      static_cast<int>(std::min(gc.edges, gc.room_nodes * (gc.room_nodes - 1) / 2)));
  if (config_.doors_online) {
    if (!online_doors_.init(config_.doors, rooms::OnlineDoorCapacities::from_budget(),
                            budgets::active::doors::kArenaBytes, error))
      return false;
    painted_stamp_.assign(tsdf_block_slots, 0u);
    painted_block_.assign(tsdf_block_slots, memory::Index3{});
  }
  return init_loop_closure(gc, frame_bytes, error);
}

bool BackendStage::init_loop_closure(const scene_graph::Capacities& gc, std::size_t frame_bytes, std::string* error) {
  if (!config_.loop_closure.enabled) return true;
  const LoopClosureConfig& c = config_.loop_closure;
  namespace lc = budgets::active::loop_closure;
  if (!descriptors_.init(c.descriptor, error)) return false;
  const loop_closure::LocalMapCapacities local_map{lc::kLocalMapKeyframes, lc::kLocalMapPoints};
  if (!detector_.init(lc::kAgents, local_map, c.detector, error)) return false;
  if (!control_points_.init(lc::kControlPoints, c.deformation.control_point_spacing_m, error)) return false;
  control_points_.set_horizon_ns(static_cast<std::uint64_t>(c.deformation.time_horizon_s * 1e9));
  deformation_ = DeformationGraph(c.deformation);
  if (!appearance_.init(c.detector.appearance, error)) return false;
  pending_.reserve(2 * lc::kAppearanceFrames);
  described_.reserve(pending_.capacity());
  loop_closures_.reserve(lc::kLoopClosures);
  if (c.closure_capacity > lc::kLoopClosures || (c.closure_capacity > 0 && c.closure_capacity < 4))
    return *error = "loop_closure.closure_capacity " + std::to_string(c.closure_capacity) +
                    " must be 0 (the budget's) or in [4, " + std::to_string(lc::kLoopClosures) + "]",
           false;
  closure_capacity_ = c.closure_capacity > 0 ? c.closure_capacity : loop_closures_.capacity();
  deformation_inputs_.reserve(gc.agent_nodes, lc::kControlPoints, gc.place_nodes, gc.edges);
  memory::prefault_capacity(&pending_);
  memory::prefault_capacity(&described_);
  memory::prefault_capacity(&loop_closures_);
  const std::size_t bytes =
      detector_.bytes() + lc::kControlPoints * (sizeof(Eigen::Vector3d) + 8 + 16) + frame_bytes +
      pending_.capacity() * sizeof(PendingAppearance) + described_.capacity() * sizeof(loop_closure::AgentEntry) +
      deformation_inputs_.capacity_bytes() + loop_closures_.capacity() * sizeof(loop_closure::LoopClosure);
  if (bytes > lc::kArenaBytes)
    return *error = "budget: loop_closure stores need " + std::to_string(bytes) + " bytes, the arena has " +
                    std::to_string(lc::kArenaBytes),
           false;
  return true;
}

// ---------------------------------------------------------------------------------------------------------
// Doors

std::uint64_t BackendStage::paint_walls(const reconstruction::SemanticTsdf& tsdf) {
  if (!online_doors_.initialized()) return 0;
  return online_doors_.wall_map().repaint(tsdf, painted_stamp_.data(), painted_block_.data(), painted_stamp_.size());
}

bool BackendStage::door_pass_due() {
  return online_doors_.initialized() && updates_due_++ % config_.doors_online_every_n == 0;
}

rooms::PassResult BackendStage::detect_doors() {
  const rooms::PassResult r = online_doors_.detect();
  if (r.climbing) counters_.door_passes_climbing.fetch_add(1);
  if (!r.ran) return r;
  counters_.door_passes.fetch_add(1);
  counters_.online_doors.store(online_doors_.doors().size());
  counters_.online_doors_kept_missed.fetch_add(r.missed);
  counters_.online_doors_dropped.fetch_add(r.removed);
  counters_.online_doors_bypassed.fetch_add(r.bypassed);
  counters_.online_bypass_refused.fetch_add(r.bypass_refused);
  return r;
}

void BackendStage::note_door_pass_us(std::uint64_t us) { store_max(counters_.door_pass_max_us, us); }

BackendStage::FinalDoors BackendStage::close_doors(const reconstruction::Mesh& mesh, scene_graph::SceneGraph* graph) {
  FinalDoors out;
  std::vector<Eigen::Vector3f> surface;
  surface.reserve(mesh.vertices.size());
  for (const reconstruction::MeshVertex& v : mesh.vertices) surface.emplace_back(v.x, v.y, v.z);
  std::vector<rooms::Door> doors;
  rooms::DoorStats stats;
  if (!rooms::find_doors(surface, *graph, config_.doors, &doors, &stats, &out.error, &final_sight_)) {
    final_sight_.clear();
    return out;
  }
  out.ok = true;
  out.doors = doors.size();
  out.slices = stats.slices;
  out.bypassed = stats.bypassed;
  out.bypass_unchecked = stats.bypass_unchecked;
  out.candidates = stats.candidates;
  out.edges_closed = rooms::cut_place_edges(doors, config_.doors, graph);
  if (config_.doors.sight_cut_edges) out.edges_through_walls = rooms::cut_edges_through_walls(final_sight_, graph);
  out.found = std::move(doors);
  online_doors_.clear_doors();  // the final doors, every storey on the whole mesh, replace the online ones
  return out;
}

// ---------------------------------------------------------------------------------------------------------
// Rooms and labels

rooms::UpdateResult BackendStage::update_rooms(scene_graph::SceneGraph* graph, std::uint64_t time_ns, bool final) {
  const bool online = online_doors_.initialized();
  // Sight lines: the final door stage's once it ran; during the run, the last online door pass's window.
  const rooms::WallSight* sight = final_sight_.slices() > 0 ? &final_sight_
                                  : online                   ? &online_doors_.sight()
                                                             : nullptr;
  const bool window = !final && final_sight_.slices() == 0;
  const rooms::UpdateResult r =
      rooms_.update(graph, time_ns, online ? &online_doors_.doors() : nullptr, sight, window);
  counters_.rooms_merged_visible.store(r.visible_merges);
  counters_.updates.fetch_add(1);
  counters_.rooms.store(r.rooms);
  if (r.rooms > 0 && classifier_ != nullptr && classifier_->ready()) label_rooms(graph, r.window, time_ns);
  return r;
}

// The classifier's input from the scene graph: rooms with their box, each object in the room of the place it hangs
// from, room-room edges, the building. After a window update (window true) only the rooms it wrote (updated at
// time_ns) are classified, among themselves; the others keep their labels, so the cost follows the window, not the
// building. The final update classifies every room.
void BackendStage::label_rooms(scene_graph::SceneGraph* graph, bool window, std::uint64_t time_ns) {
  room_graph_.clear();
  constexpr int kRooms = static_cast<int>(budgets::active::scene_graph::kRoomNodes);
  std::int32_t room_index[kRooms];
  scene_graph::NodeId room_ids[kRooms];
  int rooms = 0;
  std::uint64_t kept_labelled = 0;  // window: rooms not classified now that hold a label
  const auto index_of = [&](scene_graph::NodeId id) {
    for (int i = 0; i < rooms; ++i)
      if (room_ids[i] == id) return room_index[i];
    return -1;
  };
  graph->for_each_node_of(scene_graph::NodeKind::kRoom, [&](const scene_graph::NodeRecord& n) {
    if (rooms >= kRooms) return;
    const scene_graph::RoomAttributes* a = graph->room(n.id);
    if (window && a->last_update_time_ns != time_ns) {
      kept_labelled += a->semantic_label != semantics::kRoomUnknown ? 1 : 0;
      return;
    }
    const Eigen::Vector3d size = a->bounding_box.type == scene_graph::BoundingBox::Type::kInvalid
                                     ? Eigen::Vector3d::Zero()
                                     : Eigen::Vector3d(a->bounding_box.max_m - a->bounding_box.min_m);
    room_ids[rooms] = n.id;
    room_index[rooms++] = room_graph_.add_room(a->position_m, size);
  });
  graph->for_each_node_of(scene_graph::NodeKind::kObject, [&](const scene_graph::NodeRecord& n) {
    if (n.parent == scene_graph::kNoNode) return;
    const int room = index_of(graph->parent(n.parent));  // object -> place -> room
    if (room < 0) return;
    const scene_graph::ObjectAttributes* o = graph->object(n.id);
    const Eigen::Vector3d size = o->bounding_box.max_m - o->bounding_box.min_m;
    // Through the classifier's label map: appliances split by their box, unread labels left out (label_map.h).
    room_graph_.add_object(room, classifier_->word_index(static_cast<semantics::Label>(o->semantic_label), size),
                           o->position_m, size);
  });
  // Room-room edges among every edge of the graph: when every room carries the room prefix (the room finder's do),
  // an edge whose ends do not both carry it is skipped before the search among the rooms (same edges, same order).
  bool prefixed = true;
  for (int i = 0; i < rooms; ++i)
    prefixed = prefixed && scene_graph::node_prefix(room_ids[i]) == scene_graph::kRoomPrefix;
  const auto add_room_edge = [&](const scene_graph::EdgeRecord& e) {
    if (prefixed && (scene_graph::node_prefix(e.source) != scene_graph::kRoomPrefix ||
                     scene_graph::node_prefix(e.target) != scene_graph::kRoomPrefix))
      return;
    const int a = index_of(e.source), b = index_of(e.target);
    if (a >= 0 && b >= 0) room_graph_.add_edge(a, b);
  };
  if (!window) {
    graph->for_each_edge(add_room_edge);
  } else {  // the window's rooms' own edges (each once, from its source), not every edge of the graph
    for (int i = 0; i < rooms; ++i)
      graph->for_each_neighbor(room_ids[i], [&](scene_graph::NodeId, const scene_graph::EdgeRecord& e) {
        if (e.source == room_ids[i]) add_room_edge(e);
      });
  }
  if (!classifier_->classify(room_graph_, &classifier_error_)) return;
  std::uint64_t labelled = 0;
  for (const neural_tree::RoomPrediction& p : classifier_->predictions()) {
    for (int i = 0; i < rooms; ++i) {
      if (room_index[i] != p.node) continue;
      scene_graph::RoomAttributes* a = graph->room(room_ids[i]);
      a->semantic_label = p.label;
      a->class_probabilities.clear();
      // The most likely labels first, as many as the attribute holds.
      std::array<std::uint32_t, semantics::kNumRoomLabels> order{};
      for (std::uint32_t k = 0; k < order.size(); ++k) order[k] = k;
      std::sort(order.begin(), order.end(),
                [&](std::uint32_t x, std::uint32_t y) { return p.label_probabilities[x] > p.label_probabilities[y]; });
      for (std::uint32_t k : order) {
        if (a->class_probabilities.size() == scene_graph::kMaxRoomClasses || p.label_probabilities[k] <= 0.0f) break;
        a->class_probabilities.push_back(scene_graph::LabelProbability{k, p.label_probabilities[k]});
      }
      labelled += p.label != semantics::kRoomUnknown ? 1 : 0;
    }
  }
  counters_.rooms_labelled.store(labelled + kept_labelled);
}

// ---------------------------------------------------------------------------------------------------------
// The persistent scene graph

void BackendStage::offer_control_points(const reconstruction::SemanticTsdf& tsdf, std::uint64_t time_ns) {
  if (!config_.loop_closure.enabled) return;
  tsdf.for_each_block([&](std::uint32_t handle, const reconstruction::SemanticTsdf::BlockView& view) {
    if (view.meshed_stamp <= cp_mesh_stamp_ || view.num_vertices == 0) return;
    reconstruction::SemanticTsdf::VertexCursor cursor;
    reconstruction::MeshVertex v;
    std::uint64_t key = 0;
    if (tsdf.next_block_vertex(handle, &cursor, &v, &key)) control_points_.offer(Eigen::Vector3d(v.x, v.y, v.z), time_ns);
  });
  cp_mesh_stamp_ = tsdf.mesh_stamp();
}

void BackendStage::add_appearance(scene_graph::NodeId agent, std::uint64_t time_ns,
                                  const loop_closure::GreyDepthView& view) {
  if (!config_.loop_closure.enabled) return;
  if (pending_.size() == pending_.capacity()) {
    pending_.erase(pending_.begin());  // the oldest waits no longer (no reallocation: erase keeps capacity)
    counters_.appearances_dropped.fetch_add(1);
  }
  PendingAppearance& p = pending_.emplace_back();
  p.agent = agent;
  p.time_ns = time_ns;
  appearance_.extract(view, &p.features);
  loop_closure::make_depth_cloud(view, config_.loop_closure.detector.icp.max_depth_m, &p.cloud);
}

std::size_t BackendStage::describe_agents(const scene_graph::SceneGraph& graph, const agents::AgentLayer& agents,
                                         std::uint64_t time_ns) {
  const LoopClosureConfig& c = config_.loop_closure;
  if (!c.enabled) return 0;
  const auto horizon_ns = static_cast<std::uint64_t>(c.horizon_s * 1e9);
  if (time_ns < horizon_ns) return 0;
  std::size_t k = 0;  // the first chain node not yet described: a binary search, the chain being in time order
  for (std::size_t hi = have_last_ ? agents.chain_size() : 0; k < hi;) {
    const std::size_t mid = k + (hi - k) / 2;
    if (agents.chain(mid).time_ns <= described_until_ns_) k = mid + 1;
    else hi = mid;
  }
  std::size_t described = 0;
  // An agent is described only with its appearance, which waits in pending_: described_ holds as many as pending_
  // can, so it never fills here (the check keeps the next ones for the next call if it ever did).
  for (; k < agents.chain_size() && agents.chain(k).time_ns + horizon_ns <= time_ns &&
         described_.size() < described_.capacity();
       ++k) {
    const agents::ChainNode& n = agents.chain(k);
    // The path the odometry travelled: a change of the frontend's frame between two nodes is not motion.
    const Eigen::Vector3d odometric_m = agents::odometric_pose(n).translation();
    if (have_last_) path_m_ += (odometric_m - last_m_).norm();
    last_m_ = odometric_m;
    have_last_ = true;
    described_until_ns_ = n.time_ns;
    // Described: the agents whose keyframe was captured (one per describe_every_m of path).
    while (!pending_.empty() && pending_.front().time_ns < n.time_ns) pending_.erase(pending_.begin());
    if (pending_.empty() || pending_.front().agent != n.id) continue;
    scene_graph::NodeId place = scene_graph::kNoNode;
    graph.for_each_neighbor(n.id, [&](scene_graph::NodeId other, const scene_graph::EdgeRecord&) {
      if (place == scene_graph::kNoNode && graph.place(other) != nullptr) place = other;
    });
    described_.emplace_back();
    loop_closure::AgentEntry& e = described_.back();
    if (place == scene_graph::kNoNode || !descriptors_.describe(graph, place, n.t_m, &e.descriptor)) {
      described_.pop_back();
      continue;
    }
    e.agent = n.id;
    e.time_ns = n.time_ns;
    e.path_m = path_m_;
    e.world_T_agent = isometry(n.t_m, n.q);
    if (!n.frame_is_identity()) {
      e.frame_corrected = true;
      e.map_T_odom = isometry(n.frame_t_m, n.frame_q);
    }
    e.appearance = pending_.front().features;
    e.cloud = pending_.front().cloud;
    pending_.erase(pending_.begin());
    counters_.agents_described.fetch_add(1);
    ++described;
  }
  return described;
}

bool BackendStage::detect_described() {
  bool found = false;
  for (const loop_closure::AgentEntry& e : described_) {
    struct Bracket {  // the hook around this agent's lookup and verification, whichever way it ends
      DetectHook hook;
      void* user;
      std::uint64_t t;
      Bracket(DetectHook h, void* u, std::uint64_t time) : hook(h), user(u), t(time) {
        if (hook != nullptr) hook(user, true, t);
      }
      ~Bracket() {
        if (hook != nullptr) hook(user, false, t);
      }
    } bracket(detect_hook_, detect_hook_user_, e.time_ns);
    loop_closure::LoopClosure closure;
    if (!detector_.add_and_detect(e, &closure)) continue;
    counters_.loop_closures.fetch_add(1);
    if (loop_closures_.size() >= closure_capacity_) {
      const std::size_t folded = fold_loop_closures(&loop_closures_, [this](const loop_closure::LoopClosure& lc) {
        double w = 1.0;
        return deformation_.closure_weight(lc.query_time_ns, &w) && w <= 0.5;
      });
      counters_.loop_closure_folds.fetch_add(1);
      counters_.loop_closures_folded.fetch_add(folded);
    }
    loop_closures_.push_back(closure);
    loop_closures_high_water_ = std::max(loop_closures_high_water_, loop_closures_.size());
    if (closure.source == loop_closure::ClosureSource::kAppearance) counters_.loop_closures_by_appearance.fetch_add(1);
    found = true;
  }
  described_.clear();
  if (found) solve_pending_ = true;
  return found;
}

bool BackendStage::solve_may_follow(std::uint64_t time_ns, bool described) const {
  const auto interval_ns = static_cast<std::uint64_t>(config_.loop_closure.solve_interval_s * 1e9);
  return (solve_pending_ || described) && (last_solve_ns_ == 0 || time_ns >= last_solve_ns_ + interval_ns);
}

bool BackendStage::solve_due(std::uint64_t time_ns) {
  const auto interval_ns = static_cast<std::uint64_t>(config_.loop_closure.solve_interval_s * 1e9);
  if (!solve_pending_ || (last_solve_ns_ > 0 && time_ns < last_solve_ns_ + interval_ns)) return false;
  solve_pending_ = false;
  last_solve_ns_ = time_ns;
  return true;
}

namespace {

// The odometry's random walk over distance_m (the agent graph's sigmas per sqrt(m)), added in quadrature.
void add_odometry_walk(const AgentGraphConfig& walk, double distance_m, Eigen::Vector3d* sigma_t_m,
                       Eigen::Vector3d* sigma_rot_rad) {
  const double walk_t2 = walk.sigma_t_m_per_sqrt_m * walk.sigma_t_m_per_sqrt_m * distance_m;
  const double walk_rot2 = walk.sigma_yaw_rad_per_sqrt_m * walk.sigma_yaw_rad_per_sqrt_m * distance_m;
  *sigma_t_m = (sigma_t_m->array().square() + walk_t2).sqrt().matrix();
  *sigma_rot_rad = (sigma_rot_rad->array().square() + walk_rot2).sqrt().matrix();
}

}  // namespace

void closure_sigmas(const loop_closure::LoopClosure& lc, const LoopClosureConfig& config, Eigen::Vector3d* sigma_t_m,
                    Eigen::Vector3d* sigma_rot_rad) {
  // Appearance: depth-precise; objects: centroids of partial views, a decimetre and a degree or so.
  // ICP-refined: depth-precise too (its gate is a few centimetres).
  const bool precise = lc.source == loop_closure::ClosureSource::kAppearance || lc.refined;
  const double rmse = lc.refined                                              ? lc.icp.rmse_m
                      : lc.source == loop_closure::ClosureSource::kAppearance ? lc.appearance.inlier_rmse_m
                                                                              : lc.registration.inlier_rmse_m;
  *sigma_t_m = Eigen::Vector3d::Constant(precise ? std::max(0.02, rmse) : std::max(0.15, rmse));
  *sigma_rot_rad = Eigen::Vector3d::Constant(precise ? 0.005 : 0.03);
  if (!lc.local_map) return;
  // A local map is stitched from the keyframes within path_m of its anchor by the odometry between them, so it
  // carries the odometry's random walk over that path (both maps together: about the walk over path_m, added in
  // quadrature to the ICP's own).
  add_odometry_walk(config.deformation.agents, config.detector.local_map.path_m, sigma_t_m, sigma_rot_rad);
}

bool chain_closure(const agents::ChainView& agents, const loop_closure::LoopClosure& lc, const LoopClosureConfig& config,
                   ChainLoopClosure* out) {
  if (agents.chain_size() == 0) return false;
  out->a = static_cast<std::uint32_t>(chain_index_at(agents, lc.match_time_ns));
  out->b = static_cast<std::uint32_t>(chain_index_at(agents, lc.query_time_ns));
  if (out->a >= out->b) return false;
  const agents::ChainNode& a = agents.chain(out->a);
  const agents::ChainNode& b = agents.chain(out->b);
  Eigen::Isometry3d a_T_b = lc.match_T_query;
  // An agent the chain folded away since: join the chain node nearest it through the odometry between them, whose
  // random walk over that distance the edge then carries too (in quadrature, as a local map's stitching).
  double joined_m = 0.0;
  if (a.time_ns != lc.match_time_ns) {
    a_T_b = isometry(a.t_m, a.q).inverse() * lc.world_T_match * a_T_b;
    joined_m += (a.t_m - lc.world_T_match.translation()).norm();
  }
  if (b.time_ns != lc.query_time_ns) {
    a_T_b = a_T_b * lc.world_T_query.inverse() * isometry(b.t_m, b.q);
    joined_m += (b.t_m - lc.world_T_query.translation()).norm();
  }
  out->a_T_b = Pose3{a_T_b.translation(), Eigen::Quaterniond(a_T_b.linear())};
  closure_sigmas(lc, config, &out->sigma_t_m, &out->sigma_rot_rad);
  if (joined_m > 0.0) add_odometry_walk(config.deformation.agents, joined_m, &out->sigma_t_m, &out->sigma_rot_rad);
  out->id = lc.query_time_ns;  // one closure per query agent
  return true;
}

void BackendStage::copy_deformation_inputs(const agents::AgentLayer& agents, const scene_graph::SceneGraph& graph) {
  deformation_inputs_.copy(agents, control_points_.view(), graph);
}

DeformationProblem BackendStage::build_deformation() const {
  const agents::ChainView agents = deformation_inputs_.chain_view();
  std::vector<ChainLoopClosure> closures;
  closures.reserve(loop_closures_.size());
  for (const loop_closure::LoopClosure& lc : loop_closures_) {
    ChainLoopClosure cc;
    if (chain_closure(agents, lc, config_.loop_closure, &cc)) closures.push_back(cc);
  }
  return deformation_.build(deformation_inputs_, closures);
}

bool BackendStage::solve_deformation(DeformationProblem problem, std::string* error) {
  DeformationResult result = deformation_.solve(std::move(problem));
  counters_.graph_optimizations.fetch_add(1);
  if (!result.solve.poses_updated()) {
    counters_.graph_optimization_failures.fetch_add(1);
    if (error != nullptr) *error = result.solve.message;
    return false;
  }
  deformation_result_ = std::move(result);
  counters_.loop_closures_kept.store(deformation_result_.loop_closures_kept);
  return true;
}

Eigen::Isometry3d BackendStage::map_T_odom() const {
  if (!deformation_.solved() || deformation_.num_agent_poses() == 0) return Eigen::Isometry3d::Identity();
  const Pose3 c = deformation_.map_T_odom();
  return isometry(c.t_m, c.q);
}

Eigen::Isometry3d BackendStage::corrected_pose(const agents::AgentLayer& agents, std::size_t k) const {
  const Eigen::Isometry3d odom = isometry(agents.chain(k).t_m, agents.chain(k).q);
  if (!deformation_.solved() || deformation_.num_agent_poses() == 0) return odom;
  // By the node's time: a fold of the chain since the solve shifts its indices.
  Pose3 p;
  if (deformation_.agent_pose_at(agents.chain(k).time_ns, &p)) return isometry(p.t_m, p.q);
  // A node added since: the odometry frame onto the solution at the last solved node (a node mapped in a corrected
  // frame, LoopClosureConfig::map_in_corrected_frame, from its odometric pose).
  const Pose3 c = deformation_.map_T_odom();
  return isometry(c.t_m, c.q) * (agents.chain(k).frame_is_identity() ? odom : agents::odometric_pose(agents.chain(k)));
}

void BackendStage::correct_graph(const agents::AgentLayer& agents, scene_graph::SceneGraph* graph) const {
  if (!deformation_.solved()) return;
  for (std::size_t k = 0; k < agents.chain_size(); ++k) {
    scene_graph::AgentAttributes* a = graph->agent(agents.chain(k).id);
    if (a == nullptr) continue;
    const Eigen::Isometry3d T = corrected_pose(agents, k);
    a->position_m = T.translation();
    a->world_R_body = Eigen::Quaterniond(T.linear());
  }
  graph->for_each_node([&](const scene_graph::NodeRecord& n) {
    scene_graph::SemanticAttributes* s = nullptr;
    Eigen::Vector3d moved;
    if (n.kind == scene_graph::NodeKind::kPlace) {
      scene_graph::PlaceAttributes* p = graph->place(n.id);
      if (deformation_.place_position(n.id, &moved)) {
        p->position_m = moved;
        return;
      }
      s = p;
    } else if (n.kind == scene_graph::NodeKind::kObject) {
      s = graph->object(n.id);
    } else if (n.kind == scene_graph::NodeKind::kRoom) {
      s = graph->room(n.id);
    } else if (n.kind == scene_graph::NodeKind::kBuilding) {
      s = graph->building(n.id);
    }
    if (s == nullptr) return;
    moved = deformation_.deform(s->position_m, s->last_update_time_ns);
    const Eigen::Vector3d shift = moved - s->position_m;
    s->position_m = moved;
    if (s->bounding_box.type != scene_graph::BoundingBox::Type::kInvalid) {  // the box moves with its centre
      s->bounding_box.min_m += shift;
      s->bounding_box.max_m += shift;
      s->bounding_box.world_P_center_m += shift;
    }
  });
}

Eigen::Vector3d BackendStage::corrected_position(scene_graph::NodeId id, scene_graph::NodeKind kind,
                                                 const Eigen::Vector3d& p_m, std::uint64_t time_ns) const {
  if (!deformation_.solved()) return p_m;
  Eigen::Vector3d moved;
  if (kind == scene_graph::NodeKind::kPlace && deformation_.place_position(id, &moved)) return moved;
  return deformation_.deform(p_m, time_ns);
}

// A vertex with a time (when its block was seen) moves with the nodes seen within the time horizon of it, like a
// place or an object: a wall mapped on two visits, drifted apart, follows each visit's own correction and comes
// together again. Without times (a mesh read from a file) each moves with its nearest nodes of any time.
void BackendStage::correct_mesh(reconstruction::Mesh* mesh) const {
  if (!deformation_.solved()) return;
  const bool timed = mesh->has_vertex_times();
  for (std::size_t i = 0; i < mesh->vertices.size(); ++i) {
    reconstruction::MeshVertex& v = mesh->vertices[i];
    const Eigen::Vector3d p = deformation_.deform(Eigen::Vector3d(v.x, v.y, v.z), timed ? mesh->vertex_time_ns[i] : 0);
    v.x = static_cast<float>(p.x());
    v.y = static_cast<float>(p.y());
    v.z = static_cast<float>(p.z());
  }
}

// ---------------------------------------------------------------------------------------------------------
// Reconciliation

namespace {

// The box and centre of a set of mesh vertices; false when there is none.
bool box_of(const reconstruction::Mesh& mesh, const std::vector<std::uint32_t>& indices, Eigen::Vector3d* centre,
            Eigen::Vector3d* lo, Eigen::Vector3d* hi) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  std::size_t n = 0;
  *lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  *hi = -*lo;
  for (std::uint32_t i : indices) {
    if (i >= mesh.vertices.size()) continue;
    const reconstruction::MeshVertex& v = mesh.vertices[i];
    const Eigen::Vector3d p(v.x, v.y, v.z);
    if (!p.allFinite()) continue;
    sum += p;
    *lo = lo->cwiseMin(p);
    *hi = hi->cwiseMax(p);
    ++n;
  }
  if (n == 0) return false;
  *centre = sum / static_cast<double>(n);
  return true;
}

std::uint64_t cell_key(const Eigen::Vector3d& p, double cell_m) {
  const auto c = [&](double v) { return static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(v / cell_m)) & 0x1FFFFF); };
  return c(p.x()) | (c(p.y()) << 21) | (c(p.z()) << 42);
}

}  // namespace

BackendStage::Reconciliation BackendStage::reconcile(
    const reconstruction::Mesh& mesh,
    const std::unordered_map<scene_graph::NodeId, std::vector<std::uint32_t>>& indices,
    scene_graph::SceneGraph* graph) const {
  Reconciliation out;
  const LoopClosureConfig& c = config_.loop_closure;
  // Objects: centre and box from their vertices in the corrected mesh.
  std::vector<scene_graph::NodeId> objects;
  graph->for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind == scene_graph::NodeKind::kObject) objects.push_back(n.id);
  });
  for (scene_graph::NodeId id : objects) {
    const auto it = indices.find(id);
    Eigen::Vector3d centre, lo, hi;
    if (it == indices.end() || !box_of(mesh, it->second, &centre, &lo, &hi)) continue;
    scene_graph::ObjectAttributes* o = graph->object(id);
    o->position_m = centre;
    o->bounding_box = scene_graph::BoundingBox::aabb(lo, hi);
    ++out.objects_from_mesh;
  }
  // Places: a revisit mapped a second place where the correction now puts the first; the older one stays.
  if (c.merge_places_within_m > 0.0) {
    const double d = c.merge_places_within_m;
    std::unordered_map<std::uint64_t, std::vector<scene_graph::NodeId>> cells;
    std::vector<scene_graph::NodeId> places;
    graph->for_each_node([&](const scene_graph::NodeRecord& n) {
      if (n.kind == scene_graph::NodeKind::kPlace) places.push_back(n.id);
    });
    std::sort(places.begin(), places.end());
    for (scene_graph::NodeId id : places) {
      const scene_graph::PlaceAttributes* p = graph->place(id);
      const Eigen::Vector3d at = p->position_m;
      scene_graph::NodeId into = scene_graph::kNoNode;
      for (int dx = -1; dx <= 1 && into == scene_graph::kNoNode; ++dx)
        for (int dy = -1; dy <= 1 && into == scene_graph::kNoNode; ++dy)
          for (int dz = -1; dz <= 1 && into == scene_graph::kNoNode; ++dz) {
            const auto it = cells.find(cell_key(at + d * Eigen::Vector3d(dx, dy, dz), d));
            if (it == cells.end()) continue;
            for (scene_graph::NodeId other : it->second) {
              const scene_graph::PlaceAttributes* q = graph->place(other);
              const double gap = (q->position_m - at).norm();
              // Within the distance, and each inside the other's free space (the same space, not across a wall).
              if (gap <= d && gap < std::min(p->distance_m, q->distance_m)) {
                into = other;
                break;
              }
            }
          }
      if (into == scene_graph::kNoNode) {
        cells[cell_key(at, d)].push_back(id);
        continue;
      }
      const scene_graph::SceneGraph::MergeResult m = graph->merge_into(into, id);
      if (m.status != scene_graph::Status::kOk) {
        cells[cell_key(at, d)].push_back(id);
        continue;
      }
      out.edges_refused += m.refused;
      ++out.places_merged;
    }
  }
  return out;
}

}  // namespace qsg::backend
