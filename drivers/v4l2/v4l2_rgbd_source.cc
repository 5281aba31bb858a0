// Depth + colour V4L2 pair as one RgbdSource; see v4l2_rgbd_source.h.
#include "drivers/v4l2/v4l2_rgbd_source.h"

#include "drivers/v4l2/pixel_convert.h"

namespace qsg::v4l2 {

V4l2Capture::Config V4l2RgbdSource::Config::default_depth() {
  V4l2Capture::Config c;
  c.device = "/dev/video0";
  c.pixel_format = kPixelFormatZ16;
  return c;
}

V4l2Capture::Config V4l2RgbdSource::Config::default_colour() {
  V4l2Capture::Config c;
  c.device = "/dev/video2";
  c.pixel_format = kPixelFormatYuyv;
  return c;
}

std::string V4l2RgbdSource::Config::check() const {
  std::string p = depth.check();
  if (!p.empty()) return "depth: " + p;
  p = colour.check();
  if (!p.empty()) return "colour: " + p;
  if (depth.pixel_format != kPixelFormatZ16) return "depth: pixel_format must be Z16";
  if (colour.pixel_format != kPixelFormatYuyv && colour.pixel_format != kPixelFormatRgb24) {
    return "colour: pixel_format must be YUYV or RGB3";
  }
  if (!intrinsics.valid()) return "intrinsics: invalid (size within 640x480, fx and fy non-zero)";
  if (depth.width_px != intrinsics.width || depth.height_px != intrinsics.height || colour.width_px != intrinsics.width ||
      colour.height_px != intrinsics.height) {
    return "depth, colour and intrinsics must have the same width and height (the pair is aligned by the device)";
  }
  if (colour.pixel_format == kPixelFormatYuyv && colour.width_px % 2 != 0) return "colour: YUYV needs an even width";
  if (!(depth_scale_m > 0.0f)) return "depth_scale_m must be positive";
  if (pair_tolerance_ns < 0) return "pair_tolerance_ns must be >= 0";
  if (max_latency_ns <= 0) return "max_latency_ns must be positive";
  if (reconnect_interval_ns < 0) return "reconnect_interval_ns must be >= 0";
  if (!(invalid_depth_fraction >= 0.0 && invalid_depth_fraction <= 1.0)) return "invalid_depth_fraction must be in [0, 1]";
  return {};
}

void V4l2RgbdSource::Config::print(std::FILE* out) const {
  std::fprintf(out, "V4l2RgbdSource::Config: depth:\n  ");
  depth.print(out);
  std::fprintf(out, "  colour:\n  ");
  colour.print(out);
  std::fprintf(out,
               "  intrinsics %dx%d fx=%.3f fy=%.3f cx=%.3f cy=%.3f depth_scale_m=%g pair_tolerance_ns=%lld "
               "max_latency_ns=%lld reconnect_interval_ns=%lld invalid_depth_fraction=%.3f\n",
               intrinsics.width, intrinsics.height, intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy,
               static_cast<double>(depth_scale_m), static_cast<long long>(pair_tolerance_ns),
               static_cast<long long>(max_latency_ns), static_cast<long long>(reconnect_interval_ns),
               invalid_depth_fraction);
}

V4l2RgbdSource::V4l2RgbdSource(V4l2Syscalls& depth_sys, V4l2Syscalls& colour_sys)
    : clock_(depth_sys), depth_(depth_sys), colour_(colour_sys) {}

bool V4l2RgbdSource::init(const Config& config, std::string* error) {
  initialised_ = false;
  const std::string problem = config.check();
  if (!problem.empty()) {
    if (error) *error = "V4l2RgbdSource config: " + problem;
    return false;
  }
  config_ = config;
  std::string e;
  if (!depth_.open(config_.depth, &e) || !depth_.start(&e)) {
    if (error) *error = "depth node: " + e;
    depth_.close();
    return false;
  }
  if (!colour_.open(config_.colour, &e) || !colour_.start(&e)) {
    if (error) *error = "colour node: " + e;
    colour_.close();
    depth_.close();
    return false;
  }
  initialised_ = true;
  disconnected_ = false;
  return true;
}

void V4l2RgbdSource::release_held() {
  if (have_depth_) depth_.release(depth_frame_);
  if (have_colour_) colour_.release(colour_frame_);
  have_depth_ = have_colour_ = false;
}

void V4l2RgbdSource::update_counters() {
  const drivers::DriverCounters& d = depth_.counters().driver;
  const drivers::DriverCounters& c = colour_.counters().driver;
  counters_.timestamps_backwards = d.timestamps_backwards + c.timestamps_backwards;
  counters_.bad_frames = d.bad_frames + c.bad_frames;
}

drivers::ReadStatus V4l2RgbdSource::on_disconnect(const V4l2Capture& capture) {
  release_held();
  disconnected_ = true;
  ++counters_.disconnects;
  last_error_ = capture.last_error();
  // The first reopen attempt waits one interval: a device that just vanished is rarely back at once.
  last_reconnect_attempt_ns_ = clock_.monotonic_ns();
  return drivers::ReadStatus::kDisconnected;
}

bool V4l2RgbdSource::try_reconnect() {
  const std::int64_t now_ns = clock_.monotonic_ns();
  if (now_ns - last_reconnect_attempt_ns_ < config_.reconnect_interval_ns) return false;
  last_reconnect_attempt_ns_ = now_ns;
  ++pair_counters_.reconnect_attempts;
  // Reopen whichever node is gone (an unplugged camera usually takes both).
  if ((depth_.disconnected() || !depth_.is_streaming()) && !depth_.reopen(&reconnect_error_)) {
    reconnect_error_ = "depth node: " + reconnect_error_;
    last_error_ = reconnect_error_.c_str();
    return false;
  }
  if ((colour_.disconnected() || !colour_.is_streaming()) && !colour_.reopen(&reconnect_error_)) {
    reconnect_error_ = "colour node: " + reconnect_error_;
    last_error_ = reconnect_error_.c_str();
    return false;
  }
  disconnected_ = false;
  after_reconnect_ = true;
  ++counters_.reconnects;
  return true;
}

drivers::ReadStatus V4l2RgbdSource::fetch(V4l2Capture& capture, CapturedFrame* frame, bool* held,
                                          std::int64_t deadline_ns) {
  const std::int64_t remaining_ns = deadline_ns - clock_.monotonic_ns();
  const drivers::ReadStatus s = capture.next(frame, remaining_ns > 0 ? remaining_ns : 0);
  if (s == drivers::ReadStatus::kOk) *held = true;
  if (s == drivers::ReadStatus::kBadFrame) last_error_ = capture.last_error();
  return s;
}

void V4l2RgbdSource::assemble(messages::RgbdFrame& frame) {
  const CaptureFormat& df = depth_.format();
  const CaptureFormat& cf = colour_.format();
  const int w = config_.intrinsics.width;
  const int h = config_.intrinsics.height;
  frame.intrinsics = config_.intrinsics;
  frame.depth_scale_m = config_.depth_scale_m;
  frame.has_labels = false;
  const int invalid = z16_to_metres(depth_frame_.data, df.bytes_per_line, w, h, config_.depth_scale_m,
                                    frame.depth_m.data());
  if (cf.pixel_format == kPixelFormatYuyv) {
    yuyv_to_rgb(colour_frame_.data, cf.bytes_per_line, w, h, frame.rgb.data());
  } else {
    rgb24_to_rgb(colour_frame_.data, cf.bytes_per_line, w, h, frame.rgb.data());
  }
  std::uint32_t flags = (depth_frame_.flags | colour_frame_.flags) & messages::kFrameAfterReconnect;
  if (after_reconnect_) flags |= messages::kFrameAfterReconnect;
  after_reconnect_ = false;

  frame.sequence = depth_frame_.sequence;
  if (have_delivered_ && frame.sequence != last_sequence_ + 1) {
    flags |= messages::kFrameSequenceGap;
    counters_.dropped += frame.sequence - last_sequence_ - 1;
  }
  have_delivered_ = true;
  last_sequence_ = frame.sequence;
  frame.sample_time_ns = depth_frame_.sample_time_ns;
  const std::int64_t now_ns = clock_.monotonic_ns();
  frame.publish_time_ns = now_ns > frame.sample_time_ns ? now_ns : frame.sample_time_ns;
  if (frame.publish_time_ns - frame.sample_time_ns > config_.max_latency_ns) {
    flags |= messages::kFrameLate;
    ++counters_.late;
  }
  if (static_cast<double>(invalid) > config_.invalid_depth_fraction * static_cast<double>(w * h)) {
    flags |= messages::kFrameInvalidDepthRegion;
    ++counters_.invalid_depth_frames;
  }
  frame.flags = flags;
  ++counters_.delivered;
}

drivers::ReadStatus V4l2RgbdSource::read(messages::RgbdFrame& frame, std::int64_t timeout_ns) {
  if (!initialised_) {
    last_error_ = "read() before a successful init()";
    return drivers::ReadStatus::kDisconnected;
  }
  if (disconnected_ && !try_reconnect()) return drivers::ReadStatus::kDisconnected;
  const std::int64_t deadline_ns = clock_.monotonic_ns() + (timeout_ns > 0 ? timeout_ns : 0);
  drivers::ReadStatus status = drivers::ReadStatus::kTimeout;
  // Each pass consumes at least one frame; a bound keeps a badly skewed pair from spinning within one read.
  for (int pass = 0; pass < 4 * kMaxCaptureBuffers; ++pass) {
    if (!have_depth_) {
      status = fetch(depth_, &depth_frame_, &have_depth_, deadline_ns);
      if (status == drivers::ReadStatus::kDisconnected) return on_disconnect(depth_);
      if (status != drivers::ReadStatus::kOk) break;
    }
    if (!have_colour_) {
      status = fetch(colour_, &colour_frame_, &have_colour_, deadline_ns);
      if (status == drivers::ReadStatus::kDisconnected) return on_disconnect(colour_);
      if (status != drivers::ReadStatus::kOk) break;
    }
    const std::int64_t dt_ns = depth_frame_.sample_time_ns - colour_frame_.sample_time_ns;
    if (dt_ns <= config_.pair_tolerance_ns && dt_ns >= -config_.pair_tolerance_ns) {
      assemble(frame);
      release_held();
      update_counters();
      return drivers::ReadStatus::kOk;
    }
    // The older frame cannot pair with anything still to come: drop it, keep the newer one.
    if (dt_ns > 0) {
      colour_.release(colour_frame_);
      have_colour_ = false;
      ++pair_counters_.unpaired_colour;
    } else {
      depth_.release(depth_frame_);
      have_depth_ = false;
      ++pair_counters_.unpaired_depth;
    }
    status = drivers::ReadStatus::kTimeout;
  }
  if (status == drivers::ReadStatus::kTimeout) ++counters_.stalls;
  update_counters();
  return status;
}

}  // namespace qsg::v4l2
