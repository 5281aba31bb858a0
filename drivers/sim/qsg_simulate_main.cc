// qsg_simulate: generates or imports a world, plans the robot's exploration, renders it to disk as a TUM RGB-D
// dataset (with labels and drifting odometry), writes the ground truth and a top-down picture of the world.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

#include "drivers/replay/tum_replay.h"
#include "drivers/sim/drifting_odometry.h"
#include "drivers/sim/odometry_levels.h"
#include "drivers/sim/exploration.h"
#include "drivers/sim/ground_truth.h"
#include "drivers/sim/sim_camera.h"
#include "drivers/world/building_generator.h"
#include "drivers/world/floor_plan_import.h"
#include "drivers/world/top_down.h"
#include "drivers/world/world_file.h"

namespace {

using namespace qsg;

struct Options {
  enum class Source { kBuilding, kFloorPlan, kWorldFile } source = Source::kBuilding;
  world::BuildingConfig building;
  std::string floor_plan, floor_plan_gt, world_file;
  std::string out = "sim_out";
  int width = 320, height = 240;
  double fps = 10.0;
  sim::ExplorationConfig exploration;
  bool noise = false;
  bool render = true;
  long max_frames = -1;
  bool ground_truth = true;
  double gt_voxel_m = 0.1;
  // The evaluations' --odometry sim level is this default (sim::kSimDrift).
  double drift_m = sim::kSimDrift.translation_sigma_m_per_sqrt_m;
  double drift_yaw_rad = sim::kSimDrift.yaw_sigma_rad_per_sqrt_m;
};

void usage() {
  std::printf(
      "usage: qsg_simulate [world] [options]\n"
      "world (one of):\n"
      "  --building            a generated building (default); --rooms N (12), --two-floors, --seed S (1)\n"
      "  --floorplan PNG       an occupancy floor plan at 0.05 m/px; --gt PNG its room ground truth\n"
      "                        (default: <map>_gt_segmentation.png beside it)\n"
      "  --world FILE.json     a world file (drivers/world/WORLD_FORMAT.md)\n"
      "options:\n"
      "  --out DIR             output folder (default sim_out)\n"
      "  --size W H            image size, at most 640 480 (default 320 240)\n"
      "  --fps F               frames per second (default 10)\n"
      "  --speed M_S           robot speed, 0.5-1 m/s (default 0.7)\n"
      "  --camera-height M     0.5 quadruped (default), 1.2 hand-held\n"
      "  --noise               structured-light depth noise\n"
      "  --max-frames N        stop rendering after N frames\n"
      "  --no-render           world, trajectory and ground truth only\n"
      "  --gt-voxel M          ground-truth voxel size (default 0.1); --no-gt to skip the ground truth\n"
      "  --drift M RAD         odometry random walk per sqrt(metre) (default 0.02 0.003)\n");
}

bool parse(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&](int k) -> const char* {
      if (i + k >= argc) {
        std::fprintf(stderr, "qsg_simulate: %s needs %d value(s)\n", a.c_str(), k);
        std::exit(2);
      }
      return argv[i + k];
    };
    const auto number = [&](int k) {
      char* end = nullptr;
      const double v = std::strtod(value(k), &end);
      if (end == nullptr || *end != '\0') {
        std::fprintf(stderr, "qsg_simulate: %s: '%s' is not a number\n", a.c_str(), value(k));
        std::exit(2);
      }
      return v;
    };
    if (a == "--building") o.source = Options::Source::kBuilding;
    else if (a == "--rooms") o.building.num_rooms = static_cast<int>(number(1)), ++i;
    else if (a == "--two-floors") o.building.two_floors = true;
    else if (a == "--seed") o.building.seed = static_cast<std::uint64_t>(number(1)), ++i;
    else if (a == "--floorplan") o.source = Options::Source::kFloorPlan, o.floor_plan = value(1), ++i;
    else if (a == "--gt") o.floor_plan_gt = value(1), ++i;
    else if (a == "--world") o.source = Options::Source::kWorldFile, o.world_file = value(1), ++i;
    else if (a == "--out") o.out = value(1), ++i;
    else if (a == "--size") o.width = static_cast<int>(number(1)), o.height = static_cast<int>(number(2)), i += 2;
    else if (a == "--fps") o.fps = number(1), ++i;
    else if (a == "--speed") o.exploration.speed_m_s = number(1), ++i;
    else if (a == "--camera-height") o.exploration.camera_height_m = number(1), ++i;
    else if (a == "--noise") o.noise = true;
    else if (a == "--max-frames") o.max_frames = static_cast<long>(number(1)), ++i;
    else if (a == "--no-render") o.render = false;
    else if (a == "--gt-voxel") o.gt_voxel_m = number(1), ++i;
    else if (a == "--no-gt") o.ground_truth = false;
    else if (a == "--drift") o.drift_m = number(1), o.drift_yaw_rad = number(2), i += 2;
    else if (a == "--help" || a == "-h") usage(), std::exit(0);
    else {
      std::fprintf(stderr, "qsg_simulate: unknown argument '%s'\n", a.c_str());
      usage();
      return false;
    }
  }
  return true;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

int fail(const std::string& message) {
  std::fprintf(stderr, "qsg_simulate: %s\n", message.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, o)) return 2;
  std::error_code ec;
  std::filesystem::create_directories(o.out + "/ground_truth", ec);
  if (ec) return fail("cannot create '" + o.out + "': " + ec.message());

  // 1. The world.
  auto t0 = std::chrono::steady_clock::now();
  world::World w;
  switch (o.source) {
    case Options::Source::kBuilding:
      o.building.print(stdout);
      w = world::generate_building(o.building);
      break;
    case Options::Source::kFloorPlan: {
      const std::string gt = o.floor_plan_gt.empty() ? world::floor_plan_gt_path(o.floor_plan) : o.floor_plan_gt;
      world::FloorPlanStats stats;
      world::WorldResult r = world::import_floor_plan_files(o.floor_plan, gt, world::FloorPlanConfig{}, &stats);
      if (!r.ok) return fail(r.error);
      w = std::move(r.world);
      std::printf("floor plan %s: %d wall boxes, %d rooms, %d doors\n", o.floor_plan.c_str(), stats.wall_boxes, stats.rooms,
                  stats.doors);
      break;
    }
    case Options::Source::kWorldFile: {
      world::WorldResult r = world::read_world_file(o.world_file);
      if (!r.ok) return fail(r.error);
      w = std::move(r.world);
      break;
    }
  }
  std::string error;
  if (!world::write_world_file(w, o.out + "/world.json", &error)) return fail(error);
  std::printf("world '%s': %zu shapes, %zu rooms, %zu doors, %zu objects (%.2f s)\n", w.name.c_str(), w.shapes.size(),
              w.rooms.size(), w.doors.size(), w.objects.size(), seconds_since(t0));

  // 2. The exploration tour.
  t0 = std::chrono::steady_clock::now();
  render::RayScene scene;
  if (!scene.build(w, &error)) return fail(error);
  const world::FreeSpaceIndex free_space(w);
  o.exploration.print(stdout);
  const sim::ExplorationResult tour = sim::plan_exploration(w, scene, free_space, o.exploration);
  if (!tour.ok) return fail(tour.error);
  std::printf("tour: %zu rooms visited, %zu unreachable (%zu looked into), %.1f m in %.1f s, %zu poses "
              "(%.2f s to plan)\n",
              tour.room_order.size(), tour.unreachable_rooms.size(), tour.peeked_rooms.size(), tour.length_m,
              tour.duration_s, tour.trajectory.size(), seconds_since(t0));

  // 3. Ground truth and the picture.
  if (o.ground_truth) {
    t0 = std::chrono::steady_clock::now();
    sim::GroundTruthConfig gc;
    gc.voxel_size_m = o.gt_voxel_m;
    sim::GroundTruth truth;
    if (!sim::compute_ground_truth(w, free_space, gc, &truth, &error)) return fail(error);
    if (!sim::write_ground_truth(o.out + "/ground_truth", w, truth, tour.trajectory, &error)) return fail(error);
    std::printf("ground truth: %d x %d x %d voxels, %zu skeleton voxels (%.2f s)\n", truth.dims.x(), truth.dims.y(),
                truth.dims.z(), truth.gvd.size(), seconds_since(t0));
  }
  {
    world::TopDownStyle style;
    world::TopDownFrame frame;
    cv::Mat image = world::draw_top_down(w, style, &frame);
    std::vector<Eigen::Vector3d> path;
    for (const replay::StampedPose& p : tour.trajectory) path.push_back(p.world_t_body_m);
    world::draw_polyline(image, path, frame, cv::Scalar(30, 30, 220), 2);
    if (!world::write_png(image, o.out + "/world.png", &error)) return fail(error);
  }

  // 4. Drifting odometry beside the ground truth.
  {
    sim::DriftingOdometry::Config dc;
    dc.translation_sigma_m_per_sqrt_m = o.drift_m;
    dc.yaw_sigma_rad_per_sqrt_m = o.drift_yaw_rad;
    dc.seed = o.building.seed;
    const replay::Trajectory drifted = sim::drifted_trajectory(tour.trajectory, dc);
    if (!replay::write_tum_trajectory(o.out + "/odometry.txt", drifted, &error)) return fail(error);
  }

  // 5. Frames.
  if (o.render) {
    t0 = std::chrono::steady_clock::now();
    sim::SimCamera camera;
    sim::SimCamera::Config cc;
    const double scale = o.width / 640.0;
    cc.intrinsics = {o.width, o.height, 525.0 * scale, 525.0 * scale, 0.5 * o.width - 0.5, 0.5 * o.height - 0.5};
    cc.rate_hz = o.fps;
    cc.depth_scale_m = 1.0f / 5000.0f;
    render::Renderer::Config rc;
    rc.noise.enabled = o.noise;
    rc.seed = o.building.seed;
    if (!camera.init(cc, rc, w, tour.trajectory, &error)) return fail(error);
    cc.print(stdout);
    // odometry.json: qsg_app's odometry section that replays this folder from its own drifting estimate
    // (odometry.txt is the body's path; the frames are the camera's, mounted as body_T_camera).
    {
      const Eigen::Isometry3d& m = camera.body_T_camera();
      const Eigen::Quaterniond q(m.linear());
      std::FILE* f = std::fopen((o.out + "/odometry.json").c_str(), "w");
      if (f == nullptr) return fail(o.out + "/odometry.json: cannot create");
      std::fprintf(f,
                   "// qsg_app --driver replay --replay %s --config %s/odometry.json: map from the drifting estimate\n"
                   "{ \"odometry\": { \"source\": \"tum\", \"tum_path\": \"%s/odometry.txt\",\n"
                   "                \"body_t_camera_m\": [%.9g, %.9g, %.9g],\n"
                   "                \"body_q_camera_xyzw\": [%.17g, %.17g, %.17g, %.17g] } }\n",
                   o.out.c_str(), o.out.c_str(), o.out.c_str(), m.translation().x(), m.translation().y(),
                   m.translation().z(), q.x(), q.y(), q.z(), q.w());
      if (std::fclose(f) != 0) return fail(o.out + "/odometry.json: write failed");
    }
    replay::TumWriter writer;
    if (!writer.open(o.out, replay::TumWriter::Config{}, &error)) return fail(error);
    auto frame = std::make_unique<messages::RgbdFrame>();
    long frames = 0;
    double render_s = 0.0;
    while (o.max_frames < 0 || frames < o.max_frames) {
      const auto r0 = std::chrono::steady_clock::now();
      const drivers::ReadStatus status = camera.read(*frame, 0);
      render_s += seconds_since(r0);
      if (status == drivers::ReadStatus::kEndOfStream) break;
      if (status != drivers::ReadStatus::kOk) continue;
      Eigen::Isometry3d world_T_camera;
      camera.camera_pose(frame->sequence, &world_T_camera, nullptr);
      if (!writer.write_frame(*frame, &error) ||
          !writer.write_pose(replay::StampedPose::from_isometry(frame->sample_time_ns, world_T_camera), &error))
        return fail(error);
      if (++frames % 100 == 0) std::printf("  %ld / %zu frames\r", frames, camera.num_frames()), std::fflush(stdout);
    }
    if (!writer.close(&error)) return fail(error);
    std::printf("rendered %ld frames at %dx%d: %.1f frames/s rendering, %.1f s in all\n", frames, o.width, o.height,
                render_s > 0 ? frames / render_s : 0.0, seconds_since(t0));
  }
  // calibration.json (the rendering camera and depth scale, from TumWriter) lets qsg_app replay this folder at any
  // --size with the right camera.
  std::printf("wrote %s/{world.json, world.png, rgb.txt, depth.txt, calibration.json, groundtruth.txt (optical "
              "frame), odometry.txt (body frame, drifting), odometry.json (qsg_app's odometry section for it), "
              "ground_truth/}\n",
              o.out.c_str());
  return 0;
}
