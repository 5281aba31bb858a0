// Loop closure on the simulated robot, through the app's own pipeline (firmware_app/pipeline.h), so the figures are
// the product's: for each odometry level (drivers/sim/odometry_levels.h: "sim", qsg_simulate's default drift, and
// "vio", about 1 % of distance) and each building seed, a lockstep run of the whole tour (or --tours N of it) with
// loop closure on, scored against the simulator's truth:
//   - ATE RMSE (no alignment: the map is built in the odometry's frame from the true start) of the odometric chain
//     and of the optimized one, and their ratio (target <= 0.30);
//   - loop closures proposed, kept by the optimizer (GNC), and proposed within 10 cm / 1 degree of the truth;
//   - agents described, the longest deformation-graph solve.
// Every figure also goes to --json (bench/figures.h).
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench/figures.h"
#include "budgets/budget_table.h"
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
              "  e.g. bench/loop_closure/worlds/identical_rooms_4.json, where every false closure counts\n");
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

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> levels = {"sim", "vio"};
  std::vector<std::string> seeds = {"1"};
  int rooms = 8, tours = 1;
  double duration_s = 0.0;
  std::string output = "/tmp/lc_eval", json, world;
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
    else return usage(a == "--help" ? 0 : 2);
  }
  if (rooms < 2 || rooms > 64 || tours < 1 || tours > 1000 || duration_s < 0.0) return usage(2);
  char conditions[200];
  std::snprintf(conditions, sizeof conditions, "%s, %d tour(s), lockstep on %s, loop closure on",
                world.empty() ? (std::to_string(rooms) + "-room generated buildings").c_str() : world.c_str(), tours,
                budgets::active::kTable.board);
  bench::Figures figures(conditions);
  std::printf("%-5s %5s %10s %10s %7s %9s %6s %6s %6s %10s\n", "level", "seed", "ate_odo_m", "ate_opt_m", "ratio",
              "proposed", "kept", "true", "false", "solve_ms");
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
      c.odometry.source = app::OdometrySourceKind::kSimDrift;
      c.odometry.seed = c.building.seed;
      c.odometry.translation_sigma_m_per_sqrt_m = drift.translation_sigma_m_per_sqrt_m;
      c.odometry.yaw_sigma_rad_per_sqrt_m = drift.yaw_sigma_rad_per_sqrt_m;
      c.odometry.scale_bias = drift.scale_bias;
      c.output_dir = output + "/" + level_name + "_seed" + seed;
      c.snapshot_interval_s = 1e6;
      c.telemetry_interval_s = 1e6;
      runtime::SteppedClock clock;
      app::Pipeline p;
      std::string error;
      if (!p.init(c, &clock, &error)) {
        std::fprintf(stderr, "lc_eval: %s\n", error.c_str());
        return 1;
      }
      while (p.step()) {
      }
      if (!p.finish(&error)) {
        std::fprintf(stderr, "lc_eval: %s\n", error.c_str());
        return 1;
      }
      const metrics::TrajectoryError& odo = p.odometry_trajectory_error();
      const metrics::TrajectoryError& opt = p.trajectory_error();
      const app::PipelineCounters& k = p.counters();
      const double ratio = odo.ok && opt.ok && odo.ate_rmse_m > 0.0 ? opt.ate_rmse_m / odo.ate_rmse_m : -1.0;
      std::printf("%-5s %5s %10.3f %10.3f %7.2f %9llu %6llu %6llu %3llu/%-2llu %10.1f\n", level_name.c_str(),
                  seed.c_str(), odo.ate_rmse_m, opt.ate_rmse_m, ratio, static_cast<unsigned long long>(k.loop_closures),
                  static_cast<unsigned long long>(k.loop_closures_kept),
                  static_cast<unsigned long long>(k.loop_closures_true),
                  static_cast<unsigned long long>(k.loop_closures_false_kept),
                  static_cast<unsigned long long>(k.loop_closures_false), k.graph_optimization_max_us / 1000.0);
      const std::string prefix = level_name + "_seed" + seed + ".";
      figures.add(prefix + "ate_odometry", odo.ate_rmse_m, "m");
      figures.add(prefix + "ate_optimized", opt.ate_rmse_m, "m");
      figures.add(prefix + "ate_ratio", ratio, "ratio");
      figures.add(prefix + "loop_closures_proposed", static_cast<double>(k.loop_closures), "count");
      figures.add(prefix + "loop_closures_kept", static_cast<double>(k.loop_closures_kept), "count");
      figures.add(prefix + "loop_closures_true", static_cast<double>(k.loop_closures_true), "count");
      figures.add(prefix + "loop_closures_false", static_cast<double>(k.loop_closures_false), "count");
      figures.add(prefix + "loop_closures_false_kept", static_cast<double>(k.loop_closures_false_kept), "count");
      figures.add(prefix + "loop_closures_by_appearance", static_cast<double>(k.loop_closures_by_appearance), "count");
      figures.add(prefix + "agents_described", static_cast<double>(k.agents_described), "count");
      figures.add(prefix + "solve_max", k.graph_optimization_max_us / 1000.0, "ms");
      figures.add(prefix + "path_length", odo.path_length_m, "m");
    }
  }
  if (!json.empty() && !figures.write(json)) return 1;
  return 0;
}
