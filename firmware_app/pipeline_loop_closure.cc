// The pipeline's persistent scene graph: mesh control points (loop thread, after each frontend update), agent
// descriptors, loop-closure detection and verification, and the deformation graph (backend thread), and the
// correction of the outputs when the run finishes. All of it under graph_mutex_.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>

#include "budgets/budget_table.h"
#include "core/backend/deformation_io.h"
#include "firmware_app/pipeline.h"

namespace qsg::app {

namespace {

// The chain node with the time closest to t (the chain is ordered in time; folding may have removed the exact one).
std::size_t chain_index_at(const agents::AgentLayer& agents, std::uint64_t t) {
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

}  // namespace

bool Pipeline::init_loop_closure(std::string* error) {
  if (config_.loop_closure.enabled && odometry_.kind() == OdometrySourceKind::kGroundTruth) {
    std::printf("loop closure: off for this run (ground-truth poses need no correction)\n");
    config_.loop_closure.enabled = false;
  }
  if (!config_.loop_closure.enabled) return true;
  namespace lc = budgets::active::loop_closure;
  if (!lc_descriptors_.init(config_.loop_closure.descriptor, error)) return false;
  if (!lc_detector_.init(lc::kAgents, config_.loop_closure.detector, error)) return false;
  if (!control_points_.init(lc::kControlPoints, config_.loop_closure.deformation.control_point_spacing_m, error))
    return false;
  control_points_.set_horizon_ns(static_cast<std::uint64_t>(config_.loop_closure.deformation.time_horizon_s * 1e9));
  deformation_ = backend::DeformationGraph(config_.loop_closure.deformation);
  if (!lc_appearance_.init(config_.loop_closure.detector.appearance, error)) return false;
  const auto slots = static_cast<std::uint32_t>(lc::kAppearanceFrames);
  lc_frames_.resize(slots);
  for (AgentFrame& f : lc_frames_) {
    f.grey.assign(messages::kMaxFramePixels, 0);
    f.depth_m.assign(messages::kMaxFramePixels, 0.0f);
  }
  if (!lc_free_frames_.init(slots, budgets::DropPolicy::kDropNewest, nullptr, error) ||
      !lc_ready_frames_.init(slots, budgets::DropPolicy::kDropNewest, nullptr, error))
    return false;
  for (std::uint32_t i = 0; i < slots; ++i) lc_free_frames_.push(static_cast<int>(i));
  lc_pending_.reserve(2 * slots);
  loop_closures_.reserve(lc::kLoopClosures);
  const std::size_t bytes = lc_detector_.bytes() + lc::kControlPoints * (sizeof(Eigen::Vector3d) + 8 + 16) +
                            slots * messages::kMaxFramePixels * (1 + sizeof(float)) +
                            lc_pending_.capacity() * sizeof(PendingAppearance);
  if (bytes > lc::kArenaBytes)
    return *error = "budget: loop_closure stores need " + std::to_string(bytes) + " bytes, the arena has " +
                    std::to_string(lc::kArenaBytes),
           false;
  return true;
}

// Loop thread: the keyframe of a new agent node, when it is describe_every_m from the last captured one, goes to
// the backend for its appearance. Copies into a preallocated slot; none free, it is dropped and counted.
void Pipeline::capture_agent_frame(const messages::RgbdFrame& frame, scene_graph::NodeId agent, std::uint64_t time_ns) {
  if (!config_.loop_closure.enabled) return;
  const agents::AgentLayer& agents = frontend_.agents();
  if (agents.chain_size() == 0) return;
  const Eigen::Vector3d p = agents.chain(agents.chain_size() - 1).t_m;
  if (lc_have_captured_ && (p - lc_captured_m_).norm() < config_.loop_closure.describe_every_m) return;
  int slot = -1;
  if (!lc_free_frames_.try_pop(&slot)) {
    ++lc_frames_dropped_;
    return;
  }
  lc_captured_m_ = p;
  lc_have_captured_ = true;
  AgentFrame& f = lc_frames_[static_cast<std::size_t>(slot)];
  f.agent = agent;
  f.time_ns = time_ns;
  f.intrinsics = frame.intrinsics;
  const int n = frame.pixels();
  for (int i = 0; i < n; ++i) {
    const std::uint8_t* c = &frame.rgb[static_cast<std::size_t>(3 * i)];
    f.grey[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>((77 * c[0] + 150 * c[1] + 29 * c[2]) >> 8);
    f.depth_m[static_cast<std::size_t>(i)] = frame.depth_m[static_cast<std::size_t>(i)];
  }
  lc_ready_frames_.push(int{slot});
}

// Backend thread: the appearance of the captured keyframes, kept until their agents are described.
void Pipeline::extract_captured_frames() {
  int slot = -1;
  while (lc_ready_frames_.try_pop(&slot)) {
    const AgentFrame& f = lc_frames_[static_cast<std::size_t>(slot)];
    if (lc_pending_.size() == lc_pending_.capacity()) {
      lc_pending_.erase(lc_pending_.begin());  // the oldest waits no longer (no reallocation: erase keeps capacity)
      lc_pending_dropped_.fetch_add(1);
    }
    PendingAppearance& p = lc_pending_.emplace_back();
    p.agent = f.agent;
    p.time_ns = f.time_ns;
    loop_closure::GreyDepthView v;
    v.grey = f.grey.data();
    v.depth_m = f.depth_m.data();
    v.width = f.intrinsics.width;
    v.height = f.intrinsics.height;
    v.fx = f.intrinsics.fx;
    v.fy = f.intrinsics.fy;
    v.cx = f.intrinsics.cx;
    v.cy = f.intrinsics.cy;
    lc_appearance_.extract(v, &p.features);
    loop_closure::make_depth_cloud(v, config_.loop_closure.detector.icp.max_depth_m, &p.cloud);
    lc_free_frames_.push(int{slot});
  }
}

// Loop thread, graph_mutex_ held: one control point per newly meshed block's first vertex (its cell permitting).
void Pipeline::offer_control_points() {
  if (!config_.loop_closure.enabled) return;
  tsdf_.for_each_block([&](std::uint32_t handle, const reconstruction::SemanticTsdf::BlockView& view) {
    if (view.meshed_stamp <= cp_mesh_stamp_ || view.num_vertices == 0) return;
    reconstruction::SemanticTsdf::VertexCursor cursor;
    reconstruction::MeshVertex v;
    std::uint64_t key = 0;
    if (tsdf_.next_block_vertex(handle, &cursor, &v, &key))
      control_points_.offer(Eigen::Vector3d(v.x, v.y, v.z), latest_keyframe_ns_);
  });
  cp_mesh_stamp_ = tsdf_.mesh_stamp();
}

// Backend thread, graph_mutex_ held: describes the chain nodes the robot left horizon_s ago (one per
// describe_every_m of path), looks each up among the earlier ones, and re-solves the deformation graph when a new
// loop closure was verified.
bool Pipeline::run_loop_closure(std::uint64_t time_ns) {
  const AppConfig::LoopClosure& c = config_.loop_closure;
  if (!c.enabled) return false;
  const auto horizon_ns = static_cast<std::uint64_t>(c.horizon_s * 1e9);
  if (time_ns < horizon_ns) return false;
  extract_captured_frames();
  const agents::AgentLayer& agents = frontend_.agents();
  std::size_t k = 0;
  while (k < agents.chain_size() && agents.chain(k).time_ns <= lc_described_until_ns_ && lc_have_last_) ++k;
  bool found = false;
  for (; k < agents.chain_size() && agents.chain(k).time_ns + horizon_ns <= time_ns; ++k) {
    const agents::ChainNode& n = agents.chain(k);
    if (lc_have_last_) lc_path_m_ += (n.t_m - lc_last_m_).norm();
    lc_last_m_ = n.t_m;
    lc_have_last_ = true;
    lc_described_until_ns_ = n.time_ns;
    // Described: the agents whose keyframe was captured (one per describe_every_m of path).
    while (!lc_pending_.empty() && lc_pending_.front().time_ns < n.time_ns) lc_pending_.erase(lc_pending_.begin());
    if (lc_pending_.empty() || lc_pending_.front().agent != n.id) continue;
    scene_graph::NodeId place = scene_graph::kNoNode;
    graph_.for_each_neighbor(n.id, [&](scene_graph::NodeId other, const scene_graph::EdgeRecord&) {
      if (place == scene_graph::kNoNode && graph_.place(other) != nullptr) place = other;
    });
    loop_closure::AgentEntry e;
    if (place == scene_graph::kNoNode || !lc_descriptors_.describe(graph_, place, n.t_m, &e.descriptor)) continue;
    e.agent = n.id;
    e.time_ns = n.time_ns;
    e.path_m = lc_path_m_;
    e.world_T_agent = isometry(n.t_m, n.q);
    e.appearance = lc_pending_.front().features;
    e.cloud = lc_pending_.front().cloud;
    lc_pending_.erase(lc_pending_.begin());
    agents_described_.fetch_add(1);
    loop_closure::LoopClosure closure;
    if (!lc_detector_.add_and_detect(e, &closure)) continue;
    loop_closures_count_.fetch_add(1);
    if (loop_closures_.size() == loop_closures_.capacity()) {
      loop_closures_dropped_.fetch_add(1);
      continue;
    }
    loop_closures_.push_back(closure);
    if (closure.source == loop_closure::ClosureSource::kAppearance) loop_closures_by_appearance_.fetch_add(1);
    found = true;
  }
  return found;
}

// Backend thread (or the finish), graph_mutex_ held: the deformation graph over the chain, every loop closure so far,
// the control points and the places; solve_deformation() solves it without the lock.
backend::DeformationProblem Pipeline::build_deformation() {
  const agents::AgentLayer& agents = frontend_.agents();
  std::vector<backend::ChainLoopClosure> closures;
  closures.reserve(loop_closures_.size());
  for (const loop_closure::LoopClosure& lc : loop_closures_) {
    backend::ChainLoopClosure cc;
    cc.a = static_cast<std::uint32_t>(chain_index_at(agents, lc.match_time_ns));
    cc.b = static_cast<std::uint32_t>(chain_index_at(agents, lc.query_time_ns));
    if (cc.a >= cc.b) continue;
    cc.a_T_b = backend::Pose3{lc.match_T_query.translation(), Eigen::Quaterniond(lc.match_T_query.linear())};
    // Appearance: depth-precise; objects: centroids of partial views, a decimetre and a degree or so.
    // ICP-refined: depth-precise too (its gate is a few centimetres).
    const bool precise = lc.source == loop_closure::ClosureSource::kAppearance || lc.refined;
    const double rmse = lc.refined                                            ? lc.icp.rmse_m
                        : lc.source == loop_closure::ClosureSource::kAppearance ? lc.appearance.inlier_rmse_m
                                                                                : lc.registration.inlier_rmse_m;
    cc.sigma_t_m = Eigen::Vector3d::Constant(precise ? std::max(0.02, rmse) : std::max(0.15, rmse));
    cc.sigma_rot_rad = Eigen::Vector3d::Constant(precise ? 0.005 : 0.03);
    closures.push_back(cc);
  }
  backend::DeformationProblem problem = deformation_.build(agents, closures, control_points_, graph_);
  // Debugging and bench/loop_closure/dg_solve: the problem (and each agent's true camera position where known) to a
  // file, to reproduce this solve offline.
  if (const char* path = std::getenv("QSG_DUMP_DEFORMATION"); path != nullptr && *path != '\0') {
    std::vector<Eigen::Vector3d> truth;
    const Eigen::Isometry3d mount =
        sim_camera_ != nullptr ? sim_camera_->body_T_camera() : Eigen::Isometry3d::Identity();
    for (std::size_t k = 0; k < problem.result.agents && !ground_truth_.empty(); ++k) {
      replay::StampedPose g;
      if (!replay::interpolate_pose(ground_truth_, static_cast<std::int64_t>(agents.chain(k).time_ns), INT64_MAX, &g)) {
        truth.clear();
        break;
      }
      truth.push_back((g.world_T_body() * mount).translation());
    }
    std::string error;
    if (!backend::write_deformation_problem(path, problem, truth, &error))
      std::fprintf(stderr, "loop closure: QSG_DUMP_DEFORMATION: %s\n", error.c_str());
  }
  return problem;
}

bool Pipeline::solve_deformation(backend::DeformationProblem problem) {
  const auto start = std::chrono::steady_clock::now();
  deformation_result_ = deformation_.solve(std::move(problem));
  const auto us = static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - start).count());
  graph_optimizations_.fetch_add(1);
  if (us > graph_optimization_max_us_.load()) graph_optimization_max_us_.store(us);
  if (!deformation_result_.solve.poses_updated()) {
    graph_optimization_failures_.fetch_add(1);
    std::fprintf(stderr, "loop closure: optimization failed (kept the previous solution): %s\n",
                 deformation_result_.solve.message.c_str());
    return false;
  }
  loop_closures_kept_.store(deformation_result_.loop_closures_kept);
  return true;
}

Eigen::Isometry3d Pipeline::corrected_pose(std::size_t k) const {
  const agents::AgentLayer& agents = frontend_.agents();
  const Eigen::Isometry3d odom = isometry(agents.chain(k).t_m, agents.chain(k).q);
  if (!deformation_.solved() || deformation_.num_agent_poses() == 0) return odom;
  if (k < deformation_.num_agent_poses()) {
    const backend::Pose3 p = deformation_.agent_pose(k);
    return isometry(p.t_m, p.q);
  }
  const std::size_t last = deformation_.num_agent_poses() - 1;
  const backend::Pose3 p = deformation_.agent_pose(last);
  return isometry(p.t_m, p.q) * isometry(agents.chain(last).t_m, agents.chain(last).q).inverse() * odom;
}

}  // namespace qsg::app

namespace qsg::app {

void Pipeline::correct_outputs(reconstruction::Mesh* mesh, reconstruction::Mesh* odometric) {
  counters_.agents_described = agents_described_.load();
  if (config_.loop_closure.enabled && !loop_closures_.empty() && !optimize_graph())
    std::fprintf(stderr, "loop closure: the final optimization failed; outputs keep the last solution\n");
  counters_.loop_closures = loop_closures_count_.load();
  counters_.loop_closures_kept = loop_closures_kept_.load();
  counters_.loop_closures_dropped = loop_closures_dropped_.load();
  counters_.loop_closures_by_appearance = loop_closures_by_appearance_.load();
  counters_.agent_frames_dropped = lc_frames_dropped_ + lc_pending_dropped_.load();
  counters_.graph_optimizations = graph_optimizations_.load();
  counters_.graph_optimization_failures = graph_optimization_failures_.load();
  counters_.graph_optimization_max_us = graph_optimization_max_us_.load();
  if (!config_.loop_closure.enabled) return;
  lc_detector_.counters().print(stdout);
  std::printf("loop closure: %zu control points (%llu refused), %zu loop closures in the graph\n",
              control_points_.size(), static_cast<unsigned long long>(control_points_.stats().failed),
              loop_closures_.size());
  score_loop_closures();
  if (!deformation_.solved()) return;
  deformation_result_.print(stdout);
  // Agents to their optimized poses; places to theirs; objects and rooms moved with the deformation around them.
  const agents::AgentLayer& agents = frontend_.agents();
  for (std::size_t k = 0; k < agents.chain_size(); ++k) {
    scene_graph::AgentAttributes* a = graph_.agent(agents.chain(k).id);
    if (a == nullptr) continue;
    const Eigen::Isometry3d T = corrected_pose(k);
    a->position_m = T.translation();
    a->world_R_body = Eigen::Quaterniond(T.linear());
  }
  graph_.for_each_node([&](const scene_graph::NodeRecord& n) {
    scene_graph::SemanticAttributes* s = nullptr;
    std::uint64_t t = 0;
    Eigen::Vector3d moved;
    if (n.kind == scene_graph::NodeKind::kPlace) {
      scene_graph::PlaceAttributes* p = graph_.place(n.id);
      if (deformation_.place_position(n.id, &moved)) {
        p->position_m = moved;
        return;
      }
      s = p;
    } else if (n.kind == scene_graph::NodeKind::kObject) {
      s = graph_.object(n.id);
    } else if (n.kind == scene_graph::NodeKind::kRoom) {
      s = graph_.room(n.id);
    } else if (n.kind == scene_graph::NodeKind::kBuilding) {
      s = graph_.building(n.id);
    }
    if (s == nullptr) return;
    t = s->last_update_time_ns;
    moved = deformation_.deform(s->position_m, t);
    const Eigen::Vector3d shift = moved - s->position_m;
    s->position_m = moved;
    if (s->bounding_box.type != scene_graph::BoundingBox::Type::kInvalid) {  // the box moves with its centre
      s->bounding_box.min_m += shift;
      s->bounding_box.max_m += shift;
      s->bounding_box.world_P_center_m += shift;
    }
  });
  // The mesh: vertices carry no time, so each moves with its nearest nodes of any time. The mesh as mapped is kept
  // for the objects' vertex keys, which name positions there.
  *odometric = *mesh;
  for (reconstruction::MeshVertex& v : mesh->vertices) {
    const Eigen::Vector3d p = deformation_.deform(Eigen::Vector3d(v.x, v.y, v.z));
    v.x = static_cast<float>(p.x());
    v.y = static_cast<float>(p.y());
    v.z = static_cast<float>(p.z());
  }
  for (std::size_t i = 0; i < trajectory_m_.size(); ++i) trajectory_m_[i] = deformation_.deform(trajectory_m_[i]);
}

}  // namespace qsg::app

namespace qsg::app {

// Where the truth is known (sim, replay with poses): each loop closure's relative pose against the true one.
void Pipeline::score_loop_closures() {
  if (ground_truth_.empty() || loop_closures_.empty()) return;
  const Eigen::Isometry3d mount = sim_camera_ != nullptr ? sim_camera_->body_T_camera() : Eigen::Isometry3d::Identity();
  std::size_t scored = 0, within = 0, kept_within = 0, wrong = 0, wrong_kept = 0;
  std::vector<double> errors_m;
  for (std::size_t i = 0; i < loop_closures_.size(); ++i) {
    const loop_closure::LoopClosure& lc = loop_closures_[i];
    replay::StampedPose a, b;
    if (!replay::interpolate_pose(ground_truth_, static_cast<std::int64_t>(lc.match_time_ns), INT64_MAX, &a) ||
        !replay::interpolate_pose(ground_truth_, static_cast<std::int64_t>(lc.query_time_ns), INT64_MAX, &b))
      continue;
    const Eigen::Isometry3d truth = (a.world_T_body() * mount).inverse() * (b.world_T_body() * mount);
    const Eigen::Isometry3d error = truth.inverse() * lc.match_T_query;
    const double e_m = error.translation().norm();
    const double e_rad = Eigen::AngleAxisd(error.linear()).angle();
    ++scored;
    errors_m.push_back(e_m);
    const bool good = e_m <= 0.10 && e_rad <= M_PI / 180.0;
    within += good ? 1 : 0;
    const bool kept = i < deformation_result_.loop_closure_weight.size() && deformation_result_.loop_closure_weight[i] > 0.5;
    kept_within += good && kept ? 1 : 0;
    const bool false_closure = e_m > 0.5 || e_rad > 5.0 * M_PI / 180.0;
    wrong += false_closure ? 1 : 0;
    wrong_kept += false_closure && kept ? 1 : 0;
    if (std::getenv("QSG_DEBUG_LOOP_CLOSURES") != nullptr)
      std::printf("  closure %zu (%s%s, icp overlap %.2f): %.1f s -> %.1f s, error %.3f m %.2f deg, %u inliers, kept %d\n", i,
                  loop_closure::to_string(lc.source), lc.refined ? "+icp" : "", lc.icp.overlap, lc.match_time_ns * 1e-9, lc.query_time_ns * 1e-9, e_m,
                  e_rad * 180.0 / M_PI,
                  lc.source == loop_closure::ClosureSource::kAppearance ? lc.appearance.inliers : lc.registration.inliers,
                  kept ? 1 : 0);
  }
  if (scored == 0) return;
  std::sort(errors_m.begin(), errors_m.end());
  std::printf("loop closure: %zu of %zu proposed within 10 cm / 1 deg of the truth (%zu of them kept); median "
              "translation error %.3f m; %zu false (over 0.5 m or 5 deg off), %zu of them kept\n",
              within, scored, kept_within, errors_m[errors_m.size() / 2], wrong, wrong_kept);
  counters_.loop_closures_true = within;
  counters_.loop_closures_false = wrong;
  counters_.loop_closures_false_kept = wrong_kept;
}

}  // namespace qsg::app
