// Locking the app's memory (AppConfig::lock_memory, --mlockall): a refused mlockall is a clear message and a
// counted degradation, never a crash or a failed start-up; the resident set is read from /proc without a heap.
// The lock is tried in forked children, so the test process itself is never locked or limited.
#include <gtest/gtest.h>

#include <linux/capability.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <string>

#include "firmware_app/memory_lock.h"
#include "firmware_app/pipeline.h"
#include "tests/support/allocation_counter.h"
#include "tests/support/emulation.h"

namespace qsg::app {
namespace {

// Drops CAP_IPC_LOCK (which lets root lock past any limit) from this process; false when the kernel refused.
bool drop_ipc_lock_capability() {
  __user_cap_header_struct header{_LINUX_CAPABILITY_VERSION_3, 0};
  __user_cap_data_struct data[2] = {};
  if (::syscall(SYS_capget, &header, data) != 0) return false;
  const unsigned word = CAP_IPC_LOCK / 32, bit = 1u << (CAP_IPC_LOCK % 32);
  data[word].effective &= ~bit;
  data[word].permitted &= ~bit;
  data[word].inheritable &= ~bit;
  return ::syscall(SYS_capset, &header, data) == 0;
}

// Runs fn() in a child; its exit status (0..125), 126 when the child could not set itself up, or -1.
template <typename Fn>
int in_child(Fn&& fn, std::string* text) {
  int fds[2];
  if (::pipe(fds) != 0) return -1;
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    std::string message;
    const int status = fn(&message);
    if (!message.empty()) (void)!::write(fds[1], message.data(), message.size());
    ::_exit(status);
  }
  ::close(fds[1]);
  char buffer[4096];
  ssize_t n;
  while ((n = ::read(fds[0], buffer, sizeof(buffer))) > 0) text->append(buffer, static_cast<std::size_t>(n));
  ::close(fds[0]);
  int status = 0;
  if (::waitpid(pid, &status, 0) != pid || !WIFEXITED(status)) return -1;
  return WEXITSTATUS(status);
}

// A limited child: no CAP_IPC_LOCK and RLIMIT_MEMLOCK at 64 KB, far below the process's size.
bool limit_locking() {
  if (!drop_ipc_lock_capability()) return false;
  const rlimit small{64 * 1024, 64 * 1024};
  return ::setrlimit(RLIMIT_MEMLOCK, &small) == 0;
}

TEST(MemoryLock, ReadsTheResidentSetWithoutAllocating) {
  ProcessMemory m;
  EXPECT_NO_ALLOCATIONS(m = read_process_memory());
  ASSERT_TRUE(m.ok);
  EXPECT_GT(m.vm_rss_kb, 0u);
  EXPECT_GE(m.vm_hwm_kb, m.vm_rss_kb);
  EXPECT_GE(m.vm_size_kb, m.vm_rss_kb);
  EXPECT_GT(m.minor_faults, 0u);
}

TEST(MemoryLock, ARefusedLockIsAMessageNamingTheLimit) {
  if (qsg::testing::running_emulated()) GTEST_SKIP() << "qemu-user does not emulate mlockall's limits";
  if (qsg::testing::address_sanitizer()) GTEST_SKIP() << "AddressSanitizer replaces mlockall with a no-op";
  std::string text;
  const int status = in_child(
      [](std::string* message) {
        if (!limit_locking()) return 126;
        return lock_process_memory(message) ? 0 : 1;
      },
      &text);
  if (status == 126) GTEST_SKIP() << "cannot drop CAP_IPC_LOCK or lower RLIMIT_MEMLOCK here";
  EXPECT_EQ(status, 1) << "the lock must fail under a 64 KB limit: " << text;
  EXPECT_NE(text.find("mlockall(MCL_CURRENT | MCL_FUTURE) failed: "), std::string::npos) << text;
  EXPECT_NE(text.find("RLIMIT_MEMLOCK soft 0.1 MB, hard 0.1 MB"), std::string::npos) << text;
  EXPECT_NE(text.find("CAP_IPC_LOCK"), std::string::npos) << text;
}

TEST(MemoryLock, ALockThatSucceedsHoldsTheProcessResident) {
  if (qsg::testing::running_emulated()) GTEST_SKIP() << "qemu-user does not emulate mlockall";
  if (qsg::testing::address_sanitizer()) GTEST_SKIP() << "AddressSanitizer replaces mlockall with a no-op";
  std::string text;
  const int status = in_child(
      [](std::string* message) {
        if (!lock_process_memory(message)) return 2;
        const ProcessMemory m = read_process_memory();
        *message = std::to_string(m.vm_lck_kb) + " " + std::to_string(m.vm_rss_kb);
        return m.vm_lck_kb > 0 ? 0 : 1;
      },
      &text);
  if (status == 2) GTEST_SKIP() << "this machine refuses the lock (no CAP_IPC_LOCK, a low limit): " << text;
  EXPECT_EQ(status, 0) << "VmLck and VmRSS (kB): " << text;
}

// The app asked to lock and refused: it starts, runs and counts the failure (the exit report's memory group).
TEST(MemoryLock, ThePipelineStartsUnlockedWhenTheLockIsRefused) {
  if (qsg::testing::running_emulated()) GTEST_SKIP() << "qemu-user does not emulate mlockall's limits";
  std::string text;
  const int status = in_child(
      [](std::string* message) {
        if (!limit_locking()) return 126;
        AppConfig c;
        c.output_dir = ::testing::TempDir() + "/qsg_memory_lock";
        c.building.num_rooms = 4;
        c.building.seed = 3;
        c.camera.intrinsics = {160, 120, 131.25, 131.25, 79.5, 59.5};
        c.snapshot_interval_s = 1e6;
        c.telemetry_interval_s = 1e6;
        c.lock_memory = true;
        runtime::SteppedClock clock;
        Pipeline p;
        if (!p.init(c, &clock, message)) return 3;
        for (int k = 0; k < 200 && p.step(); ++k) {
        }
        if (p.counters().memory_locked != 0) return 4;
        if (p.counters().memory_lock_failures != 1) return 5;
        return p.counters().frames_read > 0 ? 0 : 6;
      },
      &text);
  if (status == 126) GTEST_SKIP() << "cannot drop CAP_IPC_LOCK or lower RLIMIT_MEMLOCK here";
  EXPECT_EQ(status, 0) << "3: start-up failed, 4: locked, 5: the failure not counted, 6: no frame read: " << text;
}

}  // namespace
}  // namespace qsg::app
