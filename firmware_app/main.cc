// qsg_app: the onboard program. Runs the perception pipeline on a driver (the simulated quadruped in a generated
// building by default) under the board's task table, writes periodic scene-graph snapshots and, at the end or on
// SIGINT/SIGTERM, a Spark-DSG scene graph, a PLY mesh, a top-down picture and a 3D view for the browser.
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include <unistd.h>

#include "budgets/budget_table.h"
#include "core/reconstruction/ply_writer.h"
#include "core/scene_graph/spark_dsg_json.h"
#include "core/params/params_json.h"
#include "firmware_app/app_config.h"
#include "firmware_app/app_params.h"
#include "firmware_app/graph_outputs.h"
#include "firmware_app/exit_report.h"
#include "firmware_app/fault_injection.h"
#include "firmware_app/pipeline.h"
#include "firmware_app/runtime/stage_marker.h"

namespace {

using namespace qsg;

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

void usage() {
  std::printf(
      "usage: qsg_app [--config FILE] [--driver sim|replay|v4l2] [--replay FOLDER [--calibration FILE]] [--output DIR]\n"
      "               [--duration S] [--realtime | --lockstep] [--seed N] [--rooms N] [--tours N] [--world FILE]\n"
      "               [--quiet]\n"
      "               [--odometry auto|sim_drift|ground_truth|tum|stream|static] [--odometry-tum FILE]\n"
      "               [--pose-stream udp:ADDRESS:PORT | unix:PATH] [--fault-plan FILE] [--report-json FILE]\n"
      "               [--mlockall] [--deterministic] [--stage-markers] [--set SECTION.KEY=VALUE ...] [--dump-config]\n"
      "       qsg_app --convert SPARK_DSG_JSON OUT_JSON [--mesh MESH.ply]   (validate a scene graph and write it in the\n"
      "               Spark-DSG 1.1.3 layout, canonically; --mesh embeds the mesh as Spark-DSG does)\n"
      "  Defaults: the simulated quadruped explores a generated 12-room building in lockstep on the board's\n"
      "  task table (%s); outputs go to qsg_output/. Every key of firmware_app/config/default.json can be set\n"
      "  in --config; the flags override it. With --driver replay, --replay is a TUM RGB-D, Redwood or pose-list\n"
      "  folder; its camera comes from --calibration, else calibration.json beside the frames.\n"
      "  Exit status: 0 done; 1 start-up failed or an output could not be written; 2 bad arguments or config;\n"
      "  3 nothing was mapped (an empty or all-rejected input; the outputs are written all the same).\n"
      "  --fault-plan: faults injected into the camera and odometry (firmware_app/FAULT_PLAN.md); --report-json:\n"
      "  the exit report (every counter) as JSON. --mlockall: lock the process in RAM after start-up (the robot;\n"
      "  needs CAP_IPC_LOCK or LimitMEMLOCK=infinity; a failure is logged and the run goes on unlocked).\n"
      "  --deterministic: in lockstep, measure task costs on the stepped clock too, so no deadline binds and two\n"
      "  runs (of one build or of two) write identical outputs: for regression comparisons, not for budgets.\n"
      "  --stage-markers: bracket every timed stage run with a marker system call (an unassigned number: ENOSYS)\n"
      "  that bench/arm/insn_count_plugin.c counts instructions between under qemu-aarch64; prints the stage ids.\n"
      "  --set SECTION.KEY=VALUE: one config key (e.g. rooms.visible_min_share=0.7), after --config.\n"
      "  --dump-config: print the effective configuration as a config file, every key with its doc, unit,\n"
      "  range and origin, and exit (with no other argument: the defaults, firmware_app/config/default.json).\n",
      budgets::active::kBoard);
}

int convert(const std::string& in, const std::string& out, const std::string& mesh_path) {
  scene_graph::SceneGraph graph;
  std::string error;
  if (!graph.init(scene_graph::capacities_from_budget(), scene_graph::arena_bytes_from_budget(), &error)) {
    std::fprintf(stderr, "qsg_app: %s\n", error.c_str());
    return 1;
  }
  const scene_graph::JsonImportResult r = scene_graph::read_spark_dsg_json_file(in, graph);
  if (!r.ok) {
    std::fprintf(stderr, "qsg_app: %s\n", r.error.c_str());
    return 1;
  }
  scene_graph::JsonExportOptions options;
  options.labelspaces = &r.labelspaces;  // the file's label names go through
  scene_graph::EmbeddedMesh embedded;
  if (!mesh_path.empty()) {
    reconstruction::Mesh mesh;
    if (!reconstruction::read_ply(mesh_path, &mesh, &error)) {
      std::fprintf(stderr, "qsg_app: %s\n", error.c_str());
      return 1;
    }
    embedded = app::embedded_mesh(mesh);
    options.mesh = &embedded;
  }
  if (!scene_graph::write_spark_dsg_json_file(graph, out, &error, options)) {
    std::fprintf(stderr, "qsg_app: %s\n", error.c_str());
    return 1;
  }
  std::printf("qsg_app: %s (Spark-DSG %d.%d.%d) -> %s (1.1.3, %zu nodes)\n", in.c_str(), r.version[0], r.version[1],
              r.version[2], out.c_str(), graph.num_nodes());
  if (r.truncated.total() != 0) std::printf("qsg_app: kept short of the file: %s\n", r.truncated.summary().c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  app::AppConfig config;
  bool quiet = false;
  bool dump_config = false;
  bool deterministic = false;  // --deterministic: lockstep costs on the stepped clock (regression comparisons)
  std::string error, report_json;
  // The config file first, so the flags override it wherever they appear.
  for (int i = 1; i + 1 < argc; ++i)
    if (std::strcmp(argv[i], "--config") == 0 && !config.load(argv[i + 1], &error)) {
      std::fprintf(stderr, "qsg_app: %s\n", error.c_str());
      return 2;
    }
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--config" && has_value) {
      ++i;
    } else if (a == "--convert" && i + 2 < argc) {
      const bool with_mesh = i + 4 < argc && std::strcmp(argv[i + 3], "--mesh") == 0;
      return convert(argv[i + 1], argv[i + 2], with_mesh ? argv[i + 4] : "");
    } else if (a == "--driver" && has_value) {
      const std::string d = argv[++i];
      if (d == "sim") config.driver = app::Driver::kSim;
      else if (d == "replay") config.driver = app::Driver::kReplay;
      else if (d == "v4l2") config.driver = app::Driver::kV4l2;
      else {
        std::fprintf(stderr, "qsg_app: --driver: expected sim, replay or v4l2, got '%s'\n", d.c_str());
        return 2;
      }
    } else if (a == "--replay" && has_value) {
      config.replay_path = argv[++i];
    } else if (a == "--calibration" && has_value) {
      config.replay.calibration = argv[++i];
    } else if (a == "--output" && has_value) {
      config.output_dir = argv[++i];
    } else if (a == "--duration" && has_value) {
      config.duration_s = std::atof(argv[++i]);
    } else if (a == "--realtime") {
      config.lockstep = false;
    } else if (a == "--lockstep") {
      config.lockstep = true;
    } else if (a == "--seed" && has_value) {
      config.building.seed = std::strtoull(argv[++i], nullptr, 10);
    } else if (a == "--rooms" && has_value) {
      config.building.num_rooms = std::atoi(argv[++i]);
    } else if (a == "--tours" && has_value) {
      config.exploration.tours = std::atoi(argv[++i]);
    } else if (a == "--odometry" && has_value) {
      if (!app::odometry_source_from_string(argv[++i], &config.odometry.source)) {
        std::fprintf(stderr, "qsg_app: --odometry: expected auto, sim_drift, ground_truth, tum, stream or static, got '%s'\n",
                     argv[i]);
        return 2;
      }
    } else if (a == "--odometry-tum" && has_value) {
      config.odometry.source = app::OdometrySourceKind::kTum;
      config.odometry.tum_path = argv[++i];
    } else if (a == "--pose-stream" && has_value) {
      const std::string v = argv[++i];
      config.odometry.source = app::OdometrySourceKind::kStream;
      const std::size_t colon = v.rfind(':');
      if (v.rfind("unix:", 0) == 0 && v.size() > 5) {
        config.odometry.stream_transport = "unix";
        config.odometry.stream_unix_path = v.substr(5);
      } else if (v.rfind("udp:", 0) == 0 && colon > 4 && colon + 1 < v.size()) {
        config.odometry.stream_transport = "udp";
        config.odometry.stream_bind_address = v.substr(4, colon - 4);
        char* end = nullptr;
        const long port = std::strtol(v.c_str() + colon + 1, &end, 10);
        if (*end != '\0' || port < 0 || port > 65535) {
          std::fprintf(stderr, "qsg_app: --pose-stream: bad port in '%s'\n", v.c_str());
          return 2;
        }
        config.odometry.stream_port = static_cast<int>(port);
      } else {
        std::fprintf(stderr, "qsg_app: --pose-stream: expected udp:ADDRESS:PORT or unix:PATH, got '%s'\n", v.c_str());
        return 2;
      }
    } else if (a == "--world" && has_value) {
      config.world_path = argv[++i];
    } else if (a == "--fault-plan" && has_value) {
      config.fault_plan = argv[++i];
    } else if (a == "--report-json" && has_value) {
      report_json = argv[++i];
    } else if (a == "--mlockall") {
      config.lock_memory = true;
    } else if (a == "--deterministic") {
      deterministic = true;
    } else if (a == "--stage-markers") {
      runtime::set_stage_markers(true);
    } else if (a == "--quiet") {
      quiet = true;
    } else if (a == "--set" && has_value) {
      if (!params::set(app::app_schema(), &config, argv[++i], &error)) {
        std::fprintf(stderr, "qsg_app: --set %s\n", error.c_str());
        return 2;
      }
    } else if (a == "--dump-config") {
      dump_config = true;
    } else if (a == "--help" || a == "-h") {
      usage();
      return 0;
    } else {
      std::fprintf(stderr, "qsg_app: unknown or incomplete argument '%s'\n", a.c_str());
      usage();
      return 2;
    }
  }
  if (const std::string bad = config.check(); !bad.empty()) {
    std::fprintf(stderr, "qsg_app: config: %s\n", bad.c_str());
    return 2;
  }
  if (dump_config) {
    std::fputs(params::dump_json(app::app_schema(), config, app::default_config_header()).c_str(), stdout);
    return 0;
  }
  if (app::AppFaultPlan plan; !config.fault_plan.empty() && !app::load_app_fault_plan(config.fault_plan, &plan, &error)) {
    std::fprintf(stderr, "qsg_app: %s\n", error.c_str());
    return 2;
  }

  std::printf("qsg_app: board %s (%s)\n", budgets::active::kBoard, budgets::active::kTable.description);
  config.print(stdout);
  if (runtime::stage_markers_on()) runtime::print_stage_markers(budgets::active::kTable, stdout);

  runtime::SteppedClock stepped;
  runtime::WallClock wall;
  runtime::Clock* clock = config.lockstep ? static_cast<runtime::Clock*>(&stepped) : &wall;
  app::Pipeline pipeline;
  // Lockstep steps the cadence; costs are still measured for real, unless --deterministic measures them on the
  // stepped clock too (no deadline binds: two runs of one build, or of two builds, write the same outputs).
  pipeline.set_cost_clock(deterministic && config.lockstep ? static_cast<runtime::Clock*>(&stepped) : &wall);
  if (!pipeline.init(config, clock, &error)) {
    std::fprintf(stderr, "qsg_app: start-up failed: %s\n", error.c_str());
    return 1;
  }
  pipeline.scheduler().print_table(stdout);
  const budgets::BoardTable& table = budgets::active::kTable;
  std::printf("arenas (%s):", table.board);
  for (std::size_t i = 0; i < table.num_arenas; ++i)
    std::printf(" %s %.1f MB%s", table.arenas[i].name, table.arenas[i].bytes / 1048576.0, i + 1 < table.num_arenas ? "," : "\n");
  std::printf("queues (%s):", table.board);
  for (std::size_t i = 0; i < table.num_queues; ++i)
    std::printf(" %s depth %u %s%s", table.queues[i].name, table.queues[i].depth, budgets::to_string(table.queues[i].policy),
                i + 1 < table.num_queues ? "," : "\n");

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::uint64_t steps = 0;
  int last_percent = -1;
  // The progress bar is for a terminal: into a log file its carriage returns make one endless line.
  const bool progress_bar = !quiet && ::isatty(STDERR_FILENO) == 1;
  while (pipeline.step()) {
    if (g_stop) pipeline.request_stop();
    const double progress = pipeline.progress();
    if (progress_bar && progress >= 0.0 && ++steps % 64 == 0) {
      const int percent = static_cast<int>(progress * 100.0);
      if (percent != last_percent) {
        last_percent = percent;
        char bar[41];
        for (int k = 0; k < 40; ++k) bar[k] = k < percent * 40 / 100 ? '#' : '.';
        bar[40] = '\0';
        std::fprintf(stderr, "\r[%s] %3d%%", bar, percent);
      }
    }
  }
  if (progress_bar && last_percent >= 0) std::fprintf(stderr, "\n");
  if (g_stop) std::printf("qsg_app: stopped by signal; writing the final outputs\n");

  std::printf("run: %llu frames, %llu keyframes (%llu integrated), %llu frontend updates, %llu agent nodes\n",
              (unsigned long long)pipeline.counters().frames_read, (unsigned long long)pipeline.counters().keyframes,
              (unsigned long long)pipeline.counters().keyframes_integrated,
              (unsigned long long)pipeline.counters().frontend_updates,
              (unsigned long long)pipeline.counters().agent_nodes);
  pipeline.scheduler().print_stats(stdout);
  pipeline.reconstruction().counters().print(stdout);
  pipeline.frame_queue_stats().print(stdout);
  pipeline.odometry().print_report(stdout);
  pipeline.frontend().agents().counters().print(stdout);
  pipeline.frontend().agents().chain_stats().print(stdout);
  pipeline.graph().for_each_resource([](const memory::ResourceStats& s) { s.print(stdout); });
  pipeline.frontend().for_each_resource([](const memory::ResourceStats& s) { s.print(stdout); });
  // Online doors before the final stage replaces them (finish() has stopped the backend that owns the door set).
  const app::PipelineCounters online = pipeline.counters();
  const bool outputs_written = pipeline.finish(&error);
  if (!outputs_written) std::fprintf(stderr, "qsg_app: writing the outputs failed: %s\n", error.c_str());
  // Every counter of every driver and stage, the faults injected and the recovery from them.
  const std::vector<app::ReportGroup> report = app::collect_exit_report(pipeline);
  app::print_exit_report(report, stdout);
  pipeline.faults().print_report(stdout);
  // An empty or all-rejected input is a failed run, not an empty success (the outputs above are written anyway).
  const std::string nothing = pipeline.nothing_mapped_reason();
  const int status = !nothing.empty() ? 3 : !outputs_written ? 1 : 0;
  if (!report_json.empty() && !app::write_exit_report_json(report, status, report_json, &error)) {
    std::fprintf(stderr, "qsg_app: the exit report: %s\n", error.c_str());
    if (status == 0) return 1;
  }
  if (!nothing.empty()) {
    std::fprintf(stderr, "qsg_app: nothing was mapped: %s\n", nothing.c_str());
    return 3;
  }
  if (!outputs_written) return 1;
  pipeline.online_doors().for_each_resource([](const memory::ResourceStats& s) { s.print(stdout); });
  std::printf("online doors: %llu window passes (longest %.1f ms, %llu skipped on stairs), %llu doors (%llu kept "
              "through a missed pass, %llu dropped, %llu found but gone round by the places, %llu window places or "
              "edges refused), %llu blocks painted, %llu paints deferred\n",
              (unsigned long long)online.door_passes, 1e-3 * online.door_pass_max_us,
              (unsigned long long)online.door_passes_climbing, (unsigned long long)online.online_doors,
              (unsigned long long)online.online_doors_kept_missed, (unsigned long long)online.online_doors_dropped,
              (unsigned long long)online.online_doors_bypassed, (unsigned long long)online.online_bypass_refused,
              (unsigned long long)online.blocks_painted, (unsigned long long)online.wall_paint_deferred);
  std::printf("final: %llu rooms (%llu labelled, %llu merged into a room they see), %llu doors closing %llu place "
              "edges, %llu room updates\n",
              (unsigned long long)pipeline.counters().rooms, (unsigned long long)pipeline.counters().rooms_labelled,
              (unsigned long long)pipeline.counters().rooms_merged_visible,
              (unsigned long long)pipeline.counters().doors,
              (unsigned long long)pipeline.counters().door_edges_closed,
              (unsigned long long)pipeline.counters().backend_updates);
  return 0;
}
