// Semantic TSDF integration + mesh update per frame (one thread), on frames rendered once from a generated
// building along its exploration tour; reports ms/frame and the active window's bytes (TSDF + semantics).
#include <benchmark/benchmark.h>

#include <memory>
#include <string>
#include <vector>

#include "core/reconstruction/semantic_tsdf.h"
#include "drivers/render/renderer.h"
#include "drivers/sim/exploration.h"
#include "drivers/world/building_generator.h"
#include "drivers/world/world_query.h"

namespace {

using namespace qsg;

struct Frames {
  std::vector<std::unique_ptr<drivers::RgbdFrame>> frames;
  std::vector<Eigen::Isometry3d> poses;
};

// Frozen frames: rendered once per resolution, the first `count` poses of the tour every 3rd sample (10 Hz).
const Frames& frames(int width, int height) {
  static std::unique_ptr<Frames> cache[2];
  const int slot = width == 640 ? 0 : 1;
  if (cache[slot]) return *cache[slot];
  cache[slot] = std::make_unique<Frames>();
  world::BuildingConfig bc;
  bc.num_rooms = 6;
  bc.seed = 4;
  const world::World w = world::generate_building(bc);
  render::RayScene scene;
  std::string error;
  scene.build(w, &error);
  world::FreeSpaceIndex free_space(w);
  const sim::ExplorationResult tour = sim::plan_exploration(w, scene, free_space, sim::ExplorationConfig{});
  render::Renderer renderer;
  if (!tour.ok || !renderer.init(render::Renderer::Config{}, w, &error)) return *cache[slot];
  const double f = 525.0 * width / 640.0;
  const drivers::CameraIntrinsics in{width, height, f, f, (width - 1) / 2.0, (height - 1) / 2.0};
  for (std::size_t k = 0; k < tour.trajectory.size() && cache[slot]->frames.size() < 60; k += 3) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = tour.trajectory[k].world_R_body.toRotationMatrix() * sim::body_R_optical();
    T.translation() = tour.trajectory[k].world_t_body_m;
    auto frame = std::make_unique<drivers::RgbdFrame>();
    if (!renderer.render(T, in, k, *frame, &error)) continue;
    cache[slot]->frames.push_back(std::move(frame));
    cache[slot]->poses.push_back(T);
  }
  return *cache[slot];
}

void BM_IntegrateAndMesh(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const double voxel = static_cast<double>(state.range(1)) / 100.0;
  const Frames& data = frames(width, width * 3 / 4);
  if (data.frames.empty()) {
    state.SkipWithError("no frames rendered");
    return;
  }
  reconstruction::Config config;
  config.voxel_size_m = voxel;
  reconstruction::Capacities caps = reconstruction::capacities_from_budget();
  if (voxel < 0.1) caps.max_blocks *= 4;  // a finer grid needs more blocks for the same window
  reconstruction::SemanticTsdf tsdf;
  std::string error;
  if (!tsdf.init(config, caps, reconstruction::SemanticTsdf::plan(caps).total_bytes(), &error)) {
    state.SkipWithError(error.c_str());
    return;
  }
  std::size_t k = 0;
  for (auto _ : state) {
    tsdf.process(*data.frames[k], data.poses[k]);
    k = (k + 1) % data.frames.size();
  }
  // The Time column is the per-frame time (integration + mesh update + window), in ms.
  state.counters["window_bytes"] = static_cast<double>(tsdf.window_bytes());
  state.counters["active_blocks"] = static_cast<double>(tsdf.active_blocks());
  state.counters["blocks_evicted"] = static_cast<double>(tsdf.counters().blocks_evicted);
}
BENCHMARK(BM_IntegrateAndMesh)
    ->ArgNames({"width", "voxel_cm"})
    ->Args({640, 10})
    ->Args({320, 10})
    ->Args({640, 5})
    ->Args({320, 5})
    ->Unit(benchmark::kMillisecond);

}  // namespace
