// The app's configuration: one JSON file over built-in defaults, then command-line overrides. Every key is declared
// once, in its stage's parameter table (core/params; the app's sections in firmware_app/app_params.cc), which gives
// the loader, the range check and the print; firmware_app/config/default.json is generated from the tables
// (qsg_app --dump-config). Behaviour lives here; resources (arena sizes, task budgets, queue depths) live in the
// board's budget table.
#pragma once

#include <cstdio>
#include <string>

#include "core/backend/deformation_graph.h"
#include "core/frontend/frontend.h"
#include "core/backend/backend_stage.h"
#include "core/loop_closure/detector.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/doors/door_detector.h"
#include "core/rooms/room_finder.h"
#include "drivers/replay/dataset_replay.h"
#include "drivers/sim/exploration.h"
#include "drivers/sim/odometry_levels.h"
#include "drivers/sim/sim_camera.h"
#include "drivers/world/building_generator.h"
#include "firmware_app/runtime/keyframe_selector.h"
#include "firmware_app/runtime/pose_buffer.h"
#include "firmware_app/runtime/scheduler.h"

namespace qsg::app {

enum class Driver { kSim, kReplay, kV4l2 };
const char* to_string(Driver d);

// Where the keyframes' poses come from. Every source is an odometry stream (world_T_body samples at their own
// rate); each frame takes the pose interpolated at its sample time from the pose buffer.
enum class OdometrySourceKind {
  kAuto,         // sim: kSimDrift; replay: kGroundTruth; v4l2: kStatic
  kSimDrift,     // sim only: the simulator's drifting odometry over the true path (the truth is kept for scoring)
  kGroundTruth,  // sim: the true camera path; replay: the dataset's poses (groundtruth.txt, trajectory.log, pose.txt)
  kTum,          // a TUM trajectory file (`t tx ty tz qx qy qz qw`): the robot's own estimate, replayed
  kStream,       // live pose messages on a UDP or Unix datagram socket (drivers/pose_stream)
  kStatic,       // the robot stands still at the origin
};
const char* to_string(OdometrySourceKind k);
bool odometry_source_from_string(const std::string& name, OdometrySourceKind* out);

struct AppConfig {
  Driver driver = Driver::kSim;
  std::string replay_path;              // replay: a TUM RGB-D, Redwood or pose-list folder (drivers/replay/README.md)
  std::string output_dir = "qsg_output";
  double duration_s = 0.0;              // data time to run; 0 = until the source ends
  bool lockstep = true;                 // stepped clock, one thread; false = wall clock and worker threads
  double snapshot_interval_s = 10.0;    // scene-graph snapshots by atomic replace (loop time)
  double telemetry_interval_s = 1.0;
  // After each telemetry line, one more: the resident set (VmRSS, VmHWM), page faults, and every store's
  // use / high water / capacity / refused and the fault counters, in key=value form (the soak reads it).
  bool telemetry_stores = false;
  // mlockall(MCL_CURRENT | MCL_FUTURE) once the stores are carved (and pre-faulted): no page of the process is paged
  // out or faulted in later. For the robot (needs CAP_IPC_LOCK or an RLIMIT_MEMLOCK above the process's size,
  // e.g. systemd's LimitMEMLOCK=infinity); off on the host. A failure is logged with the limit and the run goes on
  // unlocked (counted: the exit report's memory.lock_failures). Flag: --mlockall.
  bool lock_memory = false;
  bool ground_truth_labels = true;      // sim: the renderer's labels bypass segmentation
  // A fault plan (firmware_app/FAULT_PLAN.md) wrapping the camera and odometry sources; "" = none.
  std::string fault_plan;
  // Sim driver: the building from a world file (drivers/world/WORLD_FORMAT.md) instead of generating one; "" =
  // generate from `building`.
  std::string world_path;

  // Replay: the dataset's format and camera (its path is replay_path, which replay.path does not replace). fx, fy,
  // cx, cy and depth_scale_m of 0 come from the dataset: its calibration file, else the format's default.
  replay::DatasetReplayConfig replay;

  // The V4L2 RGB-D pair (a RealSense-style camera: aligned Z16 depth and colour nodes); its frames' poses come
  // from `odometry` (static by default; a pose stream on a robot).
  struct V4l2 {
    std::string depth_device = "/dev/video0";
    std::string colour_device = "/dev/video1";
    int width = 640;
    int height = 480;
    double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;  // 0: 525 px per 640 px of width (63 degrees), centred
    double depth_scale_m = 0.001;
  } v4l2;

  // Semantic segmentation (OpenCV DNN) of keyframes without ground-truth labels. Off when model_path is empty.
  struct Segmentation {
    std::string model_path;                  // e.g. ../shared/data/models/espnetv2_s2_pascal384.onnx
    std::string label_map_path = "firmware_app/config/segmentation_pascal_voc.json";
    // Keyframes never wait for labels (firmware_app/segmentation_worker.h): the worker takes the newest keyframe
    // whenever it is idle and at least min_interval_s has passed; its labels are voted into the map from that
    // frame's own depth and pose when they come back, or dropped (counted) when later than deadline_s.
    double deadline_s = 2.0;
    double min_interval_s = 0.0;
    float min_confidence = 0.5f;
    std::string backend = "opencv";          // opencv | cuda (an OpenCV built with CUDA: JetPack on the Xavier)
    std::string target = "cpu";              // cpu | cuda | cuda_fp16
    bool fallback_to_cpu = false;            // cuda unavailable: false = start-up error, true = CPU, counted
    int opencv_threads = 1;                  // cv::setNumThreads (process-wide); 0 = OpenCV's default (every core)
    // Benchmarks (not a config key: not in the parameter table): in lockstep, the worker is busy for its measured
    // CPU time in data time.
    bool lockstep_busy_from_cost = false;
  } segmentation;

  // Room labels (the neural tree). Empty: the weights in the source tree (core/neural_tree/weights); an installed
  // app uses share/qsg/room_classifier_v4.json. Missing or corrupt weights: rooms stay "unknown", the run goes on.
  std::string room_weights_path;

  // GPIO: "sim" (an in-memory chip) or a libgpiod chip ("gpiochip0", "/dev/gpiochip0", a label). Lines by
  // offset; -1 leaves a function unused.
  struct Gpio {
    std::string chip = "sim";
    int heartbeat_line = 0;   // toggled by the heartbeat task
    int trigger_line = 1;     // pulsed once per camera frame taken
    int pause_line = -1;      // high = paused: frames are read and dropped (counted), nothing is integrated
    double trigger_width_s = 0.001;
    double pause_debounce_s = 0.02;
  } gpio;

  struct Odometry {
    OdometrySourceKind source = OdometrySourceKind::kAuto;
    // sim_drift: random walk per sqrt(metre) travelled, qsg_simulate's default level, plus optional biases.
    double translation_sigma_m_per_sqrt_m = sim::kSimDrift.translation_sigma_m_per_sqrt_m;
    double yaw_sigma_rad_per_sqrt_m = sim::kSimDrift.yaw_sigma_rad_per_sqrt_m;
    double scale_bias = 0.0;
    double yaw_bias_rad_per_m = 0.0;
    std::uint64_t seed = 1;
    std::string tum_path;  // tum: the estimate's file
    // stream: "udp" (bind_address:port; loopback unless configured otherwise) or "unix" (a datagram socket path).
    std::string stream_transport = "udp";
    std::string stream_bind_address = "127.0.0.1";
    int stream_port = 47600;
    std::string stream_unix_path = "/tmp/qsg_pose.sock";
    // A source silent this long (loop time) is a logged fault; the pipeline keeps its last state meanwhile.
    double silence_fault_s = 1.0;
    // The camera in the body frame the odometry reports: world_T_camera = world_T_body * body_T_camera.
    double body_t_camera_m[3] = {0.0, 0.0, 0.0};
    double body_q_camera_xyzw[4] = {0.0, 0.0, 0.0, 1.0};
    runtime::PoseBufferConfig buffer;
  } odometry;

  world::BuildingConfig building;
  sim::ExplorationConfig exploration;
  sim::SimCamera::Config camera;
  reconstruction::Config reconstruction;
  frontend::Config frontend;
  rooms::Config rooms;
  // Doors found on the robot's surface when a run finishes (rooms::find_doors): the place edges through them close
  // and the rooms and their labels are found once more before the final outputs.
  bool doors_at_finish = true;
  // Doors during the run (rooms::OnlineDoors): the loop paints the re-meshed blocks into the "doors" arena's wall
  // map, and every doors_online_every_n-th backend update detects doors in a window around the robot first; the
  // room finder reads the place edges through them as closed. Its buffers are the budget table's "doors" arena.
  bool doors_online = true;
  std::uint32_t doors_online_every_n = 4;
  rooms::DoorConfig doors;
  // The persistent scene graph (backend thread): agents described once the robot is horizon_s past them (one per
  // describe_every_m of path), loop closures detected and verified over the scene graph, and the deformation graph
  // solved after each new one. Its stores are the budget table's "loop_closure" arena.
  using LoopClosure = backend::LoopClosureConfig;  // core/backend/backend_stage.h
  LoopClosure loop_closure;
  runtime::KeyframeConfig keyframes;
  runtime::SchedulerConfig scheduler;

  AppConfig();
  // Reads the keys present in a JSON file over the current values; unknown keys, duplicated keys, wrong types and
  // values out of range are errors naming the file and the key.
  bool load(const std::string& path, std::string* error);
  std::string check() const;
  void print(std::FILE* out) const;
  // The simulated camera as the sim driver builds it: its intrinsics follow camera.width and height (and
  // camera.hfov_deg) however they were set (a file, --set, code): f = 525 px per 640 px of width (a 63 degree
  // horizontal field of view, RealSense-like) unless hfov_deg sets the field; square pixels, centred.
  sim::SimCamera::Config sim_camera() const;

 private:
  std::string check_odometry() const;
};

}  // namespace qsg::app
