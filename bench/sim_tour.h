// Shared set-up of the evaluation programs: a world explored by the simulated robot (the tour planned through
// every room, the camera along it), plus the small statistics every program prints.
#pragma once

#include <cmath>

#include <sys/resource.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "drivers/render/ray_scene.h"
#include "drivers/sim/exploration.h"
#include "drivers/sim/sim_camera.h"
#include "drivers/world/world.h"
#include "drivers/world/world_query.h"

namespace qsg::bench {

// A RealSense-like camera of the given size: 525 px focal length at 640 px width, principal point centred.
inline drivers::CameraIntrinsics camera_of_size(int width, int height) {
  const double f = 525.0 * width / 640.0;
  return {width, height, f, f, (width - 1) / 2.0, (height - 1) / 2.0};
}

// A pinhole camera of the given size and horizontal field of view, principal point centred.
inline drivers::CameraIntrinsics camera_of_fov(int width, int height, double hfov_deg) {
  const double f = 0.5 * width / std::tan(0.5 * hfov_deg * 3.14159265358979 / 180.0);
  return {width, height, f, f, (width - 1) / 2.0, (height - 1) / 2.0};
}

struct SimTour {
  sim::ExplorationResult tour;
  std::unique_ptr<sim::SimCamera> camera;
};

// Plans the exploration of `world` and sets up the camera along it. False with a reason when either fails.
inline bool make_sim_tour(const world::World& world, const sim::ExplorationConfig& exploration,
                          const sim::SimCamera::Config& camera_config, const render::Renderer::Config& render_config,
                          SimTour* out, std::string* error) {
  render::RayScene scene;
  if (!scene.build(world, error)) return *error = "ray scene: " + *error, false;
  const world::FreeSpaceIndex free_space(world);
  out->tour = sim::plan_exploration(world, scene, free_space, exploration);
  if (!out->tour.ok) return *error = "exploration: " + out->tour.error, false;
  out->camera = std::make_unique<sim::SimCamera>();
  if (!out->camera->init(camera_config, render_config, world, out->tour.trajectory, error))
    return *error = "sim camera: " + *error, false;
  return true;
}

// Reads the camera to its end and calls fn(frame, world_T_camera, t_ns) for every frame that reads and has a
// pose (frames that fail to read or have none are skipped). Returns the number of frames passed to fn.
template <typename Fn>
std::size_t for_each_posed_frame(sim::SimCamera& camera, drivers::RgbdFrame& frame, Fn&& fn) {
  std::size_t frames = 0;
  for (;;) {
    const drivers::ReadStatus status = camera.read(frame, 0);
    if (status == drivers::ReadStatus::kEndOfStream) return frames;
    if (status != drivers::ReadStatus::kOk) continue;
    Eigen::Isometry3d world_T_camera;
    std::int64_t t_ns = 0;
    if (!camera.camera_pose(frame.sequence, &world_T_camera, &t_ns)) continue;
    fn(frame, world_T_camera, t_ns);
    ++frames;
  }
}

// The value below which a fraction q of the samples lie (nearest rank).
inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

inline double peak_rss_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

}  // namespace qsg::bench
