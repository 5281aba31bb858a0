// Stage markers (runtime/stage_marker.h): off by default, and every id names a task, thread or timed part of each
// board's table with that entry's budget, so the instruction counts of bench/arm/ line up with the budgets.
#include <gtest/gtest.h>

#include <cerrno>
#include <cstdio>
#include <set>
#include <string>

#include "budgets/budget_table.h"
#include "firmware_app/runtime/stage_marker.h"

namespace qsg::runtime {
namespace {

TEST(StageMarkerTest, OffByDefault) { EXPECT_FALSE(stage_markers_on()); }

TEST(StageMarkerTest, EveryTaskAndThreadOfEachBoardHasAnIdWithItsBudget) {
  for (const budgets::BoardTable* board : budgets::kAllBoards) {
    std::set<std::string> names;
    for (std::size_t i = 0; i < board->num_tasks; ++i) {
      std::uint32_t id = 999;
      ASSERT_TRUE(stage_marker_id(*board, board->tasks[i].name, &id)) << board->board << " " << board->tasks[i].name;
      EXPECT_EQ(id, i) << "tasks are numbered in table order";
      StageMarkerInfo info;
      ASSERT_TRUE(stage_marker_info(*board, id, &info));
      EXPECT_STREQ(info.name, board->tasks[i].name);
      EXPECT_EQ(info.budget_us, board->tasks[i].budget_us);
      names.insert(info.name);
    }
    for (std::size_t i = 0; i < board->num_threads; ++i) {
      std::uint32_t id = 999;
      ASSERT_TRUE(stage_marker_id(*board, board->threads[i].name, &id)) << board->board << " " << board->threads[i].name;
      EXPECT_EQ(id, kThreadStageBase + i);
      StageMarkerInfo info;
      ASSERT_TRUE(stage_marker_info(*board, id, &info));
      EXPECT_EQ(info.budget_us, board->threads[i].budget_us);
      EXPECT_TRUE(names.insert(info.name).second) << "a thread named like a task: " << info.name;
    }
    const budgets::ThreadBudget* backend = board->find_thread("backend");
    ASSERT_NE(backend, nullptr);
    StageMarkerInfo part;
    ASSERT_TRUE(stage_marker_info(*board, kDoorPassStage, &part));
    EXPECT_STREQ(part.name, "backend_door_pass");
    EXPECT_EQ(part.budget_us, backend->part_budget_us);
    ASSERT_TRUE(stage_marker_info(*board, kFinalStage, &part));
    EXPECT_STREQ(part.name, "backend_final_stage");
    EXPECT_EQ(part.budget_us, backend->finish_budget_us);
    // Appearance and detection run inside a backend update: the thread's budget; a solve has its own.
    for (const auto& [id, name] : {std::pair{kLoopClosureAppearanceStage, "loop_closure_appearance"},
                                   std::pair{kLoopClosureDetectStage, "loop_closure_detect"}}) {
      ASSERT_TRUE(stage_marker_info(*board, id, &part)) << name;
      EXPECT_STREQ(part.name, name);
      EXPECT_EQ(part.budget_us, backend->budget_us);
    }
    ASSERT_TRUE(stage_marker_info(*board, kLoopClosureSolveStage, &part));
    EXPECT_STREQ(part.name, "loop_closure_solve");
    EXPECT_EQ(part.budget_us, backend->solve_budget_us);
    // Ids between the groups name nothing.
    EXPECT_FALSE(stage_marker_info(*board, static_cast<std::uint32_t>(board->num_tasks), &part));
    EXPECT_FALSE(stage_marker_info(*board, kThreadStageBase + static_cast<std::uint32_t>(board->num_threads), &part));
    EXPECT_FALSE(stage_marker_info(*board, kLastStage + 1, &part));
    std::uint32_t id = 0;
    EXPECT_FALSE(stage_marker_id(*board, "no_such_stage", &id));
  }
}

TEST(StageMarkerTest, MarkersSwitchedOnAreHarmlessSystemCalls) {
  // On a kernel (not under the plugin) the marker is an unassigned system call: ENOSYS, errno kept.
  set_stage_markers(true);
  errno = 0;
  stage_begin(0, 1);
  stage_end(0, 1);
  EXPECT_EQ(errno, 0);
  set_stage_markers(false);
  EXPECT_FALSE(stage_markers_on());
}

TEST(StageMarkerTest, PrintsOneLinePerId) {
  char buffer[4096] = {};
  std::FILE* out = fmemopen(buffer, sizeof buffer, "w");
  ASSERT_NE(out, nullptr);
  const budgets::BoardTable& table = budgets::xavier_nx::kTable;
  print_stage_markers(table, out);
  std::fclose(out);
  const std::string text = buffer;
  std::size_t lines = 0;
  for (char c : text) lines += c == '\n' ? 1 : 0;
  EXPECT_EQ(lines, table.num_tasks + table.num_threads + 5) << text;  // + the backend's five parts
  for (std::size_t i = 0; i < table.num_tasks; ++i) {
    const std::string line = "stage_marker " + std::to_string(i) + " " + table.tasks[i].name + " " +
                             std::to_string(table.tasks[i].budget_us) + "\n";
    EXPECT_NE(text.find(line), std::string::npos) << line << " in\n" << text;
  }
}

}  // namespace
}  // namespace qsg::runtime
