// Replay of numbered frames with a plain pose list (slambook2's ICL-NUIM and Kinect samples).
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

#include "drivers/replay/image_list_replay.h"
#include "drivers/replay/trajectory.h"

namespace qsg::replay {

// Frames color/<i><ext> and depth/<i><ext>, i counted from first_index, with pose.txt holding one
// `tx ty tz qx qy qz qw` line per frame (camera-to-world).
class PoseListReplay : public ImageListReplay {
 public:
  struct Config {
    messages::CameraIntrinsics intrinsics;  // fy may be negative (ICL-NUIM's convention)
    float depth_scale_m = 1.0f / 5000.0f;
    std::string color_dir = "color";
    std::string color_ext = ".png";
    std::string depth_dir = "depth";
    std::string depth_ext = ".png";
    int first_index = 1;  // file number of the first pose line
    std::string pose_file = "pose.txt";
    std::int64_t frame_period_ns = 33'333'333;
    std::int64_t publish_latency_ns = 0;
    bool check_files_at_open = true;
    bool size_from_first_frame = false;  // width/height from the first depth image instead of `intrinsics`
    void print(std::FILE* out) const;
  };

  PoseListReplay() = default;
  bool open(const std::string& folder, const Config& config, std::string* error);

  const Config& config() const { return config_; }
  const Trajectory& trajectory() const { return trajectory_odometry_.trajectory(); }
  drivers::OdometrySource& trajectory_odometry() { return trajectory_odometry_; }

 private:
  Config config_;
  TrajectoryOdometry trajectory_odometry_;
};

}  // namespace qsg::replay
