// Loop closure on the simulated robot, through the app's own pipeline (firmware_app/pipeline.h), so the figures are
// the product's: for each odometry level (drivers/sim/odometry_levels.h: "sim", qsg_simulate's default drift, and
// "vio", about 1 % of distance) and each building seed, a lockstep run of the whole tour (or --tours N of it) with
// loop closure on, scored against the simulator's truth:
//   - ATE RMSE of the odometric chain and of the optimized one, and their ratio (target <= 0.30), both without
//     alignment ("as mapped": the map is built in the odometry's frame from the true start) and after SE(3) alignment
//     (Umeyama over the positions, the TUM benchmark's and evo's ATE); the same per tour (--tours N: the chain split
//     at equal times, the tours being one route walked N times);
//   - loop closures proposed, kept by the optimizer (GNC), and proposed within 10 cm / 1 degree of the truth;
//   - agents described, the longest deformation-graph solve;
//   - with --layers, every layer of the final graph as drift_baseline scores it, for three runs side by side: the
//     ground-truth poses, the odometry alone (loop closure off) and loop closure on (corrected and reconciled):
//     objects found / correct (bench/objects/object_match.h), the places' mean distance to the true GVD
//     (bench/places/place_score.h), rooms precision / recall (bench/rooms/room_score.h, generated buildings only),
//     and the written mesh against the world's surfaces: each vertex's distance to the nearest solid (0 inside
//     one), its mean, median and 90th percentile and the share beyond 5 and 10 cm (a surface mapped twice and
//     left apart: doubling).
// Every figure also goes to --json (bench/figures.h).
#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench/figures.h"
#include "bench/objects/object_match.h"
#include "bench/places/place_score.h"
#include "bench/rooms/room_score.h"
#include "budgets/budget_table.h"
#include "drivers/sim/ground_truth.h"
#include "drivers/world/world_query.h"
#include "core/metrics/trajectory_error.h"
#include "core/reconstruction/ply_writer.h"
#include "drivers/replay/trajectory.h"
#include "firmware_app/app_params.h"
#include "firmware_app/pipeline.h"

namespace {

using namespace qsg;

int usage(int status) {
  std::printf("usage: lc_eval [--levels sim,vio] [--seeds 1,2] [--rooms N (8)] [--tours N (1)] [--duration S (0: all)]\n"
              "               [--output DIR (/tmp/lc_eval)] [--json FILE] [--world FILE]\n"
              "  Loop closure through the app's own pipeline on generated buildings with drifting odometry: ATE of\n"
              "  the odometric and of the optimized chain and their ratio (target <= 0.30), loop closures proposed,\n"
              "  kept by GNC, within 10 cm / 1 degree of the truth, and false (over 0.5 m or 5 degrees off) proposed\n"
              "  and kept, agents described, the longest deformation-graph solve. JSON: <level>_seed<N>.*; results in\n"
              "  bench/results/loop_closure.md.\n"
              "  --world: explore a world file instead of generated buildings (the seeds then vary the odometry only),\n"
              "  e.g. bench/loop_closure/worlds/identical_rooms_4.json, where every false closure counts\n"
              "  --set SECTION.KEY=VALUE: a config key for every run (as qsg_app --set), e.g.\n"
              "  loop_closure.odometry_weighting=covariance_growth\n"
              "  --layers: also score objects, places and rooms of the final graph against the truth, beside a run on\n"
              "  ground-truth poses and one on the odometry alone (JSON: <level>_seed<N>.{gt,odometry,corrected}.*)\n");
  return status;
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start <= s.size()) {
    const std::size_t comma = s.find(',', start);
    out.push_back(s.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

struct Layers {
  bool ok = false;
  std::size_t objects_truth = 0, objects_found = 0, objects_estimated = 0, objects_correct = 0, places = 0;
  double places_gvd_mean_m = 0.0;
  bool rooms_scored = false;
  double rooms_precision = 0.0, rooms_recall = 0.0;
  std::size_t rooms = 0;
  bool mesh_scored = false;
  std::size_t mesh_vertices = 0;
  double mesh_mean_m = 0.0, mesh_p50_m = 0.0, mesh_p90_m = 0.0, mesh_over_5cm = 0.0, mesh_over_10cm = 0.0;
};

// The written mesh against the world: each vertex's distance to the nearest solid (capped at 1 m).
void score_mesh(const std::string& path, const world::FreeSpaceIndex& free_space, Layers* out) {
  reconstruction::Mesh mesh;
  std::string error;
  if (!reconstruction::read_ply(path, &mesh, &error)) {
    std::fprintf(stderr, "lc_eval: mesh: %s\n", error.c_str());
    return;
  }
  if (mesh.vertices.empty()) return;
  std::vector<double> d;
  d.reserve(mesh.vertices.size());
  for (const reconstruction::MeshVertex& v : mesh.vertices) d.push_back(free_space.clearance(Eigen::Vector3d(v.x, v.y, v.z), 1.0));
  std::sort(d.begin(), d.end());
  const double n = static_cast<double>(d.size());
  out->mesh_scored = true;
  out->mesh_vertices = d.size();
  for (double x : d) {
    out->mesh_mean_m += x / n;
    out->mesh_over_5cm += x > 0.05 ? 100.0 / n : 0.0;
    out->mesh_over_10cm += x > 0.10 ? 100.0 / n : 0.0;
  }
  out->mesh_p50_m = d[d.size() / 2];
  out->mesh_p90_m = d[std::min(d.size() - 1, static_cast<std::size_t>(0.9 * n))];
}

// The final graph's layers against the world's truth, as drift_baseline scores them.
Layers score_layers(const app::Pipeline& p, const app::AppConfig& c) {
  Layers out;
  const world::World& w = p.world();
  const world::FreeSpaceIndex free_space(w);
  sim::GroundTruth truth;
  std::string error;
  if (!sim::compute_ground_truth(w, free_space, sim::GroundTruthConfig{}, &truth, &error)) {
    std::fprintf(stderr, "lc_eval: ground truth: %s\n", error.c_str());
    return out;
  }
  const scene_graph::SceneGraph& g = p.graph();
  std::vector<bench::EstimatedObject> objects;
  g.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind != scene_graph::NodeKind::kObject) return;
    const scene_graph::ObjectAttributes* o = g.object(n.id);
    objects.push_back({static_cast<semantics::Label>(o->semantic_label), o->position_m});
  });
  const bench::ObjectMatch match = bench::match_objects(w, objects);
  out.objects_truth = w.objects.size();
  out.objects_found = match.num_found;
  out.objects_estimated = objects.size();
  out.objects_correct = match.num_correct;
  const std::vector<double> gvd = bench::place_distances_to_gvd(g, truth);
  out.places = gvd.size();
  out.places_gvd_mean_m = bench::mean(gvd);
  g.for_each_node([&](const scene_graph::NodeRecord& n) { out.rooms += n.kind == scene_graph::NodeKind::kRoom; });
  if (c.world_path.empty()) {
    std::vector<bench::FloorRaster> floors = bench::generated_floor_rasters(w, c.building);
    const bench::RoomSegmentationScore r = bench::score_generated_rooms(g, &floors, 3.0);
    out.rooms_scored = true;
    out.rooms_precision = r.precision_mean;
    out.rooms_recall = r.recall_mean;
  }
  score_mesh(c.output_dir + "/mesh.ply", free_space, &out);
  out.ok = true;
  return out;
}

double pct(std::size_t a, std::size_t b) { return b == 0 ? 0.0 : 100.0 * static_cast<double>(a) / static_cast<double>(b); }

void report_layers(const std::string& prefix, const char* run, const Layers& l, bench::Figures* figures) {
  std::printf("  %-9s objects found %5.1f %% correct %5.1f %% (%zu of %zu truth) | places %4zu, %.3f m to the true GVD "
              "| rooms %zu",
              run, pct(l.objects_found, l.objects_truth), pct(l.objects_correct, l.objects_estimated),
              l.objects_estimated, l.objects_truth, l.places, l.places_gvd_mean_m, l.rooms);
  if (l.rooms_scored) std::printf(", P %.3f R %.3f", l.rooms_precision, l.rooms_recall);
  if (l.mesh_scored)
    std::printf(" | mesh %zu vertices to the surfaces: mean %.3f m, median %.3f, p90 %.3f, %.1f %% > 5 cm, %.1f %% > 10 cm",
                l.mesh_vertices, l.mesh_mean_m, l.mesh_p50_m, l.mesh_p90_m, l.mesh_over_5cm, l.mesh_over_10cm);
  std::printf("\n");
  const std::string p = prefix + run + ".";
  figures->add(p + "objects_found", pct(l.objects_found, l.objects_truth), "%");
  figures->add(p + "objects_correct", pct(l.objects_correct, l.objects_estimated), "%");
  figures->add(p + "places", static_cast<double>(l.places), "count");
  figures->add(p + "places_gvd_mean", l.places_gvd_mean_m, "m");
  figures->add(p + "rooms", static_cast<double>(l.rooms), "count");
  if (l.rooms_scored) {
    figures->add(p + "rooms_precision", l.rooms_precision, "ratio");
    figures->add(p + "rooms_recall", l.rooms_recall, "ratio");
  }
  if (l.mesh_scored) {
    figures->add(p + "mesh_vertices", static_cast<double>(l.mesh_vertices), "count");
    figures->add(p + "mesh_to_surface_mean", l.mesh_mean_m, "m");
    figures->add(p + "mesh_to_surface_p50", l.mesh_p50_m, "m");
    figures->add(p + "mesh_to_surface_p90", l.mesh_p90_m, "m");
    figures->add(p + "mesh_over_5cm", l.mesh_over_5cm, "%");
    figures->add(p + "mesh_over_10cm", l.mesh_over_10cm, "%");
  }
}

// ATE of the odometric and the optimized chain (the app's trajectory files: the same agents, in order) against the
// truth, as mapped and after SE(3) alignment, over the whole run and per tour.
struct TrajectoryScores {
  bool ok = false;
  double ate[2][2] = {{0, 0}, {0, 0}};  // [odometry, optimized][as mapped, SE(3) aligned]
  std::vector<std::array<double, 4>> tours;  // per tour: odometry, optimized as mapped; odometry, optimized aligned
};

double ate_of(const replay::Trajectory& truth, const replay::Trajectory& est, std::size_t lo, std::size_t hi, bool aligned) {
  std::vector<metrics::TimedPose> ref, e;
  for (std::size_t k = lo; k < hi; ++k) {
    ref.push_back({static_cast<std::int64_t>(k), truth[k].world_t_body_m, truth[k].world_R_body});
    e.push_back({static_cast<std::int64_t>(k), est[k].world_t_body_m, est[k].world_R_body});
  }
  metrics::TrajectoryErrorConfig c;
  c.max_time_difference_ns = 0;
  c.alignment = aligned ? metrics::Alignment::kSE3 : metrics::Alignment::kNone;
  const metrics::TrajectoryError r = metrics::evaluate_trajectory(ref, e, c);
  return r.ok ? r.ate_rmse_m : -1.0;
}

TrajectoryScores score_trajectories(const std::string& dir, int tours) {
  TrajectoryScores out;
  replay::Trajectory truth, odometry, optimized;
  std::string error;
  if (!replay::read_tum_trajectory(dir + "/trajectory_ground_truth.txt", &truth, &error) ||
      !replay::read_tum_trajectory(dir + "/trajectory_estimate.txt", &optimized, &error)) {
    std::fprintf(stderr, "lc_eval: %s\n", error.c_str());
    return out;
  }
  // Without a solve the app writes no odometric file: the estimate is the odometry.
  if (!replay::read_tum_trajectory(dir + "/trajectory_odometry.txt", &odometry, &error)) odometry = optimized;
  if (truth.size() != optimized.size() || truth.size() != odometry.size() || truth.size() < 3) {
    std::fprintf(stderr, "lc_eval: %s: trajectory files of different lengths\n", dir.c_str());
    return out;
  }
  const std::size_t n = truth.size();
  for (int run = 0; run < 2; ++run)
    for (int aligned = 0; aligned < 2; ++aligned)
      out.ate[run][aligned] = ate_of(truth, run == 0 ? odometry : optimized, 0, n, aligned != 0);
  const std::int64_t t0 = truth.front().time_ns, t1 = truth.back().time_ns;
  std::size_t lo = 0;
  for (int t = 0; t < tours && tours > 1; ++t) {
    const std::int64_t end = t + 1 == tours ? t1 + 1 : t0 + (t1 - t0) / tours * (t + 1);
    std::size_t hi = lo;
    while (hi < n && truth[hi].time_ns < end) ++hi;
    out.tours.push_back({ate_of(truth, odometry, lo, hi, false), ate_of(truth, optimized, lo, hi, false),
                         ate_of(truth, odometry, lo, hi, true), ate_of(truth, optimized, lo, hi, true)});
    lo = hi;
  }
  out.ok = true;
  return out;
}

// One lockstep run of the whole tour; false (with the reason printed) when it could not start or finish.
// Loop closure's cost on the backend thread (thread CPU time): detection and verification per agent described,
// each solve, and the solve's growth with the path: the first solve at or past 10, 100 and 1,000 m, and the last.
void add_cost_figures(const app::Pipeline& p, const std::string& prefix, bench::Figures* figures) {
  const runtime::TaskStats detect = p.loop_closure_detect_cpu_stats(), solve = p.solve_cpu_stats();
  const double described = static_cast<double>(p.counters().agents_described);
  figures->add(prefix + "detect_cpu_per_agent_mean",
               described > 0 ? static_cast<double>(detect.total_us) / 1000.0 / described : 0.0, "ms");
  figures->add(prefix + "detect_cpu_update_max", static_cast<double>(detect.max_us) / 1000.0, "ms");
  // What of loop closure held the graph lock per update (description, and a solve's inputs copied).
  const runtime::TaskStats locked = p.loop_closure_lock_cpu_stats();
  figures->add(prefix + "graph_lock_cpu_update_max", static_cast<double>(locked.max_us) / 1000.0, "ms");
  figures->add(prefix + "graph_lock_cpu_update_mean", locked.mean_us() / 1000.0, "ms");
  figures->add(prefix + "solves", static_cast<double>(solve.runs), "count");
  figures->add(prefix + "solve_cpu_mean", solve.mean_us() / 1000.0, "ms");
  figures->add(prefix + "solve_cpu_max", static_cast<double>(solve.max_us) / 1000.0, "ms");
  figures->add(prefix + "solve_over_budget", static_cast<double>(solve.overruns), "count");
  const std::vector<app::Pipeline::SolveRecord> records = p.solve_records();
  // Each problem's inputs are copied under the graph lock, which the loop thread takes to add a keyframe's agent;
  // the problem is then built from the copy without it.
  std::int64_t build_max_us = 0, build_wall_max_us = 0, build_total_us = 0;
  std::int64_t lock_max_us = 0, lock_wall_max_us = 0, lock_total_us = 0;
  for (const app::Pipeline::SolveRecord& r : records) {
    build_max_us = std::max(build_max_us, r.build_cpu_us);
    build_wall_max_us = std::max(build_wall_max_us, r.build_wall_us);
    build_total_us += r.build_cpu_us;
    lock_max_us = std::max(lock_max_us, r.lock_cpu_us);
    lock_wall_max_us = std::max(lock_wall_max_us, r.lock_wall_us);
    lock_total_us += r.lock_cpu_us;
  }
  const double solves = records.empty() ? 1.0 : static_cast<double>(records.size());
  figures->add(prefix + "lock_cpu_max", static_cast<double>(lock_max_us) / 1000.0, "ms");
  figures->add(prefix + "lock_wall_max", static_cast<double>(lock_wall_max_us) / 1000.0, "ms");
  figures->add(prefix + "lock_cpu_mean", static_cast<double>(lock_total_us) / 1000.0 / solves, "ms");
  figures->add(prefix + "build_cpu_max", static_cast<double>(build_max_us) / 1000.0, "ms");
  figures->add(prefix + "build_wall_max", static_cast<double>(build_wall_max_us) / 1000.0, "ms");
  figures->add(prefix + "build_cpu_mean",
               records.empty() ? 0.0 : static_cast<double>(build_total_us) / 1000.0 / static_cast<double>(records.size()),
               "ms");
  const auto add_record = [&](const std::string& at, const app::Pipeline::SolveRecord& r) {
    figures->add(prefix + at + ".path", r.path_m, "m");
    figures->add(prefix + at + ".solve_cpu", static_cast<double>(r.cpu_us) / 1000.0, "ms");
    figures->add(prefix + at + ".agents", r.agents, "count");
    figures->add(prefix + at + ".control_points", r.control_points, "count");
    figures->add(prefix + at + ".places", r.places, "count");
    figures->add(prefix + at + ".closures", r.closures, "count");
    figures->add(prefix + at + ".build_cpu", static_cast<double>(r.build_cpu_us) / 1000.0, "ms");
    figures->add(prefix + at + ".lock_cpu", static_cast<double>(r.lock_cpu_us) / 1000.0, "ms");
    std::printf("        solve at %7.1f m: %5u agents, %5u control points, %4u places, %4u closures: %8.1f ms CPU "
                "(inputs copied in %.2f ms under the graph lock, built in %.1f ms)\n",
                r.path_m, r.agents, r.control_points, r.places, r.closures, static_cast<double>(r.cpu_us) / 1000.0,
                static_cast<double>(r.lock_cpu_us) / 1000.0, static_cast<double>(r.build_cpu_us) / 1000.0);
  };
  for (const double mark : {10.0, 100.0, 1000.0}) {
    const auto it = std::find_if(records.begin(), records.end(),
                                 [&](const app::Pipeline::SolveRecord& r) { return r.path_m >= mark; });
    if (it != records.end()) add_record("solve_at_" + std::to_string(static_cast<int>(mark)) + "m", *it);
  }
  if (!records.empty()) add_record("solve_last", records.back());
}

bool run(const app::AppConfig& c, app::Pipeline* p) {
  runtime::SteppedClock clock;
  std::string error;
  if (!p->init(c, &clock, &error)) {
    std::fprintf(stderr, "lc_eval: %s\n", error.c_str());
    return false;
  }
  while (p->step()) {
  }
  if (!p->finish(&error)) {
    std::fprintf(stderr, "lc_eval: %s\n", error.c_str());
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> levels = {"sim", "vio"};
  std::vector<std::string> seeds = {"1"};
  int rooms = 8, tours = 1;
  double duration_s = 0.0;
  std::string output = "/tmp/lc_eval", json, world;
  bool layers = false;
  std::vector<std::string> sets;
  bool reconcile = app::AppConfig().loop_closure.reconcile;
  double merge_places_m = app::AppConfig().loop_closure.merge_places_within_m;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--levels" && has) levels = split(argv[++i]);
    else if (a == "--seeds" && has) seeds = split(argv[++i]);
    else if (a == "--rooms" && has) rooms = std::atoi(argv[++i]);
    else if (a == "--tours" && has) tours = std::atoi(argv[++i]);
    else if (a == "--duration" && has) duration_s = std::atof(argv[++i]);
    else if (a == "--output" && has) output = argv[++i];
    else if (a == "--json" && has) json = argv[++i];
    else if (a == "--world" && has) world = argv[++i];
    else if (a == "--layers") layers = true;
    else if (a == "--set" && has) sets.push_back(argv[++i]);
    else if (a == "--reconcile" && has) reconcile = std::atoi(argv[++i]) != 0;
    else if (a == "--merge-places-m" && has) merge_places_m = std::atof(argv[++i]);
    else return usage(a == "--help" ? 0 : 2);
  }
  if (rooms < 2 || rooms > 64 || tours < 1 || tours > 1000 || duration_s < 0.0) return usage(2);
  char conditions[200];
  std::snprintf(conditions, sizeof conditions, "%s, %d tour(s), lockstep on %s, loop closure on",
                world.empty() ? (std::to_string(rooms) + "-room generated buildings").c_str() : world.c_str(), tours,
                budgets::active::kTable.board);
  std::string settings;  // the --set assignments, so the figures say what they were run with
  for (const std::string& kv : sets) settings += (settings.empty() ? ", set " : " ") + kv;
  bench::Figures figures(conditions + settings);
  std::printf("ATE RMSE of the agents' camera positions: as mapped (no alignment), and after SE(3) alignment (se3)\n");
  std::printf("%-5s %5s %10s %10s %7s %10s %10s %7s %9s %6s %6s %6s %10s\n", "level", "seed", "ate_odo_m", "ate_opt_m",
              "ratio", "se3_odo_m", "se3_opt_m", "ratio", "proposed", "kept", "true", "false", "solve_ms");
  for (const std::string& level_name : levels) {
    sim::OdometryLevel level;
    if (!sim::parse_odometry_level(level_name, &level) || level == sim::OdometryLevel::kGroundTruth) {
      std::fprintf(stderr, "lc_eval: --levels takes sim and vio, got '%s'\n", level_name.c_str());
      return 2;
    }
    const sim::DriftLevel drift = level == sim::OdometryLevel::kSim ? sim::kSimDrift : sim::kVioDrift;
    for (const std::string& seed : seeds) {
      app::AppConfig c;
      c.driver = app::Driver::kSim;
      c.lockstep = true;
      c.duration_s = duration_s;
      c.building.seed = std::strtoull(seed.c_str(), nullptr, 10);
      c.building.num_rooms = rooms;
      c.exploration.tours = tours;
      c.world_path = world;
      c.loop_closure.enabled = true;
      c.loop_closure.reconcile = reconcile;
      c.loop_closure.merge_places_within_m = merge_places_m;
      c.odometry.source = app::OdometrySourceKind::kSimDrift;
      c.odometry.seed = c.building.seed;
      c.odometry.translation_sigma_m_per_sqrt_m = drift.translation_sigma_m_per_sqrt_m;
      c.odometry.yaw_sigma_rad_per_sqrt_m = drift.yaw_sigma_rad_per_sqrt_m;
      c.odometry.scale_bias = drift.scale_bias;
      c.output_dir = output + "/" + level_name + "_seed" + seed;
      for (const std::string& kv : sets) {
        std::string error;
        if (!params::set(app::app_schema(), &c, kv, &error)) {
          std::fprintf(stderr, "lc_eval: --set %s\n", error.c_str());
          return 2;
        }
      }
      if (const std::string bad = c.check(); !bad.empty()) {
        std::fprintf(stderr, "lc_eval: config: %s\n", bad.c_str());
        return 2;
      }
      c.snapshot_interval_s = 1e6;
      c.telemetry_interval_s = 1e6;
      app::Pipeline p;
      if (!run(c, &p)) return 1;
      const metrics::TrajectoryError& odo = p.odometry_trajectory_error();
      const metrics::TrajectoryError& opt = p.trajectory_error();
      const app::PipelineCounters& k = p.counters();
      const double ratio = odo.ok && opt.ok && odo.ate_rmse_m > 0.0 ? opt.ate_rmse_m / odo.ate_rmse_m : -1.0;
      const TrajectoryScores ts = score_trajectories(c.output_dir, tours);
      const double se3_ratio = ts.ok && ts.ate[0][1] > 0.0 ? ts.ate[1][1] / ts.ate[0][1] : -1.0;
      std::printf("%-5s %5s %10.3f %10.3f %7.2f %10.3f %10.3f %7.2f %9llu %6llu %6llu %3llu/%-2llu %10.1f\n",
                  level_name.c_str(), seed.c_str(), odo.ate_rmse_m, opt.ate_rmse_m, ratio, ts.ate[0][1], ts.ate[1][1],
                  se3_ratio, static_cast<unsigned long long>(k.loop_closures),
                  static_cast<unsigned long long>(k.loop_closures_kept),
                  static_cast<unsigned long long>(k.loop_closures_true),
                  static_cast<unsigned long long>(k.loop_closures_false_kept),
                  static_cast<unsigned long long>(k.loop_closures_false), k.graph_optimization_max_us / 1000.0);
      const std::string prefix = level_name + "_seed" + seed + ".";
      // ate_*: as mapped (no alignment); ate_se3_*: after SE(3) alignment (Umeyama), the TUM benchmark's / evo's ATE.
      figures.add(prefix + "ate_odometry", odo.ate_rmse_m, "m");
      figures.add(prefix + "ate_optimized", opt.ate_rmse_m, "m");
      figures.add(prefix + "ate_ratio", ratio, "ratio");
      figures.add(prefix + "ate_se3_odometry", ts.ate[0][1], "m");
      figures.add(prefix + "ate_se3_optimized", ts.ate[1][1], "m");
      figures.add(prefix + "ate_se3_ratio", se3_ratio, "ratio");
      for (std::size_t t = 0; t < ts.tours.size(); ++t) {
        const std::array<double, 4>& a = ts.tours[t];
        const std::string tp = prefix + "tour" + std::to_string(t + 1) + ".";
        std::printf("        tour %zu: as mapped %.3f -> %.3f m (%.2f), SE(3) aligned %.3f -> %.3f m (%.2f)\n", t + 1, a[0],
                    a[1], a[0] > 0.0 ? a[1] / a[0] : -1.0, a[2], a[3], a[2] > 0.0 ? a[3] / a[2] : -1.0);
        figures.add(tp + "ate_odometry", a[0], "m");
        figures.add(tp + "ate_optimized", a[1], "m");
        figures.add(tp + "ate_se3_odometry", a[2], "m");
        figures.add(tp + "ate_se3_optimized", a[3], "m");
      }
      figures.add(prefix + "loop_closures_proposed", static_cast<double>(k.loop_closures), "count");
      figures.add(prefix + "loop_closures_kept", static_cast<double>(k.loop_closures_kept), "count");
      figures.add(prefix + "loop_closures_true", static_cast<double>(k.loop_closures_true), "count");
      figures.add(prefix + "loop_closures_false", static_cast<double>(k.loop_closures_false), "count");
      figures.add(prefix + "loop_closures_false_kept", static_cast<double>(k.loop_closures_false_kept), "count");
      figures.add(prefix + "loop_closures_by_appearance", static_cast<double>(k.loop_closures_by_appearance), "count");
      // Object registrations that neither keyframe ICP nor the local maps could refine, by the local maps' reason.
      const loop_closure::DetectorCounters& dc = p.backend_stage().detector().counters();
      figures.add(prefix + "local_map_refined", static_cast<double>(dc.local_map_refined), "count");
      figures.add(prefix + "local_map_refused", static_cast<double>(dc.local_map_refused), "count");
      figures.add(prefix + "local_map_refused_no_overlap", static_cast<double>(dc.local_map_no_overlap), "count");
      figures.add(prefix + "local_map_refused_degenerate", static_cast<double>(dc.local_map_degenerate), "count");
      figures.add(prefix + "local_map_refused_correction", static_cast<double>(dc.local_map_correction), "count");
      figures.add(prefix + "agents_described", static_cast<double>(k.agents_described), "count");
      figures.add(prefix + "loop_closure_folds", static_cast<double>(k.loop_closure_folds), "count");
      figures.add(prefix + "loop_closures_folded", static_cast<double>(k.loop_closures_folded), "count");
      figures.add(prefix + "solve_max", k.graph_optimization_max_us / 1000.0, "ms");
      add_cost_figures(p, prefix, &figures);
      figures.add(prefix + "path_length", odo.path_length_m, "m");
      if (!layers) continue;
      // The same building and tour on the true poses, and on the odometry alone, beside the corrected run.
      const Layers corrected = score_layers(p, c);
      app::AppConfig gt = c, odometry_only = c;
      gt.loop_closure.enabled = odometry_only.loop_closure.enabled = false;
      gt.odometry.source = app::OdometrySourceKind::kGroundTruth;
      gt.output_dir += "_gt";
      odometry_only.output_dir += "_odometry";
      app::Pipeline pg, po;
      if (!run(gt, &pg) || !run(odometry_only, &po)) return 1;
      report_layers(prefix, "gt", score_layers(pg, gt), &figures);
      report_layers(prefix, "odometry", score_layers(po, odometry_only), &figures);
      report_layers(prefix, "corrected", corrected, &figures);
    }
  }
  if (!json.empty() && !figures.write(json)) return 1;
  return 0;
}
