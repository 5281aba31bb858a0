// The process's memory, as the real-time path sees it: locking it in RAM (mlockall, for the robot) and reading
// the resident set and page-fault counts (telemetry, the soak, the exit report). The arenas are pre-faulted when
// they are created (core/memory/arena.h); locking keeps their pages, and every later one, resident.
#pragma once

#include <cstdint>
#include <string>

namespace qsg::app {

// mlockall(MCL_CURRENT | MCL_FUTURE). True when locked; otherwise false and *message says why in one line: the
// system's error, RLIMIT_MEMLOCK's soft and hard limits, the process's size, and the remedy (CAP_IPC_LOCK, or
// `ulimit -l unlimited` / systemd's LimitMEMLOCK=infinity). Never aborts: the caller logs it and runs unlocked.
bool lock_process_memory(std::string* message);

struct ProcessMemory {
  std::uint64_t vm_size_kb = 0;  // mapped (VmSize)
  std::uint64_t vm_rss_kb = 0;   // resident set now (/proc/self/status VmRSS)
  std::uint64_t vm_hwm_kb = 0;   // its peak (VmHWM)
  std::uint64_t vm_lck_kb = 0;   // locked (VmLck)
  std::uint64_t minor_faults = 0;  // getrusage(RUSAGE_SELF): page faults served without I/O since start
  std::uint64_t major_faults = 0;  // ... and with I/O
  bool ok = false;               // /proc/self/status was read
};
// Allocation-free (a stack buffer and system calls): safe on the loop thread.
ProcessMemory read_process_memory();

}  // namespace qsg::app
