// Messages between the sensors and the core: RGB-D frames in fixed buffers, the camera's intrinsics and odometry
// samples, each with a sample time (when the sensor measured) and a publish time (when the driver handed it over), as
// PX4 messages carry. The drivers publish them; core/ consumes them without knowing any driver.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>

namespace qsg::messages {

inline constexpr int kMaxFrameWidth = 640;
inline constexpr int kMaxFrameHeight = 480;
inline constexpr int kMaxFramePixels = kMaxFrameWidth * kMaxFrameHeight;

struct CameraIntrinsics {
  int width = 640;
  int height = 480;
  double fx = 525.0;
  double fy = 525.0;
  double cx = 319.5;
  double cy = 239.5;
  bool valid() const {
    return width > 0 && height > 0 && width <= kMaxFrameWidth && height <= kMaxFrameHeight && fx != 0.0 && fy != 0.0;
  }
};

// Why a frame is not pristine. A consumer may still use a flagged frame (e.g. skip its invalid pixels).
enum FrameFlag : std::uint32_t {
  kFrameLate = 1u << 0,                 // publish_time - sample_time above the source's latency bound
  kFrameTimestampBackwards = 1u << 1,   // sample time not after the previous frame's
  kFrameInvalidDepthRegion = 1u << 2,   // NaN, zero or saturated depth over a region
  kFrameSequenceGap = 1u << 3,          // frames were dropped before this one
  kFrameAfterReconnect = 1u << 4,       // first frame after the device came back
};

// One aligned depth + colour (+ optional labels) frame. Large (about 2.8 MB): preallocate and reuse,
// never put one on the stack. Pixels are row-major, width x height of `intrinsics`.
struct RgbdFrame {
  std::uint64_t sequence = 0;
  std::int64_t sample_time_ns = 0;
  std::int64_t publish_time_ns = 0;
  CameraIntrinsics intrinsics;
  float depth_scale_m = 0.001f;   // metres per raw unit of the device (1/5000 for TUM, 0.001 for RealSense Z16)
  std::uint32_t flags = 0;        // FrameFlag bits
  bool has_labels = false;
  std::array<float, kMaxFramePixels> depth_m;          // metres along the optical axis; 0 or NaN = no return
  std::array<std::uint8_t, kMaxFramePixels * 3> rgb;   // 8-bit RGB
  std::array<std::uint16_t, kMaxFramePixels> labels;   // semantic labels (core/semantics), valid if has_labels

  int width() const { return intrinsics.width; }
  int height() const { return intrinsics.height; }
  int pixels() const { return intrinsics.width * intrinsics.height; }
};

struct OdometrySample {
  std::uint64_t sequence = 0;
  std::int64_t sample_time_ns = 0;
  std::int64_t publish_time_ns = 0;
  Eigen::Vector3d world_t_body_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond world_R_body = Eigen::Quaterniond::Identity();
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity() * 1e-4;  // [t (m), r (rad)]
  std::uint32_t flags = 0;  // FrameFlag bits that apply (late, backwards, gap, after reconnect)
};

}  // namespace qsg::messages
