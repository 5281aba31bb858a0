// The evaluations' one pipeline (issue 32): the app's stages — the reconstruction (TSDF and mesh), the frontend
// (places, objects, agents and their inter-layer edges) and the backend stage (doors online and on the final surface,
// rooms, labels) — built from the same Configs the app uses and driven through the same steps as the app's threads
// (core/pipeline/pipeline_steps.h, where their order is written once), in one thread and without deadlines.
// objects_eval, places_eval, rooms_eval and drift_baseline each run a tour through it and keep only their scoring;
// none composes the stages by hand.
//
// Per keyframe (integrate): pipeline::integrate_keyframe. Every frontend_every_n-th keyframe (update):
// pipeline::frontend_update, then, after a completed places cycle (always: no deadline), pipeline::backend_update
// without its room step (a door pass when due). Where the evaluations differ from the app, on purpose: they skip the
// online room updates (they score the final rooms only); at the tour's end (finish) they run frontend updates until a
// places cycle completes, and, with online doors, a last door pass on the latest places (the app stops at its last
// keyframe, whose places its last backend update saw). Then the final stage's two steps, pipeline::final_doors
// (close_doors) and pipeline::final_rooms (update_rooms), as the app's finish does.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "bench/sim_tour.h"
#include "budgets/budget_table.h"
#include "core/backend/backend_stage.h"
#include "core/frontend/frontend.h"
#include "core/objects/revisit_merge.h"
#include "core/pipeline/pipeline_steps.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/rooms/room_finder.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::bench {

struct PipelineConfig {
  // False: no reconstruction and no frontend (the graph comes from elsewhere, e.g. an evaluation's cache); the
  // backend stage alone (close_doors, update_rooms*: integrate, update, explore and finish need the frontend).
  bool frontend_stages = true;
  reconstruction::Config reconstruction;
  reconstruction::Capacities reconstruction_capacities = reconstruction::capacities_from_budget();
  std::size_t reconstruction_arena_bytes = budgets::active::reconstruction::kArenaBytes;
  frontend::Config frontend;
  // Frontend::observe on every keyframe, as the app. False: each places cycle carves the free space of the latest
  // frame only (places_eval --no-observe).
  bool observe = true;
  std::uint32_t frontend_every_n = 1;  // a frontend update every Nth keyframe (the last ones flushed by finish)
  int finish_updates = 100;            // finish: at most this many frontend updates until a places cycle completes
  bool backend = false;                // the backend stage (doors, rooms, labels); loop closure stays off
  backend::BackendStage::Config backend_stage;
};

// One frontend update and the door pass after it.
struct FrontendStep {
  std::size_t keyframe = 0;  // keyframes integrated so far
  Eigen::Isometry3d world_T_camera = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d truth_T_camera = Eigen::Isometry3d::Identity();  // the simulator's true pose (scoring only)
  std::uint64_t time_ns = 0;
  frontend::UpdateSummary summary;
  double update_ms = 0.0;      // the frontend update's wall time
  double update_cpu_ms = 0.0;  // ... and its thread CPU time
  bool door_pass = false;  // a door pass ran (due, and not skipped on stairs)
  rooms::PassResult pass;
  double pass_ms = 0.0;
};

// A place edge as it was before the final door stage changed it (EvalPipeline::close_doors).
using EdgeBefore = std::pair<std::pair<scene_graph::NodeId, scene_graph::NodeId>, scene_graph::EdgeAttributes>;

class EvalPipeline {
 public:
  // The stages, carved from the board's budget table (the reconstruction from the config's capacities); graph is
  // the caller's, initialised, and must outlive the pipeline. A missing room classifier is not an error (*warning).
  bool init(const PipelineConfig& config, scene_graph::SceneGraph* graph, std::string* error,
            std::string* warning = nullptr);

  // One keyframe (see the top).
  void integrate(const messages::RgbdFrame& frame, const Eigen::Isometry3d& world_T_camera, std::uint64_t time_ns);
  // A frontend update at the robot's position, then a door pass when one is due.
  FrontendStep update(const Eigen::Vector3d& robot_m, std::uint64_t time_ns);
  // The tour: every posed frame integrated, a frontend update every frontend_every_n-th; on_step(const
  // FrontendStep&) after each update. Returns the keyframes integrated.
  template <typename OnStep>
  std::size_t explore(SimTour& tour, OnStep&& on_step) {
    auto frame = std::make_unique<messages::RgbdFrame>();
    return for_each_posed_frame(tour, *frame,
                                [&](const messages::RgbdFrame& f, const Eigen::Isometry3d& T, std::int64_t t_ns,
                                    const Eigen::Isometry3d& truth_T) {
                                  integrate(f, T, static_cast<std::uint64_t>(t_ns));
                                  if ((keyframes_ - 1) % config_.frontend_every_n != 0) return;
                                  FrontendStep step = update(T.translation(), static_cast<std::uint64_t>(t_ns));
                                  step.world_T_camera = T;
                                  step.truth_T_camera = truth_T;
                                  on_step(step);
                                });
  }
  // The tour's end: frontend updates until a places cycle completes (finish_updates at most), then, with online
  // doors, a last pass on the latest places (as the app's last backend update sees them). Returns that pass.
  FrontendStep finish(const Eigen::Vector3d& robot_m, std::uint64_t time_ns);
  // The object visits the frontend kept apart (objects::Config::archive_after_s) merged in the graph, as the app's
  // finish does (objects::merge_revisits; here without a correction: in the map as mapped). finish() calls it last.
  objects::RevisitMerge merge_object_visits();

  // The final door stage on the mesh's vertices (BackendStage::close_doors); *changed (optional): the place edges it
  // closed, as they were before, for a peer that runs on the graph without it.
  backend::BackendStage::FinalDoors close_doors(const reconstruction::Mesh& mesh, std::vector<EdgeBefore>* changed);
  // The room finder on the whole map and the room labels (BackendStage::update_rooms, final).
  rooms::UpdateResult update_rooms(std::uint64_t time_ns = 0);
  // The room finder on the whole map reading recorded doors and sight lines instead of the stage's own (an online
  // run's, read back from an evaluation's cache; sight may be null): the same finder settings, its own store.
  bool update_rooms_recorded(const std::vector<rooms::Door>& doors, const rooms::WallSight* sight,
                             rooms::UpdateResult* result, std::string* error);
  // The room finder that ran last (the stage's, or the recorded doors' one).
  const rooms::RoomFinder& room_finder() const;
  // Whether the room finder reads sight lines (the final door stage's, or the last online pass's window).
  bool has_sight() const;

  reconstruction::SemanticTsdf& tsdf() { return *tsdf_; }
  const frontend::Frontend& frontend() const { return *frontend_; }
  const backend::BackendStage& backend() const { return *backend_; }
  scene_graph::SceneGraph& graph() { return *graph_; }
  std::size_t keyframes() const { return keyframes_; }
  // Per keyframe integrated: the TSDF's and the free-space observation's wall time (ms).
  const std::vector<double>& integrate_ms() const { return integrate_ms_; }
  const std::vector<double>& observe_ms() const { return observe_ms_; }
  const PipelineConfig& config() const { return config_; }

 private:
  // The harness's side of the steps: one thread, no locks; each step's wall time (and the frontend update's thread
  // CPU time), read after the step.
  class Timer : public pipeline::Host {
   public:
    void begin(pipeline::Step step) override;
    void end(pipeline::Step step, bool ran) override;
    double ms(pipeline::Step step) const { return ms_[static_cast<std::size_t>(step)]; }
    double cpu_ms(pipeline::Step step) const { return cpu_ms_[static_cast<std::size_t>(step)]; }

   private:
    static constexpr std::size_t kSteps = static_cast<std::size_t>(pipeline::Step::kFinalStage) + 1;
    std::array<std::chrono::steady_clock::time_point, kSteps> t0_{};
    std::array<double, kSteps> cpu0_{}, ms_{}, cpu_ms_{};
  };
  pipeline::Stages stages() const { return {tsdf_.get(), frontend_.get(), backend_.get(), graph_}; }

  PipelineConfig config_;
  Timer host_;
  scene_graph::SceneGraph* graph_ = nullptr;
  std::unique_ptr<reconstruction::SemanticTsdf> tsdf_;
  std::unique_ptr<frontend::Frontend> frontend_;
  std::unique_ptr<backend::BackendStage> backend_;
  std::unique_ptr<rooms::RoomFinder> recorded_finder_;  // update_rooms_recorded
  bool recorded_ran_ = false;
  bool final_doors_ok_ = false;
  std::size_t keyframes_ = 0;
  std::vector<double> integrate_ms_, observe_ms_;
};

}  // namespace qsg::bench
