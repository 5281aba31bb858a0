// Shared set-up of the evaluation programs: a world explored by the simulated robot (the tour planned through
// every room, the camera along it), plus the small statistics every program prints.
#pragma once

#include <cmath>

#include <sys/resource.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "drivers/render/ray_scene.h"
#include "drivers/sim/exploration.h"
#include "drivers/sim/odometry_levels.h"
#include "drivers/sim/sim_camera.h"
#include "drivers/world/world.h"
#include "drivers/world/world_query.h"

namespace qsg::bench {

// A RealSense-like camera of the given size: 525 px focal length at 640 px width, principal point centred.
inline messages::CameraIntrinsics camera_of_size(int width, int height) {
  const double f = 525.0 * width / 640.0;
  return {width, height, f, f, (width - 1) / 2.0, (height - 1) / 2.0};
}

// A pinhole camera of the given size and horizontal field of view, principal point centred.
inline messages::CameraIntrinsics camera_of_fov(int width, int height, double hfov_deg) {
  const double f = 0.5 * width / std::tan(0.5 * hfov_deg * 3.14159265358979 / 180.0);
  return {width, height, f, f, (width - 1) / 2.0, (height - 1) / 2.0};
}

// Where the poses handed to the map come from: --odometry gt|sim|vio (sim::OdometryLevel) and --odometry-seed N.
// Scoring stays against the world's ground truth, so a map built from drifting poses scores worse.
struct OdometryOption {
  sim::OdometryLevel level = sim::OdometryLevel::kGroundTruth;
  std::uint64_t seed = 1;
  // The drift's seed for one world: the option's seed mixed with the world's, so buildings drift independently.
  std::uint64_t seed_for(std::uint64_t world_seed) const { return seed ^ (world_seed * 0x9E3779B97F4A7C15ull); }
  bool ground_truth() const { return level == sim::OdometryLevel::kGroundTruth; }
  // For a figure's conditions: "ground-truth poses" at gt (the wording the figures always had), else the level.
  std::string describe() const {
    if (ground_truth()) return "ground-truth poses";
    return std::string(sim::to_string(level)) + " odometry (seed " + std::to_string(seed) + ")";
  }
};
inline const char* odometry_usage() { return "[--odometry gt|sim|vio] [--odometry-seed N]"; }

// Reads --odometry / --odometry-seed at argv[*i] (advancing *i past the value). 1: read, 0: not an odometry flag,
// -1: bad value (a message on stderr).
inline int parse_odometry_flag(int argc, char** argv, int* i, OdometryOption* o) {
  const std::string a = argv[*i];
  if (a != "--odometry" && a != "--odometry-seed") return 0;
  if (*i + 1 >= argc) return std::fprintf(stderr, "option %s needs a value\n", a.c_str()), -1;
  const char* v = argv[++*i];
  if (a == "--odometry") {
    if (!sim::parse_odometry_level(v, &o->level))
      return std::fprintf(stderr, "--odometry: expected gt, sim or vio, got '%s'\n", v), -1;
    return 1;
  }
  char* end = nullptr;
  o->seed = std::strtoull(v, &end, 10);
  if (end == v || *end != '\0') return std::fprintf(stderr, "--odometry-seed: bad number '%s'\n", v), -1;
  return 1;
}

struct SimTour {
  sim::ExplorationResult tour;
  std::unique_ptr<sim::SimCamera> camera;
  sim::OdometryPoses odometry;  // ground truth unless set_odometry() chose a drifting level
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

// The odometry the tour's frames are posed with: the drifting odometry over the camera's ground-truth trajectory
// (its body poses; the optical frame keeps its true mount on the body), seeded per world.
inline void set_odometry(const OdometryOption& option, std::uint64_t world_seed, SimTour* tour) {
  tour->odometry = option.ground_truth()
                       ? sim::OdometryPoses()
                       : sim::OdometryPoses(tour->camera->trajectory(), option.level, option.seed_for(world_seed));
}

// Reads the camera to its end and calls fn(frame, world_T_camera, t_ns, true_world_T_camera) for every frame that
// reads and has a pose (frames that fail to read or have none are skipped): world_T_camera is the odometry's
// estimate at the frame's time, what the map is built from; true_world_T_camera the ground truth, for scoring.
// Returns the number of frames passed to fn.
template <typename Fn>
std::size_t for_each_posed_frame(sim::SimCamera& camera, const sim::OdometryPoses& odometry, messages::RgbdFrame& frame,
                                 Fn&& fn) {
  std::size_t frames = 0;
  for (;;) {
    const drivers::ReadStatus status = camera.read(frame, 0);
    if (status == drivers::ReadStatus::kEndOfStream) return frames;
    if (status != drivers::ReadStatus::kOk) continue;
    Eigen::Isometry3d true_world_T_camera, world_T_camera;
    std::int64_t t_ns = 0;
    if (!camera.camera_pose(frame.sequence, &true_world_T_camera, &t_ns)) continue;
    if (!odometry.estimate(t_ns, true_world_T_camera, &world_T_camera)) continue;
    fn(frame, world_T_camera, t_ns, true_world_T_camera);
    ++frames;
  }
}

// Tour convenience: the frames posed by the tour's odometry.
template <typename Fn>
std::size_t for_each_posed_frame(SimTour& tour, messages::RgbdFrame& frame, Fn&& fn) {
  return for_each_posed_frame(*tour.camera, tour.odometry, frame, std::forward<Fn>(fn));
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
