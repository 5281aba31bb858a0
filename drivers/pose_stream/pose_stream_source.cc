// Pose-stream reception: socket set-up, one datagram per read, and the sequence and time checks on what arrives.
#include "drivers/pose_stream/pose_stream_source.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cstring>
#include <ctime>

namespace qsg::pose_stream {
namespace {

std::int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

constexpr std::size_t kMaxUnixPathBytes = sizeof(sockaddr_un::sun_path) - 1;  // keeps the terminating NUL

bool fail(std::string* error, const std::string& message) {
  if (error) *error = "pose_stream: " + message;
  return false;
}

std::string errno_text(int err) { return std::strerror(err); }

bool make_unix_address(const std::string& path, sockaddr_un* address) {
  if (path.empty() || path.size() > kMaxUnixPathBytes) return false;
  std::memset(address, 0, sizeof *address);
  address->sun_family = AF_UNIX;
  std::memcpy(address->sun_path, path.data(), path.size());
  return true;
}

}  // namespace

std::string PoseStreamSource::Config::check() const {
  if (transport == "udp") {
    in_addr address{};
    if (inet_pton(AF_INET, bind_address.c_str(), &address) != 1) {
      return "bind_address '" + bind_address + "' is not an IPv4 address";
    }
    if (port < 0 || port > 65535) return "port " + std::to_string(port) + " is outside 0..65535";
  } else if (transport == "unix") {
    if (unix_path.empty()) return "transport 'unix' needs unix_path";
    if (unix_path.size() > kMaxUnixPathBytes) {
      return "unix_path '" + unix_path + "' is " + std::to_string(unix_path.size()) +
             " bytes; a Unix socket path holds at most " + std::to_string(kMaxUnixPathBytes);
    }
  } else {
    return "transport '" + transport + "' is neither 'udp' nor 'unix'";
  }
  if (frame_id.size() >= kFrameIdBytes) {
    return "frame_id '" + frame_id + "' is longer than " + std::to_string(kFrameIdBytes - 1) + " characters";
  }
  if (late_after_ns < 0) return "late_after_ns must be >= 0";
  if (bad_frame_log_interval_ns < 0) return "bad_frame_log_interval_ns must be >= 0";
  return "";
}

void PoseStreamSource::Config::print(std::FILE* out) const {
  std::fprintf(out,
               "PoseStreamSource: transport=%s bind_address=%s port=%d unix_path=%s frame_id=%s late_after_ns=%" PRId64
               " bad_frame_log_interval_ns=%" PRId64 " clock=%s\n",
               transport.c_str(), bind_address.c_str(), port, unix_path.empty() ? "(none)" : unix_path.c_str(),
               frame_id.empty() ? "(any)" : frame_id.c_str(), late_after_ns, bad_frame_log_interval_ns,
               clock_ns ? "injected" : "CLOCK_MONOTONIC");
}

PoseStreamSource::~PoseStreamSource() { close(); }

bool PoseStreamSource::open(const Config& config, std::string* error) {
  close();
  const std::string problem = config.check();
  if (!problem.empty()) return fail(error, problem);
  config_ = config;
  counters_ = drivers::DriverCounters{};
  stream_counters_ = PoseStreamCounters{};
  have_last_ = false;
  in_error_ = false;
  logged_once_ = false;
  unlogged_bad_frames_ = 0;
  last_frame_id_[0] = '\0';

  if (config.transport == "udp") {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(config.port));
    inet_pton(AF_INET, config.bind_address.c_str(), &address.sin_addr);
    const std::string where = "udp " + config.bind_address + ":" + std::to_string(config.port);
    const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return fail(error, where + ": socket: " + errno_text(errno));
    // No SO_REUSEADDR: on UDP it would let a second receiver share the port instead of reporting it in use.
    if (::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
      const int err = errno;
      ::close(fd);
      if (err == EADDRINUSE) return fail(error, where + " is in use (is another receiver running?)");
      if (err == EADDRNOTAVAIL) return fail(error, where + ": no interface of this machine has that address");
      return fail(error, where + ": bind: " + errno_text(err));
    }
    sockaddr_in bound{};
    socklen_t length = sizeof bound;
    if (::getsockname(fd, reinterpret_cast<sockaddr*>(&bound), &length) != 0) {
      const int err = errno;
      ::close(fd);
      return fail(error, where + ": getsockname: " + errno_text(err));
    }
    fd_ = fd;
    bound_port_ = ntohs(bound.sin_port);
    // 127.0.0.0/8: only processes on this machine can reach the socket.
    if ((ntohl(address.sin_addr.s_addr) >> 24) != 127) {
      std::fprintf(stderr,
                   "pose_stream: warning: listening on non-loopback udp %s:%d; any host that reaches it can send "
                   "poses\n",
                   config.bind_address.c_str(), bound_port_);
    }
    return true;
  }

  sockaddr_un address{};
  make_unix_address(config.unix_path, &address);  // check() has bounded the length
  const std::string where = "unix " + config.unix_path;
  struct stat info {};
  if (::lstat(config.unix_path.c_str(), &info) == 0) {
    if (!S_ISSOCK(info.st_mode)) return fail(error, where + " exists and is not a socket; not removing it");
    // A socket file is stale unless a receiver still answers on it.
    const int probe = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    const bool live =
        probe >= 0 && ::connect(probe, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0;
    if (probe >= 0) ::close(probe);
    if (live) return fail(error, where + " is in use (is another receiver running?)");
    if (::unlink(config.unix_path.c_str()) != 0) {
      return fail(error, where + ": cannot remove the stale socket file: " + errno_text(errno));
    }
  }
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return fail(error, where + ": socket: " + errno_text(errno));
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    const int err = errno;
    ::close(fd);
    return fail(error, where + ": bind: " + errno_text(err));
  }
  fd_ = fd;
  bound_port_ = 0;
  created_socket_file_ = true;
  return true;
}

void PoseStreamSource::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  bound_port_ = 0;
  if (created_socket_file_) ::unlink(config_.unix_path.c_str());
  created_socket_file_ = false;
}

std::int64_t PoseStreamSource::now_ns() const { return config_.clock_ns ? config_.clock_ns() : monotonic_ns(); }

void PoseStreamSource::log_bad_frame(const char* reason, std::size_t size) {
  const std::int64_t now = now_ns();
  if (logged_once_ && now - last_log_ns_ < config_.bad_frame_log_interval_ns) {
    ++unlogged_bad_frames_;
    return;
  }
  std::fprintf(stderr,
               "pose_stream: discarded a %zu-byte datagram (%s); %" PRIu64 " bad so far, %" PRIu64
               " more since the last report\n",
               size, reason, counters_.bad_frames, unlogged_bad_frames_);
  logged_once_ = true;
  last_log_ns_ = now;
  unlogged_bad_frames_ = 0;
}

drivers::ReadStatus PoseStreamSource::read(messages::OdometrySample& sample, std::int64_t timeout_ns) {
  if (fd_ < 0) return drivers::ReadStatus::kDisconnected;
  // Waiting is real time whatever clock stamps the samples: the datagrams arrive in real time.
  const std::int64_t deadline_ns = timeout_ns >= 0 ? monotonic_ns() + timeout_ns : 0;
  for (;;) {
    pollfd entry{fd_, POLLIN, 0};
    timespec wait{};
    if (timeout_ns >= 0) {
      const std::int64_t remaining_ns = std::max<std::int64_t>(0, deadline_ns - monotonic_ns());
      wait.tv_sec = static_cast<time_t>(remaining_ns / 1'000'000'000);
      wait.tv_nsec = static_cast<long>(remaining_ns % 1'000'000'000);
    }
    const int ready = ::ppoll(&entry, 1, timeout_ns >= 0 ? &wait : nullptr, nullptr);
    if (ready < 0 && errno == EINTR) continue;
    if (ready < 0) return socket_failed("poll", errno);
    if (ready == 0) {
      ++counters_.stalls;
      return drivers::ReadStatus::kTimeout;
    }
    // MSG_TRUNC: the return value is the datagram's real length even when it did not fit.
    const ssize_t received = ::recv(fd_, buffer_.data(), buffer_.size(), MSG_DONTWAIT | MSG_TRUNC);
    if (received < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) continue;
    if (received < 0) return socket_failed("recv", errno);
    ++stream_counters_.datagrams;
    const std::uint32_t after_error = in_error_ ? messages::kFrameAfterReconnect : 0u;
    if (in_error_) {
      in_error_ = false;
      ++counters_.reconnects;
    }

    const auto size = static_cast<std::size_t>(received);
    char frame_id[kFrameIdBytes];
    std::uint32_t message_flags = 0;
    const DecodeStatus status =
        decode_pose_message(buffer_.data(), std::min(size, buffer_.size()), &scratch_, frame_id, &message_flags);
    if (status != DecodeStatus::kOk) {
      ++counters_.bad_frames;
      ++stream_counters_.decode_failures[static_cast<int>(status)];
      log_bad_frame(to_string(status), size);
      return drivers::ReadStatus::kBadFrame;
    }
    if (!config_.frame_id.empty() && std::strcmp(frame_id, config_.frame_id.c_str()) != 0) {
      ++counters_.bad_frames;
      ++stream_counters_.wrong_frame_id;
      log_bad_frame("wrong frame id", size);
      return drivers::ReadStatus::kBadFrame;
    }

    std::uint32_t flags = after_error;
    if (have_last_) {
      if (scratch_.sequence == last_sequence_) {
        ++stream_counters_.duplicates;
        continue;  // the same pose again (a sender's retry): keep waiting for a new one
      }
      if (scratch_.sequence > last_sequence_) {
        const std::uint64_t missing = scratch_.sequence - last_sequence_ - 1;
        if (missing > 0) {
          counters_.dropped += missing;
          flags |= messages::kFrameSequenceGap;
        }
      } else {
        ++stream_counters_.sequence_restarts;
        flags |= messages::kFrameAfterReconnect;
      }
      if (scratch_.sample_time_ns <= last_sample_time_ns_) {
        ++counters_.timestamps_backwards;
        flags |= messages::kFrameTimestampBackwards;
      }
    }
    if (message_flags & kPoseMessageEstimatorReset) {
      ++stream_counters_.estimator_resets;
      flags |= messages::kFrameAfterReconnect;
    }
    have_last_ = true;
    last_sequence_ = scratch_.sequence;
    last_sample_time_ns_ = scratch_.sample_time_ns;
    std::memcpy(last_frame_id_, frame_id, kFrameIdBytes);

    scratch_.publish_time_ns = now_ns();
    if (config_.late_after_ns > 0 && scratch_.publish_time_ns - scratch_.sample_time_ns > config_.late_after_ns) {
      ++counters_.late;
      flags |= messages::kFrameLate;
    }
    scratch_.flags = flags;
    sample = scratch_;
    ++counters_.delivered;
    return drivers::ReadStatus::kOk;
  }
}

drivers::ReadStatus PoseStreamSource::socket_failed(const char* call, int err) {
  // Counted and reported once per outage; the reads after it keep returning kDisconnected until one succeeds.
  if (!in_error_) {
    in_error_ = true;
    ++counters_.disconnects;
    std::fprintf(stderr, "pose_stream: %s failed: %s\n", call, std::strerror(err));
  }
  return drivers::ReadStatus::kDisconnected;
}

}  // namespace qsg::pose_stream
