// Trivial in-memory sources for the fault-injection tests: deterministic frames and samples, no allocation.
#pragma once

#include <cstdint>

#include "drivers/sources.h"

namespace qsg::testing {

// Frames 0..count-1 at period_ns, depth = 1 m + 1 mm * sequence everywhere, colour = sequence.
class MemoryRgbdSource : public drivers::RgbdSource {
 public:
  MemoryRgbdSource(int width, int height, std::uint64_t count, std::int64_t period_ns = 33'333'333,
                   std::int64_t latency_ns = 1'000'000)
      : count_(count), period_ns_(period_ns), latency_ns_(latency_ns) {
    intrinsics_.width = width;
    intrinsics_.height = height;
    intrinsics_.cx = (width - 1) / 2.0;
    intrinsics_.cy = (height - 1) / 2.0;
  }
  const char* name() const override { return "memory_rgbd"; }
  messages::CameraIntrinsics intrinsics() const override { return intrinsics_; }
  drivers::ReadStatus read(messages::RgbdFrame& frame, std::int64_t /*timeout_ns*/) override {
    if (next_ >= count_) return drivers::ReadStatus::kEndOfStream;
    const std::uint64_t seq = next_++;
    frame.sequence = seq;
    frame.sample_time_ns = static_cast<std::int64_t>(seq) * period_ns_;
    frame.publish_time_ns = frame.sample_time_ns + latency_ns_;
    frame.intrinsics = intrinsics_;
    frame.depth_scale_m = 0.001f;
    frame.flags = 0;
    frame.has_labels = false;
    const float depth = 1.0f + 0.001f * static_cast<float>(seq);
    for (int i = 0; i < frame.pixels(); ++i) frame.depth_m[i] = depth;
    for (int i = 0; i < frame.pixels() * 3; ++i) frame.rgb[i] = static_cast<std::uint8_t>(seq);
    ++counters_.delivered;
    return drivers::ReadStatus::kOk;
  }
  const drivers::DriverCounters& counters() const override { return counters_; }
  drivers::DriverCounters& mutable_counters() { return counters_; }

 private:
  messages::CameraIntrinsics intrinsics_;
  std::uint64_t count_;
  std::int64_t period_ns_;
  std::int64_t latency_ns_;
  std::uint64_t next_ = 0;
  drivers::DriverCounters counters_;
};

// Samples 0..count-1 at period_ns moving 0.1 m along x per sample.
class MemoryOdometrySource : public drivers::OdometrySource {
 public:
  explicit MemoryOdometrySource(std::uint64_t count, std::int64_t period_ns = 10'000'000)
      : count_(count), period_ns_(period_ns) {}
  const char* name() const override { return "memory_odometry"; }
  drivers::ReadStatus read(messages::OdometrySample& sample, std::int64_t /*timeout_ns*/) override {
    if (next_ >= count_) return drivers::ReadStatus::kEndOfStream;
    const std::uint64_t seq = next_++;
    sample.sequence = seq;
    sample.sample_time_ns = static_cast<std::int64_t>(seq) * period_ns_;
    sample.publish_time_ns = sample.sample_time_ns;
    sample.world_t_body_m = Eigen::Vector3d(0.1 * static_cast<double>(seq), 0.0, 0.0);
    sample.world_R_body = Eigen::Quaterniond::Identity();
    sample.flags = 0;
    ++counters_.delivered;
    return drivers::ReadStatus::kOk;
  }
  const drivers::DriverCounters& counters() const override { return counters_; }

 private:
  std::uint64_t count_;
  std::int64_t period_ns_;
  std::uint64_t next_ = 0;
  drivers::DriverCounters counters_;
};

}  // namespace qsg::testing
