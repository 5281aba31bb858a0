// Frozen input for the Layer 1 benchmarks: frames rendered once by the simulated camera along the exploration
// tour of a small generated building (6 rooms, seed 4, 10 Hz), so every reconstruction benchmark and its peers
// integrate the same frames.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "bench/sim_tour.h"
#include "drivers/world/building_generator.h"

namespace qsg::bench {

struct FrozenFrames {
  messages::CameraIntrinsics intrinsics;
  std::vector<std::unique_ptr<messages::RgbdFrame>> frames;
  std::vector<Eigen::Isometry3d> poses;  // world_T_camera (optical frame)
};

// The first `count` frames at width x height (fx = 525 scaled from 640 px); empty when the world or tour fails.
inline std::unique_ptr<FrozenFrames> render_frozen_frames(int width, int height, std::size_t count = 60) {
  auto out = std::make_unique<FrozenFrames>();
  world::BuildingConfig bc;
  bc.num_rooms = 6;
  bc.seed = 4;
  const world::World w = world::generate_building(bc);
  sim::SimCamera::Config config;
  config.intrinsics = camera_of_size(width, height);
  config.rate_hz = 10.0;
  SimTour sim_tour;
  std::string error;
  if (!make_sim_tour(w, sim::ExplorationConfig{}, config, render::Renderer::Config{}, &sim_tour, &error)) return out;
  sim::SimCamera& camera = *sim_tour.camera;
  out->intrinsics = config.intrinsics;
  while (out->frames.size() < count) {
    auto frame = std::make_unique<messages::RgbdFrame>();
    const drivers::ReadStatus status = camera.read(*frame, 0);
    if (status == drivers::ReadStatus::kEndOfStream) break;
    if (status != drivers::ReadStatus::kOk) continue;
    Eigen::Isometry3d pose;
    camera.camera_pose(frame->sequence, &pose, nullptr);
    out->poses.push_back(pose);
    out->frames.push_back(std::move(frame));
  }
  return out;
}

}  // namespace qsg::bench
