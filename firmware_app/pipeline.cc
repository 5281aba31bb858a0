// The onboard pipeline: sources, keyframes, reconstruction, frontend, telemetry, snapshots, final outputs.
#include "firmware_app/pipeline.h"

#include "firmware_app/exit_report.h"

#include <fcntl.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <sys/resource.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <algorithm>
#include <cstring>
#include <ctime>
#include <filesystem>

#include "budgets/budget_table.h"
#include "core/backend/agent_pose_graph.h"
#include "core/scene_graph/spark_dsg_json.h"
#include "drivers/gpio/gpiod_chip.h"
#include "drivers/gpio/sim_gpio.h"
#include "drivers/render/ray_scene.h"
#include "drivers/world/top_down.h"
#include "drivers/world/world_file.h"
#include "drivers/world/world_query.h"
#include "firmware_app/graph_outputs.h"
#include "firmware_app/memory_lock.h"
#include "firmware_app/runtime/stage_marker.h"

namespace qsg::app {

namespace {

const budgets::QueueBudget* find_queue(const budgets::BoardTable& table, const char* name) {
  for (std::size_t i = 0; i < table.num_queues; ++i)
    if (std::strcmp(table.queues[i].name, name) == 0) return &table.queues[i];
  return nullptr;
}

std::int64_t thread_cpu_us() {
  timespec t{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1000000 + t.tv_nsec / 1000;
}

std::int64_t steady_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

namespace {
bool rename_into_place(const std::string& tmp, const std::string& path, std::string* error);
}  // namespace

bool write_file_atomically(const std::string& path, const std::string& text, std::string* error) {
  const std::string tmp = temporary_path_for(path);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return *error = tmp + ": " + std::strerror(errno), false;
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      *error = tmp + ": write failed: " + std::strerror(errno);
      ::close(fd);
      ::unlink(tmp.c_str());
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    *error = tmp + ": fsync/close failed: " + std::strerror(errno);
    ::unlink(tmp.c_str());
    return false;
  }
  return rename_into_place(tmp, path, error);
}

namespace {
bool rename_into_place(const std::string& tmp, const std::string& path, std::string* error) {
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    *error = path + ": rename failed: " + std::strerror(errno);
    ::unlink(tmp.c_str());
    return false;
  }
  // The rename itself is durable once the folder is synced.
  const std::string dir = std::filesystem::path(path).parent_path().string();
  const int dfd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
  return true;
}
}  // namespace

std::string temporary_path_for(const std::string& path) { return path + ".tmp"; }

bool commit_file_atomically(const std::string& tmp, const std::string& path, std::string* error) {
  const int fd = ::open(tmp.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return *error = tmp + ": " + std::strerror(errno), false;
  if (::fsync(fd) != 0) {
    *error = tmp + ": fsync failed: " + std::strerror(errno);
    ::close(fd);
    ::unlink(tmp.c_str());
    return false;
  }
  ::close(fd);
  return rename_into_place(tmp, path, error);
}

Pipeline::Pipeline() = default;
Pipeline::~Pipeline() {
  backend_stop_.store(true);
  backend_queue_.close();
  if (backend_thread_.joinable()) backend_thread_.join();
  segmentation_.stop();
  telemetry_.stop();
  keyframe_queue_.close();
  free_frames_.close();
}

bool Pipeline::init(const AppConfig& config, runtime::Clock* clock, std::string* error) {
  const auto fail = [error](const std::string& why) {
    *error = why;
    return false;
  };
  if (const std::string bad = config.check(); !bad.empty()) return fail("config: " + bad);
  if (clock == nullptr) return fail("pipeline: no clock");
  config_ = config;
  clock_ = clock;
  if (cost_clock_ == nullptr) cost_clock_ = clock;
  keyframes_ = runtime::KeyframeSelector(config.keyframes);
  const budgets::BoardTable& table = budgets::active::kTable;

  // Output folder first: a run that cannot write its results should not start.
  std::error_code ec;
  std::filesystem::create_directories(config.output_dir, ec);
  if (ec) return fail("output_dir '" + config.output_dir + "': " + ec.message());

  // Stores, from the board's budget (a fault plan may cap the graph's below it).
  if (!faults_.init(config.fault_plan, error)) return false;
  faults_.print_plan(stdout);
  if (!graph_.init(faults_.capped(scene_graph::capacities_from_budget()), scene_graph::arena_bytes_from_budget(), error))
    return false;
  if (!tsdf_.init(config.reconstruction, reconstruction::capacities_from_budget(),
                  budgets::active::reconstruction::kArenaBytes, error))
    return false;
  if (!frontend_.init(config.frontend, error)) return false;
  // Reserved and written once, so its pages are resident before the loop pushes into them (no page fault there).
  trajectory_m_.resize(graph_.capacities().agent_nodes);
  trajectory_m_.clear();

  // The source.
  switch (config.driver) {
    case Driver::kSim: {
      if (config.world_path.empty()) {
        world_ = world::generate_building(config.building);
      } else {
        world::WorldResult read = world::read_world_file(config.world_path);
        if (!read.ok) return fail("world: " + read.error);
        world_ = std::move(read.world);
      }
      render::RayScene scene;
      if (!scene.build(world_, error)) return false;
      const world::FreeSpaceIndex free_space(world_);
      const sim::ExplorationResult tour = sim::plan_exploration(world_, scene, free_space, config.exploration);
      if (!tour.ok) return fail("exploration: " + tour.error);
      std::printf("sim: building '%s' with %zu rooms; tour of %zu rooms, %.1f m in %.1f s\n", world_.name.c_str(),
                  world_.rooms.size(), tour.room_order.size(), tour.length_m, tour.duration_s);
      render::Renderer::Config rc;
      rc.seed = config.building.seed;
      sim_camera_ = std::make_unique<sim::SimCamera>();
      if (!sim_camera_->init(config.sim_camera(), rc, world_, tour.trajectory, error)) return false;
      ground_truth_ = tour.trajectory;
      camera_ = sim_camera_.get();
      prefetch_outside_tasks_ = true;
      break;
    }
    case Driver::kReplay: {
      replay::DatasetReplayConfig rc = config.replay;
      rc.path = config.replay_path;
      replay_ = std::make_unique<replay::DatasetReplay>();
      if (!replay_->open(rc, error)) return false;
      if (replay_->size() == 0) return fail("replay: '" + rc.path + "' lists no frames: nothing to map");
      replay_->print(stdout);
      ground_truth_ = replay_->ground_truth();  // the dataset's camera poses: an odometry source, and the truth
      if (ground_truth_.empty())
        std::printf("replay: NOTICE: the dataset has no poses: give the odometry (odometry.source tum or stream)\n");
      camera_ = &replay_->camera();
      prefetch_outside_tasks_ = true;
      break;
    }
    case Driver::kV4l2: {
      const AppConfig::V4l2& vc = config.v4l2;
      v4l2::V4l2RgbdSource::Config sc;
      sc.depth.device = vc.depth_device;
      sc.colour.device = vc.colour_device;
      sc.depth.width_px = sc.colour.width_px = vc.width;
      sc.depth.height_px = sc.colour.height_px = vc.height;
      const double f = 525.0 * vc.width / 640.0;
      sc.intrinsics = {vc.width, vc.height, vc.fx > 0 ? vc.fx : f, vc.fy > 0 ? vc.fy : f,
                       vc.cx > 0 ? vc.cx : 0.5 * vc.width - 0.5, vc.cy > 0 ? vc.cy : 0.5 * vc.height - 0.5};
      sc.depth_scale_m = static_cast<float>(vc.depth_scale_m);
      v4l2_ = std::make_unique<v4l2::V4l2RgbdSource>(
          v4l2_depth_sys_ != nullptr ? *v4l2_depth_sys_ : v4l2::linux_v4l2_syscalls(),
          v4l2_colour_sys_ != nullptr ? *v4l2_colour_sys_ : v4l2::linux_v4l2_syscalls());
      if (!v4l2_->init(sc, error)) return false;
      camera_ = v4l2_.get();
      break;
    }
  }

  camera_ = faults_.wrap_camera(camera_);

  // Frame buffers and the keyframe queue, with the depth and drop policy the board declares.
  const budgets::QueueBudget* frames_budget = find_queue(table, "frames");
  if (frames_budget == nullptr) return fail(std::string("budget table ") + table.board + ": no 'frames' queue");
  // + the pending frame and the keyframe in work (the segmentation worker copies what it takes into its own slots).
  const int pool = static_cast<int>(frames_budget->depth) + 2;
  frames_ = std::make_unique<messages::RgbdFrame[]>(static_cast<std::size_t>(pool));
  frame_poses_ = std::make_unique<Eigen::Isometry3d[]>(static_cast<std::size_t>(pool));
  frame_variances_ = std::make_unique<Eigen::Matrix<double, 6, 1>[]>(static_cast<std::size_t>(pool));
  if (!free_frames_.init(static_cast<std::uint32_t>(pool), budgets::DropPolicy::kDropNewest, nullptr, error) ||
      !keyframe_queue_.init(frames_budget->depth, frames_budget->policy, nullptr, error))
    return false;
  for (int i = 0; i < pool; ++i) free_frames_.push(int{i});
  keyframe_queue_.set_on_drop([](void* self, int&& index) { static_cast<Pipeline*>(self)->free_frames_.push(int{index}); },
                              this);

  if (!init_odometry(error) || !init_gpio(error) || !init_segmentation(error) || !init_backend(error))
    return false;
  const budgets::QueueBudget* telemetry_budget = find_queue(table, "telemetry");
  if (telemetry_budget == nullptr) return fail(std::string("budget table ") + table.board + ": no 'telemetry' queue");
  if (!telemetry_.init(stdout, telemetry_budget->depth, error)) return false;

  // The task table.
  if (!scheduler_.init(config.scheduler, table, clock_, error)) return false;
  scheduler_.set_cost_clock(cost_clock_);
  scheduler_.bind("camera_poll", camera_poll_task, this);
  scheduler_.bind("odometry_poll", odometry_poll_task, this);
  scheduler_.bind("reconstruction", reconstruction_task, this);
  scheduler_.bind("frontend", frontend_task, this);
  scheduler_.bind("heartbeat", heartbeat_task, this);
  scheduler_.bind("telemetry", telemetry_task, this);
  if (const char* missing = scheduler_.unbound())
    return fail(std::string("budget table ") + table.board + ": task '" + missing + "' has no implementation");
  start_ns_ = clock_->now_ns();
  next_snapshot_ns_ = start_ns_ + static_cast<std::int64_t>(config.snapshot_interval_s * 1e9);
  last_telemetry_ns_ = start_ns_;
  // Every store is carved (and its arena pre-faulted): lock it all in RAM if asked (the robot). A failure is a
  // logged, counted degradation, never a failed start-up.
  if (config.lock_memory) {
    std::string why;
    if (lock_process_memory(&why)) {
      counters_.memory_locked = 1;
      std::printf("memory: locked (mlockall MCL_CURRENT | MCL_FUTURE)\n");
    } else {
      ++counters_.memory_lock_failures;
      std::fprintf(stderr, "qsg_app: warning: %s\n", why.c_str());
    }
  }
  return true;
}

bool Pipeline::init_odometry(std::string* error) {
  const budgets::QueueBudget* q = find_queue(budgets::active::kTable, "odometry");
  if (q == nullptr)
    return *error = std::string("budget table ") + budgets::active::kTable.board + ": no 'odometry' queue", false;
  // The camera's mount: the simulator's; a dataset's poses are the camera's own; otherwise the config's extrinsics.
  Eigen::Isometry3d body_T_camera = Eigen::Isometry3d::Identity();
  const AppConfig::Odometry& o = config_.odometry;
  const bool replay_truth = config_.driver == Driver::kReplay && (o.source == OdometrySourceKind::kAuto ||
                                                                   o.source == OdometrySourceKind::kGroundTruth);
  if (sim_camera_ != nullptr) {
    body_T_camera = sim_camera_->body_T_camera();
  } else if (!replay_truth) {
    body_T_camera.linear() = Eigen::Quaterniond(o.body_q_camera_xyzw[3], o.body_q_camera_xyzw[0], o.body_q_camera_xyzw[1],
                                                o.body_q_camera_xyzw[2]).normalized().toRotationMatrix();
    body_T_camera.translation() = Eigen::Vector3d(o.body_t_camera_m[0], o.body_t_camera_m[1], o.body_t_camera_m[2]);
  }
  odometry_.set_fault_injection(&faults_);
  if (!odometry_.init(config_, ground_truth_, body_T_camera, q->depth, static_cast<std::int64_t>(q->max_wait_us) * 1000,
                      error))
    return false;
  std::printf("odometry: %s (%s), pose buffer %u samples, a frame waits up to %.0f ms for its pose\n",
              to_string(odometry_.kind()), odometry_.source_name(), q->depth, 1e-3 * q->max_wait_us);
  return true;
}

bool Pipeline::init_segmentation(std::string* error) {
  const AppConfig::Segmentation& sc = config_.segmentation;
  if (sc.model_path.empty()) return true;
  const budgets::BoardTable& table = budgets::active::kTable;
  const budgets::QueueBudget* q = find_queue(table, "segmentation");
  if (q == nullptr) return *error = std::string("budget table ") + table.board + ": no 'segmentation' queue", false;
  const budgets::ThreadBudget* t = table.find_thread("segmentation");
  if (t == nullptr) return *error = std::string("budget table ") + table.board + ": no 'segmentation' thread", false;
  segmentation::LabelMap map;
  if (!map.load(sc.label_map_path, error)) return false;
  segmentation::Config c;
  c.model_path = sc.model_path;
  c.min_confidence = sc.min_confidence;
  c.fallback_to_cpu = sc.fallback_to_cpu;
  c.opencv_threads = sc.opencv_threads;
  if (!segmentation::dnn_backend_from_string(sc.backend, &c.backend) ||
      !segmentation::dnn_target_from_string(sc.target, &c.target))
    return *error = "segmentation: backend '" + sc.backend + "' / target '" + sc.target + "' unknown", false;
  auto segmenter = std::make_unique<segmentation::Segmenter>();
  if (!segmenter->init(c, map, error)) return false;
  std::printf("segmentation: %s on %s/%s%s, its own thread%s, labels dropped after %.1f s\n", sc.model_path.c_str(),
              segmentation::dnn_backend_name(segmenter->active_backend()),
              segmentation::dnn_target_name(segmenter->active_target()),
              segmenter->counters().backend_fallbacks > 0 ? " (CUDA unavailable: CPU fallback)" : "",
              config_.lockstep ? " (lockstep: on the loop's, after the keyframe's tasks)" : "", sc.deadline_s);
  SegmentationWorkerConfig wc;
  wc.min_interval_s = sc.min_interval_s;
  wc.max_age_s = sc.deadline_s;
  wc.threaded = !config_.lockstep;  // lockstep: deterministic, segmented after the keyframe's tasks
  wc.budget_us = t->budget_us;
  wc.lockstep_busy_from_cost = sc.lockstep_busy_from_cost;
  runtime::stage_marker_id(budgets::active::kTable, "segmentation", &wc.stage_marker);
  return segmentation_.init(std::move(segmenter), std::max<std::uint32_t>(2, q->depth), wc, error);
}

bool Pipeline::init_backend(std::string* error) {
  const budgets::QueueBudget* q = find_queue(budgets::active::kTable, "frontend_to_backend");
  if (q == nullptr)
    return *error = std::string("budget table ") + budgets::active::kTable.board + ": no 'frontend_to_backend' queue", false;
  const auto collate = [](BackendUpdate& queued, BackendUpdate&& incoming) {
    queued.time_ns = incoming.time_ns;  // the backend works on the latest graph anyway: one update covers both
    queued.frontend_cycles += incoming.frontend_cycles;
    queued.robot_m = incoming.robot_m;
  };
  if (!backend_queue_.init(q->depth, q->policy, collate, error)) return false;
  const budgets::ThreadBudget* thread_budget = budgets::active::kTable.find_thread("backend");
  if (thread_budget == nullptr)
    return *error = std::string("budget table ") + budgets::active::kTable.board + ": no 'backend' thread", false;
  backend_budget_us_ = thread_budget->budget_us;
  door_pass_budget_us_ = thread_budget->part_budget_us;
  finish_budget_us_ = thread_budget->finish_budget_us;
  solve_budget_us_ = thread_budget->solve_budget_us;
  solve_records_.assign(kSolveRecords, SolveRecord{});
  runtime::stage_marker_id(budgets::active::kTable, "backend", &backend_marker_);
  if (!init_loop_closure(error)) return false;
  backend::BackendStage::Config bc;
  bc.rooms = config_.rooms;
  bc.doors = config_.doors;
  bc.doors_online = config_.doors_online;
  bc.doors_online_every_n = config_.doors_online_every_n;
  bc.room_weights_path = config_.room_weights_path;
  bc.loop_closure = config_.loop_closure;
  // The odometry edges' noise model: the simulator's drifting odometry states its own (its sigmas per sqrt(m)).
  if (config_.loop_closure.odometry_sigmas_from_source && odometry_.kind() == OdometrySourceKind::kSimDrift) {
    backend::AgentGraphConfig& g = bc.loop_closure.deformation.agents;
    if (config_.odometry.translation_sigma_m_per_sqrt_m > 0.0)
      g.sigma_t_m_per_sqrt_m = config_.odometry.translation_sigma_m_per_sqrt_m;
    if (config_.odometry.yaw_sigma_rad_per_sqrt_m > 0.0)
      g.sigma_yaw_rad_per_sqrt_m = config_.odometry.yaw_sigma_rad_per_sqrt_m;
  }
  // The labels the objects can carry, so that the classifier uses the head trained for them
  // (RoomClassifier::Config::perceived_labels): the segmentation network's map when it is the only source of labels
  // (init_segmentation has validated it), else every mpcat40 label (ground-truth labels).
  if (!config_.segmentation.model_path.empty() && !config_.ground_truth_labels) {
    segmentation::LabelMap map;
    std::string map_error;
    if (map.load(config_.segmentation.label_map_path, &map_error))
      for (int k = 0; k < map.num_classes(); ++k) bc.perceived_labels.push_back(map.label(k));
  } else {
    for (semantics::Label l = 0; l < semantics::kNumObjectLabels; ++l) bc.perceived_labels.push_back(l);
  }
  // The keyframes handed to the loop-closure stage are the app's, in the same arena.
  const std::size_t frame_bytes = lc_frames_.size() * messages::kMaxFramePixels * (1 + sizeof(float));
  std::string warning;
  if (!backend_.init(bc, graph_.capacities(), tsdf_.block_slots(), frame_bytes, error, &warning)) return false;
  // A missing or corrupt weight file is reported and the rooms keep the label "unknown": the run goes on.
  if (!warning.empty()) std::fprintf(stderr, "qsg_app: %s\n", warning.c_str());
  else
    std::printf("room labels: LR head %s\n", backend_.classifier_view().empty()
                                                  ? "the file's (no view head for these labels)"
                                                  : backend_.classifier_view().c_str());
  if (!config_.lockstep) backend_thread_ = std::thread([this] { backend_worker(); });
  return true;
}

// The pipeline's steps call these around the door passes (backend thread) and the final stage (loop thread, at the
// finish): stage markers, and the CPU time against the backend thread's part and finish budgets.
void Pipeline::StepHost::begin(pipeline::Step step) {
  if (step == pipeline::Step::kDoorPass) {
    door_pass_start_ = std::chrono::steady_clock::now();
    door_pass_cpu0_us_ = thread_cpu_us();
    runtime::stage_begin(runtime::kDoorPassStage, 0);
  } else if (step == pipeline::Step::kFinalStage) {
    finish_cpu0_us_ = thread_cpu_us();
    runtime::stage_begin(runtime::kFinalStage, 0);
  }
}

void Pipeline::StepHost::end(pipeline::Step step, bool ran) {
  if (step == pipeline::Step::kDoorPass) {
    runtime::stage_end(runtime::kDoorPassStage, 0);
    {
      std::lock_guard<std::mutex> lock(p_->backend_stats_mutex_);
      p_->door_pass_cpu_.record(thread_cpu_us() - door_pass_cpu0_us_, p_->door_pass_budget_us_);
    }
    if (!ran) return;
    p_->backend_.note_door_pass_us(static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - door_pass_start_)
            .count()));
  } else if (step == pipeline::Step::kFinalStage) {
    runtime::stage_end(runtime::kFinalStage, 0);
    std::lock_guard<std::mutex> lock(p_->backend_stats_mutex_);
    p_->finish_cpu_.record(thread_cpu_us() - finish_cpu0_us_, p_->finish_budget_us_);
  }
}

// A keyframe the TSDF took, before the map's other steps read it: offered to segmentation (frames without labels of
// their own), counted, and its time given to the fault plan's recovery.
void Pipeline::StepHost::integrated(const messages::RgbdFrame& frame, const Eigen::Isometry3d& world_T_camera) {
  Pipeline& p = *p_;
  if (!frame.has_labels) p.segmentation_.offer(frame, world_T_camera);  // no-op without a model
  ++p.counters_.keyframes_integrated;
  p.faults_.on_keyframe_integrated(frame.sample_time_ns, p.clock_->now_ns(), p.data_to_loop_ns(frame.sample_time_ns));
}

// Backend thread (lockstep: the loop, after the keyframe's tasks): a door pass when due, the rooms, loop closure.
// The captured keyframes' appearance (ORB features, depth cloud) is computed first, before any lock is taken.
void Pipeline::run_backend_update(const BackendUpdate& u) {
  if (backend_.loop_closure_enabled() && u.time_ns >= static_cast<std::uint64_t>(config_.loop_closure.horizon_s * 1e9))
    extract_captured_frames();
  pipeline::backend_update(stages(), host_, u.robot_m, u.time_ns);
}

void Pipeline::backend_worker() {
  BackendUpdate u;
  while (!backend_stop_.load())
    if (backend_queue_.pop_wait(&u, 100000000)) timed_backend_update(u);
}

void Pipeline::timed_backend_update(const BackendUpdate& u) {
  const std::int64_t c0 = thread_cpu_us(), w0 = steady_us();
  solve_cpu_in_update_us_ = solve_wall_in_update_us_ = 0;
  runtime::stage_begin(backend_marker_, u.time_ns);
  run_backend_update(u);
  runtime::stage_end(backend_marker_, u.time_ns);
  // A solve the update started is a run of its own (solve_cpu_), not part of the update's budget.
  const std::int64_t cpu = thread_cpu_us() - c0 - solve_cpu_in_update_us_;
  const std::int64_t wall = steady_us() - w0 - solve_wall_in_update_us_;
  std::lock_guard<std::mutex> lock(backend_stats_mutex_);
  backend_wall_.record(wall, backend_budget_us_);
  backend_cpu_.record(cpu, backend_budget_us_);
  if (backend_observer_ != nullptr) backend_observer_(backend_observer_user_, cpu, wall);
}

runtime::TaskStats Pipeline::backend_wall_stats() const {
  std::lock_guard<std::mutex> lock(backend_stats_mutex_);
  return backend_wall_;
}

runtime::TaskStats Pipeline::backend_cpu_stats() const {
  std::lock_guard<std::mutex> lock(backend_stats_mutex_);
  return backend_cpu_;
}

runtime::TaskStats Pipeline::door_pass_cpu_stats() const {
  std::lock_guard<std::mutex> lock(backend_stats_mutex_);
  return door_pass_cpu_;
}

runtime::TaskStats Pipeline::finish_cpu_stats() const {
  std::lock_guard<std::mutex> lock(backend_stats_mutex_);
  return finish_cpu_;
}

std::vector<Pipeline::SolveRecord> Pipeline::solve_records() const {
  std::lock_guard<std::mutex> lock(backend_stats_mutex_);
  std::vector<SolveRecord> out;
  if (solve_records_.empty()) return out;
  const std::uint64_t n = std::min<std::uint64_t>(solves_recorded_, solve_records_.size());
  for (std::uint64_t i = solves_recorded_ - n; i < solves_recorded_; ++i)
    out.push_back(solve_records_[static_cast<std::size_t>(i % solve_records_.size())]);
  return out;
}

runtime::QueueStats Pipeline::segmentation_queue_stats() const {
  runtime::QueueStats q;
  q.name = "segmentation";
  if (!segmentation_.initialized()) return q;
  const SegmentationWorkerCounters c = segmentation_.counters();
  q.depth = segmentation_.slots();
  q.high_water = segmentation_.slots_high_water();
  q.pushed = c.taken;
  q.popped = c.collected;
  q.dropped = c.busy + c.too_soon + c.stale;
  q.policy = budgets::DropPolicy::kDropNewest;
  return q;
}

// Labelled frames that came back: their votes from their own depth and pose (loop thread, reconstruction task).
void Pipeline::cast_label_votes() {
  const std::int64_t now_data_ns =
      current_keyframe_ >= 0 ? frames_[static_cast<std::size_t>(current_keyframe_)].sample_time_ns
                             : static_cast<std::int64_t>(latest_keyframe_ns_);
  while (const SegmentationWorker::Slot* slot = segmentation_.labelled(now_data_ns)) {
    if (tsdf_.integrate_label_votes(*slot->frame, slot->world_T_camera)) ++counters_.keyframes_segmented;
    segmentation_.release(slot);
  }
}

bool Pipeline::init_gpio(std::string* error) {
  const AppConfig::Gpio& g = config_.gpio;
  if (g.chip == "sim") {
    auto chip = std::make_unique<gpio::SimGpioChip>();
    sim_gpio_ = chip.get();
    gpio_chip_ = std::move(chip);
  } else {
    std::unique_ptr<gpio::GpiodChip> chip = gpio::GpiodChip::open(g.chip, error);
    if (chip == nullptr) return false;
    gpio_chip_ = std::move(chip);
  }
  const auto request = [&](int offset, gpio::GpioDirection direction, std::unique_ptr<gpio::GpioLine>* line) {
    if (offset < 0) return true;
    gpio::GpioLineRequest r;
    r.offset = static_cast<unsigned>(offset);
    r.direction = direction;
    r.consumer = "qsg_app";
    *line = gpio_chip_->request(r, error);
    return *line != nullptr;
  };
  if (!request(g.heartbeat_line, gpio::GpioDirection::kOutput, &heartbeat_line_) ||
      !request(g.trigger_line, gpio::GpioDirection::kOutput, &trigger_line_) ||
      !request(g.pause_line, gpio::GpioDirection::kInput, &pause_line_))
    return false;
  if (heartbeat_line_) heartbeat_ = std::make_unique<gpio::Heartbeat>(*heartbeat_line_);
  if (trigger_line_) {
    gpio::TriggerPulse::Config tc;
    tc.width_ns = static_cast<std::int64_t>(g.trigger_width_s * 1e9);
    trigger_ = std::make_unique<gpio::TriggerPulse>(*trigger_line_, tc);
  }
  if (pause_line_) {
    gpio::PauseSwitch::Config pc;
    pc.debounce_ns = static_cast<std::int64_t>(g.pause_debounce_s * 1e9);
    pause_ = std::make_unique<gpio::PauseSwitch>(*pause_line_, pc);
  }
  return true;
}

// ---------------------------------------------------------------------------------------------------------
// The loop

bool Pipeline::step() {
  if (done_) return false;
  const std::int64_t tick_start = clock_->now_ns();
  const bool duration_over =
      config_.duration_s > 0.0 && have_offset_ && tick_start - start_ns_ > static_cast<std::int64_t>(config_.duration_s * 1e9);
  if (stop_requested_.load() || duration_over ||
      (source_ended_ && pending_frame_ < 0 && keyframe_queue_.stats().size == 0)) {
    done_ = true;
    faults_.settle();  // a fault that ended after the last keyframe is one the run did not recover from
    return false;
  }
  if (sim_gpio_ != nullptr) sim_gpio_->set_time_ns(tick_start);
  if (trigger_ && !trigger_->update(tick_start)) ++counters_.gpio_failures;
  if (pause_ && !pause_->update(tick_start)) ++counters_.gpio_failures;
  // The simulator renders outside the measured tasks: its cost is the simulation's, not the robot's. Its
  // odometry is read first, so a frame finds the pose published at its own time.
  if (prefetch_outside_tasks_) {
    odometry_.poll(tick_start, have_offset_, data_offset_ns_);
    poll_camera();
  }
  scheduler_.tick();
  if (keyframe_queue_.try_pop(&current_keyframe_)) {
    scheduler_.keyframe(keyframe_index_++);
    free_frames_.push(int{current_keyframe_});
    current_keyframe_ = -1;
  }
  if (config_.lockstep) {
    segmentation_.run_pending();  // the frame the reconstruction task offered, after the keyframe's tasks
    BackendUpdate u;
    if (backend_queue_.try_pop(&u)) timed_backend_update(u);
  }
  if (segmentation_.initialized()) {
    const SegmentationWorkerCounters sc = segmentation_.counters();
    counters_.keyframes_unlabelled = sc.offered - std::min(sc.offered, counters_.keyframes_segmented);
  }
  copy_backend_counters();
  if (tick_start >= next_snapshot_ns_) {
    std::string error;
    bool deferred = false;
    if (!write_snapshot(&error, &deferred)) {
      ++counters_.snapshot_failures;
      std::fprintf(stderr, "qsg_app: snapshot failed (%s); the run goes on\n", error.c_str());
    }
    if (deferred) ++counters_.snapshots_deferred;  // tried again next tick
    else next_snapshot_ns_ += static_cast<std::int64_t>(config_.snapshot_interval_s * 1e9);
  }
  clock_->sleep_until_ns(tick_start + scheduler_.tick_period_ns());
  return true;
}

void Pipeline::poll_camera() {
  if (pending_frame_ < 0 && !source_ended_) {
    int index = -1;
    if (!free_frames_.try_pop(&index)) return;  // every buffer is queued: the queue's drop policy decides
    messages::RgbdFrame& frame = frames_[static_cast<std::size_t>(index)];
    const drivers::ReadStatus status = camera_->read(frame, 0);
    if (status == drivers::ReadStatus::kOk) {
      ++counters_.frames_read;
      if (!config_.ground_truth_labels) frame.has_labels = false;
      if (!have_offset_) {
        data_offset_ns_ = clock_->now_ns() - frame.sample_time_ns;
        have_offset_ = true;
      }
      pending_frame_ = index;
    } else {
      if (status == drivers::ReadStatus::kEndOfStream) source_ended_ = true;
      else if (status == drivers::ReadStatus::kBadFrame) ++counters_.frames_bad;
      free_frames_.push(int{index});
    }
  }
  if (pending_frame_ < 0) return;
  const messages::RgbdFrame& frame = frames_[static_cast<std::size_t>(pending_frame_)];
  const std::int64_t due_ns = data_to_loop_ns(frame.sample_time_ns);
  if (due_ns > clock_->now_ns()) return;  // not its time yet
  // Its pose from the odometry at its sample time; it may wait for the odometry, up to the budget's bound.
  const auto slot = static_cast<std::size_t>(pending_frame_);
  const FramePose pose =
      odometry_.frame_pose(frame.sample_time_ns, clock_->now_ns() - due_ns, &frame_poses_[slot], &frame_variances_[slot]);
  if (pose == FramePose::kWait) return;
  if (pose == FramePose::kDrop) {
    ++counters_.frames_without_pose;
    free_frames_.push(int{pending_frame_});
    pending_frame_ = -1;
    return;
  }
  const int index = pending_frame_;
  pending_frame_ = -1;
  if (trigger_ && !trigger_->active() && !trigger_->fire(clock_->now_ns())) ++counters_.gpio_failures;
  ++counters_.triggers;
  if (paused()) {
    ++counters_.frames_paused;
    free_frames_.push(int{index});
    return;
  }
  if (keyframes_.offer(frame.sample_time_ns, frame_poses_[static_cast<std::size_t>(index)])) {
    ++counters_.keyframes;
    keyframe_queue_.push(int{index});  // a full queue hands its oldest keyframe back to the free list
  } else {
    free_frames_.push(int{index});
  }
}

double Pipeline::progress() const {
  if (replay_ != nullptr && replay_->size() > 0)
    return static_cast<double>(replay_->position()) / static_cast<double>(replay_->size());
  if (sim_camera_ == nullptr || sim_camera_->num_frames() == 0) return -1.0;
  return static_cast<double>(counters_.frames_read) / static_cast<double>(sim_camera_->num_frames());
}

// ---------------------------------------------------------------------------------------------------------
// Tasks

void Pipeline::camera_poll_task(void* self, const runtime::TaskContext&) {
  Pipeline& p = *static_cast<Pipeline*>(self);
  if (!p.prefetch_outside_tasks_) p.poll_camera();
}

void Pipeline::odometry_poll_task(void* self, const runtime::TaskContext&) {
  Pipeline& p = *static_cast<Pipeline*>(self);
  p.odometry_.poll(p.clock_->now_ns(), p.have_offset_, p.data_offset_ns_);  // the loop clock, not the cost clock
}

void Pipeline::reconstruction_task(void* self, const runtime::TaskContext& c) {
  static_cast<Pipeline*>(self)->integrate_keyframe(c);
}

void Pipeline::frontend_task(void* self, const runtime::TaskContext& c) {
  static_cast<Pipeline*>(self)->update_frontend(c);
}

void Pipeline::heartbeat_task(void* self, const runtime::TaskContext&) {
  Pipeline& p = *static_cast<Pipeline*>(self);
  if (p.heartbeat_ == nullptr) return;
  if (p.heartbeat_->toggle()) ++p.counters_.heartbeat_toggles;
  else ++p.counters_.gpio_failures;
}

void Pipeline::telemetry_task(void* self, const runtime::TaskContext&) {
  Pipeline& p = *static_cast<Pipeline*>(self);
  // The loop clock, like last_telemetry_ns_ (the task's context carries the cost clock: the wall in lockstep).
  if (p.clock_->now_ns() - p.last_telemetry_ns_ < static_cast<std::int64_t>(p.config_.telemetry_interval_s * 1e9) - 1000000)
    return;
  if (!p.telemetry_.initialized()) return p.print_telemetry(stdout);
  p.print_telemetry(p.telemetry_.begin());  // into the staging buffer; the writer thread does the output
  p.telemetry_.commit();
}

Eigen::Isometry3d Pipeline::mapped_pose(const Eigen::Isometry3d& odometric) {
  if (!config_.loop_closure.map_in_corrected_frame) return odometric;
  Eigen::Isometry3d map_T_odom;
  {
    std::lock_guard<std::mutex> lock(frame_mutex_);
    map_T_odom = map_T_odom_;
  }
  frontend_.set_frame_correction(map_T_odom);  // stamped on the agent node this keyframe adds
  return map_T_odom * odometric;
}

// The reconstruction task: the keyframe through pipeline::integrate_keyframe (TSDF, wall map, free space, agent node).
void Pipeline::integrate_keyframe(const runtime::TaskContext& c) {
  if (current_keyframe_ < 0) return;
  const auto slot = static_cast<std::size_t>(current_keyframe_);
  const messages::RgbdFrame& frame = frames_[slot];
  // loop_closure.map_in_corrected_frame: the odometric pose moved by the latest correction (map_T_odom).
  const Eigen::Isometry3d world_T_camera = mapped_pose(frame_poses_[slot]);
  cast_label_votes();  // labels that came back since the last keyframe; their blocks re-mesh in process()
  const auto time_ns = static_cast<std::uint64_t>(frame.sample_time_ns);
  // A step the odometry kept (odometry.steps): the next agent's edge measures the step, not motion.
  if (const std::uint64_t steps = odometry_.buffer().counters().steps; steps != odometry_steps_seen_) {
    odometry_steps_seen_ = steps;
    frontend_.mark_odometry_step();
  }
  const pipeline::KeyframeResult r =
      pipeline::integrate_keyframe(stages(), host_, frame, world_T_camera, time_ns, frame_variances_[slot]);
  if (!r.integrated) {
    ++counters_.keyframes_refused;
    return;
  }
  counters_.blocks_painted += r.blocks_painted;
  if (r.walls_deferred) ++counters_.wall_paint_deferred;
  robot_m_ = world_T_camera.translation();
  latest_keyframe_ns_ = time_ns;
  // The agent layer: one node per keyframe, joined to the previous one by an odometry edge.
  if (r.added == agents::AddResult::kAdded) {
    ++counters_.agent_nodes;
    capture_agent_frame(frame, frontend_.agents().last_node(), latest_keyframe_ns_);
    if (trajectory_m_.size() < trajectory_m_.capacity()) trajectory_m_.push_back(robot_m_);
  } else if (r.added == agents::AddResult::kSparsified) {
    ++counters_.agent_sparsified;
  } else {
    ++counters_.agent_refused;
  }
  (void)c;
}

void Pipeline::update_frontend(const runtime::TaskContext& c) {
  if (counters_.keyframes_integrated == 0) return;
  frontend::Deadline deadline;
  deadline.now = [](const void* clock) { return static_cast<const runtime::Clock*>(clock)->now_ns(); };
  deadline.context = cost_clock_;
  deadline.deadline_ns = c.deadline_ns;
  const frontend::UpdateSummary s = pipeline::frontend_update(stages(), host_, robot_m_, latest_keyframe_ns_, deadline);
  ++counters_.frontend_updates;
  if (!pipeline::backend_update_due(s)) ++counters_.frontend_deadline_stops;
  else backend_queue_.push(BackendUpdate{latest_keyframe_ns_, 1, robot_m_});  // collates while the backend is busy
}

// ---------------------------------------------------------------------------------------------------------
// Telemetry and outputs

std::string Pipeline::nothing_mapped_reason() const {
  if (counters_.keyframes_integrated > 0) return {};
  const drivers::DriverCounters& d = camera_->counters();
  char text[512];
  std::snprintf(text, sizeof(text),
                "no keyframe was integrated: %llu frames read (%llu bad, %llu missing files, %llu without a pose, "
                "%llu while paused), %llu keyframes (%llu refused by the reconstruction)",
                (unsigned long long)counters_.frames_read, (unsigned long long)std::max(d.bad_frames, counters_.frames_bad),
                (unsigned long long)d.missing_files, (unsigned long long)counters_.frames_without_pose,
                (unsigned long long)counters_.frames_paused, (unsigned long long)counters_.keyframes,
                (unsigned long long)counters_.keyframes_refused);
  return text;
}

bool Pipeline::write_snapshot(std::string* error, bool* deferred) {
  // With loop closure, the snapshot shows the graph as the latest solve corrects it (the graph itself stays in the
  // odometry frame the frontend maps in). While the backend thread is solving, the snapshot waits for a later tick.
  std::unique_lock<std::mutex> solving(deformation_mutex_, std::try_to_lock);
  if (!solving.owns_lock()) {
    if (deferred != nullptr) *deferred = true;
    return true;
  }
  scene_graph::JsonExportOptions options = snapshot_graph_options();
  if (backend_.solved())
    options.correct_position = [this](scene_graph::NodeId id, scene_graph::NodeKind kind, const Eigen::Vector3d& p,
                                      std::uint64_t t) { return backend_.corrected_position(id, kind, p, t); };
  std::string text;
  {
    std::lock_guard<std::mutex> lock(graph_mutex_);
    text = scene_graph::write_spark_dsg_json(graph_, options);
  }
  solving.unlock();
  const bool ok = write_file_atomically(config_.output_dir + "/scene_graph_snapshot.json", text, error);
  if (ok) ++counters_.snapshots_written;
  text = std::string();
#if defined(__GLIBC__)
  // The snapshot's text (about 10 MB for an 8-hour mission's graph) is the run's largest heap block: give its pages
  // back to the system, so the resident set stays what the arenas and the loop hold.
  malloc_trim(0);
#endif
  return ok;
}

}  // namespace qsg::app
