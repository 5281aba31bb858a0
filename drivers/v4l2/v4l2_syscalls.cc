// The real system calls behind V4l2Syscalls.
#include "drivers/v4l2/v4l2_syscalls.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>

namespace qsg::v4l2 {

int LinuxV4l2Syscalls::sys_open(const char* path, int flags) {
  const int fd = ::open(path, flags | O_CLOEXEC);
  return fd < 0 ? -errno : fd;
}

int LinuxV4l2Syscalls::sys_close(int fd) { return ::close(fd) < 0 ? -errno : 0; }

int LinuxV4l2Syscalls::sys_ioctl(int fd, unsigned long request, void* arg) {
  const int r = ::ioctl(fd, request, arg);
  return r < 0 ? -errno : r;
}

void* LinuxV4l2Syscalls::sys_mmap(std::size_t length, int prot, int flags, int fd, std::int64_t offset, int* error) {
  void* p = ::mmap(nullptr, length, prot, flags, fd, static_cast<off_t>(offset));
  if (p == MAP_FAILED) {
    *error = errno;
    return nullptr;
  }
  *error = 0;
  return p;
}

int LinuxV4l2Syscalls::sys_munmap(void* address, std::size_t length) {
  return ::munmap(address, length) < 0 ? -errno : 0;
}

int LinuxV4l2Syscalls::sys_poll(int fd, short events, int timeout_ms, short* revents) {
  pollfd p{};
  p.fd = fd;
  p.events = events;
  const int r = ::poll(&p, 1, timeout_ms);
  if (r < 0) return -errno;
  *revents = p.revents;
  return r;
}

std::int64_t LinuxV4l2Syscalls::monotonic_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

V4l2Syscalls& linux_v4l2_syscalls() {
  static LinuxV4l2Syscalls instance;
  return instance;
}

const char* fourcc_to_string(std::uint32_t fourcc, char out[5]) {
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((fourcc >> (8 * i)) & 0xffu);
    out[i] = (c >= 32 && c < 127) ? c : '?';
  }
  out[4] = '\0';
  // Codes padded with spaces ("Z16 ", "Y10 ") print without them.
  for (int i = 3; i > 0 && out[i] == ' '; --i) out[i] = '\0';
  return out;
}

}  // namespace qsg::v4l2
