// The simulated robot through a generated building on the board's task table, in lockstep cadence with every
// task's cost measured on the wall clock: prints each task's runs, median, p99 and max against its budget and
// exits non-zero when a p99 exceeds its budget (CI runs it and reports, without failing on it).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "bench/figures.h"
#include "budgets/budget_table.h"
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
  config.telemetry_interval_s = 1e9;  // quiet: this program prints its own table
  config.snapshot_interval_s = 1e9;
  std::string json_path;
  double duration_s = 120.0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--json" && i + 1 < argc) json_path = argv[++i];
    else if (a == "--duration" && i + 1 < argc) duration_s = std::atof(argv[++i]);
    else if (a == "--rooms" && i + 1 < argc) config.building.num_rooms = std::atoi(argv[++i]);
    else if (a == "--seed" && i + 1 < argc) config.building.seed = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--output" && i + 1 < argc) config.output_dir = argv[++i];
    else if (a == "--size" && i + 1 < argc) {
      int w = 0, h = 0;
      if (std::sscanf(argv[++i], "%dx%d", &w, &h) != 2 || w < 16 || h < 16 || w > 640 || h > 480) {
        std::fprintf(stderr, "--size: expected WxH up to 640x480\n");
        return 2;
      }
      const double f = 525.0 * w / 640.0;
      config.camera.intrinsics = {w, h, f, f, 0.5 * w - 0.5, 0.5 * h - 0.5};
    }
    else {
      std::printf("usage: app_budget_check [--duration S (120; 0 = whole tour)] [--rooms N] [--seed N] [--size WxH] "
                  "[--output DIR] [--json FILE]\n"
                  "  The app's pipeline on the simulated robot, cadence in lockstep, every task's cost on the wall\n"
                  "  clock: each task's median / p99 / max against the board's budget (exit 1 on a violation; CI runs\n"
                  "  it and reports) and the end-to-end per-keyframe latency (reconstruction + frontend) with the\n"
                  "  keyframe rate it sustains. --size 640x480 --duration 0 for the whole tour. JSON: app_budget.*\n");
      return a == "--help" ? 0 : 2;
    }
  }
  config.duration_s = duration_s;
  runtime::SteppedClock cadence;
  runtime::WallClock wall;
  app::Pipeline pipeline;
  pipeline.set_cost_clock(&wall);
  Samples samples;
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
  std::printf("\nboard %s: %.0f s of simulated time, %llu keyframes; task costs on the wall clock of this machine\n",
              table.board, duration_s, (unsigned long long)pipeline.counters().keyframes);
  std::printf("  %-16s %8s %10s %10s %10s %10s  %s\n", "task", "runs", "median_us", "p99_us", "max_us", "budget_us",
              "p99 within budget");
  char conditions[160];
  std::snprintf(conditions, sizeof conditions, "board %s, %d-room building seed %llu, %dx%d camera, %.0f s lockstep",
                table.board, config.building.num_rooms, (unsigned long long)config.building.seed,
                config.camera.intrinsics.width, config.camera.intrinsics.height, duration_s);
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
  figures.add("app_budget.violations", violations, "tasks");
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
  std::printf("%s\n", violations == 0 ? "every task's p99 is within its budget"
                                      : "BUDGET VIOLATION: some task's p99 exceeds its budget");
  return violations == 0 ? 0 : 1;
}
