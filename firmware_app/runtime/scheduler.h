// The tick loop's scheduler: one table (the board's budget table) decides every task's cadence, budget and
// priority. Rate tasks run on ticks of the injected clock; keyframe tasks run on every Nth keyframe with an
// offset (F' rate groups). Each task's statistics live in a fixed struct that tests assert on.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

#include "budgets/budget_types.h"
#include "core/memory/bounded_array.h"
#include "firmware_app/runtime/clock.h"
#include "firmware_app/runtime/task_stats.h"

namespace qsg::runtime {

inline constexpr std::size_t kMaxTasks = 16;

// What a task body is told: when it must be done (anytime stages stop there and resume next run).
struct TaskContext {
  std::int64_t now_ns = 0;       // on the cost clock (see Scheduler::set_cost_clock)
  std::int64_t deadline_ns = 0;  // now_ns + the task's budget
  std::uint64_t keyframe = 0;  // keyframe tasks: the keyframe's index
};
using TaskFn = void (*)(void* user, const TaskContext& context);

struct SchedulerConfig {
  double tick_hz = 200.0;  // the loop's base tick: rate tasks share each tick's time, highest priority first
  // A rate task whose budget does not fit the time left in the tick waits for the next tick (ArduPilot);
  // priority-0 tasks (driver polls) always run.
  bool skip_rate_tasks_without_time = true;
  // When a keyframe task overruns, lower-priority keyframe tasks of that keyframe move to the next keyframe
  // (the frontend is deferred, never dropped: it is anytime and catches up).
  bool defer_after_overrun = true;
  std::string check() const;
  void print(std::FILE* out) const;
};

class Scheduler {
 public:
  struct Task {
    budgets::TaskBudget budget{};
    TaskFn fn = nullptr;
    void* user = nullptr;
    std::int64_t period_ns = 0;    // rate tasks
    std::int64_t next_due_ns = 0;  // rate tasks
    bool pending = false;          // keyframe tasks: deferred to the next keyframe
    std::uint32_t marker = 0;      // its stage-marker id: its index in the board's table (stage_marker.h)
    TaskStats stats;
  };

  // Takes every task of the table, ordered by priority (stable). False with a reason for a bad table.
  bool init(const SchedulerConfig& config, const budgets::BoardTable& table, Clock* clock, std::string* error);
  // Binds a task body; every task of the table must be bound before the first tick (see unbound()).
  bool bind(const char* task_name, TaskFn fn, void* user);
  const char* unbound() const;  // name of the first task without a body, nullptr when all are bound
  // Measures task costs and deadlines with this clock instead of the cadence clock: a lockstep run (stepped
  // cadence) can still measure real costs. Tests leave it unset (costs come from the stepped clock).
  void set_cost_clock(Clock* clock) { cost_clock_ = clock; }
  // Told every run's exact duration (benchmarks keep the samples for exact percentiles; the loop does not).
  using RunObserver = void (*)(void* user, std::size_t task_index, std::int64_t duration_us);
  void set_run_observer(RunObserver observer, void* user) {
    observer_ = observer;
    observer_user_ = user;
  }

  // Runs the rate tasks that are due, in priority order, within one tick period.
  void tick();
  // Announces keyframe number `keyframe`: runs the keyframe tasks that fire on it (and deferred ones).
  void keyframe(std::uint64_t keyframe);

  const Task* find(const char* name) const;
  const TaskStats* stats(const char* name) const {
    const Task* t = find(name);
    return t == nullptr ? nullptr : &t->stats;
  }
  std::size_t num_tasks() const { return tasks_.size(); }
  const Task& task(std::size_t i) const { return tasks_[i]; }
  std::int64_t tick_period_ns() const { return tick_period_ns_; }
  std::uint64_t ticks() const { return ticks_; }
  const SchedulerConfig& config() const { return config_; }

  // The effective table: cadence, budget, priority of every task.
  void print_table(std::FILE* out) const;
  // One line per task: runs, min / mean / max, p99 upper bound, overruns, slips, skips, deferrals.
  void print_stats(std::FILE* out) const;

 private:
  void run(Task& task, std::uint64_t keyframe);

  SchedulerConfig config_;
  Clock* clock_ = nullptr;
  Clock* cost_clock_ = nullptr;
  RunObserver observer_ = nullptr;
  void* observer_user_ = nullptr;
  memory::BoundedArray<Task, kMaxTasks> tasks_;
  std::int64_t tick_period_ns_ = 0;
  std::uint64_t ticks_ = 0;
  bool started_ = false;
};

}  // namespace qsg::runtime
