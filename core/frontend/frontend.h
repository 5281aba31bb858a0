// The frontend (the paper's Layers 2-3 in real time): every keyframe an agent node; every Nth keyframe an anytime
// update of places (ESDF, GVD, sparsification) and objects (clusters of new mesh vertices), their sync into the
// scene graph, and the inter-layer edges from each object and agent to its nearest active place. Stops at its
// deadline and resumes on the next call without losing work. Never allocates after init().
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>

#include "core/agents/agent_layer.h"
#include "core/frontend/incremental_place_index.h"
#include "core/frontend/nearest_place_index.h"
#include "core/memory/fixed_vector.h"
#include "core/objects/object_layer.h"
#include "core/places/places.h"

namespace qsg::frontend {

struct Config {
  places::Config places;
  objects::Config objects;
  agents::Config agents;
  bool connect_interlayer = true;  // objects and agents get their nearest active place as parent
  // Objects tracked in the window and within (places window - 1 m) of the robot, where the active places are,
  // get their parent among the active places every cycle. Every this many places cycles the others (out of the
  // window, or nearer its rim) get the place of the whole graph, active or not, whose free-space sphere is
  // nearest. Before, an object seen from afar (through a door, before its own room had places) kept the place
  // behind the wall once it left the window, in the wrong room (bench/results/objects.md). One k-d tree rebuild
  // over all places per refresh. 0: off (every
  // tracked object among the active places every cycle, as before).
  std::uint32_t reparent_untracked_every = 10;
  std::string check() const;
  void print(std::FILE* out) const;
};

// When an update must stop: a clock (the scheduler's, through a function pointer: no allocation, no dependency
// on firmware_app) and a deadline on it; or a work-unit count for deterministic tests.
struct Deadline {
  using NowFn = std::int64_t (*)(const void* context);
  NowFn now = nullptr;
  const void* context = nullptr;
  std::int64_t deadline_ns = std::numeric_limits<std::int64_t>::max();
  std::uint64_t max_work_units = std::numeric_limits<std::uint64_t>::max();
  bool expired() const { return now != nullptr && now(context) >= deadline_ns; }
};

struct Counters {
  std::uint64_t updates = 0;
  std::uint64_t places_cycles = 0;       // completed places cycles (GVD and places caught up with the TSDF)
  std::uint64_t deadline_stops = 0;      // updates that stopped at the deadline with places work left
  std::uint64_t interlayer_connected = 0;
  std::uint64_t interlayer_failed = 0;   // edge stores full
  std::uint64_t interlayer_reconnected = 0;  // keyframes whose place was removed, given the nearest one again
  std::uint64_t reparent_refreshes = 0;      // refreshes of the objects outside the window (reparent_untracked_every)
  std::uint64_t objects_reparented = 0;      // objects outside the window whose parent place changed
  std::uint64_t graph_refused = 0;       // a sync could not add everything (retried on the next one)
  void print(std::FILE* out) const;
};

struct UpdateSummary {
  bool places_complete = false;
  std::uint64_t places_work_units = 0;
  objects::UpdateResult objects;
  places::SyncResult places_sync;
  ConnectStats connect;
  ConnectStats reparent;  // objects outside the window, on the cycles that refresh them
};

class Frontend {
 public:
  Frontend() = default;
  Frontend(const Frontend&) = delete;
  Frontend& operator=(const Frontend&) = delete;

  // Every store from the board's budget table (places and objects arenas, the index from the place capacity).
  bool init(const Config& config, std::string* error);

  // Every keyframe, right after its integration: what the frame saw as free space, for the next places cycle
  // (the places update may run only every Nth keyframe).
  void observe(const reconstruction::SemanticTsdf& tsdf, const Eigen::Isometry3d& world_T_camera) {
    if (ready_) places_.observe(tsdf, world_T_camera);
  }
  // Every keyframe.
  agents::AddResult add_keyframe(scene_graph::SceneGraph* graph, std::uint64_t timestamp_ns,
                                 const Eigen::Isometry3d& world_T_body,
                                 const Eigen::Matrix<double, 6, 1>& variance = Eigen::Matrix<double, 6, 1>::Zero());
  // Every Nth keyframe: objects, then places until the deadline; when a places cycle completes, both are synced
  // and the inter-layer edges are refreshed.
  UpdateSummary update(const reconstruction::SemanticTsdf& tsdf, const Eigen::Vector3d& robot_m,
                       std::uint64_t time_ns, scene_graph::SceneGraph* graph, const Deadline& deadline);

  const places::Places& places() const { return places_; }
  const objects::ObjectLayer& objects() const { return objects_; }
  const agents::AgentLayer& agents() const { return agents_; }
  // The odometry stepped (a relocalization or a reset): the next agent's odometry edge does not measure motion.
  void mark_odometry_step() { agents_.mark_odometry_step(); }
  void set_frame_correction(const Eigen::Isometry3d& map_T_odom) { agents_.set_frame_correction(map_T_odom); }
  const Counters& counters() const { return counters_; }
  const Config& config() const { return config_; }
  template <typename Fn>
  void for_each_resource(Fn&& fn) const {  // fn(const memory::ResourceStats&)
    places_.for_each_resource(fn);
    objects_.for_each_resource(fn);
    fn(connect_nodes_.stats());
    fn(index_.stats());
    fn(all_places_index_.stats());
  }

 private:
  void connect_interlayer(scene_graph::SceneGraph* graph, const Eigen::Vector3d& robot_m, UpdateSummary* summary);
  void reparent_untracked(scene_graph::SceneGraph* graph, const Eigen::Vector3d& robot_m, UpdateSummary* summary);
  // Whether an object takes its parent among the active places each cycle (else in the periodic refresh).
  bool near_active_places(const objects::ObjectView& o, const Eigen::Vector3d& robot_m) const;

  Config config_;
  places::Places places_;
  objects::ObjectLayer objects_;
  agents::AgentLayer agents_;
  // The active places' k-d tree, rebuilt every cycle from the window's published places (not from a scan of the
  // building), and every place, active or not, kept place by place (reparent_untracked).
  NearestPlaceIndex index_;
  IncrementalPlaceIndex all_places_index_;
  void refresh_place_indices(const scene_graph::SceneGraph& graph);
  std::uint32_t cycles_since_reparent_ = 0;
  memory::FixedVector<scene_graph::NodeId, 8192> connect_nodes_{"frontend.connect_nodes"};
  std::size_t agents_connected_ = 0;  // keyframes [0, agents_connected_) were given their place edge
  // Those keyframes lose their place when it is removed (its GVD voxels vanished). After a sync that removed
  // places, a rotating sweep checks every connected keyframe once, a bounded number per update, and connects the
  // orphans again.
  std::size_t orphan_cursor_ = 0;
  std::size_t orphan_checks_left_ = 0;
  Counters counters_;
  bool ready_ = false;
};

}  // namespace qsg::frontend
