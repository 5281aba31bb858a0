// The backend stage: what the paper's backend does with the frontend's places, objects and agents — doors (online in
// a window around the robot, and once more on the final surface), rooms and the building, room labels, and the
// persistent scene graph (agent descriptors, loop-closure detection and verification, the deformation graph and the
// correction of every layer). Pure: no threads, no locks, no clock; each method says which shared state its caller
// must hold. The order of its calls is core/pipeline/pipeline_steps.h's, which the app (firmware_app/pipeline.cc) and
// the evaluations (bench/eval_harness.h) both call. Its stores are the budget table's "rooms", "doors" and
// "loop_closure" arenas; its counters are atomics, readable from any thread.
#pragma once

#include <Eigen/Geometry>
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/agents/agent_layer.h"
#include "core/backend/deformation_graph.h"
#include "core/loop_closure/detector.h"
#include "core/neural_tree/room_classifier.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/doors/door_detector.h"
#include "core/doors/online_doors.h"
#include "core/rooms/room_finder.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::backend {

// The persistent scene graph (paper: "Persistent Representations"): agents described once the robot is horizon_s
// past them (one per describe_every_m of path), loop closures detected top-down and verified bottom-up over the
// scene graph, and the deformation graph re-solved after new ones.
struct LoopClosureConfig {
  // On: on the main job and on every generated building measured it improves the trajectory and the mesh and
  // keeps the other layers (bench/results/loop_closure.md, "Session of 2026-12-05").
  bool enabled = true;
  double horizon_s = 15.0;
  double describe_every_m = 1.0;
  // The deformation graph is re-solved after a new loop closure at most once per this much mission time; closures
  // found meanwhile wait for the next solve (and the finish solves whatever is pending).
  double solve_interval_s = 10.0;
  // Closures kept at most (0: the budget's loop_closure.loop_closures, which bounds it); a full store folds
  // (fold_loop_closures). Below the budget only to try the fold on a short mission (bench/loop_closure).
  std::uint32_t closure_capacity = 0;
  loop_closure::DescriptorConfig descriptor;
  loop_closure::DetectorConfig detector;
  DeformationConfig deformation;
  // The odometry edges' per-distance noise (deformation.agents, OdometryWeighting::kPerDistance) taken from the
  // odometry source's own model when it has one (the simulator's drifting odometry: its sigmas per sqrt(m)), else the
  // configured ones. Applied by the app, which knows the source.
  bool odometry_sigmas_from_source = true;
  // The frontend maps in the corrected frame: after each solve, the keyframes that follow are integrated (TSDF,
  // agents, places, objects) at the odometric pose times the latest correction (map_T_odom: the last solved agent's
  // optimized pose times its odometric one inverted), so that a revisit lands where the corrected map has its first
  // visit. The agents keep the correction they were mapped in: the odometry edges measure the odometry alone.
  bool map_in_corrected_frame = true;
  // Reconciliation after the final correction (paper: interpolation and merging; BackendStage::reconcile): objects
  // re-boxed from the corrected mesh, revisited places and objects merged, and the final doors, rooms and labels
  // found on the corrected map. Off: they are found on the map as mapped and moved with the correction, which
  // scored better on the generated buildings (bench/results/loop_closure.md).
  bool reconcile = false;
  // The paper's last reconciliation step alone: the final doors, rooms and room labels found on the corrected map
  // (the mesh and the places as the correction moves them), objects and places otherwise as without reconcile
  // (moved, not re-boxed or merged). Off (and reconcile off): found on the map as mapped and moved with the
  // correction. reconcile implies it. Off by default: on the generated buildings it gives fewer, larger rooms, as
  // the true-pose run finds, and a lower F1 (bench/results/loop_closure.md, "rooms found on the corrected map").
  bool rooms_after_correction = false;
  // Places closer than this whose free-space spheres hold each other merge (0: none). (Objects of different visits
  // merge at the finish with or without reconciliation: objects::merge_revisits.)
  double merge_places_within_m = 0.4;
  std::string check() const;
};

// The sigmas a loop closure's edge gets in the deformation graph: by how it was verified (appearance, objects, ICP
// on keyframes or on local maps, whose stitching adds the odometry's walk over the local map's path).
void closure_sigmas(const loop_closure::LoopClosure& lc, const LoopClosureConfig& config, Eigen::Vector3d* sigma_t_m,
                    Eigen::Vector3d* sigma_rot_rad);
// A loop closure as an edge between chain nodes: the nodes nearest its two agents' times. An agent the chain has
// folded away since is joined to that node through the odometry between them (the closure's stored odometric
// poses), so the edge measures the nodes' relative pose, not the folded agent's, and its sigmas add the odometry's
// walk over the distance joined. False when both ends fall on one node (or out of order).
bool chain_closure(const agents::ChainView& agents, const loop_closure::LoopClosure& lc, const LoopClosureConfig& config,
                   ChainLoopClosure* out);
// The loop-closure store's policy when full (a fold), in place and without allocating: of the older half, the
// closures `rejected` names (the last solve's outliers) go first; when that frees less than a quarter of the store,
// every second closure left in the older half goes too, as the agent chain and the control points fold. The newer
// half stays whole. Returns how many closures went.
template <typename Rejected>
std::size_t fold_loop_closures(std::vector<loop_closure::LoopClosure>* closures, Rejected&& rejected) {
  std::vector<loop_closure::LoopClosure>& v = *closures;
  const std::size_t n = v.size(), half = n / 2;
  std::size_t out = 0;
  for (std::size_t i = 0; i < half; ++i)
    if (!rejected(v[i])) v[out++] = v[i];
  if (half - out < (n + 3) / 4) {  // too few outliers: thin what is left of the older half
    std::size_t thinned = 0;
    for (std::size_t i = 0; i < out; i += 2) v[thinned++] = v[i];
    out = thinned;
  }
  for (std::size_t i = half; i < n; ++i) v[out++] = v[i];
  v.resize(out);
  return n - out;
}

class BackendStage {
 public:
  struct Config {
    rooms::Config rooms;
    rooms::DoorConfig doors;
    bool doors_online = true;                // an online door pass every doors_online_every_n-th update
    std::uint32_t doors_online_every_n = 4;
    std::string room_weights_path;           // empty: the classifier's default weights
    // The object labels the app can perceive (RoomClassifier::Config::perceived_labels): the classifier then uses
    // the head trained on rooms as that perception shows them. Empty: the file's own head.
    std::vector<semantics::Label> perceived_labels;
    LoopClosureConfig loop_closure;
  };

  // Totals, written by the stage and readable from any thread.
  struct Counters {
    std::atomic<std::uint64_t> updates{0};
    std::atomic<std::uint64_t> rooms{0};
    std::atomic<std::uint64_t> rooms_labelled{0};
    std::atomic<std::uint64_t> rooms_merged_visible{0};
    std::atomic<std::uint64_t> door_passes{0};
    std::atomic<std::uint64_t> door_passes_climbing{0};
    std::atomic<std::uint64_t> online_doors{0};
    std::atomic<std::uint64_t> online_doors_kept_missed{0};
    std::atomic<std::uint64_t> online_doors_dropped{0};
    std::atomic<std::uint64_t> online_doors_bypassed{0};
    std::atomic<std::uint64_t> online_bypass_refused{0};
    std::atomic<std::uint64_t> door_pass_max_us{0};
    std::atomic<std::uint64_t> agents_described{0};
    std::atomic<std::uint64_t> loop_closures{0};
    std::atomic<std::uint64_t> loop_closures_kept{0};
    std::atomic<std::uint64_t> loop_closure_folds{0};    // the closure store full: fold_loop_closures
    std::atomic<std::uint64_t> loop_closures_folded{0};  // closures its folds dropped
    std::atomic<std::uint64_t> loop_closures_by_appearance{0};
    std::atomic<std::uint64_t> appearances_dropped{0};  // described too late: the oldest waiting appearance went
    std::atomic<std::uint64_t> graph_optimizations{0};
    std::atomic<std::uint64_t> graph_optimization_failures{0};
  };

  // What the final door stage found (close_doors).
  struct FinalDoors {
    bool ok = false;
    std::string error;
    std::size_t doors = 0, slices = 0, bypassed = 0, bypass_unchecked = 0;
    std::size_t candidates = 0;  // door candidates before the checks
    std::uint64_t edges_closed = 0, edges_through_walls = 0;
    std::vector<rooms::Door> found;  // the doors themselves (for the evaluations' scoring)
  };

  BackendStage() = default;
  BackendStage(const BackendStage&) = delete;
  BackendStage& operator=(const BackendStage&) = delete;

  // Carves every store. graph_capacities size the rooms' and the classifier's inputs; tsdf_block_slots the online
  // doors' paint bookkeeping; frame_bytes is what the caller holds of the "loop_closure" arena for the keyframes
  // it hands over (add_appearance), checked with the stage's own stores against the arena. A missing or corrupt
  // classifier weight file is not an error: it is reported in *warning and the rooms stay "unknown".
  bool init(const Config& config, const scene_graph::Capacities& graph_capacities, std::size_t tsdf_block_slots,
            std::size_t frame_bytes, std::string* error, std::string* warning);
  const Config& config() const { return config_; }
  const Counters& counters() const { return counters_; }

  // ---- Doors during the run (loop thread paints, backend thread detects) ----
  bool online_doors_enabled() const { return online_doors_.initialized(); }
  // Loop thread, holding the wall lock: re-meshed blocks into the wall map. Returns the blocks painted.
  std::uint64_t paint_walls(const reconstruction::SemanticTsdf& tsdf);
  // One surface point into the wall map, for an evaluation that has a surface but no TSDF (bench/rooms/
  // window_costs); false when the wall map refused it (full, or no online doors).
  bool paint_wall_point(float x, float y, float z) {
    return online_doors_.initialized() && online_doors_.wall_map().add(x, y, z);
  }
  // True when this update is one that runs a door pass (every doors_online_every_n-th); counts the updates.
  bool door_pass_due();
  // One pass in three steps, so the caller can hold the right lock for each: the places (graph lock), the wall
  // raster (wall lock), the detection (neither).
  void begin_door_pass(const Eigen::Vector3d& robot_m) { online_doors_.begin_pass(robot_m); }
  void add_door_places(const scene_graph::SceneGraph& graph) { online_doors_.add_places(graph); }
  void rasterize_walls() { online_doors_.rasterize(); }
  rooms::PassResult detect_doors();
  void note_door_pass_us(std::uint64_t us);  // the caller's timing of the whole pass (door_pass_max_us)

  // ---- Rooms, building and labels (graph lock held) ----
  // During the run (final false) the room finder reads the active window and the rooms holding it
  // (rooms::Config::window_updates); the final update (final true, or any once the final door stage ran) the
  // whole map.
  rooms::UpdateResult update_rooms(scene_graph::SceneGraph* graph, std::uint64_t time_ns, bool final = false);
  // Doors on the final surface (graph lock held): they close the place edges through them and replace the online
  // ones; the sight lines they leave are the finder's from then on. On failure the rooms stay as the run found them.
  FinalDoors close_doors(const reconstruction::Mesh& mesh, scene_graph::SceneGraph* graph);

  // ---- The persistent scene graph ----
  bool loop_closure_enabled() const { return config_.loop_closure.enabled; }
  void disable_loop_closure() { config_.loop_closure.enabled = false; }
  // Loop thread, graph lock held: one control point per newly meshed block.
  void offer_control_points(const reconstruction::SemanticTsdf& tsdf, std::uint64_t time_ns);
  // Backend thread: the appearance (features and depth cloud) of an agent's keyframe, kept until it is described.
  void add_appearance(scene_graph::NodeId agent, std::uint64_t time_ns, const loop_closure::GreyDepthView& view);
  // Backend thread, graph lock held: describes the chain nodes the robot left horizon_s ago (the places and objects
  // around each) into a buffer reserved at start-up. Returns how many.
  std::size_t describe_agents(const scene_graph::SceneGraph& graph, const agents::AgentLayer& agents,
                              std::uint64_t time_ns);
  // Backend thread, without the lock: looks each described agent up among the earlier ones and verifies the match
  // (appearance, objects, ICP). True when a new loop closure was verified.
  bool detect_described();
  // Both (graph lock held).
  bool detect_loop_closures(const scene_graph::SceneGraph& graph, const agents::AgentLayer& agents,
                            std::uint64_t time_ns) {
    describe_agents(graph, agents, time_ns);
    return detect_described();
  }
  // Both, when the mission is over (graph lock held): its map is final, so the agents of the last horizon_s before
  // last_keyframe_ns are described too (a tour's return to its start is among them).
  bool detect_at_finish(const scene_graph::SceneGraph& graph, const agents::AgentLayer& agents,
                        std::uint64_t last_keyframe_ns) {
    const auto horizon_ns = static_cast<std::uint64_t>(config_.loop_closure.horizon_s * 1e9);
    return detect_loop_closures(graph, agents, last_keyframe_ns + horizon_ns);
  }
  // Called around each described agent's lookup and verification (begin, then end), with the agent's time:
  // the app's stage markers count the instructions per agent. None set: one branch per agent.
  using DetectHook = void (*)(void* user, bool begin, std::uint64_t agent_time_ns);
  void set_detect_hook(DetectHook hook, void* user) {
    detect_hook_ = hook;
    detect_hook_user_ = user;
  }
  // True when a closure waits for a solve and solve_interval_s has passed since the last (marks it started).
  bool solve_due(std::uint64_t time_ns);
  // Whether solve_due(time_ns) can be true after detect_described(): the inputs must then be copied first.
  bool solve_may_follow(std::uint64_t time_ns, bool described) const;
  bool solve_pending() const { return solve_pending_; }
  // Graph lock held: copies what the deformation problem reads of the chain, the control points (offered by the loop
  // thread) and the graph's places into buffers reserved at start-up (DeformationInputs), so the problem is built
  // without the lock.
  void copy_deformation_inputs(const agents::AgentLayer& agents, const scene_graph::SceneGraph& graph);
  const DeformationInputs& deformation_inputs() const { return deformation_inputs_; }
  // Without the lock: the deformation graph over the last copy, every loop closure so far and the control points.
  DeformationProblem build_deformation() const;
  // Both (graph lock held).
  DeformationProblem build_deformation(const agents::AgentLayer& agents, const scene_graph::SceneGraph& graph) {
    copy_deformation_inputs(agents, graph);
    return build_deformation();
  }
  // Without the lock: solves it. False (and counted, the previous solution kept) when the solve failed.
  bool solve_deformation(DeformationProblem problem, std::string* error);
  // Graph lock held: agents and places to their optimized poses, objects, rooms and the building moved by the
  // deformation around them (nothing when no solve has succeeded).
  void correct_graph(const agents::AgentLayer& agents, scene_graph::SceneGraph* graph) const;
  // The mesh moved by the deformation (embedded deformation: each vertex by its nearest nodes of its own time, when
  // the mesh has vertex times).
  void correct_mesh(reconstruction::Mesh* mesh) const;
  // After correct_graph and correct_mesh (graph lock held; off the real-time path: it allocates): the paper's
  // reconciliation. Each object's centre and box from its mesh vertices in the corrected mesh (indices: the
  // object's vertices in it; an object without any keeps its moved box); revisited places within
  // merge_places_within_m merged. The objects' visits are the caller's next objects::merge_revisits(), rooms and
  // labels its next update_rooms().
  struct Reconciliation {
    std::size_t objects_from_mesh = 0, places_merged = 0, edges_refused = 0;
  };
  Reconciliation reconcile(const reconstruction::Mesh& corrected_mesh,
                           const std::unordered_map<scene_graph::NodeId, std::vector<std::uint32_t>>& indices,
                           scene_graph::SceneGraph* graph) const;
  Eigen::Vector3d deform(const Eigen::Vector3d& p_m) const { return deformation_.deform(p_m); }
  // Where the latest solve puts a node mapped at p_m (seen last at time_ns): a place of the solved graph at its
  // optimized position, any other node moved by the deformation around it; p_m before any solve.
  Eigen::Vector3d corrected_position(scene_graph::NodeId id, scene_graph::NodeKind kind, const Eigen::Vector3d& p_m,
                                     std::uint64_t time_ns) const;
  bool solved() const { return deformation_.solved(); }
  // world_T_camera of chain node k after the latest optimization (nodes after the solved chain follow the
  // correction of the last solved one); the odometric pose before any.
  Eigen::Isometry3d corrected_pose(const agents::AgentLayer& agents, std::size_t k) const;
  // The odometry frame onto the latest solution (DeformationGraph::map_T_odom); identity before any solve.
  Eigen::Isometry3d map_T_odom() const;
  const std::vector<loop_closure::LoopClosure>& loop_closures() const { return loop_closures_; }
  const DeformationResult& deformation_result() const { return deformation_result_; }
  const loop_closure::LoopClosureDetector& detector() const { return detector_; }
  const ControlPoints& control_points() const { return control_points_; }
  // Path along the agent chain up to the last agent looked at for description (m).
  double described_path_m() const { return path_m_; }

  // Every store, as memory::ResourceStats (capacity, use, high-water mark, failures). with_door_set false: the
  // online doors' door set, which a door pass writes without the graph lock, is left out (their arena and wall
  // map are read as usual) — for a reader on another thread than the stage's.
  template <typename Fn>
  void for_each_resource(Fn&& fn, bool with_door_set = true) const {
    rooms_.for_each_resource(fn);
    if (online_doors_.initialized()) {
      if (with_door_set) {
        online_doors_.for_each_resource(fn);
      } else {
        fn(online_doors_.arena().stats());
        fn(online_doors_.wall_map().tile_stats());
      }
    }
    if (!config_.loop_closure.enabled) return;
    fn(detector_.stats());
    fn(control_points_.stats());
    memory::ResourceStats s;
    s.name = "loop_closure.closures";
    s.unit = "closures";
    s.capacity = closure_capacity_;
    s.in_use = loop_closures_.size();
    s.high_water = loop_closures_high_water_;
    s.failed = 0;  // a full store folds (counters: loop_closure_folds, loop_closures_folded); nothing is refused
    fn(s);
  }
  const rooms::OnlineDoors& online_doors() const { return online_doors_; }
  const rooms::RoomFinder& room_finder() const { return rooms_; }
  const std::string& classifier_error() const { return classifier_error_; }
  // The classifier's view head in use (empty: the file's own head, or no classifier).
  std::string classifier_view() const { return classifier_ != nullptr ? classifier_->view() : std::string(); }

 private:
  bool init_loop_closure(const scene_graph::Capacities& gc, std::size_t frame_bytes, std::string* error);
  void label_rooms(scene_graph::SceneGraph* graph, bool window, std::uint64_t time_ns);

  Config config_;
  Counters counters_;
  rooms::RoomFinder rooms_;
  rooms::OnlineDoors online_doors_;
  rooms::WallSight final_sight_;  // the final door stage's sight lines; before it, the online window's
  std::vector<std::uint32_t> painted_stamp_;   // per TSDF block slot: the meshed_stamp last painted
  std::vector<memory::Index3> painted_block_;  // ... and the block it was
  std::uint64_t updates_due_ = 0;
  std::unique_ptr<neural_tree::RoomClassifier> classifier_;
  neural_tree::ObjectRoomGraph room_graph_;
  std::string classifier_error_;  // the latest failure

  struct PendingAppearance {
    scene_graph::NodeId agent = scene_graph::kNoNode;
    std::uint64_t time_ns = 0;
    loop_closure::AppearanceFeatures features;
    loop_closure::DepthCloud cloud;
  };
  std::vector<PendingAppearance> pending_;  // waiting for their description (time order)
  std::vector<loop_closure::AgentEntry> described_;  // described under the lock, looked up without it
  loop_closure::AppearanceExtractor appearance_;
  loop_closure::DescriptorBuilder descriptors_;
  loop_closure::LoopClosureDetector detector_;
  ControlPoints control_points_;
  DeformationGraph deformation_;
  DeformationInputs deformation_inputs_;  // the chain and places as last copied under the graph lock
  DeformationResult deformation_result_;
  std::vector<loop_closure::LoopClosure> loop_closures_;  // capacity: the budget's loop_closure.loop_closures
  std::size_t loop_closures_high_water_ = 0;
  std::size_t closure_capacity_ = 0;  // loop_closure.closure_capacity, or the store's reserved capacity
  bool solve_pending_ = false;
  std::uint64_t last_solve_ns_ = 0;
  std::uint64_t described_until_ns_ = 0;  // chain nodes up to this time are described (or skipped)
  double path_m_ = 0.0;                   // path along the chain to the last node looked at
  Eigen::Vector3d last_m_ = Eigen::Vector3d::Zero();
  bool have_last_ = false;
  DetectHook detect_hook_ = nullptr;
  void* detect_hook_user_ = nullptr;
  std::uint32_t cp_mesh_stamp_ = 0;  // blocks meshed after this stamp are offered as control points
};

}  // namespace qsg::backend
