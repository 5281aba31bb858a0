// The simulated robot through a generated building on the board's task table, in lockstep cadence with every
// task's cost measured on the wall clock: prints each task's runs, median, p99 and max against its budget and
// exits non-zero when a p99 exceeds its budget (CI runs it and reports, without failing on it). Telemetry runs at
// its real interval (its lines go through the writer thread; they are printed). The worker threads are checked
// too: the backend's room updates and, when the network is found (../shared/data/models or --model), the
// segmentation worker, each run's thread CPU time against the board's thread budget; in lockstep the worker is
// modelled busy for its measured CPU time, so the share of keyframes labelled is what one core of its own allows,
// checked against the budget's every_n_keyframes.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <sys/stat.h>
#include <vector>

#include "bench/figures.h"
#include "budgets/budget_table.h"
#include "firmware_app/app_params.h"
#include "firmware_app/pipeline.h"

namespace {

using namespace qsg;

struct Samples {
  std::vector<std::vector<std::int64_t>> per_task;
  std::vector<std::int64_t> per_keyframe;  // reconstruction + frontend of one keyframe: its processing latency
  std::size_t reconstruction = SIZE_MAX, frontend = SIZE_MAX;
  static void observe(void* user, std::size_t task, std::int64_t duration_us) {
    Samples& s = *static_cast<Samples*>(user);
    if (task < s.per_task.size()) s.per_task[task].push_back(duration_us);
    if (task == s.reconstruction) s.per_keyframe.push_back(duration_us);
    else if (task == s.frontend && !s.per_keyframe.empty()) s.per_keyframe.back() += duration_us;
  }
};

// Thread runs (backend updates, segmentation frames): CPU and wall microseconds.
struct ThreadSamples {
  std::vector<std::int64_t> backend_cpu, backend_wall, segmentation_cpu, segmentation_wall;
  static void backend(void* user, std::int64_t cpu, std::int64_t wall) {
    auto& s = *static_cast<ThreadSamples*>(user);
    s.backend_cpu.push_back(cpu);
    s.backend_wall.push_back(wall);
  }
  static void segmentation(void* user, std::int64_t cpu, std::int64_t wall) {
    auto& s = *static_cast<ThreadSamples*>(user);
    s.segmentation_cpu.push_back(cpu);
    s.segmentation_wall.push_back(wall);
  }
};

std::int64_t quantile(std::vector<std::int64_t> v, double q) {
  if (v.empty()) return 0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

}  // namespace

int main(int argc, char** argv) {
  app::AppConfig config;
  config.output_dir = "build/app_budget_check";
  config.snapshot_interval_s = 1e9;  // snapshots are not a task (heap JSON, off the loop's budget)
  // The network, when the shared data has it: segmentation on, ground-truth labels off.
  {
    const char* env = std::getenv("QSG_SHARED_DATA");
    const std::string dir = env != nullptr ? env : std::string(QSG_SOURCE_DIR) + "/../shared/data";
    const std::string model = dir + "/models/espnetv2_s2_pascal384.onnx";
    struct stat st {};
    if (::stat(model.c_str(), &st) == 0) config.segmentation.model_path = model;
  }
  config.segmentation.label_map_path = std::string(QSG_SOURCE_DIR) + "/firmware_app/config/segmentation_pascal_voc.json";
  config.segmentation.lockstep_busy_from_cost = true;
  std::string json_path;
  double duration_s = 120.0;
  bool cpu_cost = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--json" && i + 1 < argc) json_path = argv[++i];
    else if (a == "--duration" && i + 1 < argc) duration_s = std::atof(argv[++i]);
    else if (a == "--rooms" && i + 1 < argc) config.building.num_rooms = std::atoi(argv[++i]);
    else if (a == "--seed" && i + 1 < argc) config.building.seed = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--output" && i + 1 < argc) config.output_dir = argv[++i];
    else if (a == "--model" && i + 1 < argc) config.segmentation.model_path = argv[++i];
    else if (a == "--no-segmentation") config.segmentation.model_path.clear();
    else if (a == "--set" && i + 1 < argc) {  // a config key, as qsg_app --set SECTION.KEY=VALUE
      std::string error;
      if (!params::set(app::app_schema(), &config, argv[++i], &error)) {
        std::fprintf(stderr, "app_budget_check: --set %s\n", error.c_str());
        return 2;
      }
    }
    else if (a == "--cost-clock" && i + 1 < argc && (std::strcmp(argv[i + 1], "wall") == 0 || std::strcmp(argv[i + 1], "cpu") == 0))
      cpu_cost = std::strcmp(argv[++i], "cpu") == 0;
    else if (a == "--size" && i + 1 < argc) {
      int w = 0, h = 0;
      if (std::sscanf(argv[++i], "%dx%d", &w, &h) != 2 || w < 16 || h < 16 || w > 640 || h > 480) {
        std::fprintf(stderr, "--size: expected WxH up to 640x480\n");
        return 2;
      }
      config.camera.intrinsics.width = w;  // the focal length follows (AppConfig::sim_camera)
      config.camera.intrinsics.height = h;
    }
    else {
      std::printf("usage: app_budget_check [--duration S (120; 0 = whole tour)] [--rooms N] [--seed N] [--size WxH] "
                  "[--output DIR] [--json FILE] [--model ONNX | --no-segmentation] [--cost-clock wall|cpu]\n"
                  "                        [--set SECTION.KEY=VALUE]...  (a config key, as qsg_app --set)\n"
                  "  The app's pipeline on the simulated robot, cadence in lockstep: each task's and thread's median /\n"
                  "  p99 / max against the board's budget (exit 1 on a violation; CI runs it and reports) and the\n"
                  "  end-to-end per-keyframe latency with the keyframe rate it sustains. --size 640x480 --duration 0 for\n"
                  "  the whole tour. JSON: app_budget.*\n"
                  "  --cost-clock: tasks timed on the wall clock (default; includes time other processes took the\n"
                  "  core) or on the loop thread's CPU clock (what the task itself costs); threads always on CPU time\n");
      return a == "--help" ? 0 : 2;
    }
  }
  config.duration_s = duration_s;
  config.ground_truth_labels = config.segmentation.model_path.empty();  // the network labels, when it runs
  runtime::SteppedClock cadence;
  runtime::WallClock wall;
  runtime::ThreadCpuClock cpu_clock;
  app::Pipeline pipeline;
  pipeline.set_cost_clock(cpu_cost ? static_cast<runtime::Clock*>(&cpu_clock) : &wall);
  Samples samples;
  ThreadSamples threads;
  pipeline.set_thread_observers(ThreadSamples::backend, ThreadSamples::segmentation, &threads);
  std::string error;
  if (!pipeline.init(config, &cadence, &error)) {
    std::fprintf(stderr, "app_budget_check: %s\n", error.c_str());
    return 2;
  }
  samples.per_task.resize(pipeline.scheduler().num_tasks());
  for (std::size_t i = 0; i < pipeline.scheduler().num_tasks(); ++i) {
    if (std::strcmp(pipeline.scheduler().task(i).budget.name, "reconstruction") == 0) samples.reconstruction = i;
    if (std::strcmp(pipeline.scheduler().task(i).budget.name, "frontend") == 0) samples.frontend = i;
  }
  const auto wall_start = std::chrono::steady_clock::now();
  pipeline.set_run_observer(Samples::observe, &samples);
  while (pipeline.step()) {
  }
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  const budgets::BoardTable& table = budgets::active::kTable;
  std::printf("\nboard %s: %.0f s of simulated time, %llu keyframes; task costs on the %s of this machine\n",
              table.board, duration_s, (unsigned long long)pipeline.counters().keyframes,
              cpu_cost ? "loop thread's CPU clock" : "wall clock");
  std::printf("  %-16s %8s %10s %10s %10s %10s  %s\n", "task", "runs", "median_us", "p99_us", "max_us", "budget_us",
              "p99 within budget");
  char conditions[384];
  std::snprintf(conditions, sizeof conditions,
                "board %s, %d-room building seed %llu, %dx%d camera, %.0f s lockstep, telemetry every %.1f s, "
                "segmentation %s, tasks timed on the %s",
                table.board, config.building.num_rooms, (unsigned long long)config.building.seed,
                config.camera.intrinsics.width, config.camera.intrinsics.height, duration_s,
                config.telemetry_interval_s,
                config.segmentation.model_path.empty() ? "off" : "ESPNetv2 on 1 OpenCV thread (its own core, modelled)",
                cpu_cost ? "thread CPU clock" : "wall clock");
  bench::Figures figures(conditions);
  int violations = 0;
  for (std::size_t i = 0; i < pipeline.scheduler().num_tasks(); ++i) {
    const runtime::Scheduler::Task& t = pipeline.scheduler().task(i);
    const std::vector<std::int64_t>& v = samples.per_task[i];
    const std::int64_t p50 = quantile(v, 0.5), p99 = quantile(v, 0.99);
    const std::int64_t max = v.empty() ? 0 : *std::max_element(v.begin(), v.end());
    const bool ok = p99 <= static_cast<std::int64_t>(t.budget.budget_us);
    violations += ok ? 0 : 1;
    std::printf("  %-16s %8zu %10lld %10lld %10lld %10u  %s\n", t.budget.name, v.size(), (long long)p50, (long long)p99,
                (long long)max, t.budget.budget_us, ok ? "yes" : "NO (violation)");
    const std::string prefix = std::string("app_budget.") + t.budget.name;
    figures.add(prefix + ".median", static_cast<double>(p50), "us");
    figures.add(prefix + ".p99", static_cast<double>(p99), "us");
    figures.add(prefix + ".max", static_cast<double>(max), "us");
    figures.add(prefix + ".budget", static_cast<double>(t.budget.budget_us), "us");
  }
  // The worker threads: each run's CPU time on its own thread against the thread budget (wall time beside it: in
  // lockstep the backend and the segmentation run on the loop's thread, so the two agree up to preemption).
  std::printf("  %-16s %8s %10s %10s %10s %10s  %s   (thread CPU time; wall p99 after)\n", "thread", "runs",
              "median_us", "p99_us", "max_us", "budget_us", "p99 within budget");
  const auto thread_row = [&](const char* name, const std::vector<std::int64_t>& cpu,
                              const std::vector<std::int64_t>& wall_us) {
    const budgets::ThreadBudget* b = table.find_thread(name);
    const std::uint32_t budget = b != nullptr ? b->budget_us : 0;
    const std::int64_t p50 = quantile(cpu, 0.5), p99 = quantile(cpu, 0.99);
    const std::int64_t max = cpu.empty() ? 0 : *std::max_element(cpu.begin(), cpu.end());
    const bool ok = b != nullptr && p99 <= static_cast<std::int64_t>(budget);
    violations += ok ? 0 : 1;
    std::printf("  %-16s %8zu %10lld %10lld %10lld %10u  %s   wall p99 %lld us\n", name, cpu.size(), (long long)p50,
                (long long)p99, (long long)max, budget, ok ? "yes" : "NO (violation)",
                (long long)quantile(wall_us, 0.99));
    const std::string prefix = std::string("app_budget.thread.") + name;
    figures.add(prefix + ".runs", static_cast<double>(cpu.size()), "runs");
    figures.add(prefix + ".cpu_median", static_cast<double>(p50), "us");
    figures.add(prefix + ".cpu_p99", static_cast<double>(p99), "us");
    figures.add(prefix + ".cpu_max", static_cast<double>(max), "us");
    figures.add(prefix + ".wall_p99", static_cast<double>(quantile(wall_us, 0.99)), "us");
    figures.add(prefix + ".budget", static_cast<double>(budget), "us");
  };
  thread_row("backend", threads.backend_cpu, threads.backend_wall);
  // The backend's budgeted parts: the online door passes (inside its updates: at most 1 % of them over the part's
  // budget) and the final stage (finish(): doors on the whole surface, the last rooms and labels; its one run).
  {
    const budgets::ThreadBudget* b = table.find_thread("backend");
    std::string finish_error;
    if (!pipeline.finish(&finish_error)) std::fprintf(stderr, "app_budget_check: finish: %s\n", finish_error.c_str());
    const auto part_row = [&](const char* name, const runtime::TaskStats& st, std::uint32_t budget) {
      const bool ok = budget > 0 && st.overruns * 100 <= st.runs;
      violations += ok ? 0 : 1;
      std::printf("  %-16s %8llu %10.0f %10s %10lld %10u  %s   (mean; over budget in %llu runs)\n", name,
                  (unsigned long long)st.runs, st.mean_us(), "-", (long long)st.max_us, budget,
                  ok ? "yes" : "NO (violation)", (unsigned long long)st.overruns);
      const std::string prefix = std::string("app_budget.thread.") + name;
      figures.add(prefix + ".runs", static_cast<double>(st.runs), "runs");
      figures.add(prefix + ".cpu_mean", st.mean_us(), "us");
      figures.add(prefix + ".cpu_max", static_cast<double>(st.max_us), "us");
      figures.add(prefix + ".overruns", static_cast<double>(st.overruns), "runs");
      figures.add(prefix + ".budget", static_cast<double>(budget), "us");
    };
    part_row("backend.doors", pipeline.door_pass_cpu_stats(), b != nullptr ? b->part_budget_us : 0);
    part_row("backend.final", pipeline.finish_cpu_stats(), b != nullptr ? b->finish_budget_us : 0);
    if (pipeline.backend_stage().loop_closure_enabled())
      part_row("backend.solve", pipeline.solve_cpu_stats(), b != nullptr ? b->solve_budget_us : 0);
  }
  if (pipeline.segmentation().initialized()) {
    thread_row("segmentation", threads.segmentation_cpu, threads.segmentation_wall);
    const app::PipelineCounters& c = pipeline.counters();
    const budgets::ThreadBudget* b = table.find_thread("segmentation");
    const double share = c.keyframes_integrated > 0
                             ? static_cast<double>(c.keyframes_segmented) / static_cast<double>(c.keyframes_integrated)
                             : 0.0;
    const double asked = b != nullptr && b->every_n_keyframes > 0 ? 1.0 / b->every_n_keyframes : 0.0;
    const bool ok = share >= asked;
    violations += ok ? 0 : 1;
    std::printf("  segmentation labelled %llu of %llu keyframes (1 in %.1f; budget: at least 1 in %u)  %s\n",
                (unsigned long long)c.keyframes_segmented, (unsigned long long)c.keyframes_integrated,
                share > 0 ? 1.0 / share : 0.0, b != nullptr ? b->every_n_keyframes : 0, ok ? "yes" : "NO (violation)");
    figures.add("app_budget.thread.segmentation.labelled_share", 100.0 * share, "%");
    figures.add("app_budget.thread.segmentation.keyframes_per_label", share > 0 ? 1.0 / share : 0.0, "keyframes");
  } else {
    std::printf("  segmentation: off (no model: ../shared/data/models/espnetv2_s2_pascal384.onnx or --model)\n");
  }
  const runtime::TelemetryWriterStats t = pipeline.telemetry_stats();
  std::printf("  telemetry: %llu lines at %.1f s, %llu written, %llu dropped (output too slow), %llu cut\n",
              (unsigned long long)t.lines, config.telemetry_interval_s, (unsigned long long)t.written,
              (unsigned long long)t.dropped, (unsigned long long)t.truncated);
  figures.add("app_budget.telemetry.lines", static_cast<double>(t.lines), "lines");
  figures.add("app_budget.telemetry.dropped", static_cast<double>(t.dropped), "lines");
  figures.add("app_budget.violations", violations, "tasks and threads");
  // End to end: what the loop sustains. Rendering is the simulator's cost and runs outside the tasks, so the
  // keyframe rate the pipeline could sustain is 1 / (mean per-keyframe processing); the wall rate below includes
  // rendering and the simulated camera's own 10 Hz pace in simulated time.
  double sum_us = 0.0;
  for (std::int64_t v : samples.per_keyframe) sum_us += static_cast<double>(v);
  const double mean_us = samples.per_keyframe.empty() ? 0.0 : sum_us / static_cast<double>(samples.per_keyframe.size());
  const double sustainable = mean_us > 0.0 ? 1e6 / mean_us : 0.0;
  const std::int64_t kf_p50 = quantile(samples.per_keyframe, 0.5), kf_p99 = quantile(samples.per_keyframe, 0.99);
  std::printf("per keyframe (reconstruction + frontend): median %lld us, p99 %lld us, mean %.0f us -> %.1f keyframes/s "
              "sustainable (target >= 5)\n",
              (long long)kf_p50, (long long)kf_p99, mean_us, sustainable);
  std::printf("wall: %.1f s for %llu keyframes including rendering = %.1f keyframes/s\n", wall_s,
              (unsigned long long)pipeline.counters().keyframes, static_cast<double>(pipeline.counters().keyframes) / wall_s);
  figures.add("app_e2e.keyframe_latency_median", static_cast<double>(kf_p50), "us");
  figures.add("app_e2e.keyframe_latency_p99", static_cast<double>(kf_p99), "us");
  figures.add("app_e2e.sustainable_keyframes_per_s", sustainable, "keyframes/s");
  figures.add("app_e2e.wall_keyframes_per_s_with_rendering",
              static_cast<double>(pipeline.counters().keyframes) / wall_s, "keyframes/s");
  if (!json_path.empty() && !figures.write(json_path)) return 2;
  std::printf("%s\n", violations == 0 ? "every task's and thread's p99 is within its budget"
                                      : "BUDGET VIOLATION: some task's or thread's p99 exceeds its budget");
  return violations == 0 ? 0 : 1;
}
