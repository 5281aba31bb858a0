// Drift baseline: what odometry drift does to every layer, the figures loop closure must later recover. The same
// generated buildings (two floors by default) are explored by the simulated robot with each odometry level
// (--odometry's gt, sim and vio: drivers/sim/odometry_levels.h) and mapped through the app's stages in the
// evaluations' harness (bench/eval_harness.h: TSDF, the frontend every keyframe, then the final door stage and the
// room finder on the final graph, as in rooms_eval). The map is built in the odometry's frame, which starts at the
// true start; everything is scored against the world's ground truth in the world frame:
//   - ATE of the keyframe trajectory (camera positions): RMSE after SE(3) alignment and without alignment
//     (core/metrics/trajectory_error.h);
//   - objects found / correct (objects_eval's metric: bench/objects/object_match.h);
//   - the place nodes' mean distance to the true GVD (places_eval's: bench/places/place_score.h);
//   - rooms precision / recall (rooms_eval's on generated buildings: bench/rooms/room_score.h);
//   - mesh growth: the final mesh's surface area over the gt run's on the same building, and its off-surface
//     shares, the mesh vertices farther than 5 cm (and one voxel, 10 cm) from every true surface (in free space that
//     far from any solid, or inside a solid with every axis probe that far away inside too): a wall mapped twice at
//     two drifted offsets shows as more area and larger off-surface shares. The gt run gives the reconstruction's
//     own floor (a 0.1 m TSDF puts thin walls' vertices a few cm off).
// Every figure also goes to --json (bench/figures.h).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "bench/eval_harness.h"
#include "bench/figures.h"
#include "bench/objects/object_match.h"
#include "bench/places/place_score.h"
#include "bench/rooms/room_score.h"
#include "bench/sim_tour.h"
#include "budgets/budget_table.h"
#include "core/metrics/trajectory_error.h"
#include "core/scene_graph/scene_graph.h"
#include "drivers/sim/ground_truth.h"
#include "drivers/sim/odometry_levels.h"
#include "drivers/world/building_generator.h"
#include "drivers/world/world_query.h"

namespace {

using namespace qsg;
namespace sg = scene_graph;

constexpr double kOffSurfaceM = 0.05;
constexpr double kOffSurfaceVoxelM = 0.10;

// The default (5 buildings of rooms_eval's size, 3 levels) runs in about 5 minutes on one core.
struct Options {
  std::vector<std::uint64_t> seeds{1, 2, 3, 4, 5};
  int rooms = 12;  // rooms_eval's generated buildings
  bool two_floors = true;
  std::vector<sim::OdometryLevel> levels{sim::OdometryLevel::kGroundTruth, sim::OdometryLevel::kSim,
                                         sim::OdometryLevel::kVio};
  std::uint64_t odometry_seed = 1;
  int width = 320;
  int height = 240;
  double hfov_deg = 90.0;    // as places_eval and rooms_eval
  double rate_hz = 2.0;      // keyframes per second along the tour, as rooms_eval
  double max_reach_m = 3.0;  // rooms_eval's labelling reach
  std::string json_path;
};

void usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s [--seeds 1,2,3,4,5] [--rooms N] [--two-floors 0|1] [--levels gt,sim,vio] [--odometry-seed N] "
               "[--size WxH] [--hfov-deg D] [--rate-hz R] [--max-reach-m M] [--json FILE]\n"
               "  What odometry drift does to every layer, the baseline loop closure must recover. The same generated\n"
               "  buildings (default 5 two-floor buildings of 12 rooms) are mapped from each odometry level (gt, sim,\n"
               "  vio: drivers/sim/odometry_levels.h, vio about 1 %% of distance) through the TSDF, the frontend, the\n"
               "  final door stage and the room finder, and scored against the world's ground truth: ATE of the\n"
               "  keyframes (SE(3)-aligned and unaligned), objects found / correct, places' distance to the true GVD,\n"
               "  rooms P/R (the evaluations' own scoring headers) and mesh growth (area over the gt run's, share of\n"
               "  vertices more than 5 and 10 cm off every true surface). About 3.5 min on one core.\n"
               "  JSON: drift_baseline.<level>.*; results in bench/results/drift_baseline.md.\n",
               argv0);
}

bool parse(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h" || i + 1 >= argc) return false;
    const std::string v = argv[++i];
    char* end = nullptr;
    double* number = nullptr;
    if (a == "--seeds") {
      o->seeds.clear();
      std::stringstream ss(v);
      std::string item;
      while (std::getline(ss, item, ',')) {
        const std::uint64_t s = std::strtoull(item.c_str(), &end, 10);
        if (item.empty() || *end != '\0') return std::fprintf(stderr, "--seeds: bad seed '%s'\n", item.c_str()), false;
        o->seeds.push_back(s);
      }
    } else if (a == "--levels") {
      o->levels.clear();
      std::stringstream ss(v);
      std::string item;
      while (std::getline(ss, item, ',')) {
        sim::OdometryLevel l;
        if (!sim::parse_odometry_level(item, &l))
          return std::fprintf(stderr, "--levels: expected gt, sim or vio, got '%s'\n", item.c_str()), false;
        o->levels.push_back(l);
      }
    } else if (a == "--rooms") {
      o->rooms = std::atoi(v.c_str());
    } else if (a == "--two-floors") {
      o->two_floors = std::atoi(v.c_str()) != 0;
    } else if (a == "--odometry-seed") {
      o->odometry_seed = std::strtoull(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0') return std::fprintf(stderr, "--odometry-seed: bad '%s'\n", v.c_str()), false;
    } else if (a == "--size") {
      if (std::sscanf(v.c_str(), "%dx%d", &o->width, &o->height) != 2)
        return std::fprintf(stderr, "--size: expected WxH, got '%s'\n", v.c_str()), false;
    } else if (a == "--hfov-deg") {
      number = &o->hfov_deg;
    } else if (a == "--rate-hz") {
      number = &o->rate_hz;
    } else if (a == "--max-reach-m") {
      number = &o->max_reach_m;
    } else if (a == "--json") {
      o->json_path = v;
    } else {
      return std::fprintf(stderr, "unknown option %s\n", a.c_str()), false;
    }
    if (number != nullptr) {
      *number = std::strtod(v.c_str(), &end);
      if (v.empty() || *end != '\0') return std::fprintf(stderr, "%s: bad number '%s'\n", a.c_str(), v.c_str()), false;
    }
  }
  // gt first: the other levels' mesh area is reported over its.
  std::stable_sort(o->levels.begin(), o->levels.end(), [](sim::OdometryLevel x, sim::OdometryLevel y) {
    return x == sim::OdometryLevel::kGroundTruth && y != sim::OdometryLevel::kGroundTruth;
  });
  if (o->seeds.empty() || o->levels.empty() || o->rooms < 3 || !(o->rate_hz > 0.0) || o->width < 16 ||
      o->width > 640 || o->height < 16 || o->height > 480) {
    std::fprintf(stderr, "bad option value (seeds and levels not empty, rooms >= 3, rate > 0, size up to 640x480)\n");
    return false;
  }
  return true;
}

// What one level gives on one building (and, summed, over all of them).
struct Result {
  // Trajectory.
  std::size_t keyframes = 0;
  double tour_m = 0.0;
  double ate_se3_sq_sum = 0.0, ate_none_sq_sum = 0.0;  // RMSE^2 x poses, to pool over buildings
  double ate_none_max_m = 0.0;
  double end_error_m = 0.0, max_error_m = 0.0;  // odometry (body) position error at the end and its maximum
  // Objects.
  std::size_t objects_truth = 0, objects_found = 0, objects_estimated = 0, objects_correct = 0;
  // Places.
  std::size_t places = 0;
  double gvd_distance_sum_m = 0.0;
  // Rooms.
  bench::RoomSegmentationScore rooms;
  std::size_t rooms_estimated = 0;
  // Mesh.
  std::size_t mesh_vertices = 0, mesh_off_surface = 0, mesh_off_voxel = 0;
  double mesh_area_m2 = 0.0;
  double wall_s = 0.0;

  void add(const Result& o) {
    keyframes += o.keyframes;
    tour_m += o.tour_m;
    ate_se3_sq_sum += o.ate_se3_sq_sum;
    ate_none_sq_sum += o.ate_none_sq_sum;
    ate_none_max_m = std::max(ate_none_max_m, o.ate_none_max_m);
    end_error_m += o.end_error_m;
    max_error_m = std::max(max_error_m, o.max_error_m);
    objects_truth += o.objects_truth;
    objects_found += o.objects_found;
    objects_estimated += o.objects_estimated;
    objects_correct += o.objects_correct;
    places += o.places;
    gvd_distance_sum_m += o.gvd_distance_sum_m;
    rooms.add(o.rooms);
    rooms_estimated += o.rooms_estimated;
    mesh_vertices += o.mesh_vertices;
    mesh_off_surface += o.mesh_off_surface;
    mesh_off_voxel += o.mesh_off_voxel;
    mesh_area_m2 += o.mesh_area_m2;
    wall_s += o.wall_s;
  }
  double ate_se3_m() const { return keyframes == 0 ? 0.0 : std::sqrt(ate_se3_sq_sum / keyframes); }
  double ate_none_m() const { return keyframes == 0 ? 0.0 : std::sqrt(ate_none_sq_sum / keyframes); }
  // The odometry's end-point error (summed over buildings) over the tours' length (the tours return to the start,
  // where a scale error cancels).
  double end_error_percent() const { return tour_m > 0.0 ? 100.0 * end_error_m / tour_m : 0.0; }
  double pct(std::size_t a, std::size_t b) const { return b == 0 ? 0.0 : 100.0 * static_cast<double>(a) / b; }
  double gvd_mean_m() const { return places == 0 ? 0.0 : gvd_distance_sum_m / static_cast<double>(places); }
  double share(std::size_t n) const {
    return mesh_vertices == 0 ? 0.0 : static_cast<double>(n) / static_cast<double>(mesh_vertices);
  }
};

// A mesh vertex off every true surface by more than off_m: in free space that far from any solid, or inside a solid
// with all six axis probes that far away inside too.
bool off_surface(const world::FreeSpaceIndex& free_space, const Eigen::Vector3d& p, double off_m) {
  if (free_space.is_free(p, 0.0)) return free_space.clearance(p, 2.0 * off_m) > off_m;
  for (int axis = 0; axis < 3; ++axis)
    for (const double sign : {-1.0, 1.0}) {
      Eigen::Vector3d q = p;
      q[axis] += sign * off_m;
      if (free_space.is_free(q, 0.0)) return false;
    }
  return true;
}

double triangle_area_m2(const reconstruction::Mesh& mesh) {
  double area = 0.0;
  for (const reconstruction::MeshTriangle& t : mesh.triangles) {
    const auto at = [&](int k) {
      const reconstruction::MeshVertex& v = mesh.vertices[t.v[k]];
      return Eigen::Vector3d(v.x, v.y, v.z);
    };
    area += 0.5 * (at(1) - at(0)).cross(at(2) - at(0)).norm();
  }
  return area;
}

metrics::TimedPose timed_pose(std::int64_t t_ns, const Eigen::Isometry3d& world_T_camera) {
  metrics::TimedPose p;
  p.time_ns = t_ns;
  p.t_m = world_T_camera.translation();
  p.q = Eigen::Quaterniond(world_T_camera.rotation());
  return p;
}

// One level on one building: explore with the level's odometry, map, score against the ground truth.
bool run_level(const Options& opt, const world::World& w, const world::BuildingConfig& bc, bench::SimTour* sim_tour,
               const sim::SimCamera::Config& cc, const world::FreeSpaceIndex& free_space,
               const sim::GroundTruth& truth, sim::OdometryLevel level, Result* out) {
  const auto start = std::chrono::steady_clock::now();
  std::string error;
  // A fresh camera over the same tour (a camera reads its trajectory once).
  sim_tour->camera = std::make_unique<sim::SimCamera>();
  if (!sim_tour->camera->init(cc, render::Renderer::Config{}, w, sim_tour->tour.trajectory, &error))
    return std::fprintf(stderr, "sim camera: %s\n", error.c_str()), false;
  bench::OdometryOption odometry;
  odometry.level = level;
  odometry.seed = opt.odometry_seed;
  bench::set_odometry(odometry, bc.seed, sim_tour);

  auto graph = std::make_unique<sg::SceneGraph>();
  if (!graph->init(sg::capacities_from_budget(), sg::arena_bytes_from_budget(), &error))
    return std::fprintf(stderr, "scene graph: %s\n", error.c_str()), false;
  // The app's stages through the evaluations' harness: every frame a keyframe, the frontend every keyframe, no
  // online doors; the frame's free space not observed (each places cycle carves the latest frame), as this
  // baseline was recorded (bench/results/drift_baseline.md), where the app observes every keyframe.
  bench::PipelineConfig pc;
  pc.observe = false;
  pc.backend = true;
  pc.backend_stage.doors_online = false;
  bench::EvalPipeline pipeline;
  std::string warning;
  if (!pipeline.init(pc, graph.get(), &error, &warning)) return std::fprintf(stderr, "%s\n", error.c_str()), false;

  // Map from the odometry's poses, scored against the truth at the same stamps.
  std::vector<metrics::TimedPose> reference, estimate;
  Eigen::Vector3d last = Eigen::Vector3d::Zero();
  std::uint64_t t_last = 0;
  out->keyframes = pipeline.explore(*sim_tour, [&](const bench::FrontendStep& step) {
    last = step.world_T_camera.translation();
    t_last = step.time_ns;
    reference.push_back(timed_pose(static_cast<std::int64_t>(step.time_ns), step.truth_T_camera));
    estimate.push_back(timed_pose(static_cast<std::int64_t>(step.time_ns), step.world_T_camera));
  });
  pipeline.finish(last, t_last);

  // The final stage on the whole map, as the app does when a run finishes: doors on the final surface, then rooms.
  reconstruction::Mesh mesh;
  pipeline.tsdf().extract_full_mesh(&mesh);
  const backend::BackendStage::FinalDoors doors = pipeline.close_doors(mesh, nullptr);
  if (!doors.ok) std::fprintf(stderr, "  doors: %s; rooms without them\n", doors.error.c_str());
  const rooms::UpdateResult rr = pipeline.update_rooms(t_last);
  out->rooms_estimated = rr.rooms;

  // Trajectory: the keyframes' camera positions against the truth at the same stamps.
  metrics::TrajectoryErrorConfig tc;
  tc.max_time_difference_ns = 1'000'000;  // the same stamps on both sides
  tc.alignment = metrics::Alignment::kSE3;
  const metrics::TrajectoryError se3 = metrics::evaluate_trajectory(reference, estimate, tc);
  tc.alignment = metrics::Alignment::kNone;
  const metrics::TrajectoryError none = metrics::evaluate_trajectory(reference, estimate, tc);
  if (!se3.ok || !none.ok) return std::fprintf(stderr, "ATE: %s%s\n", se3.error.c_str(), none.error.c_str()), false;
  out->ate_se3_sq_sum = se3.ate_rmse_m * se3.ate_rmse_m * static_cast<double>(se3.associated);
  out->ate_none_sq_sum = none.ate_rmse_m * none.ate_rmse_m * static_cast<double>(none.associated);
  out->ate_none_max_m = none.ate_max_m;
  out->tour_m = sim_tour->tour.length_m;
  const sim::OdometryPoses& odom = sim_tour->odometry;
  for (std::size_t i = 0; i < odom.estimated().size(); ++i)
    out->max_error_m =
        std::max(out->max_error_m, (odom.estimated()[i].world_t_body_m - odom.truth()[i].world_t_body_m).norm());
  if (!odom.estimated().empty())
    out->end_error_m = (odom.estimated().back().world_t_body_m - odom.truth().back().world_t_body_m).norm();

  // Objects: the scene graph's positions, objects_eval's match.
  std::vector<bench::EstimatedObject> objects;
  pipeline.frontend().objects().for_each_object([&](const objects::ObjectView& o) {
    if (const sg::ObjectAttributes* a = graph->object(o.node)) objects.push_back({o.label, a->position_m});
  });
  const bench::ObjectMatch match = bench::match_objects(w, objects);
  out->objects_truth = w.objects.size();
  out->objects_found = match.num_found;
  out->objects_estimated = objects.size();
  out->objects_correct = match.num_correct;

  // Places.
  const std::vector<double> gvd = bench::place_distances_to_gvd(*graph, truth);
  out->places = gvd.size();
  out->gvd_distance_sum_m = bench::mean(gvd) * static_cast<double>(gvd.size());

  // Rooms.
  std::vector<bench::FloorRaster> floors = bench::generated_floor_rasters(w, bc);
  out->rooms = bench::score_generated_rooms(*graph, &floors, opt.max_reach_m);

  // Mesh.
  out->mesh_vertices = mesh.vertices.size();
  out->mesh_area_m2 = triangle_area_m2(mesh);
  for (const reconstruction::MeshVertex& v : mesh.vertices) {
    const Eigen::Vector3d p(v.x, v.y, v.z);
    if (!off_surface(free_space, p, kOffSurfaceM)) continue;
    ++out->mesh_off_surface;
    out->mesh_off_voxel += off_surface(free_space, p, kOffSurfaceVoxelM) ? 1 : 0;
  }
  out->wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return true;
}

void print_row(const char* name, const Result& r, double gt_area_m2) {
  std::printf("  %-3s | ATE SE3 %.3f m, unaligned %.3f m (max %.3f m) | odometry error at the end %.2f %% of the "
              "tour, max %.2f m | objects found %.1f %% correct %.1f %% | places to GVD %.3f m | rooms P %.3f R %.3f "
              "(%zu estimated, %zu truth) | mesh %.0f m^2 (x%.3f of gt), off > 5 cm %.1f %%, > 10 cm %.1f %% | "
              "%.0f s\n",
              name, r.ate_se3_m(), r.ate_none_m(), r.ate_none_max_m, r.end_error_percent(), r.max_error_m,
              r.pct(r.objects_found, r.objects_truth), r.pct(r.objects_correct, r.objects_estimated), r.gvd_mean_m(),
              r.rooms.precision_mean, r.rooms.recall_mean, r.rooms_estimated, r.rooms.rooms_truth, r.mesh_area_m2,
              gt_area_m2 > 0.0 ? r.mesh_area_m2 / gt_area_m2 : 0.0, 100.0 * r.share(r.mesh_off_surface),
              100.0 * r.share(r.mesh_off_voxel), r.wall_s);
}

// A level's end-point drift on a 200 m straight walk, RMS over 32 seeds (the band the unit test checks for vio).
double straight_walk_drift_percent(sim::OdometryLevel level) {
  if (level == sim::OdometryLevel::kGroundTruth) return 0.0;
  const double length_m = 200.0, step_m = 0.7 / 30.0;
  replay::Trajectory walk;
  for (int i = 0; i * step_m <= length_m; ++i) {
    replay::StampedPose p;
    p.time_ns = static_cast<std::int64_t>(i) * 33'333'333LL;
    p.world_t_body_m = Eigen::Vector3d(i * step_m, 0.0, 0.5);
    walk.push_back(p);
  }
  double sum_sq = 0.0;
  for (std::uint64_t seed = 1; seed <= 32; ++seed) {
    const sim::OdometryPoses odom(walk, level, seed);
    const double e = (odom.estimated().back().world_t_body_m - walk.back().world_t_body_m).norm();
    sum_sq += e * e;
  }
  const double walked_m = (walk.back().world_t_body_m - walk.front().world_t_body_m).norm();
  return 100.0 * std::sqrt(sum_sq / 32.0) / walked_m;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parse(argc, argv, &opt)) {
    usage(argv[0]);
    return 2;
  }
  std::printf("odometry levels (drivers/sim/odometry_levels.h), end-point drift on a 200 m straight walk, RMS over "
              "32 seeds:\n");
  for (const sim::OdometryLevel level : opt.levels) {
    const sim::DriftingOdometry::Config dc = sim::drift_config(level, opt.odometry_seed);
    std::printf("  %-3s translation %.3f m/sqrt(m), yaw %.4f rad/sqrt(m), scale bias %.3f: %.2f %% of distance\n",
                sim::to_string(level), dc.translation_sigma_m_per_sqrt_m, dc.yaw_sigma_rad_per_sqrt_m, dc.scale_bias,
                straight_walk_drift_percent(level));
  }
  std::map<sim::OdometryLevel, Result> totals;
  std::map<sim::OdometryLevel, double> gt_area_sum;  // the gt runs' area on the buildings a level ran, for its ratio
  for (const std::uint64_t seed : opt.seeds) {
    world::BuildingConfig bc;
    bc.num_rooms = opt.rooms;
    bc.seed = seed;
    bc.two_floors = opt.two_floors;
    const world::World w = world::generate_building(bc);
    sim::ExplorationConfig ec;
    sim::SimCamera::Config cc;
    cc.intrinsics = bench::camera_of_fov(opt.width, opt.height, opt.hfov_deg);
    cc.rate_hz = opt.rate_hz;
    bench::SimTour sim_tour;
    std::string error;
    if (!bench::make_sim_tour(w, ec, cc, render::Renderer::Config{}, &sim_tour, &error)) {
      std::fprintf(stderr, "seed %llu: %s\n", static_cast<unsigned long long>(seed), error.c_str());
      return 1;
    }
    const world::FreeSpaceIndex free_space(w);
    sim::GroundTruth truth;
    if (!sim::compute_ground_truth(w, free_space, sim::GroundTruthConfig{}, &truth, &error)) {
      std::fprintf(stderr, "ground truth: %s\n", error.c_str());
      return 1;
    }
    std::printf("\nbuilding seed %llu: %zu rooms%s, %zu objects, tour %.1f m\n", static_cast<unsigned long long>(seed),
                w.rooms.size(), opt.two_floors ? " on two floors" : "", w.objects.size(), sim_tour.tour.length_m);
    double gt_area = 0.0;
    for (const sim::OdometryLevel level : opt.levels) {
      Result r;
      if (!run_level(opt, w, bc, &sim_tour, cc, free_space, truth, level, &r)) return 1;
      if (level == sim::OdometryLevel::kGroundTruth) gt_area = r.mesh_area_m2;
      print_row(sim::to_string(level), r, gt_area);
      totals[level].add(r);
      gt_area_sum[level] += gt_area;
    }
  }
  std::printf("\nsummary over %zu buildings (%d rooms%s, seeds", opt.seeds.size(), opt.rooms,
              opt.two_floors ? ", two floors" : "");
  for (const std::uint64_t s : opt.seeds) std::printf(" %llu", static_cast<unsigned long long>(s));
  std::printf("), odometry seed %llu:\n", static_cast<unsigned long long>(opt.odometry_seed));
  for (const sim::OdometryLevel level : opt.levels)
    print_row(sim::to_string(level), totals[level], gt_area_sum[level]);

  if (!opt.json_path.empty()) {
    std::string seeds;
    for (const std::uint64_t s : opt.seeds) seeds += (seeds.empty() ? "" : ",") + std::to_string(s);
    char cond[384];
    std::snprintf(cond, sizeof(cond),
                  "%zu generated %sbuildings (%d rooms, seeds %s), odometry seed %llu, sim camera %dx%d %.0f deg hfov "
                  "%.1f Hz, noise-free depth and labels, TSDF 0.1 m, frontend every keyframe, doors and rooms at the "
                  "end, scored in the world frame, %s budget, one core",
                  opt.seeds.size(), opt.two_floors ? "two-floor " : "", opt.rooms, seeds.c_str(),
                  static_cast<unsigned long long>(opt.odometry_seed), opt.width, opt.height, opt.hfov_deg,
                  opt.rate_hz, budgets::active::kBoard);
    bench::Figures figures(cond);
    for (const sim::OdometryLevel level : opt.levels) {
      const Result& r = totals[level];
      const std::string p = std::string("drift_baseline.") + sim::to_string(level) + ".";
      const double gt_area = gt_area_sum[level];
      figures.add(p + "straight_200m_end_point_drift", straight_walk_drift_percent(level), "%");
      figures.add(p + "odometry_end_point_error_of_tour", r.end_error_percent(), "%");
      figures.add(p + "odometry_max_error", r.max_error_m, "m");
      figures.add(p + "tour_length", r.tour_m, "m");
      figures.add(p + "ate_rmse_se3", r.ate_se3_m(), "m");
      figures.add(p + "ate_rmse_unaligned", r.ate_none_m(), "m");
      figures.add(p + "ate_max_unaligned", r.ate_none_max_m, "m");
      figures.add(p + "objects_found", r.pct(r.objects_found, r.objects_truth), "%");
      figures.add(p + "objects_correct", r.pct(r.objects_correct, r.objects_estimated), "%");
      figures.add(p + "places_node_to_gvd_mean", r.gvd_mean_m(), "m");
      figures.add(p + "rooms_precision_mean", r.rooms.precision_mean, "fraction");
      figures.add(p + "rooms_recall_mean", r.rooms.recall_mean, "fraction");
      figures.add(p + "rooms_precision_area", r.rooms.precision_area, "fraction");
      figures.add(p + "rooms_recall_area", r.rooms.recall_area, "fraction");
      figures.add(p + "rooms_estimated", static_cast<double>(r.rooms_estimated), "rooms");
      figures.add(p + "mesh_area", r.mesh_area_m2, "m^2");
      figures.add(p + "mesh_area_over_gt", gt_area > 0.0 ? r.mesh_area_m2 / gt_area : 0.0, "ratio");
      figures.add(p + "mesh_vertices", static_cast<double>(r.mesh_vertices), "vertices");
      figures.add(p + "mesh_off_surface_5cm_share", r.share(r.mesh_off_surface), "fraction");
      figures.add(p + "mesh_off_surface_10cm_share", r.share(r.mesh_off_voxel), "fraction");
      figures.add(p + "keyframes", static_cast<double>(r.keyframes), "keyframes");
      figures.add(p + "wall_time", r.wall_s, "s");
    }
    if (!figures.write(opt.json_path)) return 1;
  }
  return 0;
}
