// The pipeline's order in one place: the steps the app's threads (firmware_app/pipeline.cc) and the evaluations'
// harness (bench/eval_harness.h) both call, per keyframe (integrate_keyframe), every Nth keyframe (frontend_update),
// after each completed places cycle (backend_update: a door pass when due, then the rooms) and at the finish
// (final_stage: doors on the final surface, then the rooms and labels on the whole map). Pure and single-threaded:
// the shared state is passed in (Stages), and the caller's locks, timers and stage markers come in through Host.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>

#include "core/agents/agent_layer.h"
#include "core/backend/backend_stage.h"
#include "core/frontend/frontend.h"
#include "core/messages/sensor_types.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::pipeline {

// The stages the steps drive and the scene graph they share; the caller owns them all.
struct Stages {
  reconstruction::SemanticTsdf* tsdf = nullptr;
  frontend::Frontend* frontend = nullptr;
  backend::BackendStage* backend = nullptr;  // null: no backend stage (a frontend-only evaluation)
  scene_graph::SceneGraph* graph = nullptr;
};

// What another thread may touch while a step runs: the scene graph (the backend thread's rooms and door passes
// against the loop's frontend), and the online doors' wall map (the loop paints it, a door pass rasterizes it).
enum class Shared : std::uint8_t { kGraph, kWallMap };
// The steps a caller may time or mark (Host::begin / Host::end).
enum class Step : std::uint8_t { kIntegrate, kObserve, kFrontendUpdate, kDoorPass, kFinalStage };

// The caller's side of the steps. The defaults are a single-threaded, untimed caller (an evaluation); the app
// locks its mutexes, marks and times its stages, and hands frames to its own consumers here.
class Host {
 public:
  virtual ~Host() = default;
  virtual void lock(Shared) {}
  virtual void unlock(Shared) {}
  // False: the state is busy and the step skips what needed it (the wall painting, done with the next keyframe).
  virtual bool try_lock(Shared) { return true; }
  virtual void begin(Step) {}
  // ran: the step did its work (a door pass declines on stairs; a refused keyframe is not integrated).
  virtual void end(Step, bool /*ran*/) {}
  // After the TSDF took a keyframe, before anything else reads it (the app: segmentation, fault recovery).
  virtual void integrated(const messages::RgbdFrame&, const Eigen::Isometry3d& /*world_T_camera*/) {}
  // The backend update's last step, the graph held (the app: loop closure, which may release it with *graph).
  class Held;
  virtual void after_rooms(std::uint64_t /*time_ns*/, Held* /*graph*/) {}
};

// A Shared held for a scope; release() gives it back early.
class Host::Held {
 public:
  Held(Host& host, Shared what) : host_(host), what_(what) { host_.lock(what_); }
  ~Held() { release(); }
  Held(const Held&) = delete;
  Held& operator=(const Held&) = delete;
  void release() {
    if (held_) host_.unlock(what_);
    held_ = false;
  }

 private:
  Host& host_;
  Shared what_;
  bool held_ = true;
};

// ---- Per keyframe ----
struct KeyframeResult {
  bool integrated = false;           // false: the reconstruction refused the frame and nothing else ran
  std::uint64_t blocks_painted = 0;  // re-meshed blocks painted into the online doors' wall map
  bool walls_deferred = false;       // the wall map was busy (a door pass): painted with the next keyframe
  agents::AddResult added = agents::AddResult::kNotInitialized;
};
// The TSDF integrates the frame; the online doors' wall map takes the re-meshed blocks; the frontend observes the
// frame's free space (observe false: each places cycle carves the latest frame only) and adds the agent node
// (graph held).
KeyframeResult integrate_keyframe(const Stages& s, Host& host, const messages::RgbdFrame& frame,
                                  const Eigen::Isometry3d& world_T_camera, std::uint64_t time_ns,
                                  const Eigen::Matrix<double, 6, 1>& variance = Eigen::Matrix<double, 6, 1>::Zero(),
                                  bool observe = true);

// ---- Every Nth keyframe ----
// The frontend's anytime update (objects, places until the deadline, their sync, the inter-layer edges) and the
// backend's control points from the newly meshed blocks, graph held. A backend update is due when it completed a
// places cycle (backend_update_due).
frontend::UpdateSummary frontend_update(const Stages& s, Host& host, const Eigen::Vector3d& robot_m,
                                        std::uint64_t time_ns, const frontend::Deadline& deadline);
inline bool backend_update_due(const frontend::UpdateSummary& summary) { return summary.places_complete; }

// ---- After each completed places cycle ----
// One online door pass around the robot: the window's places (graph held), the wall raster (wall map held), the
// detection (neither).
rooms::PassResult door_pass(const Stages& s, Host& host, const Eigen::Vector3d& robot_m);
struct BackendResult {
  bool door_pass = false;  // one was due (every doors_online_every_n-th update) and ran
  rooms::PassResult pass;
  rooms::UpdateResult rooms;
};
// A door pass when one is due; then, with rooms, the room finder in the active window and the labels, and
// Host::after_rooms, graph held. rooms false: the door passes only (the evaluations, which score the final rooms).
BackendResult backend_update(const Stages& s, Host& host, const Eigen::Vector3d& robot_m, std::uint64_t time_ns,
                             bool rooms = true);

// ---- At the finish ----
// Doors on the final surface (graph held): they close the place edges through them and replace the online ones.
backend::BackendStage::FinalDoors final_doors(const Stages& s, Host& host, const reconstruction::Mesh& mesh);
// The room finder on the whole map and the labels (graph held).
rooms::UpdateResult final_rooms(const Stages& s, Host& host, std::uint64_t time_ns);
struct FinalResult {
  backend::BackendStage::FinalDoors doors;  // ok false and no error when the door stage did not run
  rooms::UpdateResult rooms;
};
// The backend's final stage: final_doors on mesh (null: none), then final_rooms; Step::kFinalStage around both.
FinalResult final_stage(const Stages& s, Host& host, const reconstruction::Mesh* mesh, std::uint64_t time_ns);

}  // namespace qsg::pipeline
