// A simulated V4L2 capture node behind V4l2Syscalls: it keeps the kernel's state machine (formats, MMAP
// buffers, the queued / done lists, streaming) and plays a script of frames and faults (EAGAIN, EINTR, EIO,
// ENODEV mid-stream, sequence gaps, timestamps going backwards, corrupt or short buffers) on a stepped clock,
// so capture code runs on a desk deterministically and without sleeping.
#pragma once

#include <linux/videodev2.h>

#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "drivers/v4l2/v4l2_syscalls.h"

namespace qsg::v4l2 {

// Time shared by fakes that model one machine (e.g. the depth and colour nodes of one camera).
struct FakeClock {
  std::int64_t now_ns = 1'000'000'000;
};

struct FakeFormat {
  std::uint32_t pixel_format = 0;
  int width_px = 0;
  int height_px = 0;
};

// What a painter is told about the frame it fills.
struct FakeFrameInfo {
  std::uint32_t sequence = 0;
  std::int64_t timestamp_ns = 0;
  std::uint32_t pixel_format = 0;
  int width_px = 0;
  int height_px = 0;
  std::uint32_t bytes_per_line = 0;
};

enum class FakeEventKind : std::uint8_t {
  kFrame,           // one frame arrives (timestamp = previous + period unless overridden)
  kGap,             // the driver loses `count` frames: sequence and time move on, nothing is delivered
  kBackwards,       // the next frame is stamped `back_ns` before the previous one
  kStall,           // poll() times out once (the clock moves by the timeout)
  kPollEintr,       // poll() returns EINTR once
  kDqbufEagain,     // poll() says ready but VIDIOC_DQBUF returns EAGAIN once
  kDqbufEintr,      // VIDIOC_DQBUF returns EINTR once
  kDqbufEio,        // VIDIOC_DQBUF returns EIO once
  kErrorFlag,       // one frame arrives with V4L2_BUF_FLAG_ERROR
  kShortFrame,      // one frame arrives with half the bytes
  kSequenceRepeat,  // one frame arrives carrying the previous frame's sequence number
  kVanish,          // the device is unplugged: every call on it fails with ENODEV, open() with ENOENT
};

struct FakeEvent {
  FakeEventKind kind = FakeEventKind::kFrame;
  std::uint32_t count = 1;   // kGap
  std::int64_t back_ns = 0;  // kBackwards
};

class FakeV4l2Device : public V4l2Syscalls {
 public:
  struct Config {
    std::string path = "/dev/video0";
    std::string card = "quadsg fake capture";
    std::vector<FakeFormat> formats{{kYuyv, 640, 480}, {kYuyv, 320, 240}, {kRgb24, 640, 480}};
    std::uint32_t row_padding_bytes = 0;  // bytesperline = width * bpp + padding (exercises strides)
    std::uint32_t min_buffers = 2;
    std::uint32_t max_buffers = 8;
    std::int64_t frame_period_ns = 33'333'333;
    std::int64_t first_timestamp_ns = 1'000'000'000;
    std::int64_t latency_ns = 2'000'000;  // the clock reads timestamp + latency once a frame is done
    bool endless = true;                  // when the script runs out, regular frames keep coming
    bool monotonic_timestamps = true;     // else buffers carry V4L2_BUF_FLAG_TIMESTAMP_UNKNOWN
    bool streaming_capability = true;
    bool capture_capability = true;
    bool ignore_format_requests = false;  // S_FMT answers the current format whatever was asked
    bool g_fmt_disagrees = false;         // G_FMT reports a different size than S_FMT agreed to
    void print(std::FILE* out) const;
  };
  static constexpr std::uint32_t kYuyv = V4L2_PIX_FMT_YUYV;
  static constexpr std::uint32_t kRgb24 = V4L2_PIX_FMT_RGB24;
  static constexpr std::uint32_t kZ16 = V4L2_PIX_FMT_Z16;

  using Painter = std::function<void(const FakeFrameInfo& info, std::uint8_t* data, std::size_t bytes)>;

  explicit FakeV4l2Device(Config config, FakeClock* clock = nullptr);
  ~FakeV4l2Device() override;

  // Script, played in order (set it up before streaming: appending may allocate).
  void push(const FakeEvent& event);
  void push(FakeEventKind kind) { push(FakeEvent{kind, 1, 0}); }
  void push_frames(int count);
  void push_gap(std::uint32_t lost) { push(FakeEvent{FakeEventKind::kGap, lost, 0}); }
  void push_backwards(std::int64_t back_ns) { push(FakeEvent{FakeEventKind::kBackwards, 1, back_ns}); }
  // Fills each frame; the default writes a pattern of the sequence number (Z16: 1000 + sequence units).
  void set_painter(Painter painter) { painter_ = std::move(painter); }
  // Plugs the device back in after kVanish (a fresh node: new buffers, sequence from 0, time continues).
  void reappear();

  // V4l2Syscalls.
  int sys_open(const char* path, int flags) override;
  int sys_close(int fd) override;
  int sys_ioctl(int fd, unsigned long request, void* arg) override;
  void* sys_mmap(std::size_t length, int prot, int flags, int fd, std::int64_t offset, int* error) override;
  int sys_munmap(void* address, std::size_t length) override;
  int sys_poll(int fd, short events, int timeout_ms, short* revents) override;
  std::int64_t monotonic_ns() override { return clock_->now_ns; }

  // Inspection for tests.
  bool is_open() const { return fd_open_; }
  bool is_streaming() const { return streaming_; }
  bool vanished() const { return vanished_; }
  int live_mappings() const { return live_mappings_; }
  int buffer_count() const { return static_cast<int>(buffers_.size()); }
  int queued_count() const;
  std::uint64_t frames_delivered() const { return frames_delivered_; }
  std::uint64_t frames_lost_no_buffer() const { return frames_lost_no_buffer_; }
  std::uint64_t calls(unsigned long request) const;
  const v4l2_pix_format& current_format() const { return format_; }
  std::size_t script_remaining() const { return script_.size() - cursor_; }
  FakeClock& clock() { return *clock_; }

 private:
  enum class BufState : std::uint8_t { kDequeued, kQueued, kDone };
  struct Buffer {
    std::vector<std::uint8_t> memory;
    BufState state = BufState::kDequeued;
    int mappings = 0;
    v4l2_buffer done{};  // the answer DQBUF gives once the buffer is done
  };

  int ioctl_locked(unsigned long request, void* arg);
  bool choose_format(v4l2_pix_format* pix) const;
  void fill_pix(std::uint32_t pixel_format, int width, int height, v4l2_pix_format* pix) const;
  // Moves the script forward until a buffer is done or a fault is at the head; true when a buffer is done.
  bool advance();
  const FakeEvent* head();
  void skip_modifiers();  // applies gap and backwards events at the head of the script
  void consume();
  int oldest_done() const;
  void free_buffers();

  Config config_;
  FakeClock own_clock_;
  FakeClock* clock_;
  Painter painter_;
  std::vector<FakeEvent> script_;
  std::size_t cursor_ = 0;
  FakeEvent synthetic_frame_{};
  static constexpr int kFirstFd = 3;
  int check_fd(int fd) const;  // 0, -EBADF (never issued / closed) or -ENODEV (unplugged)
  bool fd_open_ = false;
  bool fd_dead_ = false;  // the open file's device was unplugged
  int fd_ = kFirstFd;
  bool vanished_ = false;
  bool streaming_ = false;
  v4l2_pix_format format_{};
  std::vector<Buffer> buffers_;
  std::vector<Buffer> orphans_;  // buffers still mapped by a closed or unplugged file
  std::vector<int> queue_order_;     // queued buffer indices, oldest first (capacity fixed at REQBUFS)
  std::vector<std::uint64_t> done_order_;  // done stamp per buffer, to dequeue oldest first
  std::uint64_t done_counter_ = 0;
  int live_mappings_ = 0;
  std::uint32_t sequence_ = 0;
  bool have_timestamp_ = false;
  std::int64_t last_timestamp_ns_ = 0;
  std::int64_t next_timestamp_ns_ = 0;
  std::int64_t pending_back_ns_ = -1;
  std::uint64_t frames_delivered_ = 0;
  std::uint64_t frames_lost_no_buffer_ = 0;
  std::vector<std::pair<unsigned long, std::uint64_t>> call_counts_;
};

}  // namespace qsg::v4l2
