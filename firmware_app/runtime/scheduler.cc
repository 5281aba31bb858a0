// Rate and keyframe scheduling over the board's task table, with per-task accounting.
#include "firmware_app/runtime/scheduler.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <thread>

#include "firmware_app/runtime/stage_marker.h"

namespace qsg::runtime {

void WallClock::sleep_until_ns(std::int64_t t_ns) {
  const std::int64_t now = now_ns();
  if (t_ns > now) std::this_thread::sleep_for(std::chrono::nanoseconds(t_ns - now));
}

std::string SchedulerConfig::check() const {
  if (!(tick_hz >= 1.0 && tick_hz <= 10000.0)) return "tick_hz must be in [1, 10000]";
  return {};
}

void SchedulerConfig::print(std::FILE* out) const {
  std::fprintf(out, "scheduler: tick_hz=%.1f skip_rate_tasks_without_time=%d defer_after_overrun=%d\n", tick_hz,
               skip_rate_tasks_without_time ? 1 : 0, defer_after_overrun ? 1 : 0);
}

bool Scheduler::init(const SchedulerConfig& config, const budgets::BoardTable& table, Clock* clock,
                     std::string* error) {
  const auto fail = [error](const std::string& why) {
    if (error != nullptr) *error = "scheduler: " + why;
    return false;
  };
  const std::string bad = config.check();
  if (!bad.empty()) return fail("config: " + bad);
  if (clock == nullptr) return fail("no clock");
  if (table.num_tasks > kMaxTasks) return fail("the table has more than 16 tasks");
  config_ = config;
  clock_ = clock;
  cost_clock_ = clock;
  tick_period_ns_ = static_cast<std::int64_t>(std::llround(1e9 / config.tick_hz));
  tasks_.clear();
  for (std::size_t i = 0; i < table.num_tasks; ++i) {
    const budgets::TaskBudget& b = table.tasks[i];
    const bool by_rate = b.rate_hz > 0.0, by_keyframe = b.every_n_keyframes > 0;
    if (by_rate == by_keyframe)
      return fail(std::string("task '") + b.name + "' needs exactly one of rate_hz and every_n_keyframes");
    if (by_rate && b.rate_hz > config.tick_hz)
      return fail(std::string("task '") + b.name + "' runs faster than the tick (" + std::to_string(b.rate_hz) +
                  " Hz > " + std::to_string(config.tick_hz) + " Hz)");
    if (by_keyframe && b.offset >= b.every_n_keyframes)
      return fail(std::string("task '") + b.name + "' has offset >= every_n_keyframes");
    Task t;
    t.budget = b;
    t.period_ns = by_rate ? static_cast<std::int64_t>(std::llround(1e9 / b.rate_hz)) : 0;
    t.marker = static_cast<std::uint32_t>(i);
    tasks_.push_back(t);
  }
  std::stable_sort(tasks_.begin(), tasks_.end(),
                   [](const Task& a, const Task& b) { return a.budget.priority < b.budget.priority; });
  ticks_ = 0;
  started_ = false;
  return true;
}

bool Scheduler::bind(const char* task_name, TaskFn fn, void* user) {
  for (Task& t : tasks_)
    if (std::strcmp(t.budget.name, task_name) == 0) {
      t.fn = fn;
      t.user = user;
      return true;
    }
  return false;
}

const char* Scheduler::unbound() const {
  for (const Task& t : tasks_)
    if (t.fn == nullptr) return t.budget.name;
  return nullptr;
}

const Scheduler::Task* Scheduler::find(const char* name) const {
  for (const Task& t : tasks_)
    if (std::strcmp(t.budget.name, name) == 0) return &t;
  return nullptr;
}

void Scheduler::run(Task& task, std::uint64_t keyframe) {
  const std::int64_t start = cost_clock_->now_ns();
  const TaskContext context{start, start + static_cast<std::int64_t>(task.budget.budget_us) * 1000, keyframe};
  // Rate tasks are numbered by the tick they ran on, keyframe tasks by their keyframe.
  const std::uint64_t sequence = task.period_ns > 0 ? ticks_ : keyframe;
  stage_begin(task.marker, sequence);
  if (task.fn != nullptr) task.fn(task.user, context);
  stage_end(task.marker, sequence);
  const std::int64_t end = cost_clock_->now_ns();
  task.stats.record((end - start) / 1000, task.budget.budget_us);
  if (observer_ != nullptr) observer_(observer_user_, static_cast<std::size_t>(&task - tasks_.begin()), (end - start) / 1000);
}

void Scheduler::tick() {
  const std::int64_t tick_start = clock_->now_ns();
  if (!started_) {
    for (Task& t : tasks_) t.next_due_ns = tick_start;
    started_ = true;
  }
  const std::int64_t tick_end = tick_start + tick_period_ns_;
  for (Task& t : tasks_) {
    if (t.period_ns == 0) continue;
    const std::int64_t now = clock_->now_ns();
    if (now < t.next_due_ns) continue;
    const std::int64_t missed = (now - t.next_due_ns) / t.period_ns;  // whole periods that passed without a run
    const std::int64_t budget_ns = static_cast<std::int64_t>(t.budget.budget_us) * 1000;
    if (config_.skip_rate_tasks_without_time && t.budget.priority > 0 && now + budget_ns > tick_end) {
      ++t.stats.skips;  // stays due: runs on a later tick, where the periods it lost count as slips
      continue;
    }
    t.stats.slips += static_cast<std::uint64_t>(missed);
    run(t, 0);
    t.next_due_ns += (missed + 1) * t.period_ns;
  }
  ++ticks_;
}

void Scheduler::keyframe(std::uint64_t keyframe) {
  bool overran = false;
  for (Task& t : tasks_) {
    if (t.budget.every_n_keyframes == 0) continue;
    const bool on_cadence = keyframe % t.budget.every_n_keyframes == t.budget.offset;
    if (!on_cadence && !t.pending) continue;
    // An earlier stage overran: a lower-priority stage waits one keyframe, never two in a row, so the loop
    // recovers even when the overrun persists.
    if (overran && config_.defer_after_overrun && !t.pending) {
      t.pending = true;
      ++t.stats.deferrals;
      continue;
    }
    if (t.pending && !on_cadence) ++t.stats.slips;
    t.pending = false;
    const std::uint64_t overruns_before = t.stats.overruns;
    run(t, keyframe);
    overran = overran || t.stats.overruns != overruns_before;
  }
}

void Scheduler::print_table(std::FILE* out) const {
  std::fprintf(out, "task table (%zu tasks, tick %.1f Hz):\n", tasks_.size(), config_.tick_hz);
  std::fprintf(out, "  %-16s %-22s %10s %8s\n", "task", "cadence", "budget_us", "priority");
  for (const Task& t : tasks_) {
    char cadence[48];
    if (t.period_ns > 0) std::snprintf(cadence, sizeof cadence, "%.1f Hz", t.budget.rate_hz);
    else std::snprintf(cadence, sizeof cadence, "every %u keyframes +%u", t.budget.every_n_keyframes, t.budget.offset);
    std::fprintf(out, "  %-16s %-22s %10u %8u\n", t.budget.name, cadence, t.budget.budget_us, t.budget.priority);
  }
}

void Scheduler::print_stats(std::FILE* out) const {
  std::fprintf(out, "  %-16s %8s %9s %9s %9s %9s %9s %8s %6s %6s %6s\n", "task", "runs", "min_us", "mean_us", "p99<=us",
               "max_us", "budget_us", "overruns", "slips", "skips", "defers");
  for (const Task& t : tasks_) {
    const TaskStats& s = t.stats;
    std::fprintf(out, "  %-16s %8llu %9lld %9.0f %9lld %9lld %9u %8llu %6llu %6llu %6llu\n", t.budget.name,
                 (unsigned long long)s.runs, (long long)s.min_us, s.mean_us(), (long long)s.quantile_upper_us(0.99),
                 (long long)s.max_us, t.budget.budget_us, (unsigned long long)s.overruns, (unsigned long long)s.slips,
                 (unsigned long long)s.skips, (unsigned long long)s.deferrals);
  }
}

}  // namespace qsg::runtime
