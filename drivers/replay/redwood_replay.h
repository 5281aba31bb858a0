// Redwood / Open3D RGB-D replay: color/ and depth/ image folders (or an rgbd.match list), a `.log` camera
// trajectory, intrinsics from an Open3D PinholeCameraIntrinsic JSON file.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "drivers/replay/image_list_replay.h"
#include "drivers/replay/trajectory.h"

namespace qsg::replay {

// Open3D camera JSON: {"width": w, "height": h, "intrinsic_matrix": [9 numbers, column-major]} (also accepted
// nested under "intrinsic", as in Open3D's PinholeCameraTrajectory files). Errors name the file and field.
// The intrinsics of read_camera_calibration (camera_calibration.h), without the depth scale.
bool read_camera_intrinsics_json(const std::string& path, messages::CameraIntrinsics* intrinsics, std::string* error);

class RedwoodReplay : public ImageListReplay {
 public:
  struct Config {
    messages::CameraIntrinsics intrinsics;  // default: PrimeSense (fx = fy = 525, cx = 319.5, cy = 239.5)
    std::string camera_json;               // if set (relative to the folder or absolute): intrinsics from it
    std::string trajectory_log = "trajectory.log";  // relative to the folder; empty: no trajectory
    std::string match_list = "rgbd.match";          // `depth/x.png color/x.jpg` lines; if absent, folders sorted
    float depth_scale_m = 0.001f;                   // depth PNGs in millimetres
    std::int64_t frame_period_ns = 33'333'333;      // Redwood has no stamps: frame i is sampled at i * period
    std::int64_t publish_latency_ns = 0;
    bool check_files_at_open = true;
    bool size_from_first_frame = false;  // width/height from the first depth image instead of `intrinsics`
    void print(std::FILE* out) const;
  };

  RedwoodReplay() = default;
  // `folder` holds color/, depth/ and the .log (Open3D's RGBD folder). Errors name file and line or field.
  bool open(const std::string& folder, const Config& config, std::string* error);

  const Config& config() const { return config_; }
  const std::vector<RedwoodLogEntry>& log() const { return log_; }
  // The log as camera poses, time = id[0] * frame_period_ns (frame id[0] is the frame the pose belongs to).
  const Trajectory& trajectory() const { return trajectory_odometry_.trajectory(); }
  drivers::OdometrySource& trajectory_odometry() { return trajectory_odometry_; }

 private:
  Config config_;
  std::vector<RedwoodLogEntry> log_;
  TrajectoryOdometry trajectory_odometry_;
};

}  // namespace qsg::replay
