// Fault suite (issue 36): the main job (qsg_app on the simulated quadruped in a generated building, lockstep) run
// fault-free and then under each fault scenario, every run a separate qsg_app process with --fault-plan
// (firmware_app/FAULT_PLAN.md) and --report-json. For each scenario it reports:
//   - how the process ended: its exit status, a signal (a crash) or a hang (killed at --timeout-s);
//   - every counter the exit report holds that is not zero (camera, odometry, pipeline, queues, stores, ...);
//   - the recovery: data (simulated) time from the end of each fault to the first keyframe integrated after it,
//     the longest over the run, and whether the run ended inside a fault; and the catch-up: loop (simulated) time
//     from that keyframe until keyframes are integrated within 0.25 s of their due time again (a stall or an
//     unplug leaves a backlog);
//   - the graph against the fault-free run's: nodes per layer, rooms precision / recall (rooms_eval's score,
//     bench/rooms/room_score.h) and objects found / correct (objects_eval's match, bench/objects/object_match.h),
//     scored against the simulator's ground truth of the same generated building.
//   - with loop closure on: the closures proposed, kept, true and false against the truth (and false ones kept),
//     the solves (and how many came at or after the faults' window opened), failed solves, and the ATE of the
//     odometry and of the optimized trajectory.
// Faults are placed from the fault-free run's own length: a transient fault starts at 40 % of its frames (or
// odometry samples) and random ones fire over 30-60 % (--window moves and stretches that span; the scripted faults
// keep their places in it). Targets: 0 crashes, 0 hangs, recovery within 1 s, no false loop closure kept, and
// rooms and objects within 5 points of the fault-free run for the transient faults. The exit status is 1 on a
// crash, a hang, a recovery miss or a false closure kept; point misses and failed solves fail the run only with
// --strict.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench/figures.h"
#include "bench/objects/object_match.h"
#include "bench/rooms/room_score.h"
#include "core/memory/resource_stats.h"
#include "core/scene_graph/scene_graph.h"
#include "core/scene_graph/spark_dsg_json.h"
#include "core/metrics/trajectory_error.h"
#include "drivers/replay/trajectory.h"
#include "drivers/world/building_generator.h"
#include "firmware_app/app_config.h"

namespace {

using namespace qsg;
using Json = nlohmann::json;

struct Options {
  std::string app = QSG_APP_PATH;
  std::string config;  // passed to qsg_app and read here for the building (empty: the app's defaults)
  int rooms = 0;       // 0: the config's
  int tours = 0;       // 0: the config's (a second tour revisits every place: loop closures)
  double duration_s = 0.0;  // 0: the whole tour
  // Where the faults go, as shares of the fault-free run: the random faults fire over [from, until] and the
  // scripted ones sit at the same places in it as in the default 30-60 % (a third of the way in, ...).
  double window_from = 0.3, window_until = 0.6;
  std::string out = "fault_suite_out";
  std::string json_path;
  std::vector<std::string> only;
  double timeout_s = 1800.0;
  bool strict = false;
  double max_recovery_s = 1.0;
  double max_points = 5.0;
};

void usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s [--app QSG_APP] [--config FILE] [--rooms N] [--tours N] [--duration S] [--window FROM,UNTIL]\n"
               "          [--out DIR] [--json FILE] [--scenarios a,b,...] [--timeout-s S] [--strict]\n"
               "  Runs qsg_app (lockstep) fault-free, then under each fault scenario (firmware_app/FAULT_PLAN.md):\n"
               "  30 %% drops, a 2 s stall, late frames, backwards timestamps, NaN / zero / saturated depth regions,\n"
               "  odometry pose jumps, a 2 s odometry dropout, a 3 s camera unplug and replug, a full place store;\n"
               "  each a separate process killed at the timeout (a hang). Per scenario: the exit status or signal,\n"
               "  the non-zero fault counters of the exit report, the longest recovery (data time from a fault's\n"
               "  end to the next integrated keyframe) and catch-up (loop time until keyframes are again within\n"
               "  0.25 s of their due time), and the graph against the fault-free run (nodes per layer, rooms P/R,\n"
               "  objects found / correct). Exit 1 on a crash, a hang, a non-zero exit or a recovery or catch-up\n"
               "  over 1 s (--strict: also rooms or objects more than 5 points off for a transient fault). The\n"
               "  default (test) build aborts on a full store and skips that scenario: run the release build for\n"
               "  all. CI runs --rooms 4 --duration 40. JSON: fault_suite.<scenario>.*; bench/results/faults.md.\n"
               "  --window FROM,UNTIL: the faults' window as shares of the fault-free run (default 0.3,0.6); the\n"
               "  scripted faults keep their places in it. With loop closure on (the config's loop_closure.enabled),\n"
               "  per scenario also: closures proposed, kept, true (within 10 cm / 1 deg), false (over 0.5 m / 5 deg)\n"
               "  and false kept, solves (and how many at or after the window's start), solve failures, ATE of the\n"
               "  odometry and of the optimized trajectory; exit 1 also when a false closure is kept (--strict: also\n"
               "  on a failed solve), and one more scenario, pose_step: the odometry steps 1.5 m and stays shifted.\n"
               "  --rooms 6 --tours 2 --window 0.5,0.85 puts the faults among the closures.\n",
               argv0);
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ',')) out.push_back(item);
  return out;
}

bool parse(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool v = i + 1 < argc;
    if (a == "--app" && v) o->app = argv[++i];
    else if (a == "--config" && v) o->config = argv[++i];
    else if (a == "--rooms" && v) o->rooms = std::atoi(argv[++i]);
    else if (a == "--tours" && v) o->tours = std::atoi(argv[++i]);
    else if (a == "--duration" && v) o->duration_s = std::atof(argv[++i]);
    else if (a == "--window" && v) {
      const std::vector<std::string> w = split(argv[++i]);
      if (w.size() != 2) return usage(argv[0]), false;
      o->window_from = std::atof(w[0].c_str());
      o->window_until = std::atof(w[1].c_str());
      if (!(o->window_from >= 0.0 && o->window_from < o->window_until && o->window_until <= 1.0))
        return usage(argv[0]), false;
    }
    else if (a == "--out" && v) o->out = argv[++i];
    else if (a == "--json" && v) o->json_path = argv[++i];
    else if (a == "--scenarios" && v) o->only = split(argv[++i]);
    else if (a == "--timeout-s" && v) o->timeout_s = std::atof(argv[++i]);
    else if (a == "--strict") o->strict = true;
    else return usage(argv[0]), false;
  }
  return true;
}

struct Scenario {
  std::string name;
  std::string what;
  bool transient = true;  // held to the points target
  Json plan;              // null: fault-free
};

// Where the fault-free run puts things: its length in frames and odometry samples, its place nodes.
struct Baseline {
  double frames = 0;
  double samples = 0;
  double place_nodes = 0;
};

// `share` is a place in the default 30-60 % window; it goes to the same place in [from, until].
// With loop closure on, one more: a step in the odometry that stays.
std::vector<Scenario> make_scenarios(const Baseline& b, double from, double until, bool loop_closure) {
  const auto place = [&](double share) { return from + (share - 0.3) / 0.3 * (until - from); };
  const auto at = [&](double n, double share) { return static_cast<std::uint64_t>(std::llround(n * place(share))); };
  const auto pct = [&](double share) { return std::to_string(std::lround(100 * place(share))); };
  const std::string span = pct(0.3) + "-" + pct(0.6) + " %", at40 = pct(0.4) + " %";
  const std::uint64_t f40 = at(b.frames, 0.4), o40 = at(b.samples, 0.4);
  const Json window = {{"from", at(b.frames, 0.3)}, {"until", at(b.frames, 0.6)}};
  const auto depth = [&](const char* kind) {
    Json random = window;
    random["region"] = {160, 120};  // a quarter of the main job's 320x240 frame
    return Json{{"camera", {{"seed", 5}, {"rates", {{kind, 0.3}}}, {"random", random}}}};
  };
  const auto camera_random = [&](const char* kind, double rate, Json extra) {
    Json random = window;
    for (auto it = extra.begin(); it != extra.end(); ++it) random[it.key()] = it.value();
    return Json{{"camera", {{"seed", 3}, {"rates", {{kind, rate}}}, {"random", random}}}};
  };
  std::vector<Scenario> s;
  s.push_back({"drops_30pct", "30 % of the camera's frames dropped over " + span + " of the run", true,
               camera_random("drop", 0.3, Json::object())});
  s.push_back({"stall_2s", "the camera stalls for 2 s (400 reads at the 200 Hz tick) at " + at40, true,
               {{"camera", {{"events", {{{"at", f40}, {"fault", "stall"}, {"reads", 400}}}}}}}});
  s.push_back({"late_frames", "30 % of frames published 80 ms late over " + span, true,
               camera_random("late", 0.3, {{"delay_ms", 80}})});
  s.push_back({"backwards_timestamps", "5 % of frames stamped 50 ms before the previous one over " + span, true,
               camera_random("backwards", 0.05, {{"back_ms", 50}})});
  s.push_back({"depth_nan", "30 % of frames with a 160x120 NaN depth region over " + span, true, depth("depth_nan")});
  s.push_back({"depth_zero", "30 % of frames with a 160x120 zero depth region over " + span, true, depth("depth_zero")});
  s.push_back({"depth_saturated", "30 % of frames with a 160x120 saturated depth region over " + span, true,
               depth("depth_saturated")});
  s.push_back({"pose_jumps", "three 2 m odometry pose jumps (one sample each) and one of 0.5 m for 10 samples, " + pct(0.35) + "-" + pct(0.5) + " %", true,
               {{"odometry",
                 {{"events",
                   {{{"at", at(b.samples, 0.35)}, {"fault", "pose_jump"}, {"offset_m", {2, 0, 0}}},
                    {{"at", o40}, {"fault", "pose_jump"}, {"offset_m", {0, -2, 0}}},
                    {{"at", at(b.samples, 0.45)}, {"fault", "pose_jump"}, {"offset_m", {0.5, 0.5, 0}}, {"samples", 10}},
                    {{"at", at(b.samples, 0.5)}, {"fault", "pose_jump"}, {"offset_m", {-2, 0, 0.2}}}}}}}}});
  if (loop_closure) {
    // A relocalization of the odometry: shifted for good. The pose buffer rejects it until its speed bound admits
    // the step, then the rest of the run is mapped 1.5 m off; the closures after it must absorb the step or be
    // dropped, never keep a wrong one. Not transient (it never ends): no recovery or points target.
    const std::uint64_t from_sample = at(b.samples, 0.4);
    const auto rest = static_cast<std::int64_t>(b.samples) - static_cast<std::int64_t>(from_sample) + 100;
    s.push_back({"pose_step", "the odometry steps 1.5 m at " + at40 + " and stays shifted (a relocalization)", false,
                 {{"odometry",
                   {{"events",
                     {{{"at", from_sample}, {"fault", "pose_jump"}, {"offset_m", {1.2, -0.9, 0}},
                       {"samples", std::max<std::int64_t>(1, rest)}}}}}}}});
  }
  s.push_back({"odometry_dropout", "the odometry loses 2 s of samples (60 at 30 Hz) at " + at40, true,
               {{"odometry", {{"events", {{{"at", o40}, {"fault", "dropout"}, {"samples", 60}}}}}}}});
  s.push_back({"camera_unplug", "the camera is unplugged for 3 s (600 reads) at " + at40 + ", then replugged", true,
               {{"camera", {{"events", {{{"at", f40}, {"fault", "unplug"}, {"reads", 600}}}}}}}});
  const auto places_cap = static_cast<std::uint64_t>(std::max(1.0, std::floor(0.6 * b.place_nodes)));
  s.push_back({"full_store", "the place-node store capped at 60 % of what the fault-free run used (" +
                                 std::to_string(places_cap) + ")",
               false, {{"stores", {{"place_nodes", places_cap}}}}});
  return s;
}

struct Score {
  std::map<std::string, double> nodes;  // per layer
  double rooms_precision = 0, rooms_recall = 0;
  double objects_found = 0, objects_correct = 0;  // fractions: of the ground truth, of the estimates
  bool ok = false;
};

struct Run {
  std::string name;
  int exit_status = -1;  // -1: did not exit
  int signal = 0;
  bool hang = false;
  double wall_s = 0;
  Json report;
  Score score;
};

// Spawns the app with stdout and stderr into `log`; kills it at the timeout (a hang).
Run run_app(const Options& o, const std::string& name, const std::vector<std::string>& extra) {
  Run r;
  r.name = name;
  const std::string dir = o.out + "/" + name;
  std::filesystem::create_directories(dir);
  std::vector<std::string> args = {o.app, "--output", dir, "--report-json", dir + "/report.json", "--quiet"};
  if (!o.config.empty()) args.insert(args.end(), {"--config", o.config});
  if (o.rooms > 0) args.insert(args.end(), {"--rooms", std::to_string(o.rooms)});
  if (o.tours > 0) args.insert(args.end(), {"--tours", std::to_string(o.tours)});
  if (o.duration_s > 0) args.insert(args.end(), {"--duration", std::to_string(o.duration_s)});
  args.insert(args.end(), extra.begin(), extra.end());
  std::filesystem::remove(dir + "/report.json");
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open((dir + "/log.txt").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) ::dup2(fd, STDOUT_FILENO), ::dup2(fd, STDERR_FILENO);
    ::setenv("QSG_DEBUG_LOOP_CLOSURES", "1", 1);  // the log lists each closure with its error against the truth
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  int status = 0;
  for (;;) {
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (done == pid) break;
    if (r.wall_s > o.timeout_s) {
      r.hang = true;
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (!r.hang && WIFEXITED(status)) r.exit_status = WEXITSTATUS(status);
  if (!r.hang && WIFSIGNALED(status)) r.signal = WTERMSIG(status);
  std::ifstream in(dir + "/report.json");
  if (in) r.report = Json::parse(in, nullptr, false);
  return r;
}

Score score_graph(const std::string& path, const world::World& w, const world::BuildingConfig& bc) {
  Score s;
  scene_graph::SceneGraph g;
  std::string error;
  if (!g.init(scene_graph::capacities_from_budget(), scene_graph::arena_bytes_from_budget(), &error)) {
    std::fprintf(stderr, "fault_suite: %s\n", error.c_str());
    return s;
  }
  const scene_graph::JsonImportResult r = scene_graph::read_spark_dsg_json_file(path, g);
  if (!r.ok) {
    std::fprintf(stderr, "fault_suite: %s: %s\n", path.c_str(), r.error.c_str());
    return s;
  }
  using scene_graph::NodeKind;
  for (NodeKind k : {NodeKind::kObject, NodeKind::kAgent, NodeKind::kPlace, NodeKind::kRoom, NodeKind::kBuilding})
    s.nodes[scene_graph::to_string(k)] = static_cast<double>(g.num_nodes(k));
  std::vector<bench::FloorRaster> floors = bench::generated_floor_rasters(w, bc);
  const bench::RoomSegmentationScore rooms = bench::score_generated_rooms(g, &floors, 3.0);
  s.rooms_precision = rooms.precision_mean;
  s.rooms_recall = rooms.recall_mean;
  std::vector<bench::EstimatedObject> objects;
  g.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind != NodeKind::kObject) return;
    if (const scene_graph::ObjectAttributes* a = g.object(n.id))
      objects.push_back({static_cast<semantics::Label>(a->semantic_label), a->position_m});
  });
  const bench::ObjectMatch m = bench::match_objects(w, objects);
  s.objects_found = w.objects.empty() ? 0.0 : static_cast<double>(m.num_found) / static_cast<double>(w.objects.size());
  s.objects_correct = objects.empty() ? 0.0 : static_cast<double>(m.num_correct) / static_cast<double>(objects.size());
  s.ok = true;
  return s;
}

double report_value(const Json& report, const char* group, const char* key, double fallback = -1.0) {
  if (!report.is_object() || !report.contains(group) || !report[group].contains(key)) return fallback;
  const Json& v = report[group][key];
  return v.is_number() ? v.get<double>() : fallback;
}

// The counters that are not zero, "group.key=value", from the groups that count faults and their effects.
std::vector<std::pair<std::string, double>> nonzero_counters(const Json& report) {
  std::vector<std::pair<std::string, double>> out;
  if (!report.is_object()) return out;
  for (const char* group : {"camera", "odometry", "odometry_driver", "pipeline", "queues", "reconstruction", "places",
                            "objects", "frontend", "agents", "rooms", "stores", "faults"}) {
    if (!report.contains(group)) continue;
    for (auto it = report[group].begin(); it != report[group].end(); ++it) {
      const std::string& k = it.key();
      if (!it.value().is_number() || it.value().get<double>() == 0.0) continue;
      // Levels and sizes, and the traffic of a healthy run, rather than counts of faults and their effects.
      static const char* const kTraffic[] = {"delivered", "accepted", "samples_read", "frames_posed", "frames_waited",
                                             "frames", "objects_created", "keyframes", "updates", "revisits_merged",
                                             "folded", "last_fault_end_s", "overwritten", "revivals_refused"};
      if (k.find("high_water") != std::string::npos || k.find("capacity") != std::string::npos ||
          k.find(".depth") != std::string::npos || k.find("collated") != std::string::npos ||
          std::find(std::begin(kTraffic), std::end(kTraffic), k) != std::end(kTraffic))
        continue;
      out.emplace_back(std::string(group) + "." + k, it.value().get<double>());
    }
  }
  return out;
}

// Loop closure's figures for one run: the exit report's counters (closures scored against the simulator's truth
// by the app), the solves the log shows (each "loop closure: solve at T s" line; T is data time) and the ATE of
// the odometry and of the optimized trajectory from the trajectories the app wrote (the odometry file only exists
// when a solve succeeded; otherwise the estimate is the odometry).
struct LoopClosureFigures {
  bool on = false;  // the run described agents (loop closure enabled)
  double proposed = 0, kept = 0, true_ = 0, false_ = 0, false_kept = 0;
  double solves = 0, solve_failures = 0;  // graph_optimizations counts the final solve too
  double solves_logged = 0, solves_from_window = 0;  // backend-thread solves; those at or after the window's start
  double ate_odometry_m = -1, ate_optimized_m = -1;  // -1: not scored
};

double ate_rmse_m(const std::string& reference_path, const std::string& estimate_path) {
  replay::Trajectory ref, est;
  std::string error;
  if (!replay::read_tum_trajectory(reference_path, &ref, &error) || !replay::read_tum_trajectory(estimate_path, &est, &error))
    return -1.0;
  const auto timed = [](const replay::Trajectory& t) {
    std::vector<metrics::TimedPose> out;
    for (const replay::StampedPose& p : t) out.push_back({p.time_ns, p.world_t_body_m, p.world_R_body});
    return out;
  };
  metrics::TrajectoryErrorConfig tc;
  tc.max_time_difference_ns = 1'000'000;  // the same stamps, written to the microsecond
  tc.alignment = metrics::Alignment::kNone;  // the map's frame is the truth's: the error as mapped
  const metrics::TrajectoryError e = metrics::evaluate_trajectory(timed(ref), timed(est), tc);
  return e.ok ? e.ate_rmse_m : -1.0;
}

LoopClosureFigures loop_closure_figures(const Json& report, const std::string& dir, double window_start_s) {
  LoopClosureFigures f;
  f.on = report_value(report, "pipeline", "agents_described", 0.0) > 0.0;
  f.proposed = report_value(report, "pipeline", "loop_closures", 0.0);
  f.kept = report_value(report, "pipeline", "loop_closures_kept", 0.0);
  f.true_ = report_value(report, "pipeline", "loop_closures_true", 0.0);
  f.false_ = report_value(report, "pipeline", "loop_closures_false", 0.0);
  f.false_kept = report_value(report, "pipeline", "loop_closures_false_kept", 0.0);
  f.solves = report_value(report, "pipeline", "graph_optimizations", 0.0);
  f.solve_failures = report_value(report, "pipeline", "graph_optimization_failures", 0.0);
  std::ifstream log(dir + "/log.txt");
  const std::string mark = "loop closure: solve at ";
  for (std::string line; std::getline(log, line);) {
    const std::size_t at = line.find(mark);
    if (at == std::string::npos) continue;
    ++f.solves_logged;
    f.solves_from_window += std::atof(line.c_str() + at + mark.size()) >= window_start_s ? 1 : 0;
  }
  const std::string truth = dir + "/trajectory_ground_truth.txt";
  f.ate_optimized_m = ate_rmse_m(truth, dir + "/trajectory_estimate.txt");
  f.ate_odometry_m = std::filesystem::exists(dir + "/trajectory_odometry.txt")
                         ? ate_rmse_m(truth, dir + "/trajectory_odometry.txt")
                         : f.ate_optimized_m;
  return f;
}

void print_loop_closure(const LoopClosureFigures& f) {
  std::printf("   loop closure: %.0f proposed, %.0f kept, %.0f true, %.0f false (%.0f kept)%s; %.0f solves (%.0f on the "
              "backend, %.0f of them from the window's start), %.0f failed; ATE %.3f m odometry, %.3f m optimized\n",
              f.proposed, f.kept, f.true_, f.false_, f.false_kept, f.false_kept > 0 ? " FALSE CLOSURE KEPT" : "",
              f.solves, f.solves_logged, f.solves_from_window, f.solve_failures, f.ate_odometry_m, f.ate_optimized_m);
}

void add_loop_closure_figures(bench::Figures* figures, const std::string& p, const LoopClosureFigures& f) {
  const std::string q = p + ".loop_closure.";
  figures->add(q + "proposed", f.proposed, "closures");
  figures->add(q + "kept", f.kept, "closures");
  figures->add(q + "true", f.true_, "closures");
  figures->add(q + "false", f.false_, "closures");
  figures->add(q + "false_kept", f.false_kept, "closures");
  figures->add(q + "solves", f.solves, "solves");
  figures->add(q + "solves_on_backend", f.solves_logged, "solves");
  figures->add(q + "solves_from_window", f.solves_from_window, "solves");
  figures->add(q + "solve_failures", f.solve_failures, "solves");
  figures->add(q + "ate_odometry", f.ate_odometry_m, "m");
  figures->add(q + "ate_optimized", f.ate_optimized_m, "m");
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, &o)) return 2;
  app::AppConfig config;
  std::string error;
  if (!o.config.empty() && !config.load(o.config, &error)) return std::fprintf(stderr, "%s\n", error.c_str()), 2;
  if (o.rooms > 0) config.building.num_rooms = o.rooms;
  std::filesystem::create_directories(o.out);
  const world::World w = world::generate_building(config.building);
  std::printf("fault_suite: %s, building seed %llu with %d rooms (%zu objects), duration %s, build overflow policy %s\n",
              o.app.c_str(), (unsigned long long)config.building.seed, config.building.num_rooms, w.objects.size(),
              o.duration_s > 0 ? (std::to_string(o.duration_s) + " s").c_str() : "the whole tour",
              memory::to_string(memory::kBuildOverflowPolicy));

  // The fault-free run: the reference, and where the faults go.
  Run base = run_app(o, "fault_free", {});
  if (base.exit_status != 0 || !base.report.is_object()) {
    std::fprintf(stderr, "fault_suite: the fault-free run failed (exit %d, signal %d, hang %d): see %s/fault_free/log.txt\n",
                 base.exit_status, base.signal, base.hang ? 1 : 0, o.out.c_str());
    return 1;
  }
  base.score = score_graph(o.out + "/fault_free/scene_graph.json", w, config.building);
  Baseline b;
  b.frames = report_value(base.report, "pipeline", "frames_read");
  b.samples = report_value(base.report, "odometry", "samples_read");
  b.place_nodes = report_value(base.report, "graph", "place_nodes");
  std::printf("fault-free: %.0f frames, %.0f odometry samples, %.0f place nodes, %.1f s wall\n", b.frames, b.samples,
              b.place_nodes, base.wall_s);
  // The window's start in data time: the frames the camera delivered from time 0 at its rate.
  const double window_start_s = o.window_from * b.frames / config.camera.rate_hz;
  const LoopClosureFigures base_lc = loop_closure_figures(base.report, o.out + "/fault_free", window_start_s);
  if (base_lc.on) {
    std::printf("fault-free, faults' window from %.1f s:\n", window_start_s);
    print_loop_closure(base_lc);
  }

  std::vector<Run> runs;
  std::vector<Scenario> scenarios = make_scenarios(b, o.window_from, o.window_until, base_lc.on);
  int failures = 0, misses = 0;
  char window[64];
  std::snprintf(window, sizeof window, ", faults over %.0f-%.0f %%", 100 * o.window_from, 100 * o.window_until);
  bench::Figures figures("qsg_app main job (" + std::to_string(config.building.num_rooms) + " rooms, seed " +
                         std::to_string(config.building.seed) + (o.duration_s > 0 ? ", " + std::to_string(o.duration_s) + " s" : "") +
                         (o.tours > 0 ? ", " + std::to_string(o.tours) + " tours" : "") + window +
                         (base_lc.on ? ", loop closure on" : "") + "), lockstep, overflow " +
                         memory::to_string(memory::kBuildOverflowPolicy));
  const auto add_graph_figures = [&](const std::string& p, const Score& s) {
    for (const auto& [layer, n] : s.nodes) figures.add(p + ".nodes." + layer, n, "nodes");
    figures.add(p + ".rooms_precision", 100 * s.rooms_precision, "%");
    figures.add(p + ".rooms_recall", 100 * s.rooms_recall, "%");
    figures.add(p + ".objects_found", 100 * s.objects_found, "%");
    figures.add(p + ".objects_correct", 100 * s.objects_correct, "%");
  };
  add_graph_figures("fault_suite.fault_free", base.score);
  figures.add("fault_suite.fault_free.exit_status", base.exit_status, "status");
  if (base_lc.on) add_loop_closure_figures(&figures, "fault_suite.fault_free", base_lc);
  int false_kept_runs = base_lc.false_kept > 0 ? 1 : 0, failed_solve_runs = base_lc.solve_failures > 0 ? 1 : 0;

  for (Scenario& sc : scenarios) {
    if (!o.only.empty() && std::find(o.only.begin(), o.only.end(), sc.name) == o.only.end()) continue;
    if (sc.plan.contains("stores") && memory::kBuildOverflowPolicy == memory::OverflowPolicy::kAbort) {
      std::printf("\n== %s: SKIPPED: this build aborts on a full store (QSG_OVERFLOW_ABORT); run the release build\n",
                  sc.name.c_str());
      continue;
    }
    const std::string plan_path = o.out + "/" + sc.name + ".plan.json";
    std::ofstream(plan_path) << sc.plan.dump(1) << "\n";
    Run r = run_app(o, sc.name, {"--fault-plan", plan_path});
    if (r.exit_status == 0 || r.exit_status == 3) r.score = score_graph(o.out + "/" + sc.name + "/scene_graph.json", w, config.building);
    const double recovery = report_value(r.report, "faults", "max_recovery_s");
    const double catch_up = report_value(r.report, "faults", "max_catch_up_s");
    const bool not_recovered = report_value(r.report, "faults", "not_recovered", 0.0) > 0.0 ||
                               report_value(r.report, "faults", "still_behind", 0.0) > 0.0;
    const bool crashed = r.signal != 0 || r.exit_status < 0;
    const bool recovery_miss =
        sc.transient && (not_recovered || recovery > o.max_recovery_s || catch_up > o.max_recovery_s);
    const double d_rp = 100 * (r.score.rooms_precision - base.score.rooms_precision);
    const double d_rr = 100 * (r.score.rooms_recall - base.score.rooms_recall);
    const double d_of = 100 * (r.score.objects_found - base.score.objects_found);
    const double d_oc = 100 * (r.score.objects_correct - base.score.objects_correct);
    const bool points_miss = sc.transient && (!r.score.ok || std::fabs(d_rp) > o.max_points || std::fabs(d_rr) > o.max_points ||
                                              std::fabs(d_of) > o.max_points || std::fabs(d_oc) > o.max_points);
    const LoopClosureFigures lc = loop_closure_figures(r.report, o.out + "/" + sc.name, window_start_s);
    const bool false_kept = lc.false_kept > 0, failed_solve = lc.solve_failures > 0;
    false_kept_runs += false_kept ? 1 : 0;
    failed_solve_runs += failed_solve ? 1 : 0;
    failures += crashed || r.hang || recovery_miss || r.exit_status != 0 || false_kept ? 1 : 0;
    misses += points_miss ? 1 : 0;
    std::printf("\n== %s: %s\n   exit %d%s%s, %.1f s wall; recovery longest %.3f s, catch-up longest %.3f s%s%s\n",
                sc.name.c_str(), sc.what.c_str(), r.exit_status,
                r.signal ? (", SIGNAL " + std::to_string(r.signal)).c_str() : "", r.hang ? ", HANG" : "", r.wall_s,
                recovery, catch_up, not_recovered ? " NOT RECOVERED" : "", recovery_miss ? " (MISS)" : "");
    std::printf("   nodes:");
    for (const auto& [layer, n] : r.score.nodes) std::printf(" %s %.0f (%+.0f)", layer.c_str(), n, n - base.score.nodes[layer]);
    std::printf("\n   rooms P %.1f (%+.1f) R %.1f (%+.1f); objects found %.1f (%+.1f) correct %.1f (%+.1f) [points vs fault-free]%s\n",
                100 * r.score.rooms_precision, d_rp, 100 * r.score.rooms_recall, d_rr, 100 * r.score.objects_found, d_of,
                100 * r.score.objects_correct, d_oc, points_miss ? " (MISS)" : "");
    if (lc.on) print_loop_closure(lc);
    std::printf("   counters:");
    for (const auto& [k, v] : nonzero_counters(r.report)) {
      if (k.rfind("pipeline.", 0) == 0 && k.find("refused") == std::string::npos && k.find("bad") == std::string::npos &&
          k.find("without") == std::string::npos && k.find("failures") == std::string::npos)
        continue;  // the pipeline's traffic counts; its fault counts stay
      std::printf(" %s=%g", k.c_str(), v);
    }
    std::printf("\n");
    const std::string p = "fault_suite." + sc.name;
    figures.add(p + ".exit_status", r.exit_status, "status");
    figures.add(p + ".crashed", crashed ? 1 : 0, "bool");
    figures.add(p + ".hang", r.hang ? 1 : 0, "bool");
    figures.add(p + ".max_recovery", recovery, "s");
    figures.add(p + ".max_catch_up", catch_up, "s");
    figures.add(p + ".not_recovered", not_recovered ? 1 : 0, "bool");
    add_graph_figures(p, r.score);
    figures.add(p + ".rooms_precision_delta", d_rp, "points");
    figures.add(p + ".rooms_recall_delta", d_rr, "points");
    figures.add(p + ".objects_found_delta", d_of, "points");
    figures.add(p + ".objects_correct_delta", d_oc, "points");
    for (const auto& [k, v] : nonzero_counters(r.report)) figures.add(p + ".counter." + k, v, "count");
    if (lc.on) add_loop_closure_figures(&figures, p, lc);
    runs.push_back(std::move(r));
  }
  std::printf("\nfault-free: rooms P %.1f R %.1f, objects found %.1f correct %.1f; nodes:", 100 * base.score.rooms_precision,
              100 * base.score.rooms_recall, 100 * base.score.objects_found, 100 * base.score.objects_correct);
  for (const auto& [layer, n] : base.score.nodes) std::printf(" %s %.0f", layer.c_str(), n);
  std::printf("\nfault_suite: %zu scenarios, %d failed (crash, hang, exit status, recovery or a false closure kept), "
              "%d outside %.0f points\n",
              runs.size(), failures, misses, o.max_points);
  if (base_lc.on)
    std::printf("fault_suite: loop closure: a false closure kept in %d runs (the fault-free one included), a failed "
                "solve in %d\n",
                false_kept_runs, failed_solve_runs);
  if (!o.json_path.empty() && !figures.write(o.json_path)) return 1;
  const bool fault_free_lc_bad = base_lc.false_kept > 0 || (o.strict && base_lc.solve_failures > 0);
  return failures > 0 || fault_free_lc_bad || (o.strict && (misses > 0 || failed_solve_runs > 0)) ? 1 : 0;
}
