// The onboard pipeline behind the tick loop: a camera source feeds keyframes (selected by time and motion) into
// Layer 1 reconstruction every keyframe and the frontend every Nth keyframe, as the board's task table says;
// telemetry, heartbeat and scene-graph snapshots run at their own rates. Lockstep mode runs it all on one
// thread against a stepped clock, deterministically.
#pragma once

#include <Eigen/Geometry>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <mutex>
#include <thread>
#include <string>
#include <vector>

#include "core/backend/agent_pose_graph.h"
#include "core/backend/backend_stage.h"
#include "core/backend/deformation_graph.h"
#include "core/loop_closure/detector.h"
#include "core/frontend/frontend.h"
#include "core/metrics/trajectory_error.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/neural_tree/room_classifier.h"
#include "core/pipeline/pipeline_steps.h"
#include "core/doors/online_doors.h"
#include "core/rooms/room_finder.h"
#include "core/segmentation/segmenter.h"
#include "core/scene_graph/scene_graph.h"
#include "drivers/gpio/gpio_devices.h"
#include "drivers/gpio/gpio_line.h"
#include "drivers/gpio/sim_gpio.h"
#include "drivers/replay/dataset_replay.h"
#include "drivers/v4l2/v4l2_rgbd_source.h"
#include "drivers/sim/sim_camera.h"
#include "drivers/world/world.h"
#include "firmware_app/app_config.h"
#include "firmware_app/fault_injection.h"
#include "firmware_app/odometry_input.h"
#include "firmware_app/segmentation_worker.h"
#include "firmware_app/runtime/telemetry_writer.h"
#include "firmware_app/runtime/bounded_queue.h"
#include "firmware_app/runtime/clock.h"
#include "firmware_app/runtime/keyframe_selector.h"
#include "firmware_app/runtime/scheduler.h"

namespace qsg::app {

// Per-run totals the app prints, tests assert on, and the budget benchmark reports.
struct PipelineCounters {
  std::uint64_t frames_read = 0;
  std::uint64_t frames_bad = 0;           // kBadFrame from the source
  std::uint64_t frames_without_pose = 0;  // dropped: no odometry pose at their sample time (see OdometryCounters)
  std::uint64_t keyframes = 0;
  std::uint64_t keyframes_integrated = 0;
  std::uint64_t keyframes_refused = 0;    // reconstruction rejected the frame (counted, the run goes on)
  std::uint64_t frontend_updates = 0;
  std::uint64_t frontend_deadline_stops = 0;  // the frontend stopped at its deadline (work carried to its next run)
  std::uint64_t agent_nodes = 0;
  std::uint64_t agent_refused = 0;
  std::uint64_t agent_sparsified = 0;     // keyframes folded into the next agent node's edge (agents::Config)
  std::uint64_t snapshots_written = 0;
  std::uint64_t snapshot_failures = 0;
  std::uint64_t snapshots_deferred = 0;  // ticks a snapshot waited for a running deformation solve
  std::uint64_t heartbeat_toggles = 0;
  std::uint64_t gpio_failures = 0;        // heartbeat, trigger or pause line calls that failed (counted, run goes on)
  std::uint64_t triggers = 0;
  std::uint64_t frames_paused = 0;        // read while the pause switch was on: dropped
  std::uint64_t backend_updates = 0;      // room updates run by the backend
  std::uint64_t rooms = 0;                // rooms after the latest backend update
  std::uint64_t rooms_labelled = 0;       // rooms the neural tree gave a label (latest update)
  std::uint64_t rooms_merged_visible = 0; // rooms merged into a room they see (latest update, its sight lines)
  std::uint64_t doors = 0;                // doors found when the run finished (AppConfig::doors_at_finish)
  std::uint64_t door_edges_closed = 0;    // place edges they closed
  std::uint64_t edges_through_walls = 0;  // place edges closed because they cross a structural wall (final stage)
  std::uint64_t doors_bypassed = 0;       // found then, but dropped: the places graph goes round them
  std::uint64_t door_failures = 0;        // the door stage failed (logged; the rooms stay as the run left them)
  // Online doors (AppConfig::doors_online).
  std::uint64_t door_passes = 0;          // window passes run before a room update
  std::uint64_t door_passes_climbing = 0; // passes skipped: the robot's height was changing (stairs)
  std::uint64_t online_doors = 0;         // doors the room finder reads (latest pass)
  std::uint64_t online_doors_kept_missed = 0;  // kept doors a pass over them missed, summed over passes (hysteresis)
  std::uint64_t online_doors_dropped = 0; // doors dropped at DoorConfig::online_misses_to_drop missed passes
  std::uint64_t online_doors_bypassed = 0;  // found doors the window's places go round, not kept (summed)
  std::uint64_t online_bypass_refused = 0;  // window places or place edges beyond the doors arena's capacity (summed)
  std::uint64_t door_pass_max_us = 0;     // the longest pass (backend thread; wall time)
  std::uint64_t blocks_painted = 0;       // re-meshed blocks painted into the wall map
  std::uint64_t wall_paint_deferred = 0;  // keyframes whose painting waited for the next (a pass held the map)
  std::uint64_t keyframes_segmented = 0;  // keyframes whose labels came back and were voted into the map
  std::uint64_t keyframes_unlabelled = 0; // keyframes with no labels of their own (segmentation busy, failed, late)
  std::uint64_t telemetry_lines = 0;
  std::uint64_t memory_locked = 0;         // 1: mlockall succeeded at start-up (AppConfig::lock_memory)
  std::uint64_t memory_lock_failures = 0;  // mlockall failed (logged with the limit; the run went on unlocked)
  // Loop closure (AppConfig::loop_closure).
  std::uint64_t agents_described = 0;      // agents given a descriptor (the detector's queries)
  std::uint64_t loop_closures = 0;         // proposed: detected and verified
  std::uint64_t loop_closures_kept = 0;    // kept by the latest optimization (GNC)
  std::uint64_t loop_closures_true = 0;    // proposed within 10 cm / 1 degree of the truth (sim, replay with poses)
  std::uint64_t loop_closures_false = 0;   // proposed more than 0.5 m or 5 degrees off the truth
  std::uint64_t loop_closures_false_kept = 0;  // ... and kept by the optimization: what bends the map
  std::uint64_t loop_closure_folds = 0;        // the "loop_closures" store full: its older half folded
  std::uint64_t loop_closures_folded = 0;      // closures those folds dropped (the last solve's outliers first)
  std::uint64_t agent_frames_dropped = 0;  // agents to describe whose keyframe found no free slot (no appearance)
  std::uint64_t loop_closures_by_appearance = 0;
  std::uint64_t places_merged_after_correction = 0;   // reconciliation at the finish (BackendStage::reconcile)
  std::uint64_t objects_merged_at_finish = 0;  // visits the object layer kept apart, joined (objects::merge_revisits)
  std::uint64_t objects_held_at_once_kept_apart = 0;  // pairs the finish's rule made that the layer held at once
  std::uint64_t graph_optimizations = 0;
  std::uint64_t graph_optimization_failures = 0;
  std::uint64_t graph_optimization_max_us = 0;  // the longest solve (backend thread; wall time)
};

class Pipeline {
 public:
  Pipeline();
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  // Builds the world and the tour (sim), every store from the board's budget table, the scheduler from its task
  // table. All allocation happens here. `clock` must outlive the pipeline; in lockstep it is a SteppedClock.
  bool init(const AppConfig& config, runtime::Clock* clock, std::string* error);
  // One tick of the loop: rate tasks, then the keyframe tasks of a keyframe that arrived. False when done.
  bool step();
  void request_stop() { stop_requested_.store(true); }
  bool done() const { return done_; }
  // Final outputs: scene_graph.json, mesh.ply, top_down.png in the output folder. With doors_at_finish, doors are
  // found on the final surface first and the rooms and labels updated once more.
  bool finish(std::string* error);

  const PipelineCounters& counters() const { return counters_; }
  // "" when the run integrated at least one keyframe; otherwise why nothing was mapped, with the counts of
  // frames read, bad, missing, without a pose and refused (qsg_app prints it and exits 3).
  std::string nothing_mapped_reason() const;
  const runtime::Scheduler& scheduler() const { return scheduler_; }
  const reconstruction::SemanticTsdf& reconstruction() const { return tsdf_; }
  const frontend::Frontend& frontend() const { return frontend_; }
  const scene_graph::SceneGraph& graph() const { return graph_; }
  const world::World& world() const { return world_; }  // sim: the world explored (empty for other drivers)
  const runtime::KeyframeSelector& keyframe_selector() const { return keyframes_; }
  // The GPIO chip (the simulated one unless the config names a libgpiod chip), for tests and telemetry.
  gpio::GpioChip* gpio_chip() { return gpio_chip_.get(); }
  bool paused() const { return pause_ != nullptr && pause_->paused(); }
  runtime::QueueStats frame_queue_stats() const { return keyframe_queue_.stats(); }
  // The segmentation worker's slots as a queue: depth = slots, dropped = keyframes it could not take (busy or too
  // soon) plus labels that came back too late.
  runtime::QueueStats segmentation_queue_stats() const;
  const SegmentationWorker& segmentation() const { return segmentation_; }
  // The backend thread's runs (room updates): wall time and the thread's CPU time against its thread budget.
  runtime::TaskStats backend_wall_stats() const;
  runtime::TaskStats backend_cpu_stats() const;
  // Parts of the backend's work with budgets of their own (the table's backend thread: part_budget_us,
  // finish_budget_us), on the CPU clock of the thread that ran them: the online door passes (inside the updates),
  // and the final stage at finish() (doors on the whole surface, the last room update and labels).
  runtime::TaskStats door_pass_cpu_stats() const;
  runtime::TaskStats finish_cpu_stats() const;
  // Loop closure on the backend thread, CPU time: detection and verification of the agents an update described
  // (one run per update that described at least one; part of the update), and each deformation-graph solve (a run
  // of its own against the table's solve_budget_us, left out of the update that started it).
  runtime::TaskStats loop_closure_detect_cpu_stats() const;
  // ... and what of it held the graph lock, per update that described an agent or copied a solve's inputs: the
  // description and the copy (the lookup, verification, build and solve run without the lock).
  runtime::TaskStats loop_closure_lock_cpu_stats() const;
  runtime::TaskStats solve_cpu_stats() const;
  // One solve during the run: when, at what path, how big, its cost. The last kSolveRecords are kept, oldest first.
  struct SolveRecord {
    double time_s = 0.0, path_m = 0.0;  // mission time; path of the agents described so far
    std::uint32_t agents = 0, control_points = 0, places = 0, closures = 0, closures_kept = 0;
    std::uint32_t map_settled = 0, closures_carried = 0;  // the bounded solve's held nodes and carried decisions
    bool decided_again = false;
    std::int64_t cpu_us = 0, wall_us = 0;
    // Copying the chain and the places under the graph lock (the loop thread waits for it to add a keyframe's
    // agent), then building the problem from the copy without the lock.
    std::int64_t lock_cpu_us = 0, lock_wall_us = 0;
    std::int64_t build_cpu_us = 0, build_wall_us = 0;
    bool ok = false;
  };
  static constexpr std::size_t kSolveRecords = 1024;
  std::vector<SolveRecord> solve_records() const;
  runtime::TelemetryWriterStats telemetry_stats() const { return telemetry_.stats(); }
  // Benchmarks: every backend update's and every segmentation run's CPU and wall microseconds. Before init().
  void set_thread_observers(SegmentationWorker::RunObserver backend, SegmentationWorker::RunObserver segmenter,
                            void* user) {
    backend_observer_ = backend;
    backend_observer_user_ = user;
    segmentation_.set_run_observer(segmenter, user);
  }
  runtime::QueueStats backend_queue_stats() const { return backend_queue_.stats(); }
  const rooms::RoomFinder& room_finder() const { return backend_.room_finder(); }
  const rooms::OnlineDoors& online_doors() const { return backend_.online_doors(); }
  const backend::BackendStage& backend_stage() const { return backend_; }
  // Fraction of the source consumed, when the source knows its length (else a negative number).
  double progress() const;
  // Wall-clock view of a stage's cost: the scheduler measures with this clock (the loop clock unless set).
  void set_cost_clock(runtime::Clock* clock) { cost_clock_ = clock; }
  // Tests: the V4L2 pair's system calls (fake devices) instead of the kernel's. Before init().
  void set_v4l2_syscalls(v4l2::V4l2Syscalls* depth, v4l2::V4l2Syscalls* colour) {
    v4l2_depth_sys_ = depth;
    v4l2_colour_sys_ = colour;
  }
  const drivers::RgbdSource* camera() const { return camera_; }
  // The fault plan's decorators and the recovery from its faults (inactive without a plan).
  const FaultInjection& faults() const { return faults_; }
  const OdometryInput& odometry() const { return odometry_; }
  // sim: the true body path of the tour; replay: the dataset's camera poses (empty when it has none).
  const replay::Trajectory& ground_truth() const { return ground_truth_; }
  // After finish(): the agents' pose graph solve, and the trajectory error against the truth (ok == false without).
  const backend::AgentGraphResult& pose_graph() const { return pose_graph_; }
  const metrics::TrajectoryError& trajectory_error() const { return ate_unaligned_; }
  const metrics::TrajectoryError& odometry_trajectory_error() const { return ate_odometry_; }
  // loop_closure.map_in_corrected_frame: the corrections the frontend followed, and the one it maps in now.
  std::uint64_t frame_corrections() {
    std::lock_guard<std::mutex> lock(frame_mutex_);
    return frame_corrections_;
  }
  Eigen::Isometry3d map_T_odom() {
    std::lock_guard<std::mutex> lock(frame_mutex_);
    return map_T_odom_;
  }
  void set_run_observer(runtime::Scheduler::RunObserver observer, void* user) {
    scheduler_.set_run_observer(observer, user);
  }

  // Every store of the run: the scene graph's, the frontend's (places, objects), the agent chain, and the backend
  // stage's (rooms, online doors, loop closure); fn(const memory::ResourceStats&). Telemetry and the exit report
  // list each under its own name. from_loop: while the backend runs (call under graph_mutex_, as telemetry does),
  // the online doors' door set, which a pass writes without that lock, is left out.
  template <typename Fn>
  void for_each_store(Fn&& fn, bool from_loop = false) const {
    graph_.for_each_resource(fn);
    frontend_.for_each_resource(fn);
    fn(frontend_.agents().chain_stats());
    backend_.for_each_resource(fn, !(from_loop && !config_.lockstep));
  }

  void print_telemetry(std::FILE* out);
  // AppConfig::telemetry_stores' line: "[t=...s] stores rss_kb=... hwm_kb=... minflt=... majflt=... | <store>=
  // in_use/high_water/capacity/refused ... | counters <group>.<key>=... ..." (exit-report names). Allocation-free.
  void print_telemetry_stores(std::FILE* out, double t_s);
  // The graph to scene_graph_snapshot.json (atomically), as the latest loop-closure solve corrects it. *deferred:
  // a solve was running, nothing written (the caller tries again).
  bool write_snapshot(std::string* error, bool* deferred = nullptr);

 private:
  static void camera_poll_task(void* self, const runtime::TaskContext& c);
  static void odometry_poll_task(void* self, const runtime::TaskContext& c);
  static void reconstruction_task(void* self, const runtime::TaskContext& c);
  static void frontend_task(void* self, const runtime::TaskContext& c);
  static void heartbeat_task(void* self, const runtime::TaskContext& c);
  static void telemetry_task(void* self, const runtime::TaskContext& c);
  void poll_camera();
  bool init_segmentation(std::string* error);
  bool init_backend(std::string* error);
  void backend_worker();
  struct BackendUpdate;
  void run_backend_update(const BackendUpdate& u);
  void report_final_doors(const backend::BackendStage::FinalDoors& d);
  void copy_backend_counters();
  bool init_gpio(std::string* error);
  void integrate_keyframe(const runtime::TaskContext& c);
  // The pose a keyframe is mapped at: odometric, or moved by map_T_odom_ (loop_closure.map_in_corrected_frame).
  Eigen::Isometry3d mapped_pose(const Eigen::Isometry3d& odometric);
  void update_frontend(const runtime::TaskContext& c);
  std::int64_t data_to_loop_ns(std::int64_t sample_time_ns) const { return sample_time_ns + data_offset_ns_; }
  bool init_odometry(std::string* error);
  bool finish_trajectory(std::string* error);

  AppConfig config_;
  runtime::Clock* clock_ = nullptr;
  runtime::Clock* cost_clock_ = nullptr;
  runtime::Scheduler scheduler_;
  runtime::KeyframeSelector keyframes_;

  world::World world_;
  std::unique_ptr<sim::SimCamera> sim_camera_;
  std::unique_ptr<replay::DatasetReplay> replay_;
  std::unique_ptr<v4l2::V4l2RgbdSource> v4l2_;
  replay::Trajectory ground_truth_;  // sim: the true body path; replay: the dataset's camera poses (may be empty)
  OdometryInput odometry_;
  backend::AgentGraphResult pose_graph_;
  metrics::TrajectoryError ate_unaligned_;  // of the estimate (optimized when loops closed), as mapped
  metrics::TrajectoryError ate_odometry_;   // of the odometric chain alone
  v4l2::V4l2Syscalls* v4l2_depth_sys_ = nullptr;
  v4l2::V4l2Syscalls* v4l2_colour_sys_ = nullptr;
  drivers::RgbdSource* camera_ = nullptr;
  FaultInjection faults_;  // the fault plan, when one is given: wraps camera_ and the odometry's source
  bool prefetch_outside_tasks_ = false;  // sim and replay: producing a frame is the simulator's cost, not the robot's

  // Frame buffers: the camera reads into a free one; keyframes wait in the queue for reconstruction.
  std::unique_ptr<messages::RgbdFrame[]> frames_;
  std::unique_ptr<Eigen::Isometry3d[]> frame_poses_;
  std::unique_ptr<Eigen::Matrix<double, 6, 1>[]> frame_variances_;  // the odometry's covariance diagonal per frame
  runtime::BoundedQueue<int> free_frames_{"free_frames"};
  runtime::BoundedQueue<int> keyframe_queue_{"frames"};
  int pending_frame_ = -1;        // read from the source, waiting for its time on the loop clock (and its pose)
  int current_keyframe_ = -1;     // popped for this keyframe's tasks
  std::int64_t data_offset_ns_ = 0;
  bool have_offset_ = false;
  bool source_ended_ = false;

  // Segmentation at its own rate (segmentation_worker.h): keyframes are integrated at once and offered to the
  // worker; labelled frames come back and their votes are cast at the start of the next reconstruction task.
  SegmentationWorker segmentation_;
  void cast_label_votes();  // the labelled frames that came back: votes into the TSDF (loop thread)

  // Backend: the frontend hands over a (collated) update after each completed places cycle; the backend thread
  // (lockstep: the loop, after the keyframe's tasks) finds rooms and the building. The graph is shared under
  // graph_mutex_: the loop holds it while a stage writes the graph, the backend while it updates rooms.
  struct BackendUpdate {
    std::uint64_t time_ns = 0;
    std::uint32_t frontend_cycles = 0;
    Eigen::Vector3d robot_m = Eigen::Vector3d::Zero();  // the camera at time_ns: the online door window's centre
  };
  // The backend stage (core/backend/backend_stage.h): doors, rooms, labels, loop closure and the deformation graph.
  // The app wires it: the loop paints walls under wall_mutex_ (try-lock: a keyframe never waits; what it skips is
  // painted with the next one) and offers control points; the backend thread runs door passes, rooms and loop
  // closure under graph_mutex_ (the door detection and the deformation solve without it).
  backend::BackendStage backend_;
  std::mutex wall_mutex_;
  // loop_closure.map_in_corrected_frame: the correction the frontend maps in, updated by the backend thread after
  // each solve, read by the reconstruction task per keyframe.
  std::mutex frame_mutex_;
  Eigen::Isometry3d map_T_odom_ = Eigen::Isometry3d::Identity();
  std::uint64_t frame_corrections_ = 0;
  std::mutex deformation_mutex_;  // the backend thread's deformation solve against a snapshot reading its solution
  // The app's side of the pipeline's steps (core/pipeline/pipeline_steps.h, where their order is written once): its
  // mutexes, the door passes' and the final stage's timing against their budgets and stage markers, the keyframe's
  // consumers besides the map (segmentation, fault recovery), and loop closure after each backend update's rooms.
  // Called by the loop thread (keyframes, frontend updates, the finish) and the backend thread (backend updates);
  // each hook touches only the state of the thread whose steps call it.
  class StepHost : public pipeline::Host {
   public:
    explicit StepHost(Pipeline* p) : p_(p) {}
    void lock(pipeline::Shared what) override { mutex(what).lock(); }
    void unlock(pipeline::Shared what) override { mutex(what).unlock(); }
    bool try_lock(pipeline::Shared what) override { return mutex(what).try_lock(); }
    void begin(pipeline::Step step) override;
    void end(pipeline::Step step, bool ran) override;
    void integrated(const messages::RgbdFrame& frame, const Eigen::Isometry3d& world_T_camera) override;
    void after_rooms(std::uint64_t time_ns, Held* graph) override { p_->run_loop_closure(time_ns, graph); }

   private:
    std::mutex& mutex(pipeline::Shared what) {
      return what == pipeline::Shared::kGraph ? p_->graph_mutex_ : p_->wall_mutex_;
    }
    Pipeline* p_;
    std::chrono::steady_clock::time_point door_pass_start_;
    std::int64_t door_pass_cpu0_us_ = 0, finish_cpu0_us_ = 0;
  };
  StepHost host_{this};
  pipeline::Stages stages() { return {&tsdf_, &frontend_, &backend_, &graph_}; }
  // Loop closure: keyframes of agents to be described (one per describe_every_m of path) are copied by the loop
  // into a free slot (none free: dropped, counted); the backend hands their appearance to the stage.
  bool init_loop_closure(std::string* error);
  void capture_agent_frame(const messages::RgbdFrame& frame, scene_graph::NodeId agent, std::uint64_t time_ns);
  void extract_captured_frames();
  void run_loop_closure(std::uint64_t time_ns, pipeline::Host::Held* graph_lock);
  bool optimize_graph();  // the final solve (graph_mutex_ held)
  backend::DeformationProblem build_deformation();  // from the copied inputs; dumps it for QSG_DUMP_DEFORMATION
  // At the finish (graph_mutex_ held): the final solve over every loop closure, then agents and places to their
  // optimized poses, objects, rooms and the mesh moved by the deformation graph; the counters and a summary line.
  void correct_outputs(reconstruction::Mesh* mesh, reconstruction::Mesh* odometric);
  void score_loop_closures();
  struct AgentFrame {
    scene_graph::NodeId agent = scene_graph::kNoNode;
    std::uint64_t time_ns = 0;
    messages::CameraIntrinsics intrinsics;
    std::vector<std::uint8_t> grey;  // sized for the largest frame at init
    std::vector<float> depth_m;
  };
  std::vector<AgentFrame> lc_frames_;
  runtime::BoundedQueue<int> lc_free_frames_{"loop_closure.free_frames"};
  runtime::BoundedQueue<int> lc_ready_frames_{"loop_closure.frames"};
  Eigen::Vector3d lc_captured_m_ = Eigen::Vector3d::Zero();
  bool lc_have_captured_ = false;
  std::uint64_t lc_frames_dropped_ = 0;  // loop thread: no free slot
  std::atomic<std::uint64_t> graph_optimization_max_us_{0};
  runtime::BoundedQueue<BackendUpdate> backend_queue_{"frontend_to_backend"};
  void timed_backend_update(const BackendUpdate& u);  // run_backend_update, timed into backend_wall_/cpu_
  mutable std::mutex backend_stats_mutex_;
  runtime::TaskStats backend_wall_;
  runtime::TaskStats backend_cpu_;
  runtime::TaskStats door_pass_cpu_;
  runtime::TaskStats finish_cpu_;
  runtime::TaskStats lc_detect_cpu_;
  runtime::TaskStats lc_lock_cpu_;
  runtime::TaskStats solve_cpu_;
  std::vector<SolveRecord> solve_records_;  // kSolveRecords slots from init, a ring
  std::uint64_t solves_recorded_ = 0;
  std::uint64_t deformations_dumped_ = 0;  // QSG_DUMP_DEFORMATION with "%d": the next file's number
  std::int64_t solve_cpu_in_update_us_ = 0, solve_wall_in_update_us_ = 0;  // backend thread: left out of its update
  std::uint32_t solve_budget_us_ = 0;
  std::uint32_t backend_budget_us_ = 0;
  std::uint32_t door_pass_budget_us_ = 0;
  std::uint32_t finish_budget_us_ = 0;
  std::uint32_t backend_marker_ = 0;  // the backend thread's stage-marker id (runtime/stage_marker.h)
  SegmentationWorker::RunObserver backend_observer_ = nullptr;
  void* backend_observer_user_ = nullptr;
  // Telemetry lines go through a bounded queue to a writer thread: the loop never blocks on its output.
  runtime::TelemetryWriter telemetry_;
  std::thread backend_thread_;
  std::atomic<bool> backend_stop_{false};
  std::mutex graph_mutex_;

  reconstruction::SemanticTsdf tsdf_;
  scene_graph::SceneGraph graph_;
  frontend::Frontend frontend_;
  Eigen::Vector3d robot_m_ = Eigen::Vector3d::Zero();  // camera position of the latest integrated keyframe
  std::uint64_t latest_keyframe_ns_ = 0;
  std::uint64_t odometry_steps_seen_ = 0;  // the pose buffer's steps counter at the last keyframe
  std::vector<Eigen::Vector3d> trajectory_m_;  // keyframe positions for the picture (reserved at init)

  PipelineCounters counters_;
  std::uint64_t keyframe_index_ = 0;
  std::int64_t start_ns_ = 0;
  std::int64_t next_snapshot_ns_ = 0;
  std::int64_t last_telemetry_ns_ = 0;
  std::uint64_t last_telemetry_keyframes_ = 0;
  std::unique_ptr<gpio::GpioChip> gpio_chip_;
  gpio::SimGpioChip* sim_gpio_ = nullptr;  // the same chip when simulated: its time follows the loop's
  std::unique_ptr<gpio::GpioLine> heartbeat_line_, trigger_line_, pause_line_;
  std::unique_ptr<gpio::Heartbeat> heartbeat_;
  std::unique_ptr<gpio::TriggerPulse> trigger_;
  std::unique_ptr<gpio::PauseSwitch> pause_;
  std::atomic<bool> stop_requested_{false};
  bool done_ = false;
};

// Writes `text` to `path` so that a reader (or a kill) sees the old file or the new one, never half of one:
// a temporary file in the same folder, fsync, rename, fsync of the folder.
bool write_file_atomically(const std::string& path, const std::string& text, std::string* error);
// The same for a file a writer of its own produced: write it to temporary_path_for(path) (same folder), then
// commit_file_atomically() fsyncs it and renames it over path (on failure the temporary file is removed).
std::string temporary_path_for(const std::string& path);
bool commit_file_atomically(const std::string& tmp, const std::string& path, std::string* error);

}  // namespace qsg::app
