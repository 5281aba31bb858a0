// Long-run Layer 1 benchmark: drives the semantic TSDF with ground-truth poses for at least a kilometre through a
// large generated building and shows that the active window's memory stays flat while the archive grows; prints
// progress every 100 m and the summary figures (optionally as JSON for the results table).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstdint>
#include <fstream>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "bench/figures.h"
#include "bench/sim_tour.h"
#include "budgets/budget_table.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "drivers/render/ray_scene.h"
#include "drivers/sim/exploration.h"
#include "drivers/sim/sim_camera.h"
#include "drivers/world/building_generator.h"
#include "drivers/world/world_query.h"


namespace {

using qsg::bench::peak_rss_mb;
using qsg::bench::quantile;

using namespace qsg;

struct Options {
  std::uint64_t seed = 1;
  int rooms = 48;
  double distance_m = 1000.0;
  int width = 320;
  int height = 240;
  double spacing_m = 0.25;  // frame spacing along the path at the tour's speed (rate = speed / spacing)
  double rate_hz = 0.0;     // > 0 overrides spacing_m
  double report_every_m = 100.0;
  std::string json_path;
};

void usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s [--seed N] [--rooms N] [--distance-m D] [--size WxH] [--spacing-m S | --rate-hz R] "
               "[--json FILE]\n"
               "  The simulated robot drives at least --distance-m (1 km) through a large generated building while\n"
               "  Layer 1 integrates every frame; every 100 m it prints the window's bytes, the archive's size, peak\n"
               "  RSS and the per-frame time, at the end the bytes per m^2 mapped (--json: recon_long_run.*).\n",
               argv0);
}

bool parse(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--help" || a == "-h") return false;
    if (!has_value) {
      std::fprintf(stderr, "option %s needs a value\n", a.c_str());
      return false;
    }
    const char* v = argv[++i];
    char* end = nullptr;
    if (a == "--seed") {
      o->seed = std::strtoull(v, &end, 10);
    } else if (a == "--rooms") {
      o->rooms = static_cast<int>(std::strtol(v, &end, 10));
    } else if (a == "--distance-m") {
      o->distance_m = std::strtod(v, &end);
    } else if (a == "--spacing-m") {
      o->spacing_m = std::strtod(v, &end);
    } else if (a == "--rate-hz") {
      o->rate_hz = std::strtod(v, &end);
    } else if (a == "--json") {
      o->json_path = v;
      continue;
    } else if (a == "--size") {
      if (std::sscanf(v, "%dx%d", &o->width, &o->height) != 2) {
        std::fprintf(stderr, "--size: expected WxH, got '%s'\n", v);
        return false;
      }
      continue;
    } else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      return false;
    }
    if (end == v || *end != '\0') {
      std::fprintf(stderr, "option %s: bad number '%s'\n", a.c_str(), v);
      return false;
    }
  }
  if (o->rooms < 3 || !(o->distance_m > 0.0) || !(o->spacing_m > 0.0) || o->rate_hz < 0.0 || o->width < 1 ||
      o->width > 640 || o->height < 1 || o->height > 480) {
    std::fprintf(stderr, "bad option value (rooms >= 3, distance and spacing > 0, size up to 640x480)\n");
    return false;
  }
  return true;
}

double polygon_area(const world::Polygon2& p) {
  double twice = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Eigen::Vector2d& a = p[i];
    const Eigen::Vector2d& b = p[(i + 1) % p.size()];
    twice += a.x() * b.y() - b.x() * a.y();
  }
  return std::abs(twice) * 0.5;
}

std::size_t window_bytes_in_use(const reconstruction::SemanticTsdf& tsdf) {
  return tsdf.active_blocks() * sizeof(reconstruction::Voxel) * reconstruction::kBlockVoxels;
}

std::size_t archive_bytes(const reconstruction::SemanticTsdf& tsdf) { return tsdf.archive_bytes(); }

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parse(argc, argv, &opt)) {
    usage(argv[0]);
    return 2;
  }
  const auto t_start = std::chrono::steady_clock::now();

  world::BuildingConfig bc;
  bc.num_rooms = opt.rooms;
  bc.seed = opt.seed;
  const world::World w = world::generate_building(bc);
  render::RayScene scene;
  std::string error;
  if (!scene.build(w, &error)) {
    std::fprintf(stderr, "ray scene: %s\n", error.c_str());
    return 1;
  }
  const world::FreeSpaceIndex free_space(w);
  const sim::ExplorationConfig ec;
  const sim::ExplorationResult tour = sim::plan_exploration(w, scene, free_space, ec);
  if (!tour.ok || tour.trajectory.size() < 2 || !(tour.length_m > 0.0)) {
    std::fprintf(stderr, "exploration: %s\n", tour.ok ? "empty tour" : tour.error.c_str());
    return 1;
  }

  // Repeat the tour (it returns to its start) until it covers the distance, continuing the timestamps.
  replay::Trajectory trajectory = tour.trajectory;
  const std::int64_t period_ns = tour.trajectory[1].time_ns - tour.trajectory[0].time_ns;
  int laps = 1;
  while (tour.length_m * laps < opt.distance_m) {
    const std::int64_t offset = trajectory.back().time_ns + period_ns - tour.trajectory.front().time_ns;
    for (replay::StampedPose p : tour.trajectory) {
      p.time_ns += offset;
      trajectory.push_back(p);
    }
    ++laps;
  }

  double mapped_area_m2 = 0.0;
  std::set<std::int32_t> visited(tour.room_order.begin(), tour.room_order.end());
  for (const world::Room& room : w.rooms) {
    if (visited.count(room.id) == 0) continue;
    for (const world::Polygon2& p : room.footprint_m) mapped_area_m2 += polygon_area(p);
  }

  sim::SimCamera camera;
  sim::SimCamera::Config cc;
  cc.intrinsics = bench::camera_of_size(opt.width, opt.height);
  cc.rate_hz = opt.rate_hz > 0.0 ? opt.rate_hz : ec.speed_m_s / opt.spacing_m;
  if (!camera.init(cc, render::Renderer::Config{}, w, trajectory, &error)) {
    std::fprintf(stderr, "sim camera: %s\n", error.c_str());
    return 1;
  }

  reconstruction::Config config;
  const reconstruction::Capacities caps = reconstruction::capacities_from_budget();
  const std::size_t budget_bytes = budgets::active::reconstruction::kArenaBytes;
  reconstruction::SemanticTsdf tsdf;
  if (!tsdf.init(config, caps, budget_bytes, &error)) {
    std::fprintf(stderr, "semantic tsdf: %s\n", error.c_str());
    return 1;
  }
  const std::size_t arena_used = reconstruction::SemanticTsdf::plan(caps).total_bytes();

  std::printf("recon_long_run: %d rooms (seed %llu), tour %.1f m x %d laps, %zu frames at %dx%d, %.2f Hz "
              "(%.2f m apart at %.2f m/s)\n",
              static_cast<int>(w.rooms.size()), static_cast<unsigned long long>(opt.seed), tour.length_m, laps,
              camera.num_frames(), opt.width, opt.height, cc.rate_hz, ec.speed_m_s / cc.rate_hz, ec.speed_m_s);
  config.print(stdout);
  std::printf("arena: budget %zu bytes, carved %zu bytes at init (nothing is carved later)\n", budget_bytes,
              arena_used);
  std::printf("%9s %7s %7s %12s %12s %10s %10s %9s %9s %9s\n", "dist_m", "frames", "blocks", "window_used_B",
              "arena_hw_B", "arch_vert", "arch_tri", "rss_MB", "med_ms", "max_ms");

  auto frame = std::make_unique<messages::RgbdFrame>();
  std::vector<double> all_ms;
  all_ms.reserve(camera.num_frames());
  std::vector<double> interval_ms;
  double distance_m = 0.0;
  double next_report_m = opt.report_every_m;
  Eigen::Vector3d last_position = Eigen::Vector3d::Zero();
  bool have_last = false;
  std::size_t max_blocks_seen = 0;
  std::size_t window_min = SIZE_MAX, window_max = 0;  // in-use bytes after the first report interval
  double rss_at_first_report_mb = 0.0;
  std::size_t archive_bytes_first_lap = 0;  // later laps re-archive surfaces already mapped
  std::uint64_t frames = 0;

  for (;;) {
    const drivers::ReadStatus status = camera.read(*frame, 0);
    if (status == drivers::ReadStatus::kEndOfStream) break;
    if (status != drivers::ReadStatus::kOk) continue;
    Eigen::Isometry3d world_T_camera;
    if (!camera.camera_pose(frame->sequence, &world_T_camera, nullptr)) continue;
    if (have_last) distance_m += (world_T_camera.translation() - last_position).norm();
    last_position = world_T_camera.translation();
    have_last = true;

    const auto t0 = std::chrono::steady_clock::now();
    tsdf.process(*frame, world_T_camera);
    const auto t1 = std::chrono::steady_clock::now();
    const double ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
    all_ms.push_back(ms);
    interval_ms.push_back(ms);
    ++frames;
    max_blocks_seen = std::max(max_blocks_seen, tsdf.active_blocks());
    if (distance_m >= opt.report_every_m) {
      window_min = std::min(window_min, window_bytes_in_use(tsdf));
      window_max = std::max(window_max, window_bytes_in_use(tsdf));
    }

    if (archive_bytes_first_lap == 0 && distance_m >= tour.length_m) archive_bytes_first_lap = archive_bytes(tsdf);
    if (distance_m >= next_report_m) {
      if (rss_at_first_report_mb == 0.0) rss_at_first_report_mb = peak_rss_mb();
      std::printf("%9.1f %7llu %7zu %12zu %12zu %10zu %10zu %9.1f %9.2f %9.2f\n", distance_m,
                  static_cast<unsigned long long>(frames), tsdf.active_blocks(), window_bytes_in_use(tsdf),
                  arena_used, tsdf.archive_vertices(), tsdf.archive_triangles(), peak_rss_mb(),
                  quantile(interval_ms, 0.5), *std::max_element(interval_ms.begin(), interval_ms.end()));
      std::fflush(stdout);
      interval_ms.clear();
      while (next_report_m <= distance_m) next_report_m += opt.report_every_m;
    }
    if (distance_m >= opt.distance_m) break;  // the last lap may be partial
  }
  if (frames == 0) {
    std::fprintf(stderr, "no frames integrated\n");
    return 1;
  }
  if (window_min == SIZE_MAX) window_min = window_max = 0;

  const double median_ms = quantile(all_ms, 0.5);
  const double p99_ms = quantile(all_ms, 0.99);
  const double max_ms = *std::max_element(all_ms.begin(), all_ms.end());
  const double rss_mb = peak_rss_mb();
  const std::size_t arch_bytes = archive_bytes(tsdf);
  const double bytes_per_m2 = mapped_area_m2 > 0.0 ? static_cast<double>(arch_bytes) / mapped_area_m2 : 0.0;
  const double first_lap_per_m2 =
      mapped_area_m2 > 0.0 ? static_cast<double>(archive_bytes_first_lap) / mapped_area_m2 : 0.0;
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();

  std::printf("\nsummary:\n");
  tsdf.counters().print(stdout);
  std::printf("  distance %.1f m, %llu frames, wall time %.1f s (rendering included)\n", distance_m,
              static_cast<unsigned long long>(frames), wall_s);
  std::printf("  mapped floor area %.1f m^2 (%zu rooms visited)\n", mapped_area_m2, visited.size());
  std::printf("  archive %zu vertices, %zu triangles, %zu bytes = %.0f bytes/m^2 mapped\n", tsdf.archive_vertices(),
              tsdf.archive_triangles(), arch_bytes, bytes_per_m2);
  std::printf("  archive after the first lap (%.1f m): %zu bytes = %.0f bytes/m^2 mapped\n", tour.length_m,
              archive_bytes_first_lap, first_lap_per_m2);
  std::printf("  window reserved %zu bytes (constant); in use after the first %.0f m: min %zu max %zu (spread %zu); "
              "peak %zu blocks of %zu\n",
              tsdf.window_bytes(), opt.report_every_m, window_min, window_max, window_max - window_min,
              max_blocks_seen, caps.max_blocks);
  std::printf("  window flat: %s (in-use never exceeds the fixed reservation)\n",
              window_max <= tsdf.window_bytes() ? "yes" : "NO");
  std::printf("  peak RSS %.1f MB (%.1f MB at %.0f m)\n", rss_mb, rss_at_first_report_mb, opt.report_every_m);
  std::printf("  per frame (integrate + mesh + window): median %.2f ms, p99 %.2f ms, max %.2f ms\n", median_ms,
              p99_ms, max_ms);

  if (!opt.json_path.empty()) {
    char cond[256];
    std::snprintf(cond, sizeof(cond), "%dx%d, %.2f Hz, voxel %.2f m, %d rooms seed %llu, host_sim budget",
                  opt.width, opt.height, cc.rate_hz, config.voxel_size_m, static_cast<int>(w.rooms.size()),
                  static_cast<unsigned long long>(opt.seed));
    bench::Figures figures(cond);
    auto add = [&](const char* name, double value, const char* unit) { figures.add(name, value, unit); };
    add("recon_long_run.distance", distance_m, "m");
    add("recon_long_run.frames", static_cast<double>(frames), "frames");
    add("recon_long_run.mapped_area", mapped_area_m2, "m^2");
    add("recon_long_run.archive_bytes", static_cast<double>(arch_bytes), "bytes");
    add("recon_long_run.archive_bytes_per_m2", bytes_per_m2, "bytes/m^2");
    add("recon_long_run.archive_bytes_per_m2_first_lap", first_lap_per_m2, "bytes/m^2");
    add("recon_long_run.archive_vertices", static_cast<double>(tsdf.archive_vertices()), "vertices");
    add("recon_long_run.archive_triangles", static_cast<double>(tsdf.archive_triangles()), "triangles");
    add("recon_long_run.peak_rss", rss_mb, "MB");
    add("recon_long_run.frame_ms_median", median_ms, "ms");
    add("recon_long_run.frame_ms_p99", p99_ms, "ms");
    add("recon_long_run.frame_ms_max", max_ms, "ms");
    add("recon_long_run.window_bytes_reserved", static_cast<double>(tsdf.window_bytes()), "bytes");
    add("recon_long_run.window_bytes_in_use_spread", static_cast<double>(window_max - window_min), "bytes");
    add("recon_long_run.window_bytes_in_use_max", static_cast<double>(window_max), "bytes");
    add("recon_long_run.arena_bytes", static_cast<double>(arena_used), "bytes");
    add("recon_long_run.blocks_evicted", static_cast<double>(tsdf.counters().blocks_evicted), "blocks");
    if (!figures.write(opt.json_path)) return 1;
  }
  return 0;
}
