// V4L2 MMAP streaming capture; see v4l2_capture.h.
#include "drivers/v4l2/v4l2_capture.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/mman.h>

#include <cerrno>
#include <cstdarg>
#include <cstring>
#include <limits>

namespace qsg::v4l2 {

static_assert(kPixelFormatYuyv == V4L2_PIX_FMT_YUYV && kPixelFormatRgb24 == V4L2_PIX_FMT_RGB24 &&
                  kPixelFormatZ16 == V4L2_PIX_FMT_Z16 && kPixelFormatGrey == V4L2_PIX_FMT_GREY,
              "fourcc constants must match the kernel's");

namespace {

// Nanoseconds to poll()'s milliseconds, rounding up so a short timeout still waits instead of spinning.
int timeout_ms_from_ns(std::int64_t timeout_ns) {
  if (timeout_ns <= 0) return 0;
  const std::int64_t ms = (timeout_ns + 999'999) / 1'000'000;
  return ms > std::numeric_limits<int>::max() ? std::numeric_limits<int>::max() : static_cast<int>(ms);
}

const char* errno_text(int error_number) { return std::strerror(error_number); }

}  // namespace

int bytes_per_pixel(std::uint32_t pixel_format) {
  switch (pixel_format) {
    case kPixelFormatYuyv: return 2;
    case kPixelFormatZ16: return 2;
    case kPixelFormatRgb24: return 3;
    case kPixelFormatGrey: return 1;
    default: return 0;
  }
}

std::string V4l2Capture::Config::check() const {
  if (device.empty()) return "device path is empty";
  if (bytes_per_pixel(pixel_format) == 0) {
    char f[5];
    return std::string("pixel format '") + fourcc_to_string(pixel_format, f) +
           "' is not supported (YUYV, RGB3, Z16, GREY)";
  }
  if (width_px <= 0 || height_px <= 0) return "width_px and height_px must be positive";
  if (buffer_count < 2 || buffer_count > kMaxCaptureBuffers) {
    return "buffer_count must be in [2, " + std::to_string(kMaxCaptureBuffers) + "]";
  }
  if (max_latency_ns <= 0) return "max_latency_ns must be positive";
  if (max_retries < 0) return "max_retries must be >= 0";
  return {};
}

void V4l2Capture::Config::print(std::FILE* out) const {
  char f[5];
  std::fprintf(out,
               "V4l2Capture::Config: device=%s pixel_format=%s width_px=%d height_px=%d buffer_count=%d "
               "max_latency_ns=%lld max_retries=%d\n",
               device.c_str(), fourcc_to_string(pixel_format, f), width_px, height_px, buffer_count,
               static_cast<long long>(max_latency_ns), max_retries);
}

V4l2Capture::V4l2Capture(V4l2Syscalls& sys) : sys_(sys) {}

V4l2Capture::~V4l2Capture() { close(); }

void V4l2Capture::set_error(const char* format, ...) {
  std::va_list args;
  va_start(args, format);
  std::vsnprintf(last_error_.data(), last_error_.size(), format, args);
  va_end(args);
}

bool V4l2Capture::fail(std::string* error) {
  if (error) *error = last_error_.data();
  close();
  return false;
}

int V4l2Capture::buffers_held() const {
  int held = 0;
  for (int i = 0; i < num_buffers_; ++i) held += buffers_[i].state == BufferState::kHeld ? 1 : 0;
  return held;
}

bool V4l2Capture::open(const Config& config, std::string* error) {
  close();
  config_ = config;
  disconnected_ = false;
  const std::string problem = config.check();
  if (!problem.empty()) {
    set_error("%s: bad capture config: %s", config.device.c_str(), problem.c_str());
    if (error) *error = last_error_.data();
    return false;
  }
  const int fd = sys_.sys_open(config_.device.c_str(), O_RDWR | O_NONBLOCK);
  if (fd < 0) {
    set_error("%s: cannot open: %s", config_.device.c_str(), errno_text(-fd));
    return fail(error);
  }
  fd_ = fd;

  v4l2_capability cap{};
  int r = sys_.sys_ioctl(fd_, VIDIOC_QUERYCAP, &cap);
  if (r < 0) {
    set_error("%s: VIDIOC_QUERYCAP failed (%s): not a V4L2 device?", config_.device.c_str(), errno_text(-r));
    return fail(error);
  }
  const std::uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE)) {
    set_error("%s: '%s' is not a single-planar video capture node (capabilities 0x%08x%s)",
              config_.device.c_str(), reinterpret_cast<const char*>(cap.card), caps,
              (caps & V4L2_CAP_VIDEO_CAPTURE_MPLANE) ? ", multi-planar capture is not supported" : "");
    return fail(error);
  }
  if (!(caps & V4L2_CAP_STREAMING)) {
    set_error("%s: '%s' does not support streaming I/O (no V4L2_CAP_STREAMING)", config_.device.c_str(),
              reinterpret_cast<const char*>(cap.card));
    return fail(error);
  }
  if (!negotiate_format(error)) return false;
  return map_buffers(error);
}

void V4l2Capture::describe_formats(char* out, std::size_t size) {
  std::size_t used = 0;
  out[0] = '\0';
  for (std::uint32_t i = 0; i < 64; ++i) {
    v4l2_fmtdesc desc{};
    desc.index = i;
    desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (sys_.sys_ioctl(fd_, VIDIOC_ENUM_FMT, &desc) < 0) break;
    char f[5];
    const int n = std::snprintf(out + used, size - used, "%s%s", i == 0 ? "" : ", ",
                                fourcc_to_string(desc.pixelformat, f));
    if (n < 0 || used + static_cast<std::size_t>(n) >= size) break;
    used += static_cast<std::size_t>(n);
  }
  if (used == 0) std::snprintf(out, size, "(none listed)");
}

bool V4l2Capture::negotiate_format(std::string* error) {
  char want[5];
  fourcc_to_string(config_.pixel_format, want);
  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  fmt.fmt.pix.width = static_cast<std::uint32_t>(config_.width_px);
  fmt.fmt.pix.height = static_cast<std::uint32_t>(config_.height_px);
  fmt.fmt.pix.pixelformat = config_.pixel_format;
  fmt.fmt.pix.field = V4L2_FIELD_NONE;
  int r = sys_.sys_ioctl(fd_, VIDIOC_S_FMT, &fmt);
  if (r < 0) {
    set_error("%s: VIDIOC_S_FMT %s %dx%d refused: %s%s", config_.device.c_str(), want, config_.width_px,
              config_.height_px, errno_text(-r), r == -EBUSY ? " (another process is streaming from it)" : "");
    return fail(error);
  }
  // The driver answers with what it will really do; anything but what was asked is a refusal.
  const v4l2_pix_format& got = fmt.fmt.pix;
  const int bpp = bytes_per_pixel(config_.pixel_format);
  if (got.pixelformat != config_.pixel_format || got.width != static_cast<std::uint32_t>(config_.width_px) ||
      got.height != static_cast<std::uint32_t>(config_.height_px) ||
      (got.field != V4L2_FIELD_NONE && got.field != V4L2_FIELD_ANY)) {
    char offered[160];
    describe_formats(offered, sizeof(offered));
    char gotf[5];
    set_error("%s: cannot give %s %dx%d progressive: the driver's VIDIOC_S_FMT answer is %s %ux%u field %u; it "
              "lists formats: %s",
              config_.device.c_str(), want, config_.width_px, config_.height_px,
              fourcc_to_string(got.pixelformat, gotf), got.width, got.height, got.field, offered);
    return fail(error);
  }
  const std::uint64_t min_line = static_cast<std::uint64_t>(config_.width_px) * static_cast<std::uint64_t>(bpp);
  if (got.bytesperline < min_line) {
    set_error("%s: driver answered bytesperline %u for %s %dx%d, below the %llu bytes a row needs",
              config_.device.c_str(), got.bytesperline, want, config_.width_px, config_.height_px,
              static_cast<unsigned long long>(min_line));
    return fail(error);
  }
  const std::uint64_t min_image = static_cast<std::uint64_t>(got.bytesperline) * got.height;
  if (got.sizeimage < min_image) {
    set_error("%s: driver answered sizeimage %u, below bytesperline x height = %llu", config_.device.c_str(),
              got.sizeimage, static_cast<unsigned long long>(min_image));
    return fail(error);
  }
  format_.pixel_format = got.pixelformat;
  format_.width_px = static_cast<int>(got.width);
  format_.height_px = static_cast<int>(got.height);
  format_.bytes_per_line = got.bytesperline;
  format_.size_image_bytes = got.sizeimage;

  v4l2_format check{};
  check.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  r = sys_.sys_ioctl(fd_, VIDIOC_G_FMT, &check);
  if (r < 0) {
    set_error("%s: VIDIOC_G_FMT failed: %s", config_.device.c_str(), errno_text(-r));
    return fail(error);
  }
  const v4l2_pix_format& now = check.fmt.pix;
  if (now.pixelformat != got.pixelformat || now.width != got.width || now.height != got.height ||
      now.bytesperline != got.bytesperline || now.sizeimage != got.sizeimage) {
    char nowf[5];
    set_error("%s: format did not stick: VIDIOC_G_FMT reports %s %ux%u bytesperline %u sizeimage %u after "
              "VIDIOC_S_FMT agreed to %s %ux%u bytesperline %u sizeimage %u",
              config_.device.c_str(), fourcc_to_string(now.pixelformat, nowf), now.width, now.height,
              now.bytesperline, now.sizeimage, want, got.width, got.height, got.bytesperline, got.sizeimage);
    return fail(error);
  }
  return true;
}

bool V4l2Capture::map_buffers(std::string* error) {
  v4l2_requestbuffers req{};
  req.count = static_cast<std::uint32_t>(config_.buffer_count);
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  int r = sys_.sys_ioctl(fd_, VIDIOC_REQBUFS, &req);
  if (r < 0) {
    set_error("%s: VIDIOC_REQBUFS (%d MMAP buffers) failed: %s%s", config_.device.c_str(), config_.buffer_count,
              errno_text(-r), r == -EINVAL ? " (the driver does not support MMAP streaming)" : "");
    return fail(error);
  }
  if (req.count < 2) {
    set_error("%s: VIDIOC_REQBUFS gave %u buffers; streaming needs at least 2", config_.device.c_str(), req.count);
    return fail(error);
  }
  num_buffers_ = req.count > static_cast<std::uint32_t>(kMaxCaptureBuffers) ? kMaxCaptureBuffers
                                                                            : static_cast<int>(req.count);
  for (int i = 0; i < num_buffers_; ++i) {
    v4l2_buffer b{};
    b.index = static_cast<std::uint32_t>(i);
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    r = sys_.sys_ioctl(fd_, VIDIOC_QUERYBUF, &b);
    if (r < 0) {
      set_error("%s: VIDIOC_QUERYBUF %d failed: %s", config_.device.c_str(), i, errno_text(-r));
      return fail(error);
    }
    if (b.length < format_.size_image_bytes) {
      set_error("%s: buffer %d has %u bytes, smaller than the %u-byte image", config_.device.c_str(), i, b.length,
                format_.size_image_bytes);
      return fail(error);
    }
    int map_error = 0;
    void* p = sys_.sys_mmap(b.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, b.m.offset, &map_error);
    if (!p) {
      set_error("%s: mmap of buffer %d (%u bytes at offset %u) failed: %s", config_.device.c_str(), i, b.length,
                b.m.offset, errno_text(map_error));
      return fail(error);
    }
    buffers_[i].address = p;
    buffers_[i].length_bytes = b.length;
    buffers_[i].state = BufferState::kIdle;
  }
  return true;
}

bool V4l2Capture::queue_buffer(int index) {
  v4l2_buffer b{};
  b.index = static_cast<std::uint32_t>(index);
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_MMAP;
  int r = 0;
  for (int attempt = 0; attempt <= config_.max_retries; ++attempt) {
    r = sys_.sys_ioctl(fd_, VIDIOC_QBUF, &b);
    if (r != -EINTR) break;
    ++counters_.eintr_retries;
  }
  if (r == 0) {
    buffers_[index].state = BufferState::kQueued;
    return true;
  }
  buffers_[index].state = BufferState::kIdle;
  if (r == -ENODEV) {
    mark_disconnected("VIDIOC_QBUF");
  } else {
    ++counters_.io_errors;
    set_error("%s: VIDIOC_QBUF of buffer %d failed: %s", config_.device.c_str(), index, errno_text(-r));
  }
  return false;
}

bool V4l2Capture::start(std::string* error) {
  if (fd_ < 0 || num_buffers_ == 0) {
    set_error("%s: start() before a successful open()", config_.device.c_str());
    if (error) *error = last_error_.data();
    return false;
  }
  if (streaming_) return true;
  for (int i = 0; i < num_buffers_; ++i) {
    if (buffers_[i].state == BufferState::kIdle && !queue_buffer(i)) {
      if (error) *error = last_error_.data();
      return false;
    }
  }
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  const int r = sys_.sys_ioctl(fd_, VIDIOC_STREAMON, &type);
  if (r < 0) {
    if (r == -ENODEV) {
      mark_disconnected("VIDIOC_STREAMON");
    } else {
      set_error("%s: VIDIOC_STREAMON failed: %s", config_.device.c_str(), errno_text(-r));
    }
    if (error) *error = last_error_.data();
    return false;
  }
  streaming_ = true;
  stream_has_frame_ = false;
  return true;
}

void V4l2Capture::mark_disconnected(const char* during) {
  if (!disconnected_) ++counters_.driver.disconnects;
  disconnected_ = true;
  streaming_ = false;
  set_error("%s: device vanished (ENODEV during %s); frames already returned stay valid until close() or "
            "reopen()",
            config_.device.c_str(), during);
}

void V4l2Capture::requeue_rejected(int index) {
  buffers_[index].state = BufferState::kHeld;
  if (streaming_) queue_buffer(index);
  else buffers_[index].state = BufferState::kIdle;
}

drivers::ReadStatus V4l2Capture::next(CapturedFrame* frame, std::int64_t timeout_ns) {
  if (disconnected_) return drivers::ReadStatus::kDisconnected;
  if (!streaming_) {
    set_error("%s: next() while not streaming (call open() and start())", config_.device.c_str());
    return drivers::ReadStatus::kDisconnected;
  }
  const std::int64_t deadline_ns = sys_.monotonic_ns() + (timeout_ns > 0 ? timeout_ns : 0);
  v4l2_buffer b{};
  bool got = false;
  for (int attempt = 0; attempt <= config_.max_retries && !got; ++attempt) {
    const std::int64_t remaining_ns = deadline_ns - sys_.monotonic_ns();
    short revents = 0;
    int r = sys_.sys_poll(fd_, POLLIN, timeout_ms_from_ns(remaining_ns), &revents);
    if (r == -EINTR) {
      ++counters_.eintr_retries;
      continue;
    }
    if (r == -ENODEV) {
      mark_disconnected("poll");
      return drivers::ReadStatus::kDisconnected;
    }
    if (r < 0) {
      ++counters_.io_errors;
      set_error("%s: poll failed: %s", config_.device.c_str(), errno_text(-r));
      return drivers::ReadStatus::kBadFrame;
    }
    if (r == 0) {
      ++counters_.driver.stalls;
      return drivers::ReadStatus::kTimeout;
    }
    // POLLERR/POLLHUP: DQBUF tells why (ENODEV when unplugged).
    b = v4l2_buffer{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    r = sys_.sys_ioctl(fd_, VIDIOC_DQBUF, &b);
    if (r == 0) {
      got = true;
    } else if (r == -EAGAIN) {
      ++counters_.eagain_retries;
    } else if (r == -EINTR) {
      ++counters_.eintr_retries;
    } else if (r == -ENODEV) {
      mark_disconnected("VIDIOC_DQBUF");
      return drivers::ReadStatus::kDisconnected;
    } else {
      ++counters_.io_errors;
      set_error("%s: VIDIOC_DQBUF failed: %s", config_.device.c_str(), errno_text(-r));
      return drivers::ReadStatus::kBadFrame;
    }
  }
  if (!got) {
    ++counters_.driver.stalls;
    return drivers::ReadStatus::kTimeout;
  }
  const std::int64_t now_ns = sys_.monotonic_ns();
  if (b.index >= static_cast<std::uint32_t>(num_buffers_)) {
    ++counters_.io_errors;
    ++counters_.driver.bad_frames;
    set_error("%s: VIDIOC_DQBUF returned buffer index %u of %d", config_.device.c_str(), b.index, num_buffers_);
    return drivers::ReadStatus::kBadFrame;
  }
  const int index = static_cast<int>(b.index);
  buffers_[index].state = BufferState::kHeld;

  // Widen the sequence; a count that did not move forward means the driver is confused: reject the frame.
  std::uint64_t sequence = 0;
  std::uint64_t dropped = 0;
  if (!stream_has_frame_) {
    sequence = next_stream_sequence_ + b.sequence;
    dropped = b.sequence;
  } else {
    const std::uint32_t delta = b.sequence - last_driver_sequence_;
    if (delta == 0 || delta > 0x80000000u) {
      ++counters_.sequence_errors;
      ++counters_.driver.bad_frames;
      set_error("%s: sequence %u after %u: rejected", config_.device.c_str(), b.sequence, last_driver_sequence_);
      requeue_rejected(index);
      return drivers::ReadStatus::kBadFrame;
    }
    sequence = last_sequence_ + delta;
    dropped = delta - 1;
  }
  stream_has_frame_ = true;
  last_driver_sequence_ = b.sequence;
  last_sequence_ = sequence;
  next_stream_sequence_ = sequence + 1;
  counters_.driver.dropped += dropped;

  if (b.flags & V4L2_BUF_FLAG_ERROR) {
    ++counters_.flagged_errors;
    ++counters_.driver.bad_frames;
    set_error("%s: buffer %d (sequence %u) flagged V4L2_BUF_FLAG_ERROR: rejected", config_.device.c_str(), index,
              b.sequence);
    requeue_rejected(index);
    return drivers::ReadStatus::kBadFrame;
  }
  if (b.bytesused < format_.size_image_bytes || b.bytesused > buffers_[index].length_bytes) {
    ++counters_.short_frames;
    ++counters_.driver.bad_frames;
    set_error("%s: buffer %d (sequence %u) carries %u bytes, the format needs %u: rejected",
              config_.device.c_str(), index, b.sequence, b.bytesused, format_.size_image_bytes);
    requeue_rejected(index);
    return drivers::ReadStatus::kBadFrame;
  }
  // Drivers with a copied or unknown timestamp source (or none) are stamped at dequeue instead.
  std::int64_t sample_ns = static_cast<std::int64_t>(b.timestamp.tv_sec) * 1'000'000'000 +
                           static_cast<std::int64_t>(b.timestamp.tv_usec) * 1'000;
  if ((b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) != V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC || sample_ns == 0) {
    sample_ns = now_ns;
  }
  if (have_time_ && sample_ns <= last_sample_time_ns_) {
    ++counters_.driver.timestamps_backwards;
    ++counters_.driver.bad_frames;
    set_error("%s: sequence %u stamped %lld ns, not after the previous %lld ns: rejected", config_.device.c_str(),
              b.sequence, static_cast<long long>(sample_ns), static_cast<long long>(last_sample_time_ns_));
    requeue_rejected(index);
    return drivers::ReadStatus::kBadFrame;
  }
  have_time_ = true;
  last_sample_time_ns_ = sample_ns;

  std::uint32_t flags = 0;
  if (have_delivered_ && sequence != last_delivered_sequence_ + 1) flags |= messages::kFrameSequenceGap;
  if (after_reconnect_) flags |= messages::kFrameAfterReconnect;
  if (now_ns - sample_ns > config_.max_latency_ns) {
    flags |= messages::kFrameLate;
    ++counters_.driver.late;
  }
  after_reconnect_ = false;
  have_delivered_ = true;
  last_delivered_sequence_ = sequence;
  ++counters_.driver.delivered;

  frame->data = static_cast<const std::uint8_t*>(buffers_[index].address);
  frame->bytes_used = b.bytesused;
  frame->buffer_index = index;
  frame->sequence = sequence;
  frame->driver_sequence = b.sequence;
  frame->sample_time_ns = sample_ns;
  frame->dequeue_time_ns = now_ns < sample_ns ? sample_ns : now_ns;
  frame->dropped_before = dropped;
  frame->flags = flags;
  return drivers::ReadStatus::kOk;
}

bool V4l2Capture::release(const CapturedFrame& frame) {
  const int index = frame.buffer_index;
  if (index < 0 || index >= num_buffers_ || buffers_[index].state != BufferState::kHeld) return false;
  if (!streaming_) {
    buffers_[index].state = BufferState::kIdle;
    return !disconnected_;
  }
  return queue_buffer(index);
}

void V4l2Capture::stop() {
  if (fd_ < 0 || !streaming_) return;
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  const int r = sys_.sys_ioctl(fd_, VIDIOC_STREAMOFF, &type);
  if (r == -ENODEV) mark_disconnected("VIDIOC_STREAMOFF");
  streaming_ = false;
  for (int i = 0; i < num_buffers_; ++i) {
    if (buffers_[i].state == BufferState::kQueued) buffers_[i].state = BufferState::kIdle;
  }
}

void V4l2Capture::close() {
  if (fd_ < 0) return;
  if (streaming_) stop();
  for (int i = 0; i < num_buffers_; ++i) {
    if (buffers_[i].address) sys_.sys_munmap(buffers_[i].address, buffers_[i].length_bytes);
    buffers_[i] = Buffer{};
  }
  // Free the driver's buffers explicitly (closing would too) so a live device can be reconfigured at once.
  if (!disconnected_ && num_buffers_ > 0) {
    v4l2_requestbuffers req{};
    req.count = 0;
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    sys_.sys_ioctl(fd_, VIDIOC_REQBUFS, &req);
  }
  num_buffers_ = 0;
  sys_.sys_close(fd_);
  fd_ = -1;
  streaming_ = false;
}

bool V4l2Capture::reopen(std::string* error) {
  close();
  const Config config = config_;
  if (!open(config, error)) return false;
  if (!start(error)) {
    close();
    return false;
  }
  ++counters_.driver.reconnects;
  after_reconnect_ = true;
  return true;
}

}  // namespace qsg::v4l2
