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
// Faults are placed from the fault-free run's own length: a transient fault starts at 40 % of its frames (or
// odometry samples) and random ones fire over 30-60 %. Targets: 0 crashes, 0 hangs, recovery within 1 s, and
// rooms and objects within 5 points of the fault-free run for the transient faults. The exit status is 1 on a
// crash, a hang or a recovery miss; point misses fail the run only with --strict.
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
#include "drivers/world/building_generator.h"
#include "firmware_app/app_config.h"

namespace {

using namespace qsg;
using Json = nlohmann::json;

struct Options {
  std::string app = QSG_APP_PATH;
  std::string config;  // passed to qsg_app and read here for the building (empty: the app's defaults)
  int rooms = 0;       // 0: the config's
  double duration_s = 0.0;  // 0: the whole tour
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
               "usage: %s [--app QSG_APP] [--config FILE] [--rooms N] [--duration S] [--out DIR] [--json FILE]\n"
               "          [--scenarios a,b,...] [--timeout-s S] [--strict]\n"
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
               "  all. CI runs --rooms 4 --duration 40. JSON: fault_suite.<scenario>.*; bench/results/faults.md.\n",
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
    else if (a == "--duration" && v) o->duration_s = std::atof(argv[++i]);
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

std::vector<Scenario> make_scenarios(const Baseline& b) {
  const auto at = [](double n, double share) { return static_cast<std::uint64_t>(std::llround(n * share)); };
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
  s.push_back({"drops_30pct", "30 % of the camera's frames dropped over 30-60 % of the run", true,
               camera_random("drop", 0.3, Json::object())});
  s.push_back({"stall_2s", "the camera stalls for 2 s (400 reads at the 200 Hz tick) at 40 %", true,
               {{"camera", {{"events", {{{"at", f40}, {"fault", "stall"}, {"reads", 400}}}}}}}});
  s.push_back({"late_frames", "30 % of frames published 80 ms late over 30-60 %", true,
               camera_random("late", 0.3, {{"delay_ms", 80}})});
  s.push_back({"backwards_timestamps", "5 % of frames stamped 50 ms before the previous one over 30-60 %", true,
               camera_random("backwards", 0.05, {{"back_ms", 50}})});
  s.push_back({"depth_nan", "30 % of frames with a 160x120 NaN depth region over 30-60 %", true, depth("depth_nan")});
  s.push_back({"depth_zero", "30 % of frames with a 160x120 zero depth region over 30-60 %", true, depth("depth_zero")});
  s.push_back({"depth_saturated", "30 % of frames with a 160x120 saturated depth region over 30-60 %", true,
               depth("depth_saturated")});
  s.push_back({"pose_jumps", "three 2 m odometry pose jumps (one sample each) and one of 0.5 m for 10 samples", true,
               {{"odometry",
                 {{"events",
                   {{{"at", at(b.samples, 0.35)}, {"fault", "pose_jump"}, {"offset_m", {2, 0, 0}}},
                    {{"at", o40}, {"fault", "pose_jump"}, {"offset_m", {0, -2, 0}}},
                    {{"at", at(b.samples, 0.45)}, {"fault", "pose_jump"}, {"offset_m", {0.5, 0.5, 0}}, {"samples", 10}},
                    {{"at", at(b.samples, 0.5)}, {"fault", "pose_jump"}, {"offset_m", {-2, 0, 0.2}}}}}}}}});
  s.push_back({"odometry_dropout", "the odometry loses 2 s of samples (60 at 30 Hz) at 40 %", true,
               {{"odometry", {{"events", {{{"at", o40}, {"fault", "dropout"}, {"samples", 60}}}}}}}});
  s.push_back({"camera_unplug", "the camera is unplugged for 3 s (600 reads) at 40 %, then replugged", true,
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
  if (o.duration_s > 0) args.insert(args.end(), {"--duration", std::to_string(o.duration_s)});
  args.insert(args.end(), extra.begin(), extra.end());
  std::filesystem::remove(dir + "/report.json");
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open((dir + "/log.txt").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) ::dup2(fd, STDOUT_FILENO), ::dup2(fd, STDERR_FILENO);
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

  std::vector<Run> runs;
  std::vector<Scenario> scenarios = make_scenarios(b);
  int failures = 0, misses = 0;
  bench::Figures figures("qsg_app main job (" + std::to_string(config.building.num_rooms) + " rooms, seed " +
                         std::to_string(config.building.seed) + (o.duration_s > 0 ? ", " + std::to_string(o.duration_s) + " s" : "") +
                         "), lockstep, overflow " + memory::to_string(memory::kBuildOverflowPolicy));
  const auto add_graph_figures = [&](const std::string& p, const Score& s) {
    for (const auto& [layer, n] : s.nodes) figures.add(p + ".nodes." + layer, n, "nodes");
    figures.add(p + ".rooms_precision", 100 * s.rooms_precision, "%");
    figures.add(p + ".rooms_recall", 100 * s.rooms_recall, "%");
    figures.add(p + ".objects_found", 100 * s.objects_found, "%");
    figures.add(p + ".objects_correct", 100 * s.objects_correct, "%");
  };
  add_graph_figures("fault_suite.fault_free", base.score);
  figures.add("fault_suite.fault_free.exit_status", base.exit_status, "status");

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
    failures += crashed || r.hang || recovery_miss || r.exit_status != 0 ? 1 : 0;
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
    runs.push_back(std::move(r));
  }
  std::printf("\nfault-free: rooms P %.1f R %.1f, objects found %.1f correct %.1f; nodes:", 100 * base.score.rooms_precision,
              100 * base.score.rooms_recall, 100 * base.score.objects_found, 100 * base.score.objects_correct);
  for (const auto& [layer, n] : base.score.nodes) std::printf(" %s %.0f", layer.c_str(), n);
  std::printf("\nfault_suite: %zu scenarios, %d failed (crash, hang, exit status or recovery), %d outside %.0f points\n",
              runs.size(), failures, misses, o.max_points);
  if (!o.json_path.empty() && !figures.write(o.json_path)) return 1;
  return failures > 0 || (o.strict && misses > 0) ? 1 : 0;
}
