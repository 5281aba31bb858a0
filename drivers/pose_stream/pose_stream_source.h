// Live odometry from another process or board: pose-stream datagrams (pose_message.h) received on a UDP or Unix
// datagram socket, checked, and handed over as OdometrySamples with their faults counted.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>

#include "drivers/pose_stream/pose_message.h"
#include "drivers/sources.h"

namespace qsg::pose_stream {

// What this source counts beyond DriverCounters (whose dropped = missing sequence numbers, stalls = timeouts,
// bad_frames = datagrams that failed to decode or carried the wrong frame id, late and disconnects as named).
struct PoseStreamCounters {
  std::uint64_t datagrams = 0;          // received, good or bad
  std::uint64_t duplicates = 0;         // same sequence as the last delivered sample: discarded
  std::uint64_t sequence_restarts = 0;  // sequence below the last one: the sender started over (delivered)
  std::uint64_t estimator_resets = 0;   // messages with kPoseMessageEstimatorReset (delivered)
  std::uint64_t wrong_frame_id = 0;     // decoded, but not Config::frame_id: discarded as a bad frame
  std::array<std::uint64_t, kDecodeStatusCount> decode_failures{};  // indexed by DecodeStatus
  std::uint64_t decode_failure(DecodeStatus status) const { return decode_failures[static_cast<int>(status)]; }
};

// One socket, one sender's stream. Sample flags: kFrameSequenceGap after missing sequence numbers,
// kFrameTimestampBackwards for a sample time not after the previous one (delivered; the consumer rejects it),
// kFrameAfterReconnect after a sequence restart or a reported estimator reset, kFrameLate past Config::late_after_ns.
class PoseStreamSource : public drivers::OdometrySource {
 public:
  struct Config {
    std::string transport = "udp";          // "udp" or "unix"
    // udp: an IPv4 address. A non-loopback one (0.0.0.0, a robot's LAN address) accepts poses from the network,
    // so it is bound only when named here, and open() warns on stderr.
    std::string bind_address = "127.0.0.1";
    int port = 47600;                       // udp; 0 binds an ephemeral port (see port())
    std::string unix_path;                  // unix: socket file; a stale socket there is removed at open
    std::string frame_id;                   // accept only this frame id; empty accepts any
    // A sample whose publish time exceeds its sample time by more than this is flagged late; 0 = off (the
    // sender's clock must be this clock for it to mean anything).
    std::int64_t late_after_ns = 0;
    std::int64_t bad_frame_log_interval_ns = 1'000'000'000;  // at most one stderr line per interval
    // Stamps publish_time_ns and rate-limits logging; empty = CLOCK_MONOTONIC. Waiting in read() is real time.
    std::function<std::int64_t()> clock_ns;

    // Empty when usable, otherwise what is wrong.
    std::string check() const;
    void print(std::FILE* out) const;
  };

  PoseStreamSource() = default;
  ~PoseStreamSource() override;
  PoseStreamSource(const PoseStreamSource&) = delete;
  PoseStreamSource& operator=(const PoseStreamSource&) = delete;

  // Creates and binds the socket (closing one already open) and clears the counters. False with a message naming
  // the address or path: a bad address, a port in use, a path too long or held by a file that is not a socket.
  bool open(const Config& config, std::string* error);
  // Closes the socket and removes the socket file it created. Reads then return kDisconnected.
  void close();
  bool is_open() const { return fd_ >= 0; }
  // UDP port actually bound (the ephemeral one when Config::port is 0); 0 for unix or when closed.
  int port() const { return bound_port_; }

  const char* name() const override { return "pose_stream"; }
  // Waits up to timeout_ns of real time (negative: without limit) for a datagram and decodes it. kOk: a sample;
  // kTimeout: nothing came (a stall); kBadFrame: a malformed datagram was discarded (counted, logged rate-limited);
  // kDisconnected: the socket failed or is closed. A duplicate is discarded and the wait goes on. Never allocates.
  drivers::ReadStatus read(messages::OdometrySample& sample, std::int64_t timeout_ns) override;
  const drivers::DriverCounters& counters() const override { return counters_; }
  const PoseStreamCounters& stream_counters() const { return stream_counters_; }
  // Frame id of the last delivered sample ("" before the first).
  const char* last_frame_id() const { return last_frame_id_; }
  const Config& config() const { return config_; }

 private:
  std::int64_t now_ns() const;
  void log_bad_frame(const char* reason, std::size_t size);
  drivers::ReadStatus socket_failed(const char* call, int err);

  Config config_;
  int fd_ = -1;
  int bound_port_ = 0;
  bool created_socket_file_ = false;
  // Larger than a message so an oversized datagram is seen as one, not cut to a valid-looking prefix.
  std::array<std::uint8_t, 2 * kPoseMessageSize> buffer_{};
  char last_frame_id_[kFrameIdBytes] = {};
  messages::OdometrySample scratch_;  // decoded here, copied out only when delivered
  bool have_last_ = false;
  std::uint64_t last_sequence_ = 0;
  std::int64_t last_sample_time_ns_ = 0;
  std::int64_t last_log_ns_ = 0;
  bool in_error_ = false;  // the last socket call failed
  bool logged_once_ = false;
  std::uint64_t unlogged_bad_frames_ = 0;
  drivers::DriverCounters counters_;
  PoseStreamCounters stream_counters_;
};

}  // namespace qsg::pose_stream
