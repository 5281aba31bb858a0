// mlockall with a clear failure, and the resident set from /proc without allocating.
#include "firmware_app/memory_lock.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace qsg::app {
namespace {

std::string limit_text(rlim_t v) {
  if (v == RLIM_INFINITY) return "unlimited";
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f MB", static_cast<double>(v) / 1048576.0);
  return text;
}

// The value of "Key:" in /proc/self/status's text (kB), or 0.
std::uint64_t status_field(const char* text, const char* key) {
  const char* at = std::strstr(text, key);
  if (at == nullptr) return 0;
  return std::strtoull(at + std::strlen(key), nullptr, 10);
}

}  // namespace

bool lock_process_memory(std::string* message) {
  if (::mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
    // Trust the kernel's account, not the return value: AddressSanitizer (and some emulators) replace mlockall
    // with a no-op that reports success.
    const ProcessMemory m = read_process_memory();
    if (!m.ok || m.vm_lck_kb > 0) return true;
    char text[320];
    std::snprintf(text, sizeof(text),
                  "mlockall(MCL_CURRENT | MCL_FUTURE) returned success but /proc/self/status shows VmLck 0 kB of "
                  "%.1f MB resident (a sanitizer or an emulator stands in for the call); the run goes on with its "
                  "memory unlocked",
                  static_cast<double>(m.vm_rss_kb) / 1024.0);
    *message = text;
    return false;
  }
  const int err = errno;
  rlimit limit{};
  ::getrlimit(RLIMIT_MEMLOCK, &limit);
  const ProcessMemory m = read_process_memory();
  char text[512];
  std::snprintf(text, sizeof(text),
                "mlockall(MCL_CURRENT | MCL_FUTURE) failed: %s (RLIMIT_MEMLOCK soft %s, hard %s; the process maps "
                "%.1f MB, %.1f MB resident); the run goes on with its memory unlocked. On the robot run qsg_app with "
                "CAP_IPC_LOCK, or raise the limit (`ulimit -l unlimited`, systemd LimitMEMLOCK=infinity)",
                std::strerror(err), limit_text(limit.rlim_cur).c_str(), limit_text(limit.rlim_max).c_str(),
                static_cast<double>(m.vm_size_kb) / 1024.0, static_cast<double>(m.vm_rss_kb) / 1024.0);
  *message = text;
  return false;
}

ProcessMemory read_process_memory() {
  ProcessMemory m;
  rusage usage{};
  if (::getrusage(RUSAGE_SELF, &usage) == 0) {
    m.minor_faults = static_cast<std::uint64_t>(usage.ru_minflt);
    m.major_faults = static_cast<std::uint64_t>(usage.ru_majflt);
  }
  const int fd = ::open("/proc/self/status", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return m;
  char text[4096];
  std::size_t n = 0;
  for (;;) {
    const ssize_t r = ::read(fd, text + n, sizeof(text) - 1 - n);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    n += static_cast<std::size_t>(r);
    if (n == sizeof(text) - 1) break;
  }
  ::close(fd);
  text[n] = '\0';
  m.vm_size_kb = status_field(text, "VmSize:");
  m.vm_rss_kb = status_field(text, "VmRSS:");
  m.vm_hwm_kb = status_field(text, "VmHWM:");
  m.vm_lck_kb = status_field(text, "VmLck:");
  m.ok = n > 0 && std::strstr(text, "VmRSS:") != nullptr;
  return m;
}

}  // namespace qsg::app
