// Types of the generated budget tables (budgets/budget_table.h): one BoardTable per target board.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace qsg::budgets {

// What a fixed-depth queue does when a producer finds it full.
enum class DropPolicy : std::uint8_t {
  kDropOldest,  // the oldest element is dropped (counted) to make room: freshness wins (camera frames)
  kDropNewest,  // the new element is dropped (counted): history wins
  kCollate,     // the new element is merged into the newest queued one (frontend-to-backend updates)
};

inline const char* to_string(DropPolicy p) {
  switch (p) {
    case DropPolicy::kDropOldest: return "drop_oldest";
    case DropPolicy::kDropNewest: return "drop_newest";
    case DropPolicy::kCollate: return "collate";
  }
  return "?";
}

struct ArenaBudget {
  const char* name;
  std::size_t bytes;
};

struct CapacityBudget {
  const char* arena;
  const char* name;
  std::size_t capacity;
};

// A task runs either at rate_hz of the tick clock, or on every Nth keyframe with an offset (F'-style
// rate groups: offsets keep slow groups from firing on the same keyframe). Exactly one of the two is set.
struct TaskBudget {
  const char* name;
  double rate_hz;                   // 0 when keyframe-driven
  std::uint32_t every_n_keyframes;  // 0 when rate-driven
  std::uint32_t offset;             // keyframe offset, < every_n_keyframes
  std::uint32_t budget_us;
  std::uint32_t priority;           // 0 runs first
};

struct QueueBudget {
  const char* name;
  std::uint32_t depth;
  DropPolicy policy;
  std::uint32_t max_wait_us;  // how long a consumer may wait for an element (0: it does not wait)
};

// A long-lived worker thread outside the tick loop (segmentation, backend): each run (one frame, one update) is
// timed on the thread's CPU clock against budget_us; every_n_keyframes > 0 asks for at least one run per that many
// keyframes (segmentation: labels for at least every Nth keyframe).
struct ThreadBudget {
  const char* name;
  std::uint32_t budget_us;
  std::uint32_t every_n_keyframes;  // 0: no rate asked
  // A pass that runs inside some runs (backend: the online door pass, every 4th update), timed on its own against
  // this share of budget_us (0: none).
  std::uint32_t part_budget_us;
  // The thread's one run at the end of a mission (backend: the final stage, doors on the whole surface, rooms and
  // labels once more), off the real-time path but bounded (0: none).
  std::uint32_t finish_budget_us;
  // A run of its own that some updates hand the thread (backend: a deformation-graph solve, at most every
  // loop_closure.solve_interval_s), timed apart from the update that started it (0: none).
  std::uint32_t solve_budget_us;
};

struct BoardTable {
  const char* board;
  const char* description;
  const ArenaBudget* arenas;
  std::size_t num_arenas;
  const CapacityBudget* capacities;
  std::size_t num_capacities;
  const TaskBudget* tasks;
  std::size_t num_tasks;
  const QueueBudget* queues;
  std::size_t num_queues;
  const ThreadBudget* threads;
  std::size_t num_threads;

  const TaskBudget* find_task(const char* name) const {
    for (std::size_t i = 0; i < num_tasks; ++i)
      if (std::strcmp(tasks[i].name, name) == 0) return &tasks[i];
    return nullptr;
  }
  const ThreadBudget* find_thread(const char* name) const {
    for (std::size_t i = 0; i < num_threads; ++i)
      if (std::strcmp(threads[i].name, name) == 0) return &threads[i];
    return nullptr;
  }
  const ArenaBudget* find_arena(const char* name) const {
    for (std::size_t i = 0; i < num_arenas; ++i)
      if (std::strcmp(arenas[i].name, name) == 0) return &arenas[i];
    return nullptr;
  }
};

}  // namespace qsg::budgets
