// The simulated robot through a generated building on the board's task table, in lockstep cadence with every
// task's cost measured on the wall clock: prints each task's runs, median, p99 and max against its budget and
// exits non-zero when a p99 exceeds its budget (CI runs it and reports, without failing on it).
#include <algorithm>
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
  static void observe(void* user, std::size_t task, std::int64_t duration_us) {
    auto& s = static_cast<Samples*>(user)->per_task;
    if (task < s.size()) s[task].push_back(duration_us);
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
    else {
      std::printf("usage: app_budget_check [--duration S (120; 0 = whole tour)] [--rooms N] [--seed N] [--output DIR] "
                  "[--json FILE]\n");
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
  pipeline.set_run_observer(Samples::observe, &samples);
  while (pipeline.step()) {
  }

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
  if (!json_path.empty() && !figures.write(json_path)) return 2;
  std::printf("%s\n", violations == 0 ? "every task's p99 is within its budget"
                                      : "BUDGET VIOLATION: some task's p99 exceeds its budget");
  return violations == 0 ? 0 : 1;
}
