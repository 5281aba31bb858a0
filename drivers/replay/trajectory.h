// Timestamped pose sequences: the trajectory file formats datasets use (TUM, Redwood .log, plain pose lists) and
// an OdometrySource that plays a trajectory back exactly (ground truth views of replayed datasets).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "drivers/sources.h"

namespace qsg::replay {

// world_T_body as translation + unit quaternion, kept in that form so values read from a file pass through
// unchanged (a matrix round trip would not be bit-exact).
struct StampedPose {
  std::int64_t time_ns = 0;
  Eigen::Vector3d world_t_body_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond world_R_body = Eigen::Quaterniond::Identity();

  Eigen::Isometry3d world_T_body() const;
  static StampedPose from_isometry(std::int64_t time_ns, const Eigen::Isometry3d& world_T_body);
};
using Trajectory = std::vector<StampedPose>;

// TUM trajectory file: lines `t tx ty tz qx qy qz qw` (t in seconds), '#' comments. Quaternions are
// normalised (the files carry 4-7 digits). Errors name the file and line.
bool read_tum_trajectory(const std::string& path, Trajectory* trajectory, std::string* error);
// The same for a robot's own estimate, where one corrupt line must not cost the mission: malformed lines are
// skipped and counted (the first one's reason kept); false only when the file cannot be read.
struct TumSkipped {
  std::size_t lines = 0;
  std::string first_reason;  // names the file and line
};
bool read_tum_trajectory_skipping(const std::string& path, Trajectory* trajectory, TumSkipped* skipped,
                                  std::string* error);
bool write_tum_trajectory(const std::string& path, const Trajectory& trajectory, std::string* error);
// One TUM trajectory line (no newline) for streaming writers.
std::string format_tum_pose(const StampedPose& pose);

// Redwood / Open3D `.log`: per pose a line `id id next` then the 4 rows of a 4x4 camera-to-world matrix.
struct RedwoodLogEntry {
  std::int64_t id[3] = {0, 0, 0};  // metadata line; id[0] is the frame index in Redwood's own trajectories
  Eigen::Matrix4d world_T_camera = Eigen::Matrix4d::Identity();
  int line_number = 0;  // of the metadata line
};
// Errors name the file and line: a metadata line without 3 integers, a matrix row without 4 numbers (a missing
// row shows up as the next metadata line in its place), a file ending inside a block, a last row not 0 0 0 1,
// or a rotation block that is not a rotation (|R^T R - I| > 1e-3).
bool read_redwood_log(const std::string& path, std::vector<RedwoodLogEntry>* entries, std::string* error);

// Plain pose list (slambook2's pose.txt): one `tx ty tz qx qy qz qw` line per frame, camera-to-world.
// Times are index * frame_period_ns.
bool read_pose_list(const std::string& path, std::int64_t frame_period_ns, Trajectory* trajectory,
                    std::string* error);

// Pose at time_ns, linearly interpolated (slerp for rotation) between the two samples around it; false when
// time_ns lies outside the trajectory or the samples around it are more than max_gap_ns apart.
// The trajectory must be sorted by time.
bool interpolate_pose(const Trajectory& trajectory, std::int64_t time_ns, std::int64_t max_gap_ns,
                      StampedPose* pose);

// Plays a trajectory back as odometry, unchanged: sequence = index, sample time = the pose's time, publish
// time = sample time + publish_latency_ns. Flags (and counts) a time that does not increase. Does not allocate
// per read; the timeout is ignored (poses are in memory).
class TrajectoryOdometry : public drivers::OdometrySource {
 public:
  struct Config {
    std::int64_t publish_latency_ns = 0;
    // Reported covariance (diagonal): ground truth is near-certain, but consumers may invert it, so not zero.
    double translation_sigma_m = 1e-3;
    double rotation_sigma_rad = 1e-3;
    void print(std::FILE* out) const;
  };

  TrajectoryOdometry() = default;
  explicit TrajectoryOdometry(Trajectory trajectory);
  TrajectoryOdometry(Trajectory trajectory, const Config& config, const char* name);
  // Replaces the trajectory, rewinds and clears the counters; `name` must outlive the source.
  void reset(Trajectory trajectory, const char* name);
  void set_config(const Config& config) { config_ = config; }
  // Starts over from the first pose (counters kept).
  void rewind();

  const char* name() const override { return name_; }
  drivers::ReadStatus read(messages::OdometrySample& sample, std::int64_t timeout_ns) override;
  const drivers::DriverCounters& counters() const override { return counters_; }

  const Trajectory& trajectory() const { return trajectory_; }

 private:
  Trajectory trajectory_;
  Config config_;
  const char* name_ = "trajectory";
  std::size_t next_ = 0;
  bool have_last_time_ = false;
  std::int64_t last_time_ns_ = 0;
  drivers::DriverCounters counters_;
};

}  // namespace qsg::replay
