// One V4L2 video-capture node streamed through mmap'ed buffers: format negotiation with the driver's answer
// checked, monotonic timestamps, 64-bit sequence numbers with drop detection, a poll timeout, and every fault
// (EINTR, EAGAIN, EIO, ENODEV, corrupt buffers, backward timestamps) counted instead of crashing.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <string>

#include "drivers/sources.h"
#include "drivers/v4l2/v4l2_syscalls.h"

namespace qsg::v4l2 {

constexpr std::uint32_t make_fourcc(char a, char b, char c, char d) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(a)) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(b)) << 8) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(c)) << 16) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(d)) << 24);
}
// The formats this project converts (same values as V4L2_PIX_FMT_*; kept here so users need no kernel header).
inline constexpr std::uint32_t kPixelFormatYuyv = make_fourcc('Y', 'U', 'Y', 'V');
inline constexpr std::uint32_t kPixelFormatRgb24 = make_fourcc('R', 'G', 'B', '3');
inline constexpr std::uint32_t kPixelFormatZ16 = make_fourcc('Z', '1', '6', ' ');
inline constexpr std::uint32_t kPixelFormatGrey = make_fourcc('G', 'R', 'E', 'Y');
// Bytes per pixel of a packed format above, 0 for any other.
int bytes_per_pixel(std::uint32_t pixel_format);

// Buffers mapped per node; a driver that insists on more keeps the extra ones unqueued.
inline constexpr int kMaxCaptureBuffers = 8;

// What the driver agreed to (its answer to VIDIOC_S_FMT, confirmed by VIDIOC_G_FMT).
struct CaptureFormat {
  std::uint32_t pixel_format = 0;
  int width_px = 0;
  int height_px = 0;
  std::uint32_t bytes_per_line = 0;
  std::uint32_t size_image_bytes = 0;
};

// One dequeued buffer. `data` stays valid and unchanged until release(), close() or reopen(), also after the
// device vanished (the mapping outlives the device).
struct CapturedFrame {
  const std::uint8_t* data = nullptr;
  std::uint32_t bytes_used = 0;
  int buffer_index = -1;
  std::uint64_t sequence = 0;         // the driver's 32-bit count widened to 64 bits and continued across reopen()
  std::uint32_t driver_sequence = 0;  // as the driver reported it
  std::int64_t sample_time_ns = 0;    // CLOCK_MONOTONIC time the driver stamped the buffer with
  std::int64_t dequeue_time_ns = 0;   // CLOCK_MONOTONIC time it was dequeued (the publish time)
  std::uint64_t dropped_before = 0;   // frames the driver lost between the previous dequeued buffer and this one
  std::uint32_t flags = 0;            // messages::FrameFlag bits: sequence gap, late, after reconnect
};

struct CaptureCounters {
  drivers::DriverCounters driver;     // delivered, dropped, stalls, late, timestamps_backwards, bad_frames, ...
  std::uint64_t eintr_retries = 0;    // poll or DQBUF interrupted by a signal, retried
  std::uint64_t eagain_retries = 0;   // DQBUF found nothing although poll said ready, retried
  std::uint64_t io_errors = 0;        // EIO or an unexpected errno from poll/DQBUF/QBUF
  std::uint64_t sequence_errors = 0;  // a sequence number that did not increase: frame rejected
  std::uint64_t flagged_errors = 0;   // buffers the driver marked V4L2_BUF_FLAG_ERROR: frame rejected
  std::uint64_t short_frames = 0;     // fewer bytes than the negotiated image size: frame rejected
};

class V4l2Capture {
 public:
  struct Config {
    std::string device = "/dev/video0";
    std::uint32_t pixel_format = kPixelFormatYuyv;
    int width_px = 640;
    int height_px = 480;
    int buffer_count = 4;                         // asked for; the driver may answer with more or fewer (>= 2)
    std::int64_t max_latency_ns = 100'000'000;    // dequeue time - sample time above this: kFrameLate
    int max_retries = 8;                          // EINTR / EAGAIN retries within one next()
    std::string check() const;                    // empty when usable, else what is wrong
    void print(std::FILE* out) const;
  };

  explicit V4l2Capture(V4l2Syscalls& sys = linux_v4l2_syscalls());
  ~V4l2Capture();
  V4l2Capture(const V4l2Capture&) = delete;
  V4l2Capture& operator=(const V4l2Capture&) = delete;

  // Opens the node, checks it can capture and stream, negotiates the format, requests, maps and prepares the
  // buffers. On failure everything is undone and *error names the device, the step and the reason.
  bool open(const Config& config, std::string* error);
  // Queues every buffer not held by the caller and starts streaming (VIDIOC_STREAMON).
  bool start(std::string* error);
  // Waits up to timeout_ns for the next buffer. kOk: *frame holds it until release(). kTimeout: nothing came.
  // kBadFrame: a buffer was dequeued but rejected (corrupt, short, backward time, sequence error, EIO) and
  // requeued. kDisconnected: the device is gone (or not streaming); reopen() to continue. Never allocates.
  drivers::ReadStatus next(CapturedFrame* frame, std::int64_t timeout_ns);
  // Gives the buffer back to the driver. false (counted as an I/O error) if the driver refused it.
  bool release(const CapturedFrame& frame);
  // VIDIOC_STREAMOFF: the driver drops the buffers it holds; held frames stay valid.
  void stop();
  // Unmaps the buffers and closes the node (held frames become invalid).
  void close();
  // close() + open() + start() with the last configuration, after a disconnect; counts a reconnect and flags the
  // next frame kFrameAfterReconnect. Sequence numbers continue where they stopped.
  bool reopen(std::string* error);

  bool is_open() const { return fd_ >= 0; }
  bool is_streaming() const { return streaming_; }
  bool disconnected() const { return disconnected_; }
  const Config& config() const { return config_; }
  const CaptureFormat& format() const { return format_; }
  int buffer_count() const { return num_buffers_; }
  int buffers_held() const;
  // The last fault's message (a fixed buffer, so reporting a fault on the streaming path never allocates).
  const char* last_error() const { return last_error_.data(); }
  const CaptureCounters& counters() const { return counters_; }

 private:
  enum class BufferState : std::uint8_t { kIdle, kQueued, kHeld };
  struct Buffer {
    void* address = nullptr;
    std::size_t length_bytes = 0;
    BufferState state = BufferState::kIdle;
  };

  bool negotiate_format(std::string* error);
  bool map_buffers(std::string* error);
  bool queue_buffer(int index);
  void requeue_rejected(int index);
  void mark_disconnected(const char* during);
  void describe_formats(char* out, std::size_t size);
  void set_error(const char* format, ...) __attribute__((format(printf, 2, 3)));
  bool fail(std::string* error);  // copies last_error_ into *error, undoes open(); returns false

  V4l2Syscalls& sys_;
  Config config_;
  int fd_ = -1;
  bool streaming_ = false;
  bool disconnected_ = false;
  bool after_reconnect_ = false;
  CaptureFormat format_;
  std::array<Buffer, kMaxCaptureBuffers> buffers_{};
  int num_buffers_ = 0;
  // Sequence and time bookkeeping across streams.
  bool stream_has_frame_ = false;      // a buffer was dequeued since the last STREAMON
  std::uint32_t last_driver_sequence_ = 0;
  std::uint64_t last_sequence_ = 0;
  std::uint64_t next_stream_sequence_ = 0;  // where the next stream's sequence 0 lands
  bool have_delivered_ = false;
  std::uint64_t last_delivered_sequence_ = 0;
  bool have_time_ = false;
  std::int64_t last_sample_time_ns_ = 0;
  CaptureCounters counters_;
  std::array<char, 512> last_error_{};
};

}  // namespace qsg::v4l2
