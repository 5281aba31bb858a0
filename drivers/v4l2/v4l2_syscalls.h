// The system calls a V4L2 capture makes, behind an interface so host tests can replace the kernel with a fake
// device (libv4l2 issues its calls through syscall(), so an LD_PRELOAD shim would not see them).
#pragma once

#include <cstddef>
#include <cstdint>

namespace qsg::v4l2 {

// Every call returns a negative errno on failure (kernel style) instead of touching the global errno, so a fake
// needs no global state and a caller cannot read a stale errno.
class V4l2Syscalls {
 public:
  virtual ~V4l2Syscalls() = default;
  virtual int sys_open(const char* path, int flags) = 0;                 // fd >= 0, or -errno
  virtual int sys_close(int fd) = 0;                                     // 0, or -errno
  virtual int sys_ioctl(int fd, unsigned long request, void* arg) = 0;   // >= 0, or -errno
  // Returns the mapping, or nullptr with *error = errno.
  virtual void* sys_mmap(std::size_t length, int prot, int flags, int fd, std::int64_t offset, int* error) = 0;
  virtual int sys_munmap(void* address, std::size_t length) = 0;         // 0, or -errno
  // Waits up to timeout_ms for `events` on fd: > 0 with *revents set, 0 on timeout, or -errno.
  virtual int sys_poll(int fd, short events, int timeout_ms, short* revents) = 0;
  // CLOCK_MONOTONIC in nanoseconds: the clock V4L2 stamps buffers with (fakes step it themselves).
  virtual std::int64_t monotonic_ns() = 0;
};

// The real libc calls. Stateless; one shared instance.
class LinuxV4l2Syscalls : public V4l2Syscalls {
 public:
  int sys_open(const char* path, int flags) override;
  int sys_close(int fd) override;
  int sys_ioctl(int fd, unsigned long request, void* arg) override;
  void* sys_mmap(std::size_t length, int prot, int flags, int fd, std::int64_t offset, int* error) override;
  int sys_munmap(void* address, std::size_t length) override;
  int sys_poll(int fd, short events, int timeout_ms, short* revents) override;
  std::int64_t monotonic_ns() override;
};
V4l2Syscalls& linux_v4l2_syscalls();

// Four-character code as text ("YUYV", "Z16 "), into a caller buffer of at least 5 bytes; returns it.
const char* fourcc_to_string(std::uint32_t fourcc, char out[5]);

}  // namespace qsg::v4l2
