// The simulated RGB-D camera: renders the world along a trajectory of camera body poses at a fixed frame rate,
// deterministically, into caller-owned frames (RgbdSource). Time is the trajectory's; nothing sleeps.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <cstdio>
#include <string>

#include "drivers/render/renderer.h"
#include "drivers/replay/trajectory.h"
#include "drivers/sources.h"

namespace qsg::sim {

class SimCamera : public drivers::RgbdSource {
 public:
  struct Config {
    messages::CameraIntrinsics intrinsics{320, 240, 262.5, 262.5, 159.5, 119.5};
    double rate_hz = 10.0;
    std::int64_t latency_ns = 15'000'000;  // publish time = sample time + latency
    float depth_scale_m = 0.001f;          // a RealSense-style Z16 device
    double pitch_rad = 0.0;                // camera tilt about the body's y axis (positive looks down)
    // Horizontal field of view: the focal length (square pixels, centred principal point) follows the image width so
    // that the image spans it. 0: the intrinsics as given.
    double hfov_deg = 0.0;
    std::string check() const;
    // The intrinsics the camera renders with: `intrinsics`, or with hfov_deg > 0 those of that field at its size.
    messages::CameraIntrinsics effective_intrinsics() const;
    void print(std::FILE* out) const;
  };

  // Builds the renderer's scene from the world (which may be destroyed afterwards).
  bool init(const Config& config, const render::Renderer::Config& render_config, const world::World& world,
            replay::Trajectory trajectory, std::string* error);

  const char* name() const override { return "sim_camera"; }
  messages::CameraIntrinsics intrinsics() const override { return config_.intrinsics; }
  // Renders frame `sequence` = number of frames read so far; kEndOfStream past the trajectory's end.
  drivers::ReadStatus read(messages::RgbdFrame& frame, std::int64_t timeout_ns) override;
  const drivers::DriverCounters& counters() const override { return counters_; }

  std::size_t num_frames() const { return num_frames_; }
  // Ground truth: the optical-frame pose and sample time of frame `sequence` (false past the end).
  bool camera_pose(std::uint64_t sequence, Eigen::Isometry3d* world_T_camera, std::int64_t* time_ns) const;
  // The camera's mount on the body (the trajectory's frame): world_T_camera = world_T_body * body_T_camera.
  const Eigen::Isometry3d& body_T_camera() const { return body_T_camera_; }
  const replay::Trajectory& trajectory() const { return trajectory_; }
  const render::Renderer& renderer() const { return renderer_; }

 private:
  Config config_;
  render::Renderer renderer_;
  replay::Trajectory trajectory_;
  Eigen::Isometry3d body_T_camera_ = Eigen::Isometry3d::Identity();
  std::size_t num_frames_ = 0;
  std::uint64_t next_ = 0;
  drivers::DriverCounters counters_;
  std::string render_error_;
};

}  // namespace qsg::sim
