// One interface per device class. Backends (simulated, dataset replay, V4L2, ...) implement these; contract
// tests run against every backend. read() fills a caller-owned, preallocated message and never allocates.
#pragma once

#include <cstdint>

#include "core/messages/sensor_types.h"

namespace qsg::drivers {

enum class ReadStatus : std::uint8_t {
  kOk,            // a message was written (it may carry FrameFlag bits)
  kTimeout,       // nothing arrived within the timeout (a stall); try again
  kEndOfStream,   // a finite source (replay, scripted trajectory) is exhausted
  kDisconnected,  // the device is gone; reads keep returning this until it is back
  kBadFrame,      // the device delivered something unusable (wrong size, corrupt); counted and discarded
};
const char* to_string(ReadStatus status);

// Fault and traffic counters every driver keeps next to its state (PX4 perf-counter style).
struct DriverCounters {
  std::uint64_t delivered = 0;
  std::uint64_t dropped = 0;             // sequence numbers never delivered
  std::uint64_t stalls = 0;              // reads that timed out
  std::uint64_t late = 0;
  std::uint64_t timestamps_backwards = 0;
  std::uint64_t invalid_depth_frames = 0;
  std::uint64_t bad_frames = 0;          // wrong size or corrupt, discarded
  std::uint64_t disconnects = 0;
  std::uint64_t reconnects = 0;
  std::uint64_t missing_files = 0;       // replay: a listed frame file that could not be read
};

class RgbdSource {
 public:
  virtual ~RgbdSource() = default;
  virtual const char* name() const = 0;
  virtual messages::CameraIntrinsics intrinsics() const = 0;
  // Waits up to timeout_ns (of the source's clock; simulated sources do not sleep) for the next frame.
  virtual ReadStatus read(messages::RgbdFrame& frame, std::int64_t timeout_ns) = 0;
  virtual const DriverCounters& counters() const = 0;
};

class OdometrySource {
 public:
  virtual ~OdometrySource() = default;
  virtual const char* name() const = 0;
  virtual ReadStatus read(messages::OdometrySample& sample, std::int64_t timeout_ns) = 0;
  virtual const DriverCounters& counters() const = 0;
};

}  // namespace qsg::drivers
