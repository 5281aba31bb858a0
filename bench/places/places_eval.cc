// Places evaluation: the simulated robot explores generated buildings or an extruded benchmark floor plan
// (ground-truth poses, or drifting ones with --odometry sim|vio, noise-free depth, 0.1 m voxels); the TSDF and the
// app's frontend (places, with objects and agents beside them: bench/eval_harness.h) run every keyframe; prints the
// mean distance from the place nodes to the ground-truth GVD (in the world frame), places components against
// connected free-space regions, place edges through solid ground truth (walls, floors, slabs), nodes per 100 m^2,
// the per-update time of the frontend (median, p99) and the memory of the ESDF and GVD in the window, optionally as
// JSON.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "core/params/params.h"
#include "core/places/places.h"
#include "core/places/places_params.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/scene_graph/scene_graph.h"
#include "bench/figures.h"
#include "bench/eval_harness.h"
#include "bench/places/place_score.h"
#include "bench/places/places_diagnosis.h"
#include "bench/sim_tour.h"
#include "budgets/budget_table.h"
#include "drivers/render/ray_scene.h"
#include "drivers/sim/exploration.h"
#include "drivers/sim/ground_truth.h"
#include "drivers/sim/sim_camera.h"
#include "drivers/world/building_generator.h"
#include "drivers/world/floor_plan_import.h"
#include "drivers/world/world_query.h"


namespace {

using namespace qsg;

struct Options {
  std::vector<std::uint64_t> seeds{1, 2, 3};
  int rooms = 8;
  int width = 320;
  int height = 240;
  double hfov_deg = 90.0;  // RealSense D455-like depth field of view: it sees floor and ceiling
  double rate_hz = 5.0;    // keyframes per second along the tour
  std::string json_path;
  bool verbose = false;
  bool diagnose = false;  // explain every component but the largest
  int every_n = 1;        // places update every Nth keyframe (observe() on every keyframe)
  bool observe = true;    // --no-observe: update() carves from the latest frame only (the old behaviour)
  std::string floorplan;   // --floorplan NAME: explore this extruded benchmark plan instead of generated buildings
  bool furnished = false;
  std::string plans_dir = std::string(QSG_SHARED_DATA_DIR) + "/floorplans/ipa";
  double window_radius_m = 0.0;  // --window-radius-m: places window (0: the Config default)
  std::vector<Eigen::Vector3d> trace;  // --trace X,Y,Z (repeatable): the ESDF voxel there, whenever it changes
  bool two_floors = false;           // --two-floors: generated buildings with a second floor over a 0.2 m slab
  bench::OdometryOption odometry;    // --odometry gt|sim|vio, --odometry-seed N (scored in the world frame)
  // The places stage's settings, each set by --set places.KEY=VALUE from its parameter table (core/params; --help
  // lists them). --window-radius-m stays a flag: it also sizes the TSDF window and pools around the places'.
  places::Config places;
};

const char kDetails[] = R"(
Places of the app's pipeline on generated buildings (--two-floors: a second floor over a 0.2 m slab) or on an
extruded IPA plan (--floorplan NAME [--furnished]), against the simulator's ground truth (places_eval.*):
  - every run counts the place edges that run through solid ground truth (walls, floors, slabs) for at least 0.1 m,
    an edge a planner would follow through a wall (edges_through_solid[_share]), and of those the ones whose ends
    the ground truth's free space does not join within 1 m around them, two free spaces the edge wrongly makes one
    rather than a wall corner its straight segment clips (edges_joining_apart); and the places whose clearance
    exceeds the true one by more than 0.25 m and 0.5 m.
  - --set places.KEY=VALUE sets any field of places::Config (the table below), e.g. --set
    places.revive_in_same_free_space=false, --set places.merge_revisited_within_m=0 (revisited places not merged),
    --set places.bridge_fragments=false --set places.enclosed_max_voxels=0 (no bridges, no pockets held back).
  - --verbose --diagnose lists the places farthest from the true GVD with the ESDF around them and their basis
    points, and explains every extra component; --trace X,Y,Z prints the ESDF voxel there (state, distance,
    parent) at every keyframe where it changes.
What each option earned: bench/results/places.md.
)";

const std::vector<params::Section>& places_sections() {
  static const std::vector<params::Section> sections = params::sections_of("places", places::params_table());
  return sections;
}

// ", places.key=value" for every setting that differs from places::Config's default (for the JSON's conditions).
std::string settings_changed(const places::Config& config) {
  const places::Config defaults;
  std::string out;
  for (const params::Field& f : places_sections().front().fields) {
    const std::string v = f.text(f.get(&config));
    if (v != f.text(f.get(&defaults))) out += ", places." + f.key + "=" + v;
  }
  return out;
}

// The hand-written flags of places::Config fields are gone: each names the --set it now is.
std::string retired_flag_hint(const std::string& flag) {
  static const std::pair<const char*, const char*> kRetired[] = {
      {"--no-free-space-edges", "places.free_space_edges=false"},
      {"--no-relink", "places.relink_inactive=false"},
      {"--no-bridges", "places.bridge_fragments=false --set places.enclosed_max_voxels=0"},
      {"--no-bridge-paths", "places.bridge_path_search=false"},
      {"--no-hold-distant", "places.hold_distant_fragments=false"},
      {"--no-projective-correction", "places.correct_projective_distance=false"},
      {"--no-signed-seeds", "places.signed_surface_seeds=false"},
      {"--no-rim-guard", "places.rim_guard=false"},
      {"--no-keep-rim-distances", "places.keep_distances_at_rim=false"},
      {"--no-unobserved-obstacle", "places.unobserved_is_obstacle=false"},
      {"--no-relink-check", "places.relink_in_same_free_space=false"},
      {"--no-revive-check", "places.revive_in_same_free_space=false"},
      {"--no-contract", "places.contract_removed=false"},
      {"--slab-above-m", "places.slab_above_m=H"},
      {"--unobserved-above-m", "places.unobserved_obstacle_above_m=H"},
      {"--bridge-max-places", "places.bridge_max_fragment_places=N"},
      {"--keep-edges-at-rim-m", "places.keep_edges_at_rim_m=M"},
      {"--merge-revisited-m", "places.merge_revisited_within_m=M"},
  };
  for (const auto& [old_flag, replacement] : kRetired)
    if (flag == old_flag) return std::string(" (now --set ") + replacement + ")";
  return " (places settings: --set places.KEY=VALUE, listed by --help)";
}

void usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s [--seeds 1,2,3] [--rooms N] [--size WxH] [--hfov-deg D] [--rate-hz R] [--every-n N] "
               "[--no-observe] [--set places.KEY=VALUE ...] [--two-floors] [--floorplan NAME [--furnished]] "
               "[--plans-dir DIR] [--window-radius-m R] [--trace X,Y,Z] %s [--json FILE] [--verbose] [--diagnose]\n"
               "  NAME: a map of the plans dir (Freiburg52_scan, lab_c_scan, lab_intel, lab_ipa, office_a, office_e)\n"
               "%s",
               argv0, bench::odometry_usage(), kDetails);
  std::fprintf(stderr, "Settings (--set places.KEY=VALUE):\n");
  params::print_help(places_sections(), stderr);
}

bool parse(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") return false;
    if (const int odometry = bench::parse_odometry_flag(argc, argv, &i, &o->odometry)) {
      if (odometry < 0) return false;
      continue;
    }
    if (const std::string hint = retired_flag_hint(a); hint.rfind(" (now", 0) == 0) {
      std::fprintf(stderr, "retired option %s%s\n", a.c_str(), hint.c_str());
      return false;
    }
    if (a == "--verbose") {
      o->verbose = true;
      continue;
    }
    if (a == "--diagnose") {
      o->diagnose = true;
      continue;
    }
    if (a == "--no-observe") {
      o->observe = false;
      continue;
    }
    if (a == "--two-floors") {
      o->two_floors = true;
      continue;
    }
    if (a == "--furnished") {
      o->furnished = true;
      continue;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "option %s needs a value\n", a.c_str());
      return false;
    }
    const std::string v = argv[++i];
    char* end = nullptr;
    if (a == "--seeds") {
      o->seeds.clear();
      std::size_t pos = 0;
      while (pos <= v.size()) {
        const std::size_t comma = v.find(',', pos);
        const std::string item = v.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
        o->seeds.push_back(std::strtoull(item.c_str(), &end, 10));
        if (end == item.c_str() || *end != '\0') {
          std::fprintf(stderr, "--seeds: bad seed '%s'\n", item.c_str());
          return false;
        }
        if (comma == std::string::npos) break;
        pos = comma + 1;
      }
      continue;
    } else if (a == "--every-n") {
      o->every_n = static_cast<int>(std::strtol(v.c_str(), &end, 10));
    } else if (a == "--rooms") {
      o->rooms = static_cast<int>(std::strtol(v.c_str(), &end, 10));
    } else if (a == "--hfov-deg") {
      o->hfov_deg = std::strtod(v.c_str(), &end);
    } else if (a == "--rate-hz") {
      o->rate_hz = std::strtod(v.c_str(), &end);
    } else if (a == "--json") {
      o->json_path = v;
      continue;
    } else if (a == "--floorplan") {
      o->floorplan = v;
      continue;
    } else if (a == "--plans-dir") {
      o->plans_dir = v;
      continue;
    } else if (a == "--trace") {
      Eigen::Vector3d p;
      if (std::sscanf(v.c_str(), "%lf,%lf,%lf", &p.x(), &p.y(), &p.z()) != 3) {
        std::fprintf(stderr, "--trace: expected X,Y,Z in metres, got '%s'\n", v.c_str());
        return false;
      }
      o->trace.push_back(p);
      continue;

    } else if (a == "--window-radius-m") {
      o->window_radius_m = std::strtod(v.c_str(), &end);
      if (end != v.c_str() && *end == '\0' && !(o->window_radius_m > 0.0 && o->window_radius_m <= 50.0)) {
        std::fprintf(stderr, "--window-radius-m: must be in (0, 50] m\n");
        return false;
      }
    } else if (a == "--size") {
      if (std::sscanf(v.c_str(), "%dx%d", &o->width, &o->height) != 2) {
        std::fprintf(stderr, "--size: expected WxH, got '%s'\n", v.c_str());
        return false;
      }
      continue;
    } else if (a == "--set") {
      std::string error;
      if (!params::set(places_sections(), &o->places, "places." + v.substr(v.rfind("places.", 0) == 0 ? 7 : 0), &error)) {
        std::fprintf(stderr, "--set %s\n", error.c_str());
        return false;
      }
      continue;
    } else {
      std::fprintf(stderr, "unknown option %s%s\n", a.c_str(), retired_flag_hint(a).c_str());
      return false;
    }
    if (end == nullptr || *end != '\0') {
      std::fprintf(stderr, "option %s: bad value '%s'\n", a.c_str(), v.c_str());
      return false;
    }
  }
  if (o->furnished && o->floorplan.empty()) {
    std::fprintf(stderr, "--furnished needs --floorplan NAME\n");
    return false;
  }
  if (const std::string bad = o->places.check(); !bad.empty()) {
    std::fprintf(stderr, "places settings: %s\n", bad.c_str());
    return false;
  }
  return !o->seeds.empty() && o->rooms >= 3 && o->width > 0 && o->height > 0 && o->hfov_deg > 10 &&
         o->hfov_deg < 170 && o->rate_hz > 0 && o->every_n >= 1;
}

using bench::quantile;
using bench::diagnose_components;
using bench::free_space_regions;
using bench::free_space_regions_gt;
using bench::gt_cell;
using bench::gt_index;
using bench::NodeHistory;
using bench::place_components;
using bench::polygon_area;
using bench::track_history;


struct BuildingResult {
  std::uint64_t seed = 0;
  std::string name;  // "seed N" or the floor plan's name and variant
  std::size_t keyframes = 0;
  std::size_t nodes = 0;
  std::size_t edges = 0;
  double mean_gvd_distance_m = 0.0;
  double median_gvd_distance_m = 0.0;
  // Places whose clearance exceeds the true one (walls, floor and ceiling) by more than 0.25 m / 0.5 m. Some
  // excess is by design (the ceiling above the camera is rarely seen, Config::unobserved_obstacle_above_m); a wall
  // missing from the ESDF (e.g. one that left the window) shows as more.
  std::size_t clearance_over_25cm = 0, clearance_over_50cm = 0;
  std::size_t places_in_solid = 0;  // place nodes inside solid ground truth (e.g. in a cavity of furniture)
  // Place-place edges whose segment runs through solid ground truth (walls, floors, slabs) for at least 0.1 m: an
  // edge a planner would follow through a wall.
  std::size_t place_edges = 0, edges_through_solid = 0;
  // ... and those whose two ends the ground truth's free space does not join within a box 1 m around them: not a
  // wall corner the straight segment clips, but two free spaces the edge claims are one (a wall or a slab between).
  std::size_t edges_joining_apart = 0;
  std::size_t components = 0;
  std::size_t components_3 = 0;   // with at least 3 nodes
  double largest_share = 0.0;     // of the nodes in the largest component
  std::size_t regions = 0;
  double area_m2 = 0.0;
  std::vector<double> update_ms;
  std::vector<double> observe_ms;
  places::MemoryUse memory;
  std::size_t tsdf_arena_bytes = 0;
  std::uint64_t tsdf_evicted = 0;
};

// Runs the tour of one world; floor plans count free-space regions on the ground-truth grid, generated buildings
// through the doors between visited rooms.
bool run_world(const Options& opt, const world::World& w, bool floor_plan, BuildingResult* out) {
  const std::uint64_t seed = out->seed;
  const sim::ExplorationConfig ec;
  sim::SimCamera::Config cc;
  cc.intrinsics = bench::camera_of_fov(opt.width, opt.height, opt.hfov_deg);
  cc.rate_hz = opt.rate_hz;
  bench::SimTour sim_tour;
  std::string error;
  if (!bench::make_sim_tour(w, ec, cc, render::Renderer::Config{}, &sim_tour, &error)) {
    std::fprintf(stderr, "seed %llu: %s\n", static_cast<unsigned long long>(seed), error.c_str());
    return false;
  }
  bench::set_odometry(opt.odometry, seed, &sim_tour);
  const sim::ExplorationResult& tour = sim_tour.tour;
  // The app's stages (bench/eval_harness.h): the frontend (places, objects, agents) on the TSDF every
  // --every-n-th keyframe, each keyframe's free space observed (--no-observe: not).
  bench::PipelineConfig config;
  config.frontend.places = opt.places;
  config.observe = opt.observe;
  config.frontend_every_n = static_cast<std::uint32_t>(opt.every_n);
  reconstruction::Config& tc = config.reconstruction;
  places::Config& pc = config.frontend.places;
  reconstruction::Capacities& rcaps = config.reconstruction_capacities;
  std::size_t& tsdf_bytes = config.reconstruction_arena_bytes;
  const places::Capacities pcaps = places::capacities_from_budget();
  if (opt.window_radius_m > 0.0) {
    // Every ESDF block the places read must exist in the TSDF: its window is one ESDF block larger.
    const double esdf_block_m = places::kBlockSide * pc.voxel_factor * tc.voxel_size_m;
    const double tsdf_radius_m = opt.window_radius_m + esdf_block_m;
    // The budget's TSDF pool holds the default window; a larger one holds more blocks (they grow with the area the
    // window covers: the slab is bounded in height). The ESDF pool keeps the budget's size: a refusal is reported.
    const double tsdf_scale = std::max(1.0, std::pow(tsdf_radius_m / tc.window_radius_m, 2.0));
    pc.window_radius_m = opt.window_radius_m;
    tc.window_radius_m = tsdf_radius_m;
    if (tsdf_scale > 1.0) {
      rcaps.max_blocks = static_cast<std::size_t>(std::ceil(static_cast<double>(rcaps.max_blocks) * tsdf_scale));
      rcaps.mesh_vertices = static_cast<std::size_t>(std::ceil(static_cast<double>(rcaps.mesh_vertices) * tsdf_scale));
      rcaps.mesh_triangles = static_cast<std::size_t>(std::ceil(static_cast<double>(rcaps.mesh_triangles) * tsdf_scale));
      tsdf_bytes = std::max(tsdf_bytes, reconstruction::SemanticTsdf::plan(rcaps).total_bytes());
      if (seed == opt.seeds.front())
        std::printf("note: TSDF window %.1f m does not fit the budget's reconstruction pools (sized for %.1f m): "
                    "sized for this eval: %zu blocks, arena %.1f MiB (budget %.1f MiB)\n",
                    tsdf_radius_m, reconstruction::Config{}.window_radius_m, rcaps.max_blocks,
                    tsdf_bytes / 1048576.0, budgets::active::reconstruction::kArenaBytes / 1048576.0);
    }
  }
  out->tsdf_arena_bytes = tsdf_bytes;
  scene_graph::SceneGraph graph;
  if (!graph.init(scene_graph::capacities_from_budget(), scene_graph::arena_bytes_from_budget(), &error)) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return false;
  }
  bench::EvalPipeline pipeline;
  if (!pipeline.init(config, &graph, &error)) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return false;
  }
  const places::Places& places = pipeline.frontend().places();
  if (seed == opt.seeds.front()) {
    tc.print(stdout);
    pc.print(stdout);
    pcaps.print(stdout);
  }

  std::map<scene_graph::NodeId, NodeHistory> history;
  std::vector<std::string> traced(opt.trace.size());
  const auto trace_voxels = [&](std::size_t keyframe, const Eigen::Vector3d& robot_m) {
    for (std::size_t i = 0; i < opt.trace.size(); ++i) {
      places::VoxelProbe v;
      char line[384];
      if (!places.probe(opt.trace[i], &v)) {
        std::snprintf(line, sizeof(line), "no block");
      } else {
        int n = std::snprintf(line, sizeof(line), "%s%s%s d %.2f basis %d", v.state, v.carved ? " carved" : "",
                              v.gvd ? " GVD" : "", v.distance_m, v.num_basis_points);
        if (v.has_parent)
          std::snprintf(line + n, sizeof(line) - static_cast<std::size_t>(n), " parent %.2f %.2f %.2f (%s, d %.2f)",
                        v.parent_m.x(), v.parent_m.y(), v.parent_m.z(), v.parent_state, v.parent_distance_m);
      }
      if (traced[i] == line) continue;
      traced[i] = line;
      std::printf("  trace %.2f %.2f %.2f keyframe %zu robot %.2f %.2f %.2f: %s\n", opt.trace[i].x(), opt.trace[i].y(),
                  opt.trace[i].z(), keyframe, robot_m.x(), robot_m.y(), robot_m.z(), line);
    }
  };
  std::uint64_t last_ns = 0;
  out->keyframes = pipeline.explore(sim_tour, [&](const bench::FrontendStep& step) {
    last_ns = step.time_ns;
    out->update_ms.push_back(step.update_ms);
    if (opt.diagnose) track_history(graph, static_cast<int>(step.keyframe), &history);
    trace_voxels(step.keyframe, step.world_T_camera.translation());
  });
  out->observe_ms = pipeline.observe_ms();
  // Finish any cycle in flight, and take in the keyframes observed since the last update (the robot where the
  // odometry puts it at the tour's end).
  const replay::Trajectory& odometry = sim_tour.odometry.estimated();
  const Eigen::Vector3d last_m =
      odometry.empty() ? tour.trajectory.back().world_t_body_m : odometry.back().world_t_body_m;
  pipeline.finish(last_m, last_ns);
  const reconstruction::SemanticTsdf& tsdf = pipeline.tsdf();

  sim::GroundTruth truth;
  const world::FreeSpaceIndex free_space(w);
  if (!sim::compute_ground_truth(w, free_space, sim::GroundTruthConfig{}, &truth, &error)) {
    std::fprintf(stderr, "ground truth: %s\n", error.c_str());
    return false;
  }
  out->memory = places.memory_use();
  out->tsdf_evicted = tsdf.counters().blocks_evicted;
  const std::vector<double> distances = bench::place_distances_to_gvd(graph, truth);
  graph.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind != scene_graph::NodeKind::kPlace) return;
    const scene_graph::PlaceAttributes* a = graph.place(n.id);
    std::size_t at = 0;
    if (!gt_index(truth, a->position_m, &at)) return;
    out->places_in_solid += truth.voxel_room[at] == sim::kVoxelOccupied ? 1 : 0;
    const double over = a->distance_m - truth.clearance_m[at];
    out->clearance_over_25cm += over > 0.25 ? 1 : 0;
    out->clearance_over_50cm += over > 0.5 ? 1 : 0;
  });
  if (opt.verbose) {
    // Where the worst nodes are (x, y, z, clearance, distance to the true GVD, active).
    std::vector<std::pair<double, scene_graph::NodeId>> worst;
    graph.for_each_node([&](const scene_graph::NodeRecord& n) {
      if (n.kind == scene_graph::NodeKind::kPlace)
        worst.emplace_back(truth.distance_to_gvd(graph.place(n.id)->position_m), n.id);
    });
    std::sort(worst.rbegin(), worst.rend());
    // Where the error comes from: mean distance to the true GVD by the place's clearance and by its height.
    const auto print_binned = [&](const char* what, const std::vector<double>& edges, auto&& value_of) {
      std::printf("  distance to the true GVD by %s:", what);
      for (std::size_t b = 0; b + 1 < edges.size(); ++b) {
        double sum_b = 0.0;
        int n_b = 0;
        for (const auto& [d, id] : worst) {
          const double x = value_of(id);
          if (x >= edges[b] && x < edges[b + 1]) {
            sum_b += d;
            ++n_b;
          }
        }
        std::printf(" [%.1f, %.1f): %d nodes mean %.3f;", std::max(-9.9, edges[b]), std::min(9.9, edges[b + 1]), n_b,
                    n_b > 0 ? sum_b / n_b : 0.0);
      }
      std::printf("\n");
    };
    print_binned("clearance (m)", {0.0, 0.3, 0.4, 0.6, 1.0, 1e9},
                 [&](scene_graph::NodeId id) { return graph.place(id)->distance_m; });
    print_binned("height (m)", {-1e9, 0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 1e9},
                 [&](scene_graph::NodeId id) { return graph.place(id)->position_m.z(); });
    // The ESDF along a line through p (x when no voxel holds a distance there).
    const auto print_profile = [&](const char* what, const Eigen::Vector3d& p, const Eigen::Vector3d& step, int from,
                                   int to) {
      std::printf("    %s:", what);
      for (int k = from; k <= to; ++k) {
        float d = 0.0f;
        if (places.distance_at(p + step * k, &d)) std::printf(" %.2f", d);
        else std::printf(" x");
      }
      std::printf("\n");
    };
    std::vector<places::GvdVoxelInfo> gvd_now;
    if (opt.diagnose) places.gvd_voxels(&gvd_now);
    for (std::size_t i = 0; i < std::min<std::size_t>(15, worst.size()); ++i) {
      const scene_graph::PlaceAttributes* a = graph.place(worst[i].second);
      // What the ground truth holds at the node: its voxel's room (-2 occupied, -1 free outside every room)
      // and true clearance.
      const Eigen::Vector3i q =
          ((a->position_m - truth.origin_m) / truth.config.voxel_size_m).array().floor().cast<int>();
      int truth_room = -3;
      double truth_clearance = -1.0;
      if ((q.array() >= 0).all() && (q.array() < truth.dims.array()).all()) {
        truth_room = truth.voxel_room[truth.index(q.x(), q.y(), q.z())];
        truth_clearance = truth.clearance_m[truth.index(q.x(), q.y(), q.z())];
      }
      std::printf("  worst: %.2f %.2f %.2f clearance %.2f dist %.2f active %d; truth: room %d clearance %.2f\n",
                  a->position_m.x(), a->position_m.y(), a->position_m.z(), a->distance_m, worst[i].first,
                  a->is_active ? 1 : 0, truth_room, truth_clearance);
      if (opt.diagnose && a->is_active) {
        const double s = places.voxel_size_m();
        print_profile("ESDF along z from -1 m to +0.6 m", a->position_m, Eigen::Vector3d(0, 0, s), -5, 3);
        print_profile("ESDF along x from -1 m to +1 m", a->position_m, Eigen::Vector3d(s, 0, 0), -5, 5);
        print_profile("ESDF along y from -1 m to +1 m", a->position_m, Eigen::Vector3d(0, s, 0), -5, 5);
        for (const places::GvdVoxelInfo& g : gvd_now) {
          if ((g.position_m - a->position_m).norm() > 0.25) continue;
          std::printf("    gvd %.2f %.2f %.2f d %.2f basis:", g.position_m.x(), g.position_m.y(), g.position_m.z(),
                      g.clearance_m);
          for (const Eigen::Vector3d& b : g.basis_m) std::printf(" (%.2f %.2f %.2f)", b.x(), b.y(), b.z());
          std::printf("\n");
        }
      }
    }
  }
  if (opt.verbose) {
    // Component sizes: (nodes, active, centroid) of every component but the largest.
    std::set<scene_graph::NodeId> seen;
    std::vector<std::tuple<std::size_t, std::size_t, Eigen::Vector3d>> comps;
    graph.for_each_node([&](const scene_graph::NodeRecord& n) {
      if (n.kind != scene_graph::NodeKind::kPlace || !seen.insert(n.id).second) return;
      std::vector<scene_graph::NodeId> stack{n.id};
      std::size_t size = 0, active = 0;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      std::set<scene_graph::NodeId> members;
      while (!stack.empty()) {
        const scene_graph::NodeId id = stack.back();
        stack.pop_back();
        members.insert(id);
        ++size;
        active += graph.place(id)->is_active ? 1 : 0;
        sum += graph.place(id)->position_m;
        graph.for_each_neighbor(id, [&](scene_graph::NodeId m, const scene_graph::EdgeRecord&) {
          if (scene_graph::node_prefix(m) == scene_graph::kPlacePrefix && seen.insert(m).second) stack.push_back(m);
        });
      }
      comps.emplace_back(size, active, sum / static_cast<double>(size));
      if (opt.diagnose && size <= 4) {
        // A small fragment: the ESDF along the way to the nearest place outside it.
        const Eigen::Vector3d c = sum / static_cast<double>(size);
        double best = 1e9;
        Eigen::Vector3d to = c;
        graph.for_each_node([&](const scene_graph::NodeRecord& o) {
          if (o.kind != scene_graph::NodeKind::kPlace || !graph.place(o.id)->is_active || members.count(o.id) != 0)
            return;
          const double d = (graph.place(o.id)->position_m - c).norm();
          if (d < best) {
            best = d;
            to = graph.place(o.id)->position_m;
          }
        });
        std::printf("    fragment %.2f %.2f %.2f -> %.2f %.2f %.2f, ESDF on the way:", c.x(), c.y(), c.z(), to.x(),
                    to.y(), to.z());
        for (int k = 0; k <= 12; ++k) {
          float d = 0.0f;
          if (places.distance_at(c + (to - c) * (k / 12.0), &d)) std::printf(" %.2f", d);
          else std::printf(" x");
        }
        std::printf("\n");
        for (scene_graph::NodeId m : members)
          std::printf("    member %.2f %.2f %.2f clearance %.2f\n", graph.place(m)->position_m.x(),
                      graph.place(m)->position_m.y(), graph.place(m)->position_m.z(), graph.place(m)->distance_m);
      }
    });
    std::sort(comps.begin(), comps.end(), [](const auto& a, const auto& b) { return std::get<0>(a) > std::get<0>(b); });
    for (const auto& [size, active, c] : comps)
      std::printf("  component: %zu nodes (%zu active) around %.1f %.1f %.1f\n", size, active, c.x(), c.y(), c.z());
  }
  if (opt.diagnose) diagnose_components(graph, places, truth, history);
  out->seed = seed;
  out->nodes = distances.size();
  graph.for_each_edge([&](const scene_graph::EdgeRecord& e) {
    const scene_graph::PlaceAttributes* a = graph.place(e.source);
    const scene_graph::PlaceAttributes* b = graph.place(e.target);
    if (a == nullptr || b == nullptr) return;
    ++out->place_edges;
    constexpr double kStep = 0.02, kSolid = 0.1;
    const int steps = std::max(1, static_cast<int>(std::ceil((b->position_m - a->position_m).norm() / kStep)));
    int solid = 0;
    for (int k = 0; k <= steps; ++k) {
      const Eigen::Vector3d p = a->position_m + (b->position_m - a->position_m) * (static_cast<double>(k) / steps);
      std::size_t at = 0;
      if (gt_index(truth, p, &at)) solid += truth.voxel_room[at] == sim::kVoxelOccupied ? 1 : 0;
    }
    if (solid * kStep < kSolid) return;
    ++out->edges_through_solid;
    // Breadth-first through free ground-truth voxels (26-connected) inside the ends' box grown by 1 m.
    const double vs = truth.config.voxel_size_m;
    const Eigen::Vector3i from = gt_cell(truth, a->position_m), to = gt_cell(truth, b->position_m);
    const Eigen::Vector3i lo = (from.cwiseMin(to).array() - static_cast<int>(std::ceil(1.0 / vs))).max(0).matrix();
    const Eigen::Vector3i hi =
        (from.cwiseMax(to).array() + static_cast<int>(std::ceil(1.0 / vs))).min(truth.dims.array() - 1).matrix();
    const Eigen::Vector3i ext = hi - lo + Eigen::Vector3i::Ones();
    if ((ext.array() <= 0).any()) return;
    std::vector<std::uint8_t> seen(static_cast<std::size_t>(ext.x()) * ext.y() * ext.z(), 0);
    const auto local = [&](const Eigen::Vector3i& q) {
      const Eigen::Vector3i d = q - lo;
      return (static_cast<std::size_t>(d.z()) * ext.y() + d.y()) * ext.x() + d.x();
    };
    const auto free_at = [&](const Eigen::Vector3i& q) {
      return (q.array() >= lo.array()).all() && (q.array() <= hi.array()).all() &&
             truth.voxel_room[truth.index(q.x(), q.y(), q.z())] != sim::kVoxelOccupied;
    };
    bool joined = false;
    std::vector<Eigen::Vector3i> queue;
    if (free_at(from)) {
      seen[local(from)] = 1;
      queue.push_back(from);
    }
    for (std::size_t head = 0; head < queue.size() && !joined; ++head) {
      const Eigen::Vector3i q = queue[head];
      if ((q - to).cwiseAbs().maxCoeff() <= 1) joined = true;
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const Eigen::Vector3i n = q + Eigen::Vector3i(dx, dy, dz);
            if (!free_at(n) || seen[local(n)] != 0) continue;
            seen[local(n)] = 1;
            queue.push_back(n);
          }
    }
    if (joined) return;
    ++out->edges_joining_apart;
    if (opt.verbose)
      std::printf("  edge joining apart: %.2f %.2f %.2f (clearance %.2f, %s) - %.2f %.2f %.2f (clearance %.2f, %s), "
                  "%.2f m through solid\n",
                  a->position_m.x(), a->position_m.y(), a->position_m.z(), a->distance_m,
                  a->is_active ? "active" : "inactive", b->position_m.x(), b->position_m.y(), b->position_m.z(),
                  b->distance_m, b->is_active ? "active" : "inactive", solid * kStep);
  });
  out->edges = out->place_edges;  // the graph also holds objects, agents and their edges to places
  out->mean_gvd_distance_m = bench::mean(distances);
  out->median_gvd_distance_m = quantile(distances, 0.5);
  std::vector<std::size_t> sizes;
  out->components = place_components(graph, &sizes);
  for (std::size_t n : sizes) out->components_3 += n >= 3 ? 1 : 0;
  if (!sizes.empty())
    out->largest_share = static_cast<double>(*std::max_element(sizes.begin(), sizes.end())) /
                         static_cast<double>(std::max<std::size_t>(1, distances.size()));
  std::set<std::int32_t> visited(tour.room_order.begin(), tour.room_order.end());
  if (floor_plan) {
    std::vector<Eigen::Vector3d> path;
    for (const auto& pose : tour.trajectory) path.push_back(pose.world_t_body_m);
    out->regions = free_space_regions_gt(truth, path, pc.min_clearance_m);
  } else {
    out->regions = free_space_regions(w, visited);
  }
  for (const world::Room& room : w.rooms) {
    if (visited.count(room.id) == 0) continue;
    for (const world::Polygon2& p : room.footprint_m) out->area_m2 += polygon_area(p);
  }
  std::printf("%s: %zu rooms (%zu visited), tour %.1f m, %zu keyframes at %dx%d\n", out->name.c_str(), w.rooms.size(), visited.size(), tour.length_m, out->keyframes,
              opt.width, opt.height);
  std::printf("  place nodes %zu, edges %zu; distance to the true GVD mean %.3f m, median %.3f m; components %zu "
              "(%zu with >= 3 nodes, largest holds %.1f %% of the nodes; free-space regions %zu); %.1f nodes per 100 m^2 of %.1f m^2; update median %.2f ms p99 %.2f ms max "
              "%.2f ms\n",
              out->nodes, out->edges, out->mean_gvd_distance_m, out->median_gvd_distance_m, out->components,
              out->components_3, 100.0 * out->largest_share, out->regions, 100.0 * static_cast<double>(out->nodes) / std::max(1.0, out->area_m2), out->area_m2,
              quantile(out->update_ms, 0.5), quantile(out->update_ms, 0.99),
              *std::max_element(out->update_ms.begin(), out->update_ms.end()));
  std::printf("  place edges through solid (walls, floors, slabs) for >= 0.1 m: %zu of %zu; of those, %zu join two "
              "free spaces that are apart within 1 m of them; places inside solid: %zu\n",
              out->edges_through_solid, out->place_edges, out->edges_joining_apart, out->places_in_solid);
  std::printf("  clearance above the true one by > 0.25 m: %.1f %% of the places, by > 0.5 m: %.1f %%\n",
              100.0 * static_cast<double>(out->clearance_over_25cm) / std::max<std::size_t>(1, out->nodes),
              100.0 * static_cast<double>(out->clearance_over_50cm) / std::max<std::size_t>(1, out->nodes));
  out->memory.print(stdout);
  if (places.counters().blocks_refused > 0)
    std::printf("  note: the ESDF block pool refused %llu blocks (window larger than the budget's pool)\n",
                static_cast<unsigned long long>(places.counters().blocks_refused));
  if (out->tsdf_evicted > 0)
    std::printf("  note: the TSDF pool evicted %llu blocks early (window larger than its pool)\n",
                static_cast<unsigned long long>(out->tsdf_evicted));
  if (opt.verbose) {
    places.counters().print(stdout);
    places.for_each_resource([](const memory::ResourceStats& s) { s.print(stdout); });
  }
  return true;
}

bool run_building(const Options& opt, std::uint64_t seed, BuildingResult* out) {
  world::BuildingConfig bc;
  bc.num_rooms = opt.rooms;
  bc.seed = seed;
  out->seed = seed;
  bc.two_floors = opt.two_floors;
  out->name = (opt.two_floors ? "two-floor building seed " : "building seed ") + std::to_string(seed);
  return run_world(opt, world::generate_building(bc), false, out);
}

// 1 ran, 0 skipped (no data), -1 failed.
int run_floor_plan(const Options& opt, BuildingResult* out) {
  const std::string occ_path = opt.plans_dir + "/" + opt.floorplan + (opt.furnished ? "_furnitures" : "") + ".png";
  if (!std::ifstream(opt.plans_dir + "/lab_ipa.png")) {
    std::printf("skipped: no benchmark floor plans in %s (the shared data directory is absent)\n",
                opt.plans_dir.c_str());
    return 0;
  }
  if (!std::ifstream(occ_path)) {
    std::fprintf(stderr, "floor plan %s not found; names: Freiburg52_scan, lab_c_scan, lab_intel, lab_ipa, "
                 "office_a, office_e\n", occ_path.c_str());
    return -1;
  }
  world::FloorPlanConfig fc;
  const world::WorldResult wr = world::import_floor_plan_files(occ_path, world::floor_plan_gt_path(occ_path), fc);
  if (!wr.ok) {
    std::fprintf(stderr, "%s: %s\n", occ_path.c_str(), wr.error.c_str());
    return -1;
  }
  out->seed = 0;
  out->name = opt.floorplan + (opt.furnished ? " furnished" : " plain");
  return run_world(opt, wr.world, true, out) ? 1 : -1;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parse(argc, argv, &opt)) {
    usage(argv[0]);
    return 2;
  }
  std::vector<BuildingResult> results;
  if (!opt.floorplan.empty()) {
    opt.seeds = {0};
    BuildingResult r;
    const int ran = run_floor_plan(opt, &r);
    if (ran < 0) return 1;
    if (ran == 0) return 0;
    results.push_back(std::move(r));
  } else {
    for (std::uint64_t seed : opt.seeds) {
      BuildingResult r;
      if (!run_building(opt, seed, &r)) return 1;
      results.push_back(std::move(r));
    }
  }
  std::vector<double> all_ms;
  double dist_sum = 0.0, area = 0.0;
  std::size_t nodes = 0, matched = 0, matched_3 = 0, over_25 = 0, over_50 = 0, place_edges = 0, through_solid = 0;
  std::size_t joining_apart = 0, in_solid = 0;
  double largest_share_sum = 0.0;
  for (const BuildingResult& r : results) {
    all_ms.insert(all_ms.end(), r.update_ms.begin(), r.update_ms.end());
    dist_sum += r.mean_gvd_distance_m * static_cast<double>(r.nodes);
    nodes += r.nodes;
    over_25 += r.clearance_over_25cm;
    over_50 += r.clearance_over_50cm;
    place_edges += r.place_edges;
    through_solid += r.edges_through_solid;
    joining_apart += r.edges_joining_apart;
    in_solid += r.places_in_solid;
    area += r.area_m2;
    matched += r.components == r.regions ? 1 : 0;
    matched_3 += r.components_3 == r.regions ? 1 : 0;
    largest_share_sum += r.largest_share;
  }
  const double mean_dist = nodes > 0 ? dist_sum / static_cast<double>(nodes) : 0.0;
  const double per_100 = area > 0 ? 100.0 * static_cast<double>(nodes) / area : 0.0;
  const double median_ms = quantile(all_ms, 0.5), p99_ms = quantile(all_ms, 0.99);
  const double max_ms = all_ms.empty() ? 0.0 : *std::max_element(all_ms.begin(), all_ms.end());
  std::printf("\nsummary over %zu %s (%zu keyframes):\n", results.size(),
              opt.floorplan.empty() ? "buildings" : "floor plan", all_ms.size());
  std::printf("  mean distance place node -> true GVD: %.3f m (target <= 0.15)\n", mean_dist);
  const double over_25_share = static_cast<double>(over_25) / static_cast<double>(std::max<std::size_t>(1, nodes));
  const double over_50_share = static_cast<double>(over_50) / static_cast<double>(std::max<std::size_t>(1, nodes));
  std::printf("  place clearance above the true clearance by > 0.25 m: %.1f %% of the places, by > 0.5 m: %.1f %%\n",
              100.0 * over_25_share, 100.0 * over_50_share);
  for (const BuildingResult& r : results)
    std::printf("  %s: %zu places components (%zu with >= 3 nodes; the largest holds %.1f %% of the nodes) for "
                "%zu connected free-space regions\n",
                r.name.c_str(), r.components, r.components_3, 100.0 * r.largest_share,
                r.regions);
  std::printf("  buildings with one component per region: %zu of %zu (counting components of >= 3 nodes: %zu)\n",
              matched, results.size(), matched_3);
  std::printf("  place nodes per 100 m^2: %.1f\n", per_100);
  const double solid_share =
      static_cast<double>(through_solid) / static_cast<double>(std::max<std::size_t>(1, place_edges));
  std::printf("  place edges through solid for >= 0.1 m: %zu of %zu (%.2f %%); joining two free spaces apart "
              "within 1 m of them: %zu; places inside solid: %zu of %zu\n",
              through_solid, place_edges, 100.0 * solid_share, joining_apart, in_solid, nodes);
  std::printf("  frontend update per keyframe (places and their sync, objects, inter-layer edges): median %.2f "
              "ms, p99 %.2f ms, max %.2f ms (places target median <= 10)\n",
              median_ms, p99_ms, max_ms);
  // Memory: the largest run's high water (the window's data does not grow with the tour).
  places::MemoryUse mem;
  std::size_t tsdf_arena = 0;
  for (const BuildingResult& r : results) {
    if (r.memory.window_used_bytes() >= mem.window_used_bytes()) mem = r.memory;
    tsdf_arena = std::max(tsdf_arena, r.tsdf_arena_bytes);
  }
  const double window_mb = static_cast<double>(mem.window_used_bytes()) / 1048576.0;
  std::printf("  ESDF + GVD in the window (places window %.1f m): %.2f MiB = %zu blocks x %zu bytes (%.2f MiB) + work "
              "lists %.2f MiB at their high water (target <= 16; the paper's system: 47.8 MB)\n",
              opt.window_radius_m > 0.0 ? opt.window_radius_m : places::Config{}.window_radius_m, window_mb,
              mem.blocks_high_water, mem.block_bytes, mem.esdf_used_bytes / 1048576.0,
              mem.work_lists_used_bytes / 1048576.0);
  std::printf("  planned: ESDF blocks %.2f MiB + work lists %.2f MiB; place bookkeeping %.2f MiB used of %.2f MiB "
              "planned; places arena %.2f MiB; reconstruction arena %.2f MiB\n",
              mem.esdf_planned_bytes / 1048576.0, mem.work_lists_planned_bytes / 1048576.0,
              mem.places_used_bytes / 1048576.0, mem.places_planned_bytes / 1048576.0,
              mem.arena_planned_bytes / 1048576.0, tsdf_arena / 1048576.0);
  // The deployed board's table plans fewer ESDF blocks: what its window reserves (capacity, not use).
  std::size_t xavier_window_planned = 0;
  {
    places::Capacities xc;
    xc.max_blocks = budgets::xavier_nx::places::kMaxBlocks;
    xc.place_nodes = budgets::xavier_nx::places::kPlaceNodes;
    xc.inactive_cells = budgets::xavier_nx::places::kInactiveCells;
    xc.observed_blocks = budgets::xavier_nx::places::kObservedBlocks;
    xc.pending_relinks = budgets::xavier_nx::places::kPendingRelinks;
    auto xavier = std::make_unique<places::Places>();
    std::string error;
    if (xavier->init(places::Config{}, xc, budgets::xavier_nx::places::kArenaBytes, &error)) {
      const places::MemoryUse xm = xavier->memory_use();
      xavier_window_planned = xm.esdf_planned_bytes + xm.work_lists_planned_bytes;
      std::printf("  xavier_nx table: ESDF + GVD planned %.2f MiB (%zu blocks: %.2f MiB + work lists %.2f MiB), places "
                  "arena %.2f MiB\n",
                  xavier_window_planned / 1048576.0, xm.blocks_capacity, xm.esdf_planned_bytes / 1048576.0,
                  xm.work_lists_planned_bytes / 1048576.0, xm.arena_planned_bytes / 1048576.0);
    } else {
      std::fprintf(stderr, "xavier_nx places table: %s\n", error.c_str());
    }
  }

  if (!opt.json_path.empty()) {
    std::string seeds;
    for (std::uint64_t s : opt.seeds) seeds += (seeds.empty() ? "" : ",") + std::to_string(s);
    char cond[1024];
    const std::string world_desc =
        opt.floorplan.empty() ? std::to_string(opt.rooms) + "-room generated " + (opt.two_floors ? "two-floor " : "") +
                                    "buildings seeds " + seeds + settings_changed(opt.places)
                              : "extruded floor plan " + opt.floorplan + (opt.furnished ? " furnished" : " plain");
    std::snprintf(cond, sizeof(cond),
                  "%s, %dx%d %.0f deg hfov, %.1f Hz keyframes, voxel 0.10 m, GVD voxel 0.20 m, places window "
                  "%.1f m, %s, noise-free depth, one core",
                  world_desc.c_str(), opt.width, opt.height, opt.hfov_deg, opt.rate_hz,
                  opt.window_radius_m > 0.0 ? opt.window_radius_m : places::Config{}.window_radius_m,
                  opt.odometry.describe().c_str());
    bench::Figures figures(cond);
    const auto add = [&](const std::string& name, double value, const char* unit) { figures.add(name, value, unit); };
    add("places_eval.node_to_gvd_mean", mean_dist, "m");
    add("places_eval.clearance_over_25cm_share", over_25_share, "fraction");
    add("places_eval.clearance_over_50cm_share", over_50_share, "fraction");
    add("places_eval.buildings_one_component_per_region", static_cast<double>(matched), "buildings");
    add("places_eval.buildings", static_cast<double>(results.size()), "buildings");
    std::size_t components = 0, components_3 = 0, regions = 0;
    for (const BuildingResult& r : results) {
      components += r.components;
      components_3 += r.components_3;
      regions += r.regions;
    }
    add("places_eval.buildings_one_component_per_region_min3", static_cast<double>(matched_3), "buildings");
    add("places_eval.places_components_min3", static_cast<double>(components_3), "components");
    add("places_eval.largest_component_share", largest_share_sum / static_cast<double>(results.size()), "fraction");
    add("places_eval.places_components", static_cast<double>(components), "components");
    add("places_eval.free_space_regions", static_cast<double>(regions), "regions");
    add("places_eval.nodes_per_100m2", per_100, "nodes/100 m^2");
    add("places_eval.edges_through_solid", static_cast<double>(through_solid), "edges");
    add("places_eval.edges_through_solid_share", solid_share, "fraction");
    add("places_eval.edges_joining_apart", static_cast<double>(joining_apart), "edges");
    add("places_eval.places_in_solid", static_cast<double>(in_solid), "places");
    add("places_eval.frontend_update_ms_median", median_ms, "ms");
    add("places_eval.frontend_update_ms_p99", p99_ms, "ms");
    add("places_eval.frontend_update_ms_max", max_ms, "ms");
    for (const BuildingResult& r : results) {
      std::string key = r.name;
      for (char& ch : key)
        if (ch == ' ') ch = '_';
      add("places_eval." + key + ".places_components", static_cast<double>(r.components), "components");
      add("places_eval." + key + ".free_space_regions", static_cast<double>(r.regions), "regions");
      add("places_eval." + key + ".node_to_gvd_mean", r.mean_gvd_distance_m, "m");
      add("places_eval." + key + ".nodes_per_100m2", 100.0 * static_cast<double>(r.nodes) / std::max(1.0, r.area_m2),
          "nodes/100 m^2");
      add("places_eval." + key + ".frontend_update_ms_median", quantile(r.update_ms, 0.5), "ms");
      add("places_eval." + key + ".frontend_update_ms_p99", quantile(r.update_ms, 0.99), "ms");
    }
    add("places_eval.window_esdf_gvd_bytes", static_cast<double>(mem.window_used_bytes()), "bytes");
    add("places_eval.window_esdf_blocks_bytes", static_cast<double>(mem.esdf_used_bytes), "bytes");
    add("places_eval.window_esdf_blocks_high_water", static_cast<double>(mem.blocks_high_water), "blocks");
    add("places_eval.window_work_lists_bytes", static_cast<double>(mem.work_lists_used_bytes), "bytes");
    add("places_eval.window_esdf_gvd_planned_bytes",
        static_cast<double>(mem.esdf_planned_bytes + mem.work_lists_planned_bytes), "bytes");
    if (xavier_window_planned > 0)
      add("places_eval.xavier_nx_window_esdf_gvd_planned_bytes", static_cast<double>(xavier_window_planned), "bytes");
    add("places_eval.place_bookkeeping_bytes", static_cast<double>(mem.places_used_bytes), "bytes");
    add("places_eval.place_bookkeeping_planned_bytes", static_cast<double>(mem.places_planned_bytes), "bytes");
    add("places_eval.places_arena_planned_bytes", static_cast<double>(mem.arena_planned_bytes), "bytes");
    add("places_eval.reconstruction_arena_bytes", static_cast<double>(tsdf_arena), "bytes");
    add("places_eval.window_radius", opt.window_radius_m > 0.0 ? opt.window_radius_m : places::Config{}.window_radius_m,
        "m");
    if (!figures.write(opt.json_path)) return 1;
  }
  return 0;
}
