// The app's odometry input: builds the configured source (the simulator's drifting odometry, ground truth, a TUM
// estimate, a live pose stream, or none), moves its samples into the pose buffer, and gives each frame the pose
// interpolated at its sample time, or says to wait (up to the budget's bound) or to drop the frame.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "drivers/replay/trajectory.h"
#include "drivers/sim/drifting_odometry.h"
#include "firmware_app/app_config.h"
#include "firmware_app/runtime/pose_buffer.h"

namespace qsg::pose_stream {
class PoseStreamSource;
}

namespace qsg::app {

class FaultInjection;

struct OdometryCounters {
  std::uint64_t samples_read = 0;       // delivered by the source (before the pose buffer's checks)
  std::uint64_t source_bad = 0;         // the source said kBadFrame (a malformed message, counted by the driver)
  std::uint64_t file_lines_skipped = 0;  // malformed lines of a TUM estimate, skipped at start-up
  std::uint64_t frames_posed = 0;
  std::uint64_t frames_waited = 0;      // frames whose pose had not arrived when they were due (they waited)
  std::uint64_t frames_no_pose = 0;     // dropped: no pose within the wait bound, or the source had ended
  std::uint64_t frames_pose_too_old = 0;  // dropped: older than every buffered sample
  std::uint64_t frames_in_gap = 0;      // dropped: inside a gap of the odometry
  std::uint64_t silences = 0;           // the source was silent longer than silence_fault_s (logged faults)
  std::uint64_t disconnects = 0;        // reads that said the source is gone
  std::uint64_t frames_dropped() const { return frames_no_pose + frames_pose_too_old + frames_in_gap; }
};

enum class FramePose : std::uint8_t { kReady, kWait, kDrop };

class OdometryInput {
 public:
  OdometryInput();
  ~OdometryInput();
  OdometryInput(const OdometryInput&) = delete;
  OdometryInput& operator=(const OdometryInput&) = delete;

  // `ground_truth` is the true body trajectory (sim) or the dataset's camera poses (replay, body = camera); it
  // backs the ground_truth source and sim_drift's truth. `body_T_camera` is the camera's mount (the simulator's, or
  // the config's extrinsics). Allocates (start-up only).
  bool init(const AppConfig& config, const replay::Trajectory& ground_truth, const Eigen::Isometry3d& body_T_camera,
            std::uint32_t buffer_depth, std::int64_t max_wait_ns, std::string* error);

  // Moves the source's samples into the pose buffer. Samples held in memory (sim_drift, ground_truth, tum) are
  // published on the loop clock: a sample waits until loop time reaches its sample time + data_offset_ns (known
  // once the first frame arrived). A live stream is read as it comes. Never allocates.
  void poll(std::int64_t now_loop_ns, bool have_offset, std::int64_t data_offset_ns);

  // The pose of a frame sampled at sample_time_ns, due on the loop clock `waited_ns` ago, and the odometry's
  // covariance diagonal there (zero when static).
  FramePose frame_pose(std::int64_t sample_time_ns, std::int64_t waited_ns, Eigen::Isometry3d* world_T_camera,
                       Eigen::Matrix<double, 6, 1>* variance);

  // Before init(): the source is read through the plan's odometry faults (when it has any).
  void set_fault_injection(FaultInjection* faults) { faults_ = faults; }

  OdometrySourceKind kind() const { return kind_; }
  const char* source_name() const;
  const runtime::PoseBuffer& buffer() const { return buffer_; }
  const OdometryCounters& counters() const { return counters_; }
  const drivers::DriverCounters* driver_counters() const;
  // The UDP port a stream listens on (0 otherwise): a port of 0 in the config asks the kernel for a free one.
  int stream_port() const;
  void print_report(std::FILE* out) const;

 private:
  OdometrySourceKind kind_ = OdometrySourceKind::kStatic;
  std::unique_ptr<sim::DriftingOdometry> drift_;
  std::unique_ptr<replay::TrajectoryOdometry> trajectory_;
  std::unique_ptr<pose_stream::PoseStreamSource> stream_;
  drivers::OdometrySource* source_ = nullptr;  // null: static
  const char* source_name_ = "static";         // the source's own name (source_ may be a fault decorator)
  FaultInjection* faults_ = nullptr;
  bool paced_ = false;                         // in-memory: published on the loop clock
  bool ended_ = false;
  bool have_pending_ = false;
  messages::OdometrySample pending_;
  runtime::PoseBuffer buffer_;
  Eigen::Isometry3d body_T_camera_ = Eigen::Isometry3d::Identity();
  std::int64_t max_wait_ns_ = 0;
  std::int64_t silence_fault_ns_ = 0;
  std::int64_t last_sample_loop_ns_ = -1;
  std::int64_t first_poll_loop_ns_ = -1;  // a live stream that never sends is a silence too, from its first poll
  bool silent_ = false;
  OdometryCounters counters_;
};

}  // namespace qsg::app
