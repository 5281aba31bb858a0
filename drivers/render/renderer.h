// The simulated RGB-D camera's renderer: ray casts depth (along the optical axis), semantic labels and a textured,
// shaded colour image of a World into a caller-owned RgbdFrame, at any resolution up to 640x480, without
// allocating per frame, deterministically for a seed (optionally with a depth noise model).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <cstdio>
#include <string>

#include "drivers/render/depth_noise.h"
#include "drivers/render/ray_scene.h"
#include "core/messages/sensor_types.h"
#include "drivers/world/world.h"

namespace qsg::render {

struct RendererCounters {
  std::uint64_t frames = 0;
  std::uint64_t rejected_frames = 0;  // bad intrinsics or pose
  std::uint64_t rays = 0;
  std::uint64_t hits = 0;      // rays that met a surface within max range
  std::uint64_t too_near = 0;  // hits closer than min range (depth 0, colour and label kept)
  std::uint64_t dropouts = 0;  // valid hits the noise model dropped
  void print(std::FILE* out) const;
};

class Renderer {
 public:
  struct Config {
    double min_range_m = 0.1;   // nearer surfaces give depth 0 (they still block what is behind them)
    double max_range_m = 10.0;  // nothing is seen beyond (depth 0, label kVoid, black)
    std::uint64_t seed = 0;     // only the noise model is random
    DepthNoiseConfig noise;
    // Empty when usable, else the first bad field and why.
    std::string check() const;
    void print(std::FILE* out) const;
  };

  // Validates the config and compiles the world (the world may be destroyed afterwards).
  bool init(const Config& config, const world::World& world, std::string* error);

  // Renders the view of a camera at world_T_camera (optical frame: x right, y down, z forward). Writes the
  // frame's intrinsics, sequence, has_labels = true and the first width x height pixels of depth_m (z-depth,
  // 0 = no return), rgb and labels (kVoid where nothing is seen); leaves times, flags and depth_scale_m (read for
  // quantisation) to the caller. Returns false with a reason, and leaves the frame untouched, for bad
  // intrinsics (size above 640x480, non-positive or non-finite focal length, non-finite centre), a non-finite or
  // non-rigid pose, or an uninitialised renderer.
  bool render(const Eigen::Isometry3d& world_T_camera, const messages::CameraIntrinsics& intrinsics,
              std::uint64_t sequence, messages::RgbdFrame& frame, std::string* error);

  const Config& config() const { return config_; }
  const RayScene& scene() const { return scene_; }
  const RendererCounters& counters() const { return counters_; }

 private:
  Config config_;
  RayScene scene_;
  DepthNoise noise_;
  RendererCounters counters_;
  bool ready_ = false;
};

// Empty when the intrinsics are usable for rendering, else the first bad field and why.
std::string check_intrinsics(const messages::CameraIntrinsics& intrinsics);

}  // namespace qsg::render
