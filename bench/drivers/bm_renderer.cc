// BM_render_*: the simulated RGB-D camera's ray casting on one core, in a self-contained 20-room building, along
// a fixed path at 0.5 m camera height; reports frames/s and the worst frame time (the camera's real-time budget).
// When drivers/world's generator is built, BM_render_generated_building also renders its 20-room building.
#include <benchmark/benchmark.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "drivers/render/renderer.h"
#ifdef QSG_BENCH_RENDER_WITH_GENERATOR
#include "drivers/world/building_generator.h"
#endif

namespace {

using qsg::world::Material;
using qsg::world::Texture;
namespace sem = qsg::semantics;

constexpr int kRoomsX = 5;
constexpr int kRoomsY = 4;
constexpr double kRoomXM = 5.0;
constexpr double kRoomYM = 4.0;
constexpr double kWallHeightM = 2.6;
constexpr double kWallHalfThicknessM = 0.06;
constexpr double kDoorWidthM = 1.0;
constexpr double kDoorHeightM = 2.1;
constexpr double kCameraHeightM = 0.5;

// Small deterministic generator so the building is identical on every machine.
struct Lcg {
  std::uint64_t state;
  double uniform(double lo, double hi) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return lo + (hi - lo) * static_cast<double>(state >> 11) * (1.0 / 9007199254740992.0);
  }
};

Material material(sem::Label label, std::uint8_t r, std::uint8_t g, std::uint8_t b, Texture texture, float scale_m) {
  Material m;
  m.label = label;
  m.color = {{r, g, b}};
  m.texture = texture;
  m.texture_scale_m = scale_m;
  return m;
}

void add_aabb(qsg::world::World& w, double x0, double y0, double z0, double x1, double y1, double z1, const Material& m,
              int room = -1) {
  qsg::world::BoxShape box;
  box.center_m = Eigen::Vector3d(0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * (z0 + z1));
  box.half_extents_m = Eigen::Vector3d(0.5 * (x1 - x0), 0.5 * (y1 - y0), 0.5 * (z1 - z0));
  w.add_box(box, m, -1, room);
}

// A wall along x (horizontal = true) or y from a to b at coordinate c, with an optional centred door.
void add_wall(qsg::world::World& w, bool along_x, double c, double a, double b, bool door, bool as_prism,
              const Material& m) {
  auto piece = [&](double s0, double s1, double z0, double z1) {
    if (s1 - s0 < 1e-6) return;
    const double x0 = along_x ? s0 : c - kWallHalfThicknessM, x1 = along_x ? s1 : c + kWallHalfThicknessM;
    const double y0 = along_x ? c - kWallHalfThicknessM : s0, y1 = along_x ? c + kWallHalfThicknessM : s1;
    if (as_prism) {
      qsg::world::PrismShape p;
      p.polygon_m = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
      p.z_min_m = z0;
      p.z_max_m = z1;
      w.add_prism(p, m);
    } else {
      add_aabb(w, x0, y0, z0, x1, y1, z1, m);
    }
  };
  if (!door) {
    piece(a, b, 0.0, kWallHeightM);
    return;
  }
  const double mid = 0.5 * (a + b);
  piece(a, mid - 0.5 * kDoorWidthM, 0.0, kWallHeightM);
  piece(mid + 0.5 * kDoorWidthM, b, 0.0, kWallHeightM);
  piece(mid - 0.5 * kDoorWidthM, mid + 0.5 * kDoorWidthM, kDoorHeightM, kWallHeightM);  // lintel
}

// 5 x 4 rooms of 5 m x 4 m joined by doors in a serpentine, floor and ceiling slabs, 3-5 pieces of furniture in
// the corners of each room (boxes, some rotated, cylinders, L-shaped counters), clear of the path.
qsg::world::World make_building() {
  qsg::world::World w;
  w.name = "bench_building_20_rooms";
  const double size_x = kRoomsX * kRoomXM, size_y = kRoomsY * kRoomYM;
  add_aabb(w, -0.5, -0.5, -0.1, size_x + 0.5, size_y + 0.5, 0.0,
           material(sem::kFloor, 170, 150, 120, Texture::kChecker, 0.6f));
  add_aabb(w, -0.5, -0.5, kWallHeightM, size_x + 0.5, size_y + 0.5, kWallHeightM + 0.1,
           material(sem::kCeiling, 230, 230, 225, Texture::kNoise, 1.5f));
  const Material outer = material(sem::kWall, 200, 190, 170, Texture::kStripes, 0.4f);
  // Walls between columns (lines x = const): doors in every interior wall, so each row is a corridor of rooms.
  for (int i = 0; i <= kRoomsX; ++i) {
    for (int j = 0; j < kRoomsY; ++j) {
      const bool exterior = i == 0 || i == kRoomsX;
      const Material m = exterior ? outer
                                  : material(sem::kWall, static_cast<std::uint8_t>(140 + 20 * j),
                                             static_cast<std::uint8_t>(160 + 15 * i), 150, Texture::kNoise, 0.8f);
      add_wall(w, false, i * kRoomXM, j * kRoomYM, (j + 1) * kRoomYM, !exterior, exterior, m);
    }
  }
  // Walls between rows (lines y = const): doors at alternate ends make the serpentine.
  for (int j = 0; j <= kRoomsY; ++j) {
    for (int i = 0; i < kRoomsX; ++i) {
      const bool exterior = j == 0 || j == kRoomsY;
      const bool door = !exterior && ((j % 2 == 1 && i == kRoomsX - 1) || (j % 2 == 0 && i == 0) || i == 2);
      const Material m = exterior ? outer
                                  : material(sem::kWall, 150, static_cast<std::uint8_t>(140 + 20 * j),
                                             static_cast<std::uint8_t>(130 + 20 * i), Texture::kNoise, 0.8f);
      add_wall(w, true, j * kRoomYM, i * kRoomXM, (i + 1) * kRoomXM, door, exterior, m);
    }
  }
  // Furniture.
  Lcg rng{12345};
  for (int j = 0; j < kRoomsY; ++j) {
    for (int i = 0; i < kRoomsX; ++i) {
      const int room = j * kRoomsX + i;
      const double x0 = i * kRoomXM, y0 = j * kRoomYM;
      const int items = 3 + static_cast<int>(rng.uniform(0.0, 2.999));
      for (int k = 0; k < items; ++k) {
        // Corner k (the 5th item is a picture on the south wall).
        if (k == 4) {
          add_aabb(w, x0 + 3.2, y0 + kWallHalfThicknessM, 1.2, x0 + 4.2, y0 + kWallHalfThicknessM + 0.03, 1.8,
                   material(sem::kPicture, 60, 90, 160, Texture::kNoise, 0.2f), room);
          continue;
        }
        const double cx = (k & 1) ? x0 + kRoomXM - 1.0 : x0 + 1.0;
        const double cy = (k & 2) ? y0 + kRoomYM - 0.8 : y0 + 0.8;
        const int type = static_cast<int>(rng.uniform(0.0, 3.999));
        if (type == 0) {  // table, rotated
          qsg::world::BoxShape b;
          b.center_m = Eigen::Vector3d(cx, cy, 0.375);
          b.half_extents_m = Eigen::Vector3d(rng.uniform(0.35, 0.6), rng.uniform(0.3, 0.45), 0.375);
          b.world_R_box = Eigen::Quaterniond(Eigen::AngleAxisd(rng.uniform(-0.6, 0.6), Eigen::Vector3d::UnitZ()));
          w.add_box(b, material(sem::kTable, 150, 100, 60, Texture::kStripes, 0.1f), -1, room);
        } else if (type == 1) {  // cabinet, axis-aligned
          const double hx = rng.uniform(0.3, 0.5), hy = rng.uniform(0.2, 0.35);
          add_aabb(w, cx - hx, cy - hy, 0.0, cx + hx, cy + hy, rng.uniform(1.2, 2.0),
                   material(sem::kCabinet, 120, 120, 140, Texture::kChecker, 0.3f), room);
        } else if (type == 2) {  // plant pot / stool
          qsg::world::CylinderShape c;
          c.base_center_m = Eigen::Vector3d(cx, cy, 0.0);
          c.radius_m = rng.uniform(0.15, 0.35);
          c.height_m = rng.uniform(0.4, 1.1);
          w.add_cylinder(c, material(sem::kPlant, 60, 140, 70, Texture::kNoise, 0.15f), -1, room);
        } else {  // L-shaped counter (concave prism)
          const double s = 0.6, t = 0.3;
          qsg::world::PrismShape p;
          p.polygon_m = {{cx - s, cy - s},         {cx + s, cy - s},     {cx + s, cy - s + t},
                         {cx - s + t, cy - s + t}, {cx - s + t, cy + s}, {cx - s, cy + s}};
          p.z_min_m = 0.0;
          p.z_max_m = 0.9;
          w.add_prism(p, material(sem::kCounter, 200, 200, 210, Texture::kChecker, 0.2f), -1, room);
        }
      }
    }
  }
  return w;
}

// Camera poses along the serpentine through the room centres, heading along the path with a slow yaw sweep.
std::vector<Eigen::Isometry3d> make_path(int num_poses) {
  const std::vector<Eigen::Vector2d> waypoints = {{2.5, 2.0},  {22.5, 2.0},  {22.5, 6.0},  {2.5, 6.0},
                                                  {2.5, 10.0}, {22.5, 10.0}, {22.5, 14.0}, {2.5, 14.0}};
  double total = 0.0;
  for (std::size_t i = 1; i < waypoints.size(); ++i) total += (waypoints[i] - waypoints[i - 1]).norm();
  std::vector<Eigen::Isometry3d> poses;
  for (int p = 0; p < num_poses; ++p) {
    double s = total * p / num_poses;
    std::size_t seg = 1;
    while (seg + 1 < waypoints.size() && s > (waypoints[seg] - waypoints[seg - 1]).norm()) {
      s -= (waypoints[seg] - waypoints[seg - 1]).norm();
      ++seg;
    }
    const Eigen::Vector2d dir = (waypoints[seg] - waypoints[seg - 1]).normalized();
    const Eigen::Vector2d xy = waypoints[seg - 1] + s * dir;
    const double yaw = std::atan2(dir.y(), dir.x()) + 0.5 * std::sin(0.3 * p);
    const Eigen::Vector3d forward(std::cos(yaw), std::sin(yaw), 0.0);
    const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
    Eigen::Matrix3d R;
    R.col(0) = forward.cross(up);  // optical x: right
    R.col(1) = -up;                // optical y: down
    R.col(2) = forward;            // optical z: forward
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R;
    T.translation() = Eigen::Vector3d(xy.x(), xy.y(), kCameraHeightM);
    poses.push_back(T);
  }
  return poses;
}

qsg::messages::CameraIntrinsics intrinsics_for_width(int width) {
  qsg::messages::CameraIntrinsics k;
  const double scale = width / 640.0;
  k.width = width;
  k.height = width * 3 / 4;
  k.fx = k.fy = 525.0 * scale;
  k.cx = 0.5 * k.width - 0.5;
  k.cy = 0.5 * k.height - 0.5;
  return k;
}

// CPU time of this thread: the per-frame maximum is then not inflated by other processes on a shared machine.
double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

void run_render(benchmark::State& state, const qsg::world::World& world, const std::vector<Eigen::Isometry3d>& path,
                bool noise) {
  qsg::render::Renderer::Config config;
  config.noise.enabled = noise;
  config.seed = 7;
  qsg::render::Renderer renderer;
  std::string error;
  if (!renderer.init(config, world, &error)) {
    state.SkipWithError(error.c_str());
    return;
  }
  const qsg::messages::CameraIntrinsics k = intrinsics_for_width(static_cast<int>(state.range(0)));
  auto frame = std::make_unique<qsg::messages::RgbdFrame>();
  std::size_t next = 0;
  double max_frame_s = 0.0, max_frame_cpu_s = 0.0;
  std::uint64_t sequence = 0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    const double start_cpu = thread_cpu_s();
    if (!renderer.render(path[next], k, sequence++, *frame, &error)) {
      state.SkipWithError(error.c_str());
      break;
    }
    max_frame_cpu_s = std::max(max_frame_cpu_s, thread_cpu_s() - start_cpu);
    max_frame_s =
        std::max(max_frame_s, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    benchmark::DoNotOptimize(frame->depth_m[static_cast<std::size_t>(k.width * k.height / 2)]);
    next = (next + 1) % path.size();
  }
  const auto& c = renderer.counters();
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  // Rate counters divide by CPU time (one core); the maxima: thread CPU time and wall time of the worst frame.
  state.counters["max_frame_cpu_ms"] = 1e3 * max_frame_cpu_s;
  state.counters["max_frame_wall_ms"] = 1e3 * max_frame_s;
  state.counters["hit_fraction"] = c.rays > 0 ? static_cast<double>(c.hits) / static_cast<double>(c.rays) : 0.0;
  state.counters["primitives"] = static_cast<double>(renderer.scene().stats().num_primitives);
  state.counters["bvh_depth"] = renderer.scene().stats().bvh_depth;
  state.SetItemsProcessed(static_cast<std::int64_t>(c.rays));  // rays/s
}

void BM_render_building(benchmark::State& state) { run_render(state, make_building(), make_path(240), false); }
void BM_render_building_noise(benchmark::State& state) { run_render(state, make_building(), make_path(240), true); }

#ifdef QSG_BENCH_RENDER_WITH_GENERATOR
// Views from every doorway of the generated building, looking into both rooms and diagonally, at 0.5 m.
std::vector<Eigen::Isometry3d> doorway_path(const qsg::world::World& world) {
  std::vector<Eigen::Isometry3d> poses;
  for (const qsg::world::Door& door : world.doors) {
    const Eigen::Vector2d mid = 0.5 * (door.a_m + door.b_m);
    const Eigen::Vector2d along = (door.b_m - door.a_m).normalized();
    const double base_yaw = std::atan2(-along.x(), along.y());  // perpendicular to the door
    for (double yaw_offset : {0.0, 0.6, -0.6, 3.14159265358979, 3.74159265358979, 2.54159265358979}) {
      const double yaw = base_yaw + yaw_offset;
      const Eigen::Vector3d forward(std::cos(yaw), std::sin(yaw), 0.0);
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.linear().col(0) = forward.cross(Eigen::Vector3d::UnitZ());
      T.linear().col(1) = -Eigen::Vector3d::UnitZ();
      T.linear().col(2) = forward;
      T.translation() = Eigen::Vector3d(mid.x(), mid.y(), door.floor_z_m + kCameraHeightM);
      poses.push_back(T);
    }
  }
  return poses;
}

void BM_render_generated_building(benchmark::State& state) {
  qsg::world::BuildingConfig config;
  config.name = "bench_generated_20_rooms";
  config.seed = 3;
  config.num_rooms = 20;
  const qsg::world::World world = qsg::world::generate_building(config);
  const std::vector<Eigen::Isometry3d> path = doorway_path(world);
  if (path.empty()) {
    state.SkipWithError("generated building has no doors");
    return;
  }
  state.counters["rooms"] = static_cast<double>(world.rooms.size());
  state.counters["views"] = static_cast<double>(path.size());
  run_render(state, world, path, false);
}
BENCHMARK(BM_render_generated_building)
    ->Arg(320)
    ->Arg(640)
    ->ArgName("width")
    ->Unit(benchmark::kMillisecond)
    ->MinTime(4.0);
#endif

void BM_render_scene_build(benchmark::State& state) {
  const qsg::world::World world = make_building();
  std::string error;
  for (auto _ : state) {
    qsg::render::RayScene scene;
    if (!scene.build(world, &error)) {
      state.SkipWithError(error.c_str());
      break;
    }
    benchmark::DoNotOptimize(scene.stats().num_bvh_nodes);
  }
}

// Whole-path sweeps (240 poses) so the mean and max cover every room, not just the first view.
BENCHMARK(BM_render_building)->Arg(320)->Arg(640)->ArgName("width")->Unit(benchmark::kMillisecond)->MinTime(4.0);
BENCHMARK(BM_render_building_noise)->Arg(640)->ArgName("width")->Unit(benchmark::kMillisecond)->MinTime(4.0);
BENCHMARK(BM_render_scene_build)->Unit(benchmark::kMicrosecond);

}  // namespace
