// Rooms evaluation: benchmark floor plans (IPA, plain and furnished) extruded to 3D and generated two-floor buildings
// are explored by the simulated robot (ground-truth poses, or drifting ones with --odometry sim|vio, noise-free
// depth) and run through the app's stages (bench/eval_harness.h): reconstruction (TSDF) and frontend every
// keyframe, then the backend stage's final door stage and room finder once on the final graph. Scored with the
// benchmark's max-overlap precision and recall (mean over rooms and area-weighted) against the ground truth, in the
// world frame (bench/rooms/room_score.h).
//
// How estimated rooms become pixel sets (documented in the report): the free cells of a 2D raster (the floor plan's
// own pixels, 0.05 m; for generated buildings a 0.05 m raster of each floor's room footprints) are labelled by a
// multi-source breadth-first wavefront (8-connected, through free cells only) started from the cell of every place
// that has a room, so every free cell takes the room of the place geodesically nearest to it; cells farther than
// --max-reach-m from every place stay unlabelled (not seen). Scoring is restricted to cells that are free and
// inside a ground-truth room: |r_e| counts r_e's cells there, |r_g| all of r_g's free cells (unlabelled included,
// so unexplored space lowers recall).
//
// Peers, scored the same way: on the IPA plans, classical 2D segmentations of the complete plan (distance transform
// at two thresholds, morphological); on every plan and generated building, Hydra's room clustering
// (rooms::Config::paper(), the paper's plateau seeding, without our door stage) on the same explored places, the
// peer that saw what our robot saw. Each total prints ours over the peer.
//
// Room parameters come from the command line (--seeding plateau|persistence, --min-component, --alpha,
// --min-persistence-m, ...); --cache-dir saves each run's frontend graph and reuses it, so a parameter sweep
// explores each plan once.
#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <memory>
#include <string>
#include <vector>

#include "bench/figures.h"
#include "bench/eval_harness.h"
#include "bench/rooms/room_label_score.h"
#include "bench/rooms/room_score.h"
#include "bench/rooms/rooms_eval_io.h"
#include "bench/rooms/rooms_eval_options.h"
#include "bench/sim_tour.h"
#include "budgets/budget_table.h"
#include "core/params/params.h"
#include "core/places/places_params.h"
#include "core/doors/door_params.h"
#include "core/rooms/rooms_params.h"
#include "core/doors/door_detector.h"
#include "core/rooms/room_finder.h"
#include "core/scene_graph/scene_graph.h"
#include "core/scene_graph/spark_dsg_json.h"
#include "drivers/render/ray_scene.h"
#include "drivers/sim/exploration.h"
#include "drivers/sim/sim_camera.h"
#include "drivers/world/building_generator.h"
#include "drivers/world/floor_plan_import.h"
#include "bench/rooms/floor_plan_rooms.h"
#include "drivers/world/world_query.h"


namespace {

using namespace qsg;
namespace sg = scene_graph;
using bench::label_from_places;
using bench::Raster;
using bench::score;
using bench::truth_near;
using bench::apply_door_oracle;
using bench::dump_places;
using bench::label_rooms;
using bench::label_truth_rooms;
using bench::LabelScore;
using bench::write_image;
using bench::write_surface;
using Options = bench::RoomsEvalOptions;


double ratio(double a, double b) { return b > 0.0 ? a / b : 0.0; }

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}



using Score = bench::RoomSegmentationScore;



struct RunStats {
  std::size_t keyframes = 0, places = 0, rooms = 0;
  double tour_m = 0.0, rooms_ms = 0.0, dilation_m = 0.0, wall_s = 0.0;
  std::size_t unreachable = 0;
  std::size_t peeked = 0;                     // unreachable rooms the tour looked into
  std::vector<std::int32_t> unreachable_ids;  // world rooms outside the start's free-space component
  std::vector<rooms::Door> doors;             // --doors: the doors found on the robot's surface
  std::size_t door_edges_closed = 0;
  // ... and those edges as they were before (the Hydra peer runs on the graph without the door stage).
  std::vector<bench::EdgeBefore> uncut_edges;
  double door_ms = 0.0;                       // the door stage's wall time (find_doors + cut_place_edges)
  std::vector<rooms::Door> online_doors;      // --doors online: the DoorSet when the exploration ended
  std::vector<double> pass_ms;                // ... each window pass's wall time
  std::size_t wall_tiles = 0;                 // ... the wall map's tiles in use
  std::size_t passes_climbing = 0;            // ... passes skipped on stairs
  std::size_t doors_added = 0;                // ... doors new to the set, summed over passes
  std::size_t doors_dropped = 0;              // ... doors dropped (online_misses_to_drop missed passes)
  std::size_t doors_kept_missed = 0;          // ... kept doors a pass missed, still kept
  std::size_t doors_bypassed = 0;             // ... found doors the window's places went round (not kept)
  // The doors the room finder read (final stage, or online), against the ground truth (IPA plans): a door whose two
  // sides lie in two ground-truth rooms separates rooms; one with both sides in the same room is a false door (it
  // can only split that room); unknown: a side in no room (outside, or unlabelled free space).
  bench::DoorJudgement judged;
  // The run's stages (bench/eval_harness.h), kept for the room finder's later runs (--door-oracle-m); with
  // --doors online from a cache, the doors and the last window's sight lines read back from it.
  std::shared_ptr<bench::EvalPipeline> pipeline;
  std::shared_ptr<rooms::WallSight> recorded_sight;
  std::size_t visible_merges = 0;
};

// The classical 2D segmentations of the complete plan (IPA plans), scored like ours: the peers that see everything.
struct Peers {
  Score distance, distance_plateau, erosion;
  double distance_level_m = 0.0, distance_plateau_level_m = 0.0, erosion_level_m = 0.0;
  // Hydra's room clustering (rooms::Config::paper(): one plateau dilation for the graph, 15-place components, no
  // extent split) on the same explored places, without the door stage (the paper has none): the peer that sees what
  // our robot saw. Not run with --door-oracle-m.
  Score hydra;
  bool has_hydra = false;
  double hydra_dilation_m = 0.0;
};

// The stages as the app configures them, from the options; frontend_stages false: the backend alone (a cached graph).
bench::PipelineConfig pipeline_config(const Options& opt, bool frontend_stages) {
  bench::PipelineConfig pc;
  pc.frontend_stages = frontend_stages;
  pc.frontend.places = opt.places;
  // Every keyframe's free space observed (Frontend::observe), as the app does; before the shared harness (issue
  // 32) this evaluation did not, so each places cycle carved the latest frame only (bench/results/rooms.md).
  pc.backend = true;
  pc.backend_stage.rooms = opt.rooms;
  pc.backend_stage.doors = opt.door;
  pc.backend_stage.doors_online = opt.online_doors;
  pc.backend_stage.doors_online_every_n = static_cast<std::uint32_t>(opt.online_every);
  return pc;
}

// --doors: the final door stage on the robot's surface; it closes the place edges that cross the doors.
bool apply_doors(const Options& opt, const std::string& name, const std::vector<Eigen::Vector3f>& surface,
                 RunStats* stats) {
  if (!opt.doors) return true;
  if (surface.empty()) {
    std::fprintf(stderr, "%s: --doors needs the robot's surface (a cache without .surface.f32 files: explore again)\n",
                 name.c_str());
    return false;
  }
  reconstruction::Mesh mesh;
  mesh.vertices.resize(surface.size());
  for (std::size_t i = 0; i < surface.size(); ++i) {
    mesh.vertices[i].x = surface[i].x();
    mesh.vertices[i].y = surface[i].y();
    mesh.vertices[i].z = surface[i].z();
  }
  const auto t0 = std::chrono::steady_clock::now();
  const backend::BackendStage::FinalDoors d = stats->pipeline->close_doors(mesh, &stats->uncut_edges);
  stats->door_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (!d.ok) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), d.error.c_str());
    return false;
  }
  stats->doors = d.found;
  stats->door_edges_closed = d.edges_closed;
  std::printf("  %s: doors: %zu (%zu candidates, %zu gone round by the places) in %zu storey slice(s), %zu place "
              "edges closed, %zu more through walls, %.0f ms\n",
              name.c_str(), d.doors, d.candidates, d.bypassed, d.slices, stats->door_edges_closed,
              static_cast<std::size_t>(d.edges_through_walls), stats->door_ms);
  return true;
}

// The room finder on the final graph (five updates, the median time reported): the backend stage's final update
// (with the final door stage's sight lines, or the online doors and the last pass's window), or with --doors online
// from a cache the doors and sight lines read back from it.
bool run_rooms(const Options& opt, const std::string& name, RunStats* stats) {
  bench::EvalPipeline& pipeline = *stats->pipeline;
  const bool recorded = !pipeline.config().frontend_stages && opt.online_doors;
  std::vector<double> ms;
  rooms::UpdateResult r;
  for (int i = 0; i < 5; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    std::string error;
    if (!recorded) {
      r = pipeline.update_rooms();
    } else if (!pipeline.update_rooms_recorded(stats->online_doors, stats->recorded_sight.get(), &r, &error)) {
      std::fprintf(stderr, "%s: rooms: %s\n", name.c_str(), error.c_str());
      return false;
    }
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  const rooms::RoomFinder& finder = pipeline.room_finder();
  std::printf("  %s: Betti curve (delta m: components):", name.c_str());
  for (std::size_t i = 0; i < finder.curve_size(); i += 5) std::printf(" %.2f:%u", finder.dilation_at(i), finder.betti_at(i));
  std::printf("\n");
  if (recorded ? stats->recorded_sight != nullptr : pipeline.has_sight())
    std::printf("  %s: sight lines: %zu rooms merged into a room they see (%zu of them near the boundary only; %zu "
                "room pairs tested; %zu place pairs in two rooms touching in sight, %zu dropped), %zu open place "
                "edges read as closed through walls\n",
                name.c_str(), r.visible_merges, r.visible_near_merges, r.visible_pairs, r.visible_touching_pairs,
                r.visible_touching_dropped, r.edges_through_walls);
  stats->visible_merges = r.visible_merges;
  stats->places = r.places;
  stats->rooms = r.rooms;
  stats->rooms_ms = median(ms);
  stats->dilation_m = r.dilation_m;
  if (r.outcome != rooms::Outcome::kOk)
    std::fprintf(stderr, "%s: rooms: %s (%zu places)\n", name.c_str(), rooms::to_string(r.outcome), r.places);
  return true;
}

// Reads a cached run back: the graph, the robot's surface and, with --doors online, the doors and the last
// window's sight lines. False when the cache cannot serve this run.
bool read_cached_run(const Options& opt, const std::string& name, const std::string& cache_path,
                     const std::string& surface_path, const std::string& doors_path, sg::SceneGraph* graph,
                     std::vector<Eigen::Vector3f>* surface, RunStats* stats) {
  const sg::JsonImportResult in = sg::read_spark_dsg_json_file(cache_path, *graph);
  if (!in.ok) {
    std::fprintf(stderr, "%s: %s\n", cache_path.c_str(), in.error.c_str());
    return false;
  }
  if (!bench::read_surface(surface_path, surface)) surface->clear();
  if (!opt.online_doors) return true;
  if (!bench::read_doors(doors_path, &stats->online_doors)) {
    std::fprintf(stderr, "%s: --doors online needs %s (a cache made without --doors online, or with other online "
                 "settings: explore again in a new cache dir)\n", name.c_str(), doors_path.c_str());
    return false;
  }
  // The last window's sight lines (caches from before they existed have none: no sight lines).
  rooms::DoorRaster window;
  std::vector<std::uint8_t> structure;
  double slice_z = 0.0;
  std::string error;
  if (bench::read_window(doors_path + ".sight", &window, &structure, &slice_z)) {
    stats->recorded_sight = std::make_shared<rooms::WallSight>();
    if (!stats->recorded_sight->add_structure(window, structure.data(), slice_z, opt.door, &error, /*window=*/true))
      std::fprintf(stderr, "%s: online sight lines: %s\n", name.c_str(), error.c_str());
  } else {
    std::printf("  %s: no %s.sight in the cache: the online rooms without sight lines\n", name.c_str(),
                doors_path.c_str());
  }
  return true;
}

// --doors online, after the exploration: the door set and the passes' figures, and the last window's sight lines
// and the doors into the cache.
void collect_online_doors(const std::string& name, const std::string& doors_path, RunStats* stats) {
  const rooms::OnlineDoors& online = stats->pipeline->backend().online_doors();
  for (std::size_t i = 0; i < online.doors().size(); ++i) stats->online_doors.push_back(online.doors()[i]);
  const rooms::WallSight& window = online.sight();
  if (window.slices() > 0 && !doors_path.empty() &&
      !bench::write_window(window.raster(0), window.structure(0), window.slice_z(0), doors_path + ".sight"))
    std::fprintf(stderr, "cache: cannot write %s.sight\n", doors_path.c_str());
  stats->wall_tiles = online.wall_map().tile_stats().in_use;
  std::sort(stats->pass_ms.begin(), stats->pass_ms.end());
  std::printf("  %s: online doors: %zu after %zu window passes (median %.1f ms, max %.1f ms; %zu skipped on stairs), "
              "%zu wall tiles; over the passes %zu doors added, %zu dropped, %zu kept through a miss, %zu found doors "
              "gone round by the places\n",
              name.c_str(), stats->online_doors.size(), stats->pass_ms.size(),
              stats->pass_ms.empty() ? 0.0 : stats->pass_ms[stats->pass_ms.size() / 2],
              stats->pass_ms.empty() ? 0.0 : stats->pass_ms.back(), stats->passes_climbing, stats->wall_tiles,
              stats->doors_added, stats->doors_dropped, stats->doors_kept_missed, stats->doors_bypassed);
  if (!doors_path.empty() && !bench::write_doors(stats->online_doors, doors_path))
    std::fprintf(stderr, "cache: cannot write %s\n", doors_path.c_str());
}

// Explores and runs the app's stages (bench/eval_harness.h): reconstruction and frontend every keyframe, the online
// door passes (--doors online), then the final door stage (--doors) and the room finder on the whole map. *surface:
// the robot's mesh vertices (from the cache when the graph comes from there; empty when the cache has none).
// world_seed seeds the odometry's drift (--odometry).
bool run_pipeline(const Options& opt, const world::World& w, std::uint64_t world_seed, const std::string& plan_key,
                  sg::SceneGraph* graph, std::vector<Eigen::Vector3f>* surface, RunStats* stats) {
  const auto start = std::chrono::steady_clock::now();
  const std::string odometry_key =
      opt.odometry.ground_truth()
          ? std::string()
          : std::string(".odom-") + sim::to_string(opt.odometry.level) + "-" + std::to_string(opt.odometry.seed);
  const std::string key = plan_key + (opt.look_into_unreachable ? ".peek" : "") + odometry_key;
  const std::string cache_path = opt.cache_dir.empty() ? "" : opt.cache_dir + "/" + key + ".json";
  const std::string surface_path = opt.cache_dir.empty() ? "" : opt.cache_dir + "/" + key + ".surface.f32";
  // The online doors depend on the pass settings, so those name the file: a cache explored with other settings is
  // not read back as if it were this one (the --door-* detector flags are not in the name: change them in a new
  // cache dir).
  char online_settings[96];
  std::snprintf(online_settings, sizeof online_settings, ".every%d.misses%d.match%.2f", opt.online_every,
                opt.door.online_misses_to_drop, opt.door.online_match_m);
  const std::string doors_path =
      opt.cache_dir.empty() ? "" : opt.cache_dir + "/" + key + ".online_doors" + online_settings + ".f64";
  sim::ExplorationConfig ec;
  ec.robot_radius_m = opt.robot_radius_m;
  ec.look_into_unreachable_rooms = opt.look_into_unreachable;
  sim::SimCamera::Config cc;
  cc.intrinsics = bench::camera_of_fov(opt.width, opt.height, opt.hfov_deg);
  cc.rate_hz = opt.rate_hz;
  bench::SimTour sim_tour;
  std::string error;
  if (!bench::make_sim_tour(w, ec, cc, render::Renderer::Config{}, &sim_tour, &error)) {
    std::fprintf(stderr, "%s: %s\n", w.name.c_str(), error.c_str());
    return false;
  }
  bench::set_odometry(opt.odometry, world_seed, &sim_tour);
  const sim::ExplorationResult& tour = sim_tour.tour;
  stats->tour_m = tour.length_m;
  stats->unreachable = tour.unreachable_rooms.size();
  stats->unreachable_ids = tour.unreachable_rooms;
  stats->peeked = tour.peeked_rooms.size();
  const bool cached = !cache_path.empty() && std::ifstream(cache_path).good();
  if (cached && !read_cached_run(opt, w.name, cache_path, surface_path, doors_path, graph, surface, stats))
    return false;
  stats->pipeline = std::make_shared<bench::EvalPipeline>();
  bench::EvalPipeline& pipeline = *stats->pipeline;
  if (!pipeline.init(pipeline_config(opt, !cached), graph, &error)) {
    std::fprintf(stderr, "%s: %s\n", w.name.c_str(), error.c_str());
    return false;
  }
  if (!cached) {
    const auto note_pass = [&](const bench::FrontendStep& step) {
      if (step.pass.climbing) ++stats->passes_climbing;
      if (!step.door_pass) return;
      stats->doors_added += step.pass.added;
      stats->doors_dropped += step.pass.removed;
      stats->doors_kept_missed += step.pass.missed;
      stats->doors_bypassed += step.pass.bypassed;
      stats->pass_ms.push_back(step.pass_ms);
    };
    Eigen::Vector3d last = Eigen::Vector3d::Zero();
    std::uint64_t t_last = 0;
    stats->keyframes = pipeline.explore(sim_tour, [&](const bench::FrontendStep& step) {
      note_pass(step);
      last = step.world_T_camera.translation();
      t_last = step.time_ns;
    });
    note_pass(pipeline.finish(last, t_last));
    if (opt.online_doors) collect_online_doors(w.name, doors_path, stats);
    reconstruction::Mesh mesh;
    pipeline.tsdf().extract_full_mesh(&mesh);
    surface->clear();
    surface->reserve(mesh.vertices.size());
    for (const reconstruction::MeshVertex& v : mesh.vertices) surface->emplace_back(v.x, v.y, v.z);
    if (!cache_path.empty() && !sg::write_spark_dsg_json_file(*graph, cache_path, &error))
      std::fprintf(stderr, "cache: %s\n", error.c_str());
    if (!surface_path.empty() && !bench::write_surface(*surface, surface_path))
      std::fprintf(stderr, "cache: cannot write %s\n", surface_path.c_str());
  }
  if (!apply_doors(opt, w.name, *surface, stats)) return false;
  const bool ok = run_rooms(opt, w.name, stats);
  stats->wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return ok;
}

// The Hydra peer (Peers::hydra): the door stage's cuts undone and our rooms removed, then the paper's room
// clustering on the same graph. The graph is left with the peer's rooms, so call it after everything that reads ours.
bool run_hydra_peer(const std::string& name, const RunStats& st, sg::SceneGraph* graph, double* dilation_m) {
  for (const auto& [ends, info] : st.uncut_edges)
    if (sg::EdgeAttributes* e = graph->edge_info(ends.first, ends.second)) *e = info;
  std::vector<sg::NodeId> ours;
  graph->for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind == sg::NodeKind::kRoom || n.kind == sg::NodeKind::kBuilding) ours.push_back(n.id);
  });
  for (const sg::NodeId id : ours) graph->remove_node(id);
  auto finder = std::make_unique<rooms::RoomFinder>();
  std::string error;
  if (!finder->init(rooms::Config::paper(), rooms::Capacities::from_scene_graph(graph->capacities()), 0, &error)) {
    std::fprintf(stderr, "%s: Hydra peer: %s\n", name.c_str(), error.c_str());
    return false;
  }
  const rooms::UpdateResult r = finder->update(graph, 0, nullptr);
  *dilation_m = r.dilation_m;
  if (r.outcome != rooms::Outcome::kOk)
    std::fprintf(stderr, "%s: Hydra peer: %s (%zu places)\n", name.c_str(), rooms::to_string(r.outcome), r.places);
  return true;
}

void print_line(const std::string& name, const Score& s, const RunStats& st) {
  std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu | places %zu, delta* %.2f m, "
              "rooms update %.2f ms, %zu keyframes, tour %.0f m, %zu unreachable (%zu looked into), %.0f s\n",
              name.c_str(), s.precision_mean, s.recall_mean, s.precision_area, s.recall_area, s.rooms_found,
              s.rooms_truth, st.places, st.dilation_m, st.rooms_ms, st.keyframes, st.tour_m, st.unreachable,
              st.peeked, st.wall_s);
  std::fflush(stdout);
}

// *peers: the classical distance-transform (its level by the most regions, and by the alpha plateau of their curve)
// and morphological segmentations of the complete plan (the benchmark's own occupancy image, furniture included in
// the furnished variant), scored the same way.
void print_peer(const std::string& name, const Score& s, const char* level_name, double level_m) {
  std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu | complete plan, %s %.2f m\n",
              name.c_str(), s.precision_mean, s.recall_mean, s.precision_area, s.recall_area, s.rooms_found,
              s.rooms_truth, level_name, level_m);
}


bool eval_plan(const Options& opt, const std::string& map, bool furnished, Score* out, RunStats* st,
               Score* reachable, Score* oracle, Peers* peers) {
  const std::string occ_path = opt.plans_dir + "/" + map + (furnished ? "_furnitures" : "") + ".png";
  const std::string gt_path = world::floor_plan_gt_path(occ_path);
  world::FloorPlanConfig fc;
  fc.furniture_height_m = furnished ? opt.furniture_height_m : 0.0;
  const world::WorldResult wr =
      fc.furniture_height_m > 0.0
          ? world::import_furnished_floor_plan_files(opt.plans_dir + "/" + map + ".png", occ_path, gt_path, fc)
          : world::import_floor_plan_files(occ_path, gt_path, fc);
  if (!wr.ok) {
    std::fprintf(stderr, "%s\n", wr.error.c_str());
    return false;
  }
  auto graph = std::make_unique<sg::SceneGraph>();
  std::string error;
  if (!graph->init(sg::capacities_from_budget(), sg::arena_bytes_from_budget(), &error)) {
    std::fprintf(stderr, "scene graph: %s\n", error.c_str());
    return false;
  }
  char furniture_key[32] = "";
  if (fc.furniture_height_m > 0.0) std::snprintf(furniture_key, sizeof(furniture_key), "_h%.2f", fc.furniture_height_m);
  std::vector<Eigen::Vector3f> surface;
  if (!run_pipeline(opt, wr.world, 0, map + (furnished ? "_furnished" : "_plain") + furniture_key, graph.get(),
                    &surface, st))
    return false;
  // Ground truth straight from the benchmark's image: 8-connected white regions of more than 100 px.
  bench::PlanRaster plan;
  std::string read_error;
  if (!bench::read_plan_raster(occ_path, gt_path, fc, &plan, &read_error)) {
    std::fprintf(stderr, "%s\n", read_error.c_str());
    return false;
  }
  Raster ras;
  ras.cols = plan.cols;
  ras.rows = plan.rows;
  ras.res_m = fc.resolution_m_per_px;
  ras.free = std::move(plan.free);
  ras.truth = std::move(plan.truth);
  if (peers != nullptr) {
    bench::DistanceSegmentationConfig dc;
    dc.resolution_m = ras.res_m;
    bench::MorphologicalSegmentationConfig mc;
    mc.resolution_m = ras.res_m;
    bench::DistanceSegmentationConfig dpc = dc;
    dpc.level = bench::DistanceSegmentationConfig::Level::kPlateau;
    bench::PlanSegmentation by_distance, by_distance_plateau, by_erosion;
    const char* why = nullptr;
    if (!bench::segment_by_distance_transform(ras.free, ras.cols, ras.rows, dc, &by_distance, &why) ||
        !bench::segment_by_distance_transform(ras.free, ras.cols, ras.rows, dpc, &by_distance_plateau, &why) ||
        !bench::segment_by_erosion(ras.free, ras.cols, ras.rows, mc, &by_erosion, &why)) {
      std::fprintf(stderr, "%s: %s\n", map.c_str(), why);
      return false;
    }
    peers->distance = bench::score_room_segmentation(ras.free, ras.truth, by_distance.labels);
    peers->distance_plateau = bench::score_room_segmentation(ras.free, ras.truth, by_distance_plateau.labels);
    peers->erosion = bench::score_room_segmentation(ras.free, ras.truth, by_erosion.labels);
    peers->distance_level_m = by_distance.level_m;
    peers->distance_plateau_level_m = by_distance_plateau.level_m;
    peers->erosion_level_m = by_erosion.level_m;
  }
  if (opt.door_oracle_m >= 0.0) {
    const std::size_t doors = apply_door_oracle(ras, opt.door_oracle_m, graph.get());
    std::printf("  %s: door oracle: %zu place edges between ground-truth rooms set to %.2f m\n", map.c_str(), doors,
                opt.door_oracle_m);
    if (!run_rooms(opt, map, st)) return false;
  }
  if (oracle != nullptr) {
    label_from_places(*graph, -1e9, 1e9, opt.max_reach_m, &ras, /*oracle=*/true);
    *oracle = score(ras);
  }
  label_from_places(*graph, -1e9, 1e9, opt.max_reach_m, &ras);
  *out = score(ras);
  st->judged = bench::check_doors(ras, opt.online_doors ? st->online_doors : st->doors);
  if (!opt.dump_dir.empty()) {
    const std::string stem = opt.dump_dir + "/" + map + (furnished ? "_furnished" : "_plain");
    dump_places(*graph, ras, stem + ".txt", opt.online_doors ? st->online_doors : st->doors);
    if (!surface.empty() && !write_surface(surface, stem + ".surface.f32"))
      std::fprintf(stderr, "--dump-places: cannot write %s.surface.f32\n", stem.c_str());
  }
  if (!opt.images_dir.empty())
    write_image(ras, opt.images_dir + "/" + map + (furnished ? "_furnished" : "_plain") + "_rooms.png", st->doors);
  // The same score over the rooms the robot could enter: ground-truth rooms the tour could not reach (closed doors
  // in the scan, or doors narrower than the robot) are left out. Each unreachable world room is the ground-truth
  // region holding most of its footprint's cells.
  if (reachable != nullptr) {
    std::set<std::int32_t> excluded;
    for (const std::int32_t id : st->unreachable_ids) {
      const world::Room* room = nullptr;
      for (const world::Room& candidate : wr.world.rooms)
        if (candidate.id == id) room = &candidate;
      if (room == nullptr) continue;
      std::map<std::int32_t, int> votes;
      for (int r = 0; r < ras.rows; ++r)
        for (int c = 0; c < ras.cols; ++c) {
          const std::int32_t t = ras.truth[ras.idx(c, r)];
          if (t <= 0) continue;
          for (const world::Polygon2& poly : room->footprint_m)
            if (world::point_in_polygon(poly, ras.center_of(c, r))) ++votes[t];
        }
      if (!votes.empty())
        excluded.insert(std::max_element(votes.begin(), votes.end(), [](const auto& a, const auto& b) {
                          return a.second < b.second;
                        })->first);
    }
    Raster masked = ras;
    for (std::int32_t& t : masked.truth)
      if (excluded.count(t) != 0) t = 0;
    *reachable = score(masked);
  }
  if (peers != nullptr && opt.door_oracle_m < 0.0) {
    if (!run_hydra_peer(map, *st, graph.get(), &peers->hydra_dilation_m)) return false;
    label_from_places(*graph, -1e9, 1e9, opt.max_reach_m, &ras);
    peers->hydra = score(ras);
    peers->has_hydra = true;
  }
  return true;
}


bool eval_generated(const Options& opt, std::uint64_t seed, Score* out, RunStats* st, LabelScore* labels,
                    Score* oracle, Score* hydra) {
  world::BuildingConfig bc;
  bc.seed = seed;
  bc.num_rooms = opt.generated_rooms;
  bc.two_floors = true;
  world::World w = world::generate_building(bc);
  w.name = "generated_two_floor_" + std::to_string(seed);
  auto graph = std::make_unique<sg::SceneGraph>();
  std::string error;
  if (!graph->init(sg::capacities_from_budget(), sg::arena_bytes_from_budget(), &error)) return false;
  std::vector<Eigen::Vector3f> surface;
  if (!run_pipeline(opt, w, seed, w.name, graph.get(), &surface, st)) return false;
  label_rooms(w, *graph, labels);
  label_truth_rooms(w, labels);
  std::vector<bench::FloorRaster> floor_rasters = bench::generated_floor_rasters(w, bc);
  Score total, bound;
  for (bench::FloorRaster& f : floor_rasters) {
    Raster& ras = f.raster;
    const double z_lo = f.z_min_m, z_hi = f.z_max_m;
    label_from_places(*graph, z_lo, z_hi, opt.max_reach_m, &ras, /*oracle=*/true);
    bound.add(score(ras));
    label_from_places(*graph, z_lo, z_hi, opt.max_reach_m, &ras);
    total.add(score(ras));
    const std::string stem = w.name + "_floor" + std::to_string(f.floor_index);
    if (!opt.dump_dir.empty())
      dump_places(*graph, ras, opt.dump_dir + "/" + stem + ".txt", opt.online_doors ? st->online_doors : st->doors,
                  z_lo, z_hi);
    if (!opt.images_dir.empty()) write_image(ras, opt.images_dir + "/" + stem + "_rooms.png", st->doors);
  }
  *out = total;
  *oracle = bound;
  if (hydra != nullptr) {
    double dilation_m = 0.0;
    if (!run_hydra_peer(w.name, *st, graph.get(), &dilation_m)) return false;
    *hydra = bench::score_generated_rooms(*graph, &floor_rasters, opt.max_reach_m);
  }
  return true;
}

}  // namespace


int main(int argc, char** argv) {
  Options opt;
  if (!bench::parse_rooms_eval(argc, argv, &opt)) {
    bench::print_rooms_eval_usage(argv[0]);
    return 2;
  }
  // The output directories are made here, so a typo is one clear error at start-up rather than a missed cache.
  for (const std::string* dir : {&opt.cache_dir, &opt.images_dir, &opt.dump_dir}) {
    if (dir->empty()) continue;
    std::error_code ec;
    std::filesystem::create_directories(*dir, ec);
    if (ec || !std::filesystem::is_directory(*dir)) {
      std::fprintf(stderr, "cannot make directory '%s': %s\n", dir->c_str(),
                   ec ? ec.message().c_str() : "a file is in the way");
      return 2;
    }
  }
  params::print(bench::rooms_eval_schema(), opt, stdout);
  if (opt.doors) {
    std::string door_error;
    if (!opt.door.validate(&door_error)) {
      std::fprintf(stderr, "%s\n", door_error.c_str());
      return 2;
    }
    std::printf("doors: found on the robot's surface, %.2f m above its height on each storey, widths %.2f .. %.2f m, "
                "clearance rise %.2f m within %.2f m, dropped where the places go round within %.2f m "
                "(--door-bypass-max-m 0: off); crossing place edges closed (--doors 0: off)\n",
                opt.door.slice_above_robot_m, opt.door.min_width_m, opt.door.max_width_m, opt.door.min_rise_m,
                opt.door.rise_reach_m, opt.door.bypass_max_m);
  } else if (opt.online_doors) {
    std::string door_error;
    if (!opt.door.validate(&door_error)) {
      std::fprintf(stderr, "%s\n", door_error.c_str());
      return 2;
    }
    std::printf("doors: online (the app's window passes during the run, every %d. frontend update; no final stage)\n",
                opt.online_every);
  } else {
    std::printf("doors: off\n");
  }
  if (opt.door_oracle_m >= 0.0)
    std::printf("DOOR ORACLE: on the IPA plans every place edge between two ground-truth rooms has clearance %.2f m; "
                "the scores are the bound a perfect door and opening cue gives the room finder\n",
                opt.door_oracle_m);
  std::printf("camera %dx%d, %.0f deg hfov, %.1f Hz keyframes, %s, noise-free depth; labels reach "
              "%.1f m from places; robot radius %.2f m, %s\n",
              opt.width, opt.height, opt.hfov_deg, opt.rate_hz, opt.odometry.describe().c_str(), opt.max_reach_m,
              opt.robot_radius_m,
              opt.look_into_unreachable ? "the tour looks into rooms it cannot enter" : "no looks into rooms");
  char cond[1536];
  std::snprintf(cond, sizeof(cond),
                "sim camera %dx%d %.0f deg hfov %.1f Hz, %s, noise-free depth, robot radius %.2f m%s, "
                "TSDF 0.1 m, frontend every keyframe, rooms seeding %s alpha %.2f persistence %.2f m [%.2f, %.2f] m "
                "min %u",
                opt.width, opt.height, opt.hfov_deg, opt.rate_hz, opt.odometry.describe().c_str(), opt.robot_radius_m,
                opt.look_into_unreachable ? ", looks into unreachable rooms" : "", rooms::to_string(opt.rooms.seeding),
                opt.rooms.plateau_alpha, opt.rooms.min_persistence_m, opt.rooms.min_dilation_m,
                opt.rooms.max_dilation_m, opt.rooms.min_component_size);
  if (opt.rooms.split_by_extent)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond),
                  ", extent split saturation %.2f m [%.2f, %.2f] m persistence %.2f m min %u",
                  opt.rooms.extent_saturation_m, opt.rooms.split_min_extent_m, opt.rooms.split_max_extent_m,
                  opt.rooms.split_min_persistence_m, opt.rooms.split_min_component_size);
  else
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond), ", no extent split");
  if (opt.rooms.merge_corridors)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond),
                  ", corridor merge >= %u rooms >= %u open edges", opt.rooms.corridor_min_neighbours,
                  opt.rooms.corridor_min_open_edges);
  else
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond), ", no corridor merge");
  if (opt.rooms.merge_visible && opt.doors)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond),
                  ", visibility merge >= %.2f of %u x %u sight lines (near the boundary: %.2f m, >= %.2f; rooms "
                  "whose places' spheres touch in sight adjacent: %s) past walls >= %.1f m (dilated %.2f m; islands "
                  "< %.1f m wider than %.2f m are furniture)",
                  opt.rooms.visible_min_share, opt.rooms.visible_samples, opt.rooms.visible_samples,
                  opt.rooms.visible_local_radius_m, opt.rooms.visible_local_min_share,
                  opt.rooms.visible_touching ? "yes" : "no", opt.door.sight_min_wall_m, opt.door.sight_wall_dilation_m,
                  opt.door.sight_furniture_max_m, opt.door.sight_furniture_min_width_m);
  else
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond), ", no visibility merge");
  if (opt.rooms.close_edges_through_walls && opt.online_doors)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond),
                  ", place edges through walls read as closed in the last online window");
  else if (opt.door.sight_cut_edges && opt.doors)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond), ", place edges through walls closed");
  if (opt.door_oracle_m >= 0.0)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond), ", door oracle %.2f m", opt.door_oracle_m);
  if (opt.doors)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond),
                  ", doors on the robot's surface (slice +%.2f m, widths %.2f-%.2f m, rise %.2f m in %.2f m, "
                  "dropped where the places go round within %.2f m in steps <= %.2f m, line +%.2f m)",
                  opt.door.slice_above_robot_m, opt.door.min_width_m, opt.door.max_width_m, opt.door.min_rise_m,
                  opt.door.rise_reach_m, opt.door.bypass_max_m, opt.door.bypass_max_edge_m,
                  opt.door.bypass_extension_m);
  else if (opt.online_doors)
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond),
                  ", online doors every %d. frontend update (window passes, slice +%.2f m, dropped where the "
                  "window's places go round within %.2f m)",
                  opt.online_every, opt.door.slice_above_robot_m, opt.door.bypass_max_m);
  else
    std::snprintf(cond + std::strlen(cond), sizeof(cond) - std::strlen(cond), ", no doors");
  bench::Figures figures(cond);
  const auto add = [&](const std::string& prefix, const Score& s) {
    figures.add(prefix + ".precision_mean", s.precision_mean, "fraction");
    figures.add(prefix + ".recall_mean", s.recall_mean, "fraction");
    figures.add(prefix + ".precision_area", s.precision_area, "fraction");
    figures.add(prefix + ".recall_area", s.recall_area, "fraction");
    figures.add(prefix + ".rooms_found", static_cast<double>(s.rooms_found), "rooms");
    figures.add(prefix + ".rooms_truth", static_cast<double>(s.rooms_truth), "rooms");
  };
  // A peer's totals, printed and added with ours over it: "ALL peer <short> (<set>)", figures
  // rooms_eval.<set>.peer_<name>[.ours_over_peer.*].
  const auto add_peer_total = [&](const std::string& set, const char* name, const char* short_name, const char* what,
                                  const Score& overall, const Score& peer) {
    const std::size_t dot = set.find('.');
    const std::string shown = dot == std::string::npos ? set : set.substr(dot + 1);
    std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu (%s; ours over it: P %.3f R %.3f "
                "area P %.3f)\n",
                ("ALL peer " + std::string(short_name) + " (" + shown + ")").c_str(), peer.precision_mean,
                peer.recall_mean, peer.precision_area, peer.recall_area, peer.rooms_found, peer.rooms_truth, what,
                ratio(overall.precision_mean, peer.precision_mean), ratio(overall.recall_mean, peer.recall_mean),
                ratio(overall.precision_area, peer.precision_area));
    const std::string prefix = "rooms_eval." + set + ".peer_" + name;
    add(prefix, peer);
    figures.add(prefix + ".ours_over_peer.precision_mean", ratio(overall.precision_mean, peer.precision_mean),
                "ratio");
    figures.add(prefix + ".ours_over_peer.recall_mean", ratio(overall.recall_mean, peer.recall_mean), "ratio");
    figures.add(prefix + ".ours_over_peer.precision_area", ratio(overall.precision_area, peer.precision_area),
                "ratio");
  };
  int failures = 0;
  std::vector<double> rooms_ms, door_ms;
  // Per run: the door stage's doors, closed edges and time (--doors).
  std::vector<double> pass_ms;
  std::size_t wall_tiles_max = 0, doors_added = 0, doors_dropped = 0;
  const auto add_doors = [&](const std::string& prefix, const RunStats& st) {
    if (opt.online_doors) {
      figures.add(prefix + ".online_doors", static_cast<double>(st.online_doors.size()), "doors");
      pass_ms.insert(pass_ms.end(), st.pass_ms.begin(), st.pass_ms.end());
      wall_tiles_max = std::max(wall_tiles_max, st.wall_tiles);
      doors_added += st.doors_added;
      doors_dropped += st.doors_dropped;
    }
    if (!opt.doors) return;
    figures.add(prefix + ".doors", static_cast<double>(st.doors.size()), "doors");
    figures.add(prefix + ".door_edges_closed", static_cast<double>(st.door_edges_closed), "edges");
    door_ms.push_back(st.door_ms);
  };
  for (const std::string& plan_variant : opt.variants) {
    if (opt.maps.empty()) break;
    const bool furnished = plan_variant == "furnished";
    // Printed and figure name: "furnished_low" when the furniture stands at --furniture-height-m.
    const std::string variant = furnished && opt.furniture_height_m > 0.0 ? "furnished_low" : plan_variant;
    if (variant == "furnished_low")
      std::printf("furnished_low: the furnished plans with their furniture extruded to %.2f m, not to the walls' "
                  "%.2f m\n", opt.furniture_height_m, world::FloorPlanConfig{}.wall_height_m);
    Score overall, overall_reachable, overall_oracle, overall_distance, overall_distance_plateau, overall_erosion;
    Score overall_hydra;
    std::size_t hydra_plans = 0;
    std::size_t doors_between = 0, doors_inside = 0, doors_unknown = 0;
    for (const std::string& map : opt.maps) {
      Score s, reachable, oracle;
      Peers peers;
      RunStats st;
      if (!eval_plan(opt, map, furnished, &s, &st, &reachable, &oracle, &peers)) {
        ++failures;
        continue;
      }
      print_line(map + " (" + variant + ")", s, st);
      if (opt.doors || opt.online_doors) {
        std::printf("  doors against the ground truth: %zu between two rooms, %zu inside one room, %zu unknown\n",
                    st.judged.between, st.judged.inside, st.judged.unknown);
        doors_between += st.judged.between;
        doors_inside += st.judged.inside;
        doors_unknown += st.judged.unknown;
      }
      print_peer("  peer: distance transform", peers.distance, "threshold", peers.distance_level_m);
      print_peer("  peer: distance, PH plateau", peers.distance_plateau, "threshold", peers.distance_plateau_level_m);
      print_peer("  peer: morphological", peers.erosion, "deepest erosion", peers.erosion_level_m);
      if (peers.has_hydra) {
        std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu | our graph, no doors, delta* "
                    "%.2f m\n",
                    "  peer: Hydra room clustering", peers.hydra.precision_mean, peers.hydra.recall_mean,
                    peers.hydra.precision_area, peers.hydra.recall_area, peers.hydra.rooms_found,
                    peers.hydra.rooms_truth, peers.hydra_dilation_m);
        add("rooms_eval.ipa." + variant + "." + map + ".peer_hydra", peers.hydra);
        overall_hydra.add(peers.hydra);
        ++hydra_plans;
      }
      add("rooms_eval.ipa." + variant + "." + map, s);
      add("rooms_eval.ipa." + variant + "." + map + ".peer_distance_transform", peers.distance);
      add("rooms_eval.ipa." + variant + "." + map + ".peer_distance_plateau", peers.distance_plateau);
      add("rooms_eval.ipa." + variant + "." + map + ".peer_morphological", peers.erosion);
      overall_distance.add(peers.distance);
      overall_distance_plateau.add(peers.distance_plateau);
      overall_erosion.add(peers.erosion);
      rooms_ms.push_back(st.rooms_ms);
      add_doors("rooms_eval.ipa." + variant + "." + map, st);
      overall.add(s);
      overall_reachable.add(reachable);
      overall_oracle.add(oracle);
    }
    std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu (means pooled over all rooms)\n",
                ("ALL (" + variant + ")").c_str(), overall.precision_mean, overall.recall_mean, overall.precision_area,
                overall.recall_area, overall.rooms_found, overall.rooms_truth);
    if (opt.doors || opt.online_doors) {
      const std::size_t judged = doors_between + doors_inside;
      const double inside_share = judged > 0 ? static_cast<double>(doors_inside) / static_cast<double>(judged) : 0.0;
      std::printf("%-30s %zu between two ground-truth rooms, %zu inside one room (%.1f %% of those judged), %zu "
                  "unknown\n",
                  ("ALL doors (" + variant + ")").c_str(), doors_between, doors_inside, 100.0 * inside_share,
                  doors_unknown);
      const std::string prefix = "rooms_eval.ipa." + variant + (opt.online_doors ? ".online_doors" : ".doors");
      figures.add(prefix + "_between_rooms", static_cast<double>(doors_between), "doors");
      figures.add(prefix + "_inside_a_room", static_cast<double>(doors_inside), "doors");
      figures.add(prefix + "_inside_a_room_share", inside_share, "ratio");
    }
    std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu (rooms the tour could reach)\n",
                ("ALL reachable (" + variant + ")").c_str(), overall_reachable.precision_mean,
                overall_reachable.recall_mean, overall_reachable.precision_area, overall_reachable.recall_area,
                overall_reachable.rooms_found, overall_reachable.rooms_truth);
    std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu (bound: each place in its "
                "ground-truth room)\n",
                ("ALL oracle (" + variant + ")").c_str(), overall_oracle.precision_mean, overall_oracle.recall_mean,
                overall_oracle.precision_area, overall_oracle.recall_area, overall_oracle.rooms_found,
                overall_oracle.rooms_truth);
    add_peer_total("ipa." + variant, "distance_transform", "dist", "the complete plan", overall, overall_distance);
    add_peer_total("ipa." + variant, "distance_plateau", "dist PH", "the complete plan", overall,
                   overall_distance_plateau);
    add_peer_total("ipa." + variant, "morphological", "morph", "the complete plan", overall, overall_erosion);
    if (hydra_plans > 0)
      add_peer_total("ipa." + variant, "hydra", "Hydra", "the paper's room clustering on our graph, no doors",
                     overall, overall_hydra);
    add("rooms_eval.ipa." + variant + ".all", overall);
    add("rooms_eval.ipa." + variant + ".oracle", overall_oracle);
    add("rooms_eval.ipa." + variant + ".reachable", overall_reachable);
  }
  Score generated, generated_oracle, generated_hydra;
  LabelScore labels;
  for (int seed = 1; seed <= opt.generated; ++seed) {
    Score s, oracle, hydra;
    RunStats st;
    if (!eval_generated(opt, static_cast<std::uint64_t>(seed), &s, &st, &labels, &oracle, &hydra)) {
      ++failures;
      continue;
    }
    print_line("generated two-floor seed " + std::to_string(seed), s, st);
    add("rooms_eval.generated_two_floor.seed" + std::to_string(seed), s);
    rooms_ms.push_back(st.rooms_ms);
    add_doors("rooms_eval.generated_two_floor.seed" + std::to_string(seed), st);
    std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu | our graph, no doors\n",
                "  peer: Hydra room clustering", hydra.precision_mean, hydra.recall_mean, hydra.precision_area,
                hydra.recall_area, hydra.rooms_found, hydra.rooms_truth);
    add("rooms_eval.generated_two_floor.seed" + std::to_string(seed) + ".peer_hydra", hydra);
    generated.add(s);
    generated_oracle.add(oracle);
    generated_hydra.add(hydra);
  }
  if (opt.generated > 0) {
    std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu\n", "ALL generated two-floor",
                generated.precision_mean, generated.recall_mean, generated.precision_area, generated.recall_area,
                generated.rooms_found, generated.rooms_truth);
    std::printf("%-30s P %.3f R %.3f | area P %.3f R %.3f | rooms %zu / truth %zu (bound: each place in its "
                "ground-truth room)\n",
                "ALL generated oracle", generated_oracle.precision_mean, generated_oracle.recall_mean,
                generated_oracle.precision_area, generated_oracle.recall_area, generated_oracle.rooms_found,
                generated_oracle.rooms_truth);
    add_peer_total("generated_two_floor", "hydra", "Hydra", "the paper's room clustering on our graph, no doors",
                   generated, generated_hydra);
    add("rooms_eval.generated_two_floor.all", generated);
    add("rooms_eval.generated_two_floor.oracle", generated_oracle);
    const double accuracy = labels.rooms > 0 ? static_cast<double>(labels.correct) / labels.rooms : 0.0;
    std::printf("room labels (room classifier, generated two-floor): %zu of %zu estimated rooms correct (%.1f %%), %zu "
                "unknown; each room scored against the ground-truth room holding most of its places\n",
                labels.correct, labels.rooms, 100.0 * accuracy, labels.unknown);
    const std::size_t labelled = labels.rooms - labels.unknown;
    std::printf("  of the %zu labelled (not unknown), %zu correct (%.1f %%)\n", labelled, labels.correct,
                labelled > 0 ? 100.0 * labels.correct / labelled : 0.0);
    for (const auto& [pair, n] : labels.confusions) std::printf("  wrong: %s x %zu\n", pair.c_str(), n);
    std::printf("  objects whose parent place is in their own ground-truth room: %zu of %zu (%.1f %%)\n",
                labels.objects_in_own_room, labels.objects,
                labels.objects > 0 ? 100.0 * labels.objects_in_own_room / labels.objects : 0.0);
    std::printf("room labels on the ground-truth rooms and objects of the same buildings: %zu of %zu (%.1f %%)\n",
                labels.truth_correct, labels.truth_rooms,
                labels.truth_rooms > 0 ? 100.0 * labels.truth_correct / labels.truth_rooms : 0.0);
    figures.add("rooms_eval.generated_two_floor.label_accuracy", accuracy, "fraction");
    figures.add("rooms_eval.generated_two_floor.labelled_rooms", static_cast<double>(labels.rooms), "rooms");
    figures.add("rooms_eval.generated_two_floor.objects_in_own_room",
                labels.objects > 0 ? static_cast<double>(labels.objects_in_own_room) / labels.objects : 0.0, "fraction");
  }
  if (opt.label_buildings > 0) {
    LabelScore truth;
    for (int i = 1; i <= opt.label_buildings; ++i) {
      world::BuildingConfig bc;
      bc.seed = static_cast<std::uint64_t>(1000 + i);
      bc.num_rooms = opt.generated_rooms;
      bc.two_floors = true;
      label_truth_rooms(world::generate_building(bc), &truth);
    }
    const double accuracy = truth.truth_rooms > 0 ? static_cast<double>(truth.truth_correct) / truth.truth_rooms : 0.0;
    std::printf("room labels on the ground-truth rooms and objects of %d generated two-floor buildings (seeds "
                "1001..%d): %zu of %zu (%.1f %%)\n",
                opt.label_buildings, 1000 + opt.label_buildings, truth.truth_correct, truth.truth_rooms,
                100.0 * accuracy);
    const std::size_t labelled = truth.truth_rooms - truth.truth_unknown;
    std::printf("  %zu left unknown; of the %zu labelled, %zu correct (%.1f %%)\n", truth.truth_unknown, labelled,
                truth.truth_correct, labelled > 0 ? 100.0 * truth.truth_correct / labelled : 0.0);
    figures.add("rooms_eval.generated_truth.unknown_rooms", static_cast<double>(truth.truth_unknown), "rooms");
    figures.add("rooms_eval.generated_truth.labelled_precision",
                labelled > 0 ? static_cast<double>(truth.truth_correct) / labelled : 0.0, "fraction");
    for (const auto& [type, n] : truth.truth_per_type)
      std::printf("  %-14s %3zu of %3zu\n", type.c_str(), n.first, n.second);
    for (const auto& [pair, n] : truth.truth_confusions) std::printf("  wrong: %s x %zu\n", pair.c_str(), n);
    figures.add("rooms_eval.generated_truth.label_accuracy", accuracy, "fraction");
    figures.add("rooms_eval.generated_truth.labelled_rooms", static_cast<double>(truth.truth_rooms), "rooms");
  }
  if (!rooms_ms.empty()) figures.add("rooms_eval.rooms_update_ms_median", median(rooms_ms), "ms");
  if (!door_ms.empty()) figures.add("rooms_eval.door_stage_ms_median", median(door_ms), "ms");
  if (!pass_ms.empty()) {
    std::sort(pass_ms.begin(), pass_ms.end());
    figures.add("rooms_eval.online_door_pass_ms_median", pass_ms[pass_ms.size() / 2], "ms");
    figures.add("rooms_eval.online_door_pass_ms_p99", pass_ms[pass_ms.size() * 99 / 100], "ms");
    figures.add("rooms_eval.online_door_pass_ms_max", pass_ms.back(), "ms");
    figures.add("rooms_eval.online_wall_tiles_max", static_cast<double>(wall_tiles_max), "tiles");
    // Churn: doors that came and went during the runs (a door a pass adds and a later one drops made the rooms
    // flicker in between).
    figures.add("rooms_eval.online_doors_added_per_pass", static_cast<double>(doors_added) / pass_ms.size(), "doors");
    figures.add("rooms_eval.online_doors_dropped_per_pass", static_cast<double>(doors_dropped) / pass_ms.size(),
                "doors");
    std::printf("online door passes: %zu, median %.1f ms, p99 %.1f ms, max %.1f ms; wall tiles at most %zu; doors "
                "added %zu, dropped %zu over the passes\n",
                pass_ms.size(), pass_ms[pass_ms.size() / 2], pass_ms[pass_ms.size() * 99 / 100], pass_ms.back(),
                wall_tiles_max, doors_added, doors_dropped);
  }
  if (!opt.json_path.empty() && !figures.write(opt.json_path)) return 1;
  return failures == 0 ? 0 : 1;
}
