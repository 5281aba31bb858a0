// Stage markers: when switched on (qsg_app --stage-markers), every timed stage run is bracketed by two marker
// system calls that a qemu-aarch64 plugin (bench/arm/insn_count_plugin.c) sees, so it can count the guest
// instructions of each run deterministically. Off by default; off, a marker costs one predictable branch.
#pragma once

#include <cstdint>
#include <cstdio>

#include "budgets/budget_types.h"

namespace qsg::runtime {

// A system call number that neither arm64 nor x86-64 Linux assigns (their tables end near 460): the kernel, and
// qemu-user, answer ENOSYS and do nothing else. The first argument is a magic word so no other call is mistaken.
inline constexpr long kStageMarkerSyscall = 0x5153;
inline constexpr std::uint64_t kStageMarkerMagic = 0x7173672d73746167ULL;  // "qsg-stag"
enum class StageMarkerOp : std::uint64_t { kBegin = 1, kEnd = 2 };

// Stage ids, fixed by the board's table: its tasks in table order (0 .. num_tasks - 1), then its worker threads
// (kThreadStageBase + index), then the backend's timed parts: the online door pass, the final stage, and with loop
// closure on, per keyframe captured its appearance (features, depth cloud), per agent described its detection and
// verification, per online solve the deformation graph (built and solved). The loop-closure parts run inside a
// backend update and carry the backend thread's budget: they add to that update's cost.
inline constexpr std::uint32_t kThreadStageBase = 32;
inline constexpr std::uint32_t kDoorPassStage = 64;
inline constexpr std::uint32_t kFinalStage = 65;
inline constexpr std::uint32_t kLoopClosureAppearanceStage = 66;
inline constexpr std::uint32_t kLoopClosureDetectStage = 67;
inline constexpr std::uint32_t kLoopClosureSolveStage = 68;
inline constexpr std::uint32_t kLastStage = kLoopClosureSolveStage;

// One stage id's name (the table's task or thread name, or the exit report's name of the part) and budget.
struct StageMarkerInfo {
  const char* name = nullptr;
  std::uint32_t budget_us = 0;
};
// False for an id the table does not define.
bool stage_marker_info(const budgets::BoardTable& table, std::uint32_t stage, StageMarkerInfo* info);
// The id of a task or thread name of the table (tasks first); false when it has none.
bool stage_marker_id(const budgets::BoardTable& table, const char* name, std::uint32_t* stage);
// One line per stage id: "stage_marker ID NAME BUDGET_US" (what bench/arm/insn_counts.py reads).
void print_stage_markers(const budgets::BoardTable& table, std::FILE* out);

// Process-wide switch, set once at start-up before any worker thread exists.
void set_stage_markers(bool on);
bool stage_markers_on();

namespace detail {
extern bool g_stage_markers_on;
void stage_marker_call(StageMarkerOp op, std::uint32_t stage, std::uint64_t sequence);
}  // namespace detail

// Brackets one run of `stage`; `sequence` is the keyframe (keyframe tasks, threads) or the tick (rate tasks).
inline void stage_begin(std::uint32_t stage, std::uint64_t sequence) {
  if (__builtin_expect(detail::g_stage_markers_on, 0)) detail::stage_marker_call(StageMarkerOp::kBegin, stage, sequence);
}
inline void stage_end(std::uint32_t stage, std::uint64_t sequence) {
  if (__builtin_expect(detail::g_stage_markers_on, 0)) detail::stage_marker_call(StageMarkerOp::kEnd, stage, sequence);
}

}  // namespace qsg::runtime
