// Stage markers for instruction counting under qemu-aarch64: the id table and the marker system call.
#include "firmware_app/runtime/stage_marker.h"

#include <cerrno>
#include <cstring>

#include <sys/syscall.h>
#include <unistd.h>

namespace qsg::runtime {

namespace detail {
bool g_stage_markers_on = false;

void stage_marker_call(StageMarkerOp op, std::uint32_t stage, std::uint64_t sequence) {
  const int saved = errno;  // the call fails with ENOSYS by design; nobody downstream should see it
  ::syscall(kStageMarkerSyscall, kStageMarkerMagic, static_cast<std::uint64_t>(op), std::uint64_t{stage}, sequence);
  errno = saved;
}
}  // namespace detail

void set_stage_markers(bool on) { detail::g_stage_markers_on = on; }
bool stage_markers_on() { return detail::g_stage_markers_on; }

bool stage_marker_info(const budgets::BoardTable& table, std::uint32_t stage, StageMarkerInfo* info) {
  if (stage < table.num_tasks && stage < kThreadStageBase) {
    *info = {table.tasks[stage].name, table.tasks[stage].budget_us};
    return true;
  }
  if (stage >= kThreadStageBase && stage - kThreadStageBase < table.num_threads && stage < kDoorPassStage) {
    const budgets::ThreadBudget& t = table.threads[stage - kThreadStageBase];
    *info = {t.name, t.budget_us};
    return true;
  }
  // The backend's parts carry the names the exit report gives them.
  const budgets::ThreadBudget* backend = table.find_thread("backend");
  if (backend == nullptr) return false;
  if (stage == kDoorPassStage && backend->part_budget_us > 0) {
    *info = {"backend_door_pass", backend->part_budget_us};
    return true;
  }
  if (stage == kFinalStage && backend->finish_budget_us > 0) {
    *info = {"backend_final_stage", backend->finish_budget_us};
    return true;
  }
  // Appearance and detection run in a backend update, against the thread's budget; a solve is a run of its own
  // (solve_budget_us, the exit report's backend_solve).
  if (stage == kLoopClosureAppearanceStage) {
    *info = {"loop_closure_appearance", backend->budget_us};
    return true;
  }
  if (stage == kLoopClosureDetectStage) {
    *info = {"loop_closure_detect", backend->budget_us};
    return true;
  }
  if (stage == kLoopClosureSolveStage) {
    *info = {"loop_closure_solve", backend->solve_budget_us > 0 ? backend->solve_budget_us : backend->budget_us};
    return true;
  }
  return false;
}

bool stage_marker_id(const budgets::BoardTable& table, const char* name, std::uint32_t* stage) {
  for (std::uint32_t s = 0; s <= kLastStage; ++s) {
    StageMarkerInfo info;
    if (stage_marker_info(table, s, &info) && std::strcmp(info.name, name) == 0) {
      *stage = s;
      return true;
    }
  }
  return false;
}

void print_stage_markers(const budgets::BoardTable& table, std::FILE* out) {
  for (std::uint32_t s = 0; s <= kLastStage; ++s) {
    StageMarkerInfo info;
    if (stage_marker_info(table, s, &info)) std::fprintf(out, "stage_marker %u %s %u\n", s, info.name, info.budget_us);
  }
}

}  // namespace qsg::runtime
