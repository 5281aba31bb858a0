#include "firmware_app/app_params.h"

#include "core/backend/backend_stage_params.h"
#include "core/frontend/frontend_params.h"
#include "core/objects/objects_params.h"
#include "core/places/places_params.h"
#include "core/reconstruction/reconstruction_params.h"
#include "core/doors/door_params.h"
#include "core/rooms/rooms_params.h"

namespace qsg::app {

namespace {

using params::above;
using params::any;
using params::at_least;
using params::in;
constexpr auto project = params::Origin::kProject;
// Times become int64 nanoseconds: 10^9 s ("never" in tests and benchmarks) keeps them from overflow.
constexpr double kMaxTime_s = 1e9;

params::Table<AppConfig> top_table() {
  params::Table<AppConfig> t;
  t.choice("driver", &AppConfig::driver, {{"sim", Driver::kSim}, {"replay", Driver::kReplay}, {"v4l2", Driver::kV4l2}},
           project, "where frames come from (flag --driver)");
  t.add("replay_path", &AppConfig::replay_path, "", any(), project,
        "replay: a TUM RGB-D, Redwood or pose-list folder (flag --replay)");
  t.add("output_dir", &AppConfig::output_dir, "", any(), project, "outputs go here (flag --output)");
  t.add("duration_s", &AppConfig::duration_s, "s", in(0, kMaxTime_s), project,
        "data time to run; 0: until the source ends (flag --duration)");
  t.flag("lockstep", &AppConfig::lockstep, project, "stepped clock, one thread; false: wall clock and worker threads");
  t.add("snapshot_interval_s", &AppConfig::snapshot_interval_s, "s", above(0, kMaxTime_s), project,
        "scene-graph snapshots by atomic replace (loop time)");
  t.add("telemetry_interval_s", &AppConfig::telemetry_interval_s, "s", above(0, kMaxTime_s), project,
        "a telemetry line this often (loop time)");
  t.flag("telemetry_stores", &AppConfig::telemetry_stores, project,
         "a second telemetry line: resident set, page faults, every store's use, fault counters (bench/soak)");
  t.flag("lock_memory", &AppConfig::lock_memory, project,
         "mlockall after start-up (the robot: CAP_IPC_LOCK or LimitMEMLOCK=infinity; flag --mlockall)");
  t.flag("ground_truth_labels", &AppConfig::ground_truth_labels, project,
         "sim: the renderer's labels bypass segmentation");
  t.add("fault_plan", &AppConfig::fault_plan, "", any(), project,
        "faults injected into camera and odometry (firmware_app/FAULT_PLAN.md); empty: none (flag --fault-plan)");
  t.add("world_path", &AppConfig::world_path, "", any(), project,
        "sim: a world file instead of the generated building (drivers/world/WORLD_FORMAT.md; flag --world)");
  return t;
}

params::Table<world::BuildingConfig> building_table() {
  using C = world::BuildingConfig;
  params::Table<C> t;
  t.add("seed", &C::seed, "", any(), project, "the generated building's seed (flag --seed)");
  t.add("num_rooms", &C::num_rooms, "", any(), project, "rooms, hallways and stairwells counted (flag --rooms)");
  t.flag("two_floors", &C::two_floors, project, "a second floor reached by stairs");
  t.flag("furnish", &C::furnish, project, "furniture by room type");
  return t;
}

params::Table<sim::ExplorationConfig> exploration_table() {
  using C = sim::ExplorationConfig;
  params::Table<C> t;
  t.add("camera_height_m", &C::camera_height_m, "m", any(), project, "above the ground: quadruped 0.5, hand-held 1.2");
  t.add("speed_m_s", &C::speed_m_s, "m/s", any(), project, "walking speed");
  t.flag("spin_in_rooms", &C::spin_in_rooms, project, "turn once around at each room's centre");
  t.flag("return_to_start", &C::return_to_start, project, "the tour ends where it started");
  t.add("rate_hz", &C::rate_hz, "Hz", any(), project, "the tour's pose samples (the simulated odometry's rate)");
  t.add("tours", &C::tours, "", in(1, 100000), project,
        "the same tour walked again and again (a long mission; flag --tours)");
  return t;
}

params::Table<messages::CameraIntrinsics> camera_size_table() {
  using C = messages::CameraIntrinsics;
  params::Table<C> t;
  t.add("width", &C::width, "px", any(), project,
        "image width (the focal length follows: a 63 degree field of view, or camera.hfov_deg)");
  t.add("height", &C::height, "px", any(), project, "image height");
  return t;
}

params::Table<sim::SimCamera::Config> camera_table() {
  using C = sim::SimCamera::Config;
  params::Table<C> t;
  t.include(camera_size_table(), [](C& c) -> messages::CameraIntrinsics& { return c.intrinsics; });
  t.add("rate_hz", &C::rate_hz, "Hz", any(), project, "frames per second");
  t.add("pitch_rad", &C::pitch_rad, "rad", any(), project, "camera tilt about the body's y axis (positive: down)");
  t.add("hfov_deg", &C::hfov_deg, "deg", in(0, 170), project,
        "horizontal field of view (0: 525 px of focal length per 640 px of width, 63 degrees)");
  return t;
}

params::Table<runtime::KeyframeConfig> keyframes_table() {
  using C = runtime::KeyframeConfig;
  params::Table<C> t;
  t.add("min_interval_s", &C::min_interval_s, "s", in(0, 3600), project, "never more keyframes than one per this");
  t.add("max_interval_s", &C::max_interval_s, "s", above(0, 3600), project,
        "at least one keyframe per this, even standing still (> min_interval_s)");
  t.add("min_translation_m", &C::min_translation_m, "m", in(0, 100), project, "a keyframe after this much motion");
  t.add("min_rotation_rad", &C::min_rotation_rad, "rad", in(0, 3.1416), project, "... or this much turn");
  return t;
}

params::Table<AppConfig> doors_app_table() {
  params::Table<AppConfig> t;
  t.flag("online", &AppConfig::doors_online, project,
         "doors during the run, in a window around the robot (the budget table's doors arena)");
  t.add("online_every_n_updates", &AppConfig::doors_online_every_n, "", in(1, 1000000), project,
        "... before every this many backend updates");
  t.flag("at_finish", &AppConfig::doors_at_finish, project,
         "doors on the whole final mesh; rooms and labels found once more before the outputs");
  return t;
}

params::Table<replay::DatasetReplayConfig> replay_table() {
  using C = replay::DatasetReplayConfig;
  params::Table<C> t;
  t.add("format", &C::format, "", any(), project, "auto|tum|redwood|pose_list");
  t.add("calibration", &C::calibration, "", any(), project,
        "a camera file; empty: calibration.json beside the frames (flag --calibration)");
  t.add("fx", &C::fx, "px", any(), project, "0: from the dataset (its file, else the format's default)");
  t.add("fy", &C::fy, "px", any(), project, "0: from the dataset (may be negative: ICL-NUIM)");
  t.add("cx", &C::cx, "px", any(), project, "0: from the dataset");
  t.add("cy", &C::cy, "px", any(), project, "0: from the dataset");
  t.add("depth_scale_m", &C::depth_scale_m, "m", any(), project, "metres per raw depth unit; 0: from the dataset");
  t.add("frame_period_s", &C::frame_period_s, "s", any(), project,
        "Redwood and pose lists carry no stamps: frame i is at i x this");
  t.flag("check_files_at_open", &C::check_files_at_open, project,
         "a missing listed file fails start-up (false: skipped and counted)");
  return t;
}

params::Table<AppConfig::V4l2> v4l2_table() {
  using C = AppConfig::V4l2;
  params::Table<C> t;
  t.add("depth_device", &C::depth_device, "", any(), project, "the Z16 depth node");
  t.add("colour_device", &C::colour_device, "", any(), project, "the colour node");
  t.add("width", &C::width, "px", in(16, 640), project, "image width");
  t.add("height", &C::height, "px", in(16, 480), project, "image height");
  t.add("fx", &C::fx, "px", in(0, 100000), project,
        "0: 525 px per 640 px of width (a 63 degree field of view); else >= 1");
  t.add("fy", &C::fy, "px", in(0, 100000), project, "0: as fx; else >= 1");
  t.add("cx", &C::cx, "px", in(0, 640), project, "0: centred; within the image");
  t.add("cy", &C::cy, "px", in(0, 480), project, "0: centred; within the image");
  t.add("depth_scale_m", &C::depth_scale_m, "m", above(0, 1), project, "metres per raw depth unit");
  return t;
}

params::Table<AppConfig::Odometry> odometry_table() {
  using C = AppConfig::Odometry;
  params::Table<C> t;
  t.choice("source", &C::source,
           {{"auto", OdometrySourceKind::kAuto}, {"sim_drift", OdometrySourceKind::kSimDrift},
            {"ground_truth", OdometrySourceKind::kGroundTruth}, {"tum", OdometrySourceKind::kTum},
            {"stream", OdometrySourceKind::kStream}, {"static", OdometrySourceKind::kStatic}},
           project, "where keyframe poses come from (auto: sim_drift, ground_truth on replay, static on v4l2)");
  t.add("translation_sigma_m_per_sqrt_m", &C::translation_sigma_m_per_sqrt_m, "m/sqrt(m)", in(0, 1), project,
        "sim_drift: translation random walk per sqrt(metre) travelled");
  t.add("yaw_sigma_rad_per_sqrt_m", &C::yaw_sigma_rad_per_sqrt_m, "rad/sqrt(m)", in(0, 1), project,
        "sim_drift: yaw random walk per sqrt(metre)");
  t.add("scale_bias", &C::scale_bias, "", in(-0.5, 0.5), project, "sim_drift: scale error");
  t.add("yaw_bias_rad_per_m", &C::yaw_bias_rad_per_m, "rad/m", in(-0.5, 0.5), project, "sim_drift: yaw drift");
  t.add("seed", &C::seed, "", in(0, 9007199254740992.0), project, "sim_drift: the random walk's seed");
  t.add("tum_path", &C::tum_path, "", any(), project, "tum: the estimate's file (flag --odometry-tum)");
  t.add("stream_transport", &C::stream_transport, "", any(), project, "stream: udp or unix");
  t.add("stream_bind_address", &C::stream_bind_address, "", any(), project, "stream udp: the address to bind");
  t.add("stream_port", &C::stream_port, "", in(0, 65535), project, "stream udp: the port");
  t.add("stream_unix_path", &C::stream_unix_path, "", any(), project, "stream unix: the datagram socket's path");
  t.add("silence_fault_s", &C::silence_fault_s, "s", above(0, 3600), project,
        "a source silent this long is a logged fault");
  t.array("body_t_camera_m", &C::body_t_camera_m, "m", in(-10, 10), project, "the camera's position in the body frame");
  t.array("body_q_camera_xyzw", &C::body_q_camera_xyzw, "", in(-1, 1), project,
          "the camera's orientation in the body frame (a unit quaternion)");
  using B = runtime::PoseBufferConfig;
  params::Table<B> buffer;
  buffer.add("max_gap_s", &B::max_gap_s, "s", above(0, 60), project, "samples further apart are a gap (a fault)");
  buffer.add("max_time_jump_s", &B::max_time_jump_s, "s", in(0, 3600), project,
             "a sample this far past the previous is held until confirmed (>= max_gap_s)");
  buffer.add("max_speed_m_per_s", &B::max_speed_m_per_s, "m/s", above(0, 1000), project,
             "faster between two samples is a pose jump, rejected");
  t.include(buffer, [](C& c) -> B& { return c.buffer; });
  return t;
}

params::Table<AppConfig::Segmentation> segmentation_table() {
  using C = AppConfig::Segmentation;
  params::Table<C> t;
  t.add("model_path", &C::model_path, "", any(), project, "an ONNX model; empty: segmentation off");
  t.add("label_map_path", &C::label_map_path, "", any(), project, "the model's labels to ours");
  t.add("deadline_s", &C::deadline_s, "s", above(0, 60), project, "labels later than this are dropped (counted)");
  t.add("min_interval_s", &C::min_interval_s, "s", in(0, 60), project, "at most one keyframe segmented per this");
  t.add("min_confidence", &C::min_confidence, "", in(0, 1), project, "pixels below this confidence get no label");
  t.add("backend", &C::backend, "", any(), project, "opencv | cuda (an OpenCV built with CUDA)");
  t.add("target", &C::target, "", any(), project, "cpu | cuda | cuda_fp16 (cuda ones with backend cuda)");
  t.flag("fallback_to_cpu", &C::fallback_to_cpu, project, "cuda unavailable: run on the CPU (counted), not fail");
  t.add("opencv_threads", &C::opencv_threads, "", in(0, 64), project, "cv::setNumThreads; 0: every core");
  return t;
}

params::Table<AppConfig> room_labels_table() {
  params::Table<AppConfig> t;
  t.add("weights_path", &AppConfig::room_weights_path, "", any(), project,
        "the room classifier's weights; empty: the source tree's (installed: share/qsg/room_classifier_v4.json)");
  return t;
}

params::Table<AppConfig::Gpio> gpio_table() {
  using C = AppConfig::Gpio;
  params::Table<C> t;
  t.add("chip", &C::chip, "", any(), project, "sim, or a libgpiod chip (gpiochip0, /dev/gpiochip0, a label)");
  t.add("heartbeat_line", &C::heartbeat_line, "", in(-1, 1023), project, "toggled by the heartbeat task; -1: unused");
  t.add("trigger_line", &C::trigger_line, "", in(-1, 1023), project, "pulsed once per camera frame; -1: unused");
  t.add("pause_line", &C::pause_line, "", in(-1, 1023), project, "high: paused (frames dropped, counted); -1: unused");
  t.add("trigger_width_s", &C::trigger_width_s, "s", above(0, 1), project, "the trigger pulse's width");
  t.add("pause_debounce_s", &C::pause_debounce_s, "s", in(0, 10), project, "the pause line's debounce");
  return t;
}

params::Table<runtime::SchedulerConfig> scheduler_table() {
  params::Table<runtime::SchedulerConfig> t;
  t.add("tick_hz", &runtime::SchedulerConfig::tick_hz, "Hz", in(1, 10000), project, "the loop's base tick");
  return t;
}

}  // namespace

const params::Schema<AppConfig>& app_schema() {
  static const params::Schema<AppConfig> schema = [] {
    params::Schema<AppConfig> s;
    s.section("", top_table());
    s.section("building", building_table(), [](AppConfig& a) -> world::BuildingConfig& { return a.building; });
    s.section("exploration", exploration_table(), [](AppConfig& a) -> sim::ExplorationConfig& { return a.exploration; });
    s.section("camera", camera_table(), [](AppConfig& a) -> sim::SimCamera::Config& { return a.camera; });
    s.section("reconstruction", reconstruction::params_table(),
              [](AppConfig& a) -> reconstruction::Config& { return a.reconstruction; });
    s.section("keyframes", keyframes_table(), [](AppConfig& a) -> runtime::KeyframeConfig& { return a.keyframes; });
    s.section("places", places::params_table(), [](AppConfig& a) -> places::Config& { return a.frontend.places; });
    s.section("objects", objects::params_table(), [](AppConfig& a) -> objects::Config& { return a.frontend.objects; });
    s.section("frontend", frontend::params_table(), [](AppConfig& a) -> frontend::Config& { return a.frontend; });
    s.section("loop_closure", backend::loop_closure_params_table(),
              [](AppConfig& a) -> AppConfig::LoopClosure& { return a.loop_closure; });
    s.section("agents", agents::params_table(), [](AppConfig& a) -> agents::Config& { return a.frontend.agents; });
    s.section("rooms", rooms::params_table(), [](AppConfig& a) -> rooms::Config& { return a.rooms; });
    s.section("doors", doors_app_table());
    s.section("doors", rooms::door_params_table(), [](AppConfig& a) -> rooms::DoorConfig& { return a.doors; });
    s.section("replay", replay_table(), [](AppConfig& a) -> replay::DatasetReplayConfig& { return a.replay; });
    s.section("v4l2", v4l2_table(), [](AppConfig& a) -> AppConfig::V4l2& { return a.v4l2; });
    s.section("odometry", odometry_table(), [](AppConfig& a) -> AppConfig::Odometry& { return a.odometry; });
    s.section("segmentation", segmentation_table(),
              [](AppConfig& a) -> AppConfig::Segmentation& { return a.segmentation; });
    s.section("room_labels", room_labels_table());
    s.section("gpio", gpio_table(), [](AppConfig& a) -> AppConfig::Gpio& { return a.gpio; });
    s.section("scheduler", scheduler_table(), [](AppConfig& a) -> runtime::SchedulerConfig& { return a.scheduler; });
    return s;
  }();
  return schema;
}

const char* default_config_header() {
  return "qsg_app's defaults, every key spelled out; generated by `qsg_app --dump-config` from the parameter tables\n"
         "(core/params; each stage's *_params.cc): do not edit by hand. Every key is optional in a config and\n"
         "overrides the built-in value. Each key's comment: what it does (range unit; paper | refinement | project).\n"
         "Resources (arena sizes, task budgets and cadence, queue depths) are not here: budgets/<board>.json.";
}

}  // namespace qsg::app
