// A RealSense-style RGB-D camera seen as two V4L2 nodes (Z16 depth and YUYV or RGB24 colour, already aligned by
// the device): frames are paired by nearest timestamp within a tolerance and published as one RgbdFrame with
// depth in metres (0 = no return) and RGB colour.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

#include "drivers/sources.h"
#include "drivers/v4l2/v4l2_capture.h"

namespace qsg::v4l2 {

class V4l2RgbdSource : public drivers::RgbdSource {
 public:
  struct Config {
    V4l2Capture::Config depth = default_depth();    // pixel_format must be Z16
    V4l2Capture::Config colour = default_colour();  // YUYV or RGB3, same size as depth
    messages::CameraIntrinsics intrinsics;           // of the aligned pair; width/height must match both nodes
    float depth_scale_m = 0.001f;                   // metres per Z16 unit (RealSense D4xx default)
    std::int64_t pair_tolerance_ns = 10'000'000;    // depth and colour sample times further apart do not pair
    std::int64_t max_latency_ns = 100'000'000;      // publish - sample above this: kFrameLate
    std::int64_t reconnect_interval_ns = 1'000'000'000;  // between reopen attempts after a disconnect
    double invalid_depth_fraction = 0.5;            // more pixels without return than this: kFrameInvalidDepthRegion
    std::string check() const;
    void print(std::FILE* out) const;
    static V4l2Capture::Config default_depth();
    static V4l2Capture::Config default_colour();
  };

  // Pairing statistics beyond DriverCounters.
  struct PairCounters {
    std::uint64_t unpaired_depth = 0;   // depth frames dropped because no colour frame was close enough
    std::uint64_t unpaired_colour = 0;  // colour frames dropped likewise
    std::uint64_t reconnect_attempts = 0;
  };

  // The two nodes may share one syscall backend (the real one) or each have a fake.
  V4l2RgbdSource(V4l2Syscalls& depth_sys, V4l2Syscalls& colour_sys);

  // Opens, negotiates and starts both nodes. false with *error naming the node and the reason.
  bool init(const Config& config, std::string* error);

  const char* name() const override { return "v4l2_rgbd"; }
  messages::CameraIntrinsics intrinsics() const override { return config_.intrinsics; }
  // Never allocates while the devices behave; a reconnect attempt (at most one per reconnect_interval_ns) does.
  drivers::ReadStatus read(messages::RgbdFrame& frame, std::int64_t timeout_ns) override;
  const drivers::DriverCounters& counters() const override { return counters_; }

  const PairCounters& pair_counters() const { return pair_counters_; }
  const V4l2Capture& depth_capture() const { return depth_; }
  const V4l2Capture& colour_capture() const { return colour_; }
  const Config& config() const { return config_; }
  // Why the last read failed (disconnect, reconnect failure, rejected frame).
  const char* last_error() const { return last_error_; }

 private:
  drivers::ReadStatus fetch(V4l2Capture& capture, CapturedFrame* frame, bool* held, std::int64_t deadline_ns);
  drivers::ReadStatus on_disconnect(const V4l2Capture& capture);
  bool try_reconnect();
  void release_held();
  void assemble(messages::RgbdFrame& frame);
  void update_counters();

  V4l2Syscalls& clock_;
  Config config_;
  V4l2Capture depth_;
  V4l2Capture colour_;
  CapturedFrame depth_frame_;
  CapturedFrame colour_frame_;
  bool have_depth_ = false;
  bool have_colour_ = false;
  bool initialised_ = false;
  bool disconnected_ = false;
  bool after_reconnect_ = false;
  std::int64_t last_reconnect_attempt_ns_ = 0;
  bool have_delivered_ = false;
  std::uint64_t last_sequence_ = 0;
  drivers::DriverCounters counters_;
  PairCounters pair_counters_;
  const char* last_error_ = "";
  std::string reconnect_error_;
};

}  // namespace qsg::v4l2
