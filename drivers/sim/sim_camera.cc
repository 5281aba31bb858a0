// Simulated RGB-D camera over the renderer.
#include "drivers/sim/sim_camera.h"

#include <cmath>

#include "drivers/sim/exploration.h"

namespace qsg::sim {

std::string SimCamera::Config::check() const {
  if (!intrinsics.valid()) return "intrinsics: size must be 1..640 x 1..480 with non-zero focal lengths";
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0)) return "rate_hz must be in (0, 1000]";
  if (latency_ns < 0) return "latency_ns must not be negative";
  if (!(depth_scale_m > 0.0f)) return "depth_scale_m must be positive";
  if (!std::isfinite(pitch_rad)) return "pitch_rad must be finite";
  if (!(hfov_deg == 0.0 || (hfov_deg >= 10.0 && hfov_deg <= 170.0))) return "hfov_deg must be 0 or in [10, 170]";
  return {};
}

messages::CameraIntrinsics SimCamera::Config::effective_intrinsics() const {
  if (hfov_deg <= 0.0) return intrinsics;
  const double f = 0.5 * intrinsics.width / std::tan(0.5 * hfov_deg * 3.14159265358979323846 / 180.0);
  return {intrinsics.width, intrinsics.height, f, f, 0.5 * intrinsics.width - 0.5, 0.5 * intrinsics.height - 0.5};
}

void SimCamera::Config::print(std::FILE* out) const {
  std::fprintf(out, "sim camera: %dx%d fx %.1f fy %.1f cx %.1f cy %.1f, %.1f Hz, latency %.1f ms, depth scale %g m, pitch %.1f deg\n",
               intrinsics.width, intrinsics.height, intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy, rate_hz,
               latency_ns * 1e-6, static_cast<double>(depth_scale_m), pitch_rad * 180.0 / 3.14159265358979);
}

bool SimCamera::init(const Config& config, const render::Renderer::Config& render_config, const world::World& world,
                     replay::Trajectory trajectory, std::string* error) {
  if (std::string bad = config.check(); !bad.empty()) {
    if (error != nullptr) *error = "sim camera config: " + bad;
    return false;
  }
  if (trajectory.empty()) {
    if (error != nullptr) *error = "sim camera: empty trajectory";
    return false;
  }
  for (std::size_t k = 1; k < trajectory.size(); ++k) {
    if (trajectory[k].time_ns <= trajectory[k - 1].time_ns) {
      if (error != nullptr) *error = "sim camera: trajectory time does not increase at pose " + std::to_string(k);
      return false;
    }
  }
  if (!renderer_.init(render_config, world, error)) return false;
  config_ = config;
  config_.intrinsics = config.effective_intrinsics();
  trajectory_ = std::move(trajectory);
  const double span_s = 1e-9 * static_cast<double>(trajectory_.back().time_ns - trajectory_.front().time_ns);
  num_frames_ = static_cast<std::size_t>(std::floor(span_s * config.rate_hz + 1e-9)) + 1;
  body_T_camera_ = Eigen::Isometry3d::Identity();
  body_T_camera_.linear() = Eigen::AngleAxisd(config.pitch_rad, Eigen::Vector3d::UnitY()).toRotationMatrix() * body_R_optical();
  next_ = 0;
  counters_ = {};
  return true;
}

bool SimCamera::camera_pose(std::uint64_t sequence, Eigen::Isometry3d* world_T_camera, std::int64_t* time_ns) const {
  if (sequence >= num_frames_) return false;
  const std::int64_t t = trajectory_.front().time_ns +
                         static_cast<std::int64_t>(std::llround(static_cast<double>(sequence) * 1e9 / config_.rate_hz));
  replay::StampedPose pose;
  if (!replay::interpolate_pose(trajectory_, std::min(t, trajectory_.back().time_ns), INT64_MAX, &pose)) return false;
  *world_T_camera = pose.world_T_body() * body_T_camera_;
  if (time_ns != nullptr) *time_ns = t;
  return true;
}

drivers::ReadStatus SimCamera::read(messages::RgbdFrame& frame, std::int64_t /*timeout_ns*/) {
  Eigen::Isometry3d world_T_camera;
  std::int64_t t = 0;
  if (!camera_pose(next_, &world_T_camera, &t)) return drivers::ReadStatus::kEndOfStream;
  frame.depth_scale_m = config_.depth_scale_m;
  if (!renderer_.render(world_T_camera, config_.intrinsics, next_, frame, &render_error_)) {
    ++counters_.bad_frames;
    ++next_;
    return drivers::ReadStatus::kBadFrame;
  }
  frame.sequence = next_;
  frame.sample_time_ns = t;
  frame.publish_time_ns = t + config_.latency_ns;
  frame.flags = 0;
  ++next_;
  ++counters_.delivered;
  return drivers::ReadStatus::kOk;
}

}  // namespace qsg::sim
