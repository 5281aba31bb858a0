// The scheduler against the boards' real task tables and against injected stage costs on a stepped clock:
// cadence, overruns, slips, skips, frontend deferral and recovery, no allocation per tick.
#include <gtest/gtest.h>

#include <vector>

#include "budgets/budget_table.h"
#include "firmware_app/runtime/scheduler.h"
#include "tests/support/allocation_counter.h"

namespace qsg::runtime {
namespace {

// A task body that costs a scripted number of microseconds on the stepped clock, and records when it ran.
struct Stage {
  SteppedClock* clock = nullptr;
  std::int64_t cost_us = 0;
  std::vector<std::uint64_t> keyframes;
  std::int64_t last_deadline_ns = 0;
  std::int64_t last_start_ns = 0;
  static void run(void* user, const TaskContext& c) {
    Stage& s = *static_cast<Stage*>(user);
    s.last_start_ns = c.now_ns;
    s.clock->advance_us(s.cost_us);
    s.keyframes.push_back(c.keyframe);
    s.last_deadline_ns = c.deadline_ns;
  }
};

void noop(void*, const TaskContext&) {}

budgets::BoardTable table_of(const budgets::TaskBudget* tasks, std::size_t n) {
  budgets::BoardTable t = budgets::host_sim::kTable;
  t.tasks = tasks;
  t.num_tasks = n;
  return t;
}

TEST(SchedulerTest, TakesEveryTaskOfEachBoardInPriorityOrder) {
  for (const budgets::BoardTable* board : budgets::kAllBoards) {
    SteppedClock clock;
    Scheduler s;
    std::string error;
    ASSERT_TRUE(s.init(SchedulerConfig{}, *board, &clock, &error)) << board->board << ": " << error;
    ASSERT_EQ(s.num_tasks(), board->num_tasks);
    for (std::size_t i = 1; i < s.num_tasks(); ++i)
      EXPECT_LE(s.task(i - 1).budget.priority, s.task(i).budget.priority) << board->board;
    EXPECT_STREQ(s.unbound(), s.task(0).budget.name) << "nothing bound yet";
    for (std::size_t i = 0; i < board->num_tasks; ++i) EXPECT_TRUE(s.bind(board->tasks[i].name, noop, nullptr));
    EXPECT_EQ(s.unbound(), nullptr);
    EXPECT_FALSE(s.bind("no_such_task", noop, nullptr));
    s.print_table(stdout);
  }
}

TEST(SchedulerTest, BadTablesAndConfigsAreRefusedByName) {
  SteppedClock clock;
  Scheduler s;
  std::string error;
  SchedulerConfig config;
  config.tick_hz = 0.0;
  EXPECT_FALSE(s.init(config, budgets::host_sim::kTable, &clock, &error));
  EXPECT_NE(error.find("tick_hz"), std::string::npos) << error;
  const budgets::TaskBudget both[] = {{"both", 10.0, 2, 0, 100, 1}};
  EXPECT_FALSE(s.init(SchedulerConfig{}, table_of(both, 1), &clock, &error));
  EXPECT_NE(error.find("'both'"), std::string::npos) << error;
  const budgets::TaskBudget fast[] = {{"fast", 1000.0, 0, 0, 100, 1}};
  EXPECT_FALSE(s.init(SchedulerConfig{}, table_of(fast, 1), &clock, &error));
  EXPECT_NE(error.find("faster than the tick"), std::string::npos) << error;
  const budgets::TaskBudget offset[] = {{"offset", 0.0, 5, 5, 100, 1}};
  EXPECT_FALSE(s.init(SchedulerConfig{}, table_of(offset, 1), &clock, &error));
  EXPECT_NE(error.find("offset"), std::string::npos) << error;
  EXPECT_FALSE(s.init(SchedulerConfig{}, budgets::host_sim::kTable, nullptr, &error));
}

TEST(SchedulerTest, RateTasksRunAtTheirTableRate) {
  SteppedClock clock;
  Scheduler s;
  std::string error;
  ASSERT_TRUE(s.init(SchedulerConfig{}, budgets::host_sim::kTable, &clock, &error)) << error;
  for (std::size_t i = 0; i < s.num_tasks(); ++i) s.bind(s.task(i).budget.name, noop, nullptr);
  for (int k = 0; k < 2000; ++k) {  // 10 s of 200 Hz ticks
    s.tick();
    clock.advance_ns(s.tick_period_ns());
  }
  for (std::size_t i = 0; i < s.num_tasks(); ++i) {
    const Scheduler::Task& t = s.task(i);
    if (t.period_ns == 0) {
      EXPECT_EQ(t.stats.runs, 0u) << t.budget.name << ": keyframe tasks do not run on ticks";
      continue;
    }
    const double expected = 10.0 * t.budget.rate_hz;
    EXPECT_NEAR(static_cast<double>(t.stats.runs), expected, 1.0 + expected * 0.01) << t.budget.name;
    EXPECT_EQ(t.stats.overruns, 0u);
    EXPECT_EQ(t.stats.slips, 0u);
  }
}

TEST(SchedulerTest, OverrunsSlipsAndSkipsAreCountedFromInjectedCosts) {
  // A poll (priority 0) that costs more than its budget, and a 50 Hz task that no longer fits in the tick.
  const budgets::TaskBudget tasks[] = {{"poll", 100.0, 0, 0, 500, 0}, {"report", 50.0, 0, 0, 2000, 3}};
  SteppedClock clock;
  Scheduler s;
  std::string error;
  ASSERT_TRUE(s.init(SchedulerConfig{}, table_of(tasks, 2), &clock, &error)) << error;
  Stage poll{&clock, 4000, {}, 0, 0};  // 4 ms of a 5 ms tick: the 2 ms report no longer fits
  Stage report{&clock, 100, {}, 0, 0};
  s.bind("poll", Stage::run, &poll);
  s.bind("report", Stage::run, &report);
  std::int64_t t0 = clock.now_ns();
  s.tick();
  EXPECT_EQ(s.stats("poll")->runs, 1u);
  EXPECT_EQ(s.stats("poll")->overruns, 1u);
  EXPECT_EQ(s.stats("poll")->max_us, 4000);
  EXPECT_EQ(s.stats("report")->runs, 0u);
  EXPECT_EQ(s.stats("report")->skips, 1u);
  // The poll becomes cheap again: report runs on the next tick, late by less than a period (no slip).
  poll.cost_us = 100;
  clock.sleep_until_ns(t0 + s.tick_period_ns());
  s.tick();
  EXPECT_EQ(s.stats("report")->runs, 1u);
  EXPECT_EQ(s.stats("report")->slips, 0u);
  // The loop stalls for 100 ms (a blocked driver): the 100 Hz poll lost 9 periods, the report 4.
  clock.advance_us(100000);
  s.tick();
  EXPECT_EQ(s.stats("poll")->slips, 9u);
  EXPECT_EQ(s.stats("report")->slips, 4u);
  // And recovers: on time again afterwards.
  for (int k = 0; k < 100; ++k) {
    clock.advance_ns(s.tick_period_ns());
    s.tick();
  }
  EXPECT_EQ(s.stats("poll")->slips, 9u);
  EXPECT_EQ(s.stats("report")->slips, 4u);
}

TEST(SchedulerTest, KeyframeTasksFollowDivisorAndOffset) {
  // The Xavier's table: frontend every 5th keyframe at offset 2.
  const budgets::TaskBudget* xavier_frontend = budgets::xavier_nx::kTable.find_task("frontend");
  ASSERT_NE(xavier_frontend, nullptr);
  const budgets::TaskBudget tasks[] = {{"reconstruction", 0.0, 1, 0, 20000, 1}, *xavier_frontend};
  SteppedClock clock;
  Scheduler s;
  std::string error;
  ASSERT_TRUE(s.init(SchedulerConfig{}, table_of(tasks, 2), &clock, &error)) << error;
  Stage recon{&clock, 5000, {}, 0, 0}, frontend{&clock, 20000, {}, 0, 0};
  s.bind("reconstruction", Stage::run, &recon);
  s.bind("frontend", Stage::run, &frontend);
  for (std::uint64_t k = 0; k < 20; ++k) s.keyframe(k);
  EXPECT_EQ(recon.keyframes.size(), 20u);
  std::vector<std::uint64_t> expected;
  for (std::uint64_t k = 0; k < 20; ++k)
    if (k % xavier_frontend->every_n_keyframes == xavier_frontend->offset) expected.push_back(k);
  EXPECT_EQ(frontend.keyframes, expected);
  // The frontend's deadline is its budget from the table.
  EXPECT_EQ(frontend.last_deadline_ns - frontend.last_start_ns,
            static_cast<std::int64_t>(xavier_frontend->budget_us) * 1000);
}

TEST(SchedulerTest, FrontendIsDeferredAfterAnOverrunAndTheLoopRecovers) {
  const budgets::TaskBudget tasks[] = {{"reconstruction", 0.0, 1, 0, 20000, 1}, {"frontend", 0.0, 1, 0, 60000, 2}};
  SteppedClock clock;
  Scheduler s;
  std::string error;
  ASSERT_TRUE(s.init(SchedulerConfig{}, table_of(tasks, 2), &clock, &error)) << error;
  Stage recon{&clock, 5000, {}, 0, 0}, frontend{&clock, 10000, {}, 0, 0};
  s.bind("reconstruction", Stage::run, &recon);
  s.bind("frontend", Stage::run, &frontend);
  s.keyframe(0);
  recon.cost_us = 30000;  // keyframe 1: reconstruction overruns -> frontend waits for keyframe 2
  s.keyframe(1);
  recon.cost_us = 5000;
  s.keyframe(2);
  EXPECT_EQ(s.stats("reconstruction")->overruns, 1u);
  EXPECT_EQ(s.stats("frontend")->deferrals, 1u);
  EXPECT_EQ(frontend.keyframes, (std::vector<std::uint64_t>{0, 2}));
  // A persistent overrun never starves the frontend: it runs at least every other keyframe.
  recon.cost_us = 30000;
  for (std::uint64_t k = 3; k < 13; ++k) s.keyframe(k);
  EXPECT_EQ(s.stats("frontend")->deferrals, 6u);
  EXPECT_GE(frontend.keyframes.size(), 2u + 5u);
  // Recovery: cheap again, the frontend runs on every keyframe.
  recon.cost_us = 5000;
  const std::size_t before = frontend.keyframes.size();
  for (std::uint64_t k = 13; k < 23; ++k) s.keyframe(k);
  EXPECT_EQ(frontend.keyframes.size(), before + 10u);
  s.print_stats(stdout);
}

TEST(SchedulerTest, TicksAndKeyframesDoNotAllocate) {
  SteppedClock clock;
  Scheduler s;
  std::string error;
  ASSERT_TRUE(s.init(SchedulerConfig{}, budgets::host_sim::kTable, &clock, &error)) << error;
  for (std::size_t i = 0; i < s.num_tasks(); ++i) s.bind(s.task(i).budget.name, noop, nullptr);
  EXPECT_NO_ALLOCATIONS({
    for (int k = 0; k < 1000; ++k) {
      s.tick();
      if (k % 20 == 0) s.keyframe(static_cast<std::uint64_t>(k / 20));
      clock.advance_ns(s.tick_period_ns());
    }
  });
}

TEST(TaskStatsTest, QuantileIsAnUpperBoundWithinAFactorOfTwo) {
  TaskStats s;
  for (int i = 1; i <= 1000; ++i) s.record(i, 900);
  EXPECT_EQ(s.runs, 1000u);
  EXPECT_EQ(s.min_us, 1);
  EXPECT_EQ(s.max_us, 1000);
  EXPECT_EQ(s.overruns, 100u);
  EXPECT_NEAR(s.mean_us(), 500.5, 1e-9);
  const std::int64_t p99 = s.quantile_upper_us(0.99);
  EXPECT_GE(p99, 990);
  EXPECT_LE(p99, 1000);
  const std::int64_t p50 = s.quantile_upper_us(0.5);
  EXPECT_GE(p50, 500);
  EXPECT_LE(p50, 1000);
}

}  // namespace
}  // namespace qsg::runtime
