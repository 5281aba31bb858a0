// The simulated V4L2 node; see fake_v4l2_device.h.
#include "drivers/v4l2/fake_v4l2_device.h"

#include <fcntl.h>
#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>

namespace qsg::v4l2 {

namespace {

// Offsets handed out by QUERYBUF: page-aligned and distinct per buffer, as the kernel's are.
constexpr std::uint32_t kOffsetStride = 1u << 20;

constexpr unsigned long kCountedRequests[] = {VIDIOC_QUERYCAP, VIDIOC_ENUM_FMT, VIDIOC_S_FMT,    VIDIOC_G_FMT,
                                              VIDIOC_TRY_FMT,  VIDIOC_REQBUFS,  VIDIOC_QUERYBUF, VIDIOC_QBUF,
                                              VIDIOC_DQBUF,    VIDIOC_STREAMON, VIDIOC_STREAMOFF};

int fake_bytes_per_pixel(std::uint32_t pixel_format) {
  switch (pixel_format) {
    case V4L2_PIX_FMT_YUYV: return 2;
    case V4L2_PIX_FMT_Z16: return 2;
    case V4L2_PIX_FMT_RGB24: return 3;
    case V4L2_PIX_FMT_GREY: return 1;
    default: return 2;
  }
}

void default_painter(const FakeFrameInfo& info, std::uint8_t* data, std::size_t bytes) {
  if (info.pixel_format == V4L2_PIX_FMT_Z16) {
    const std::uint16_t value = static_cast<std::uint16_t>(1000 + (info.sequence % 1000));
    for (int y = 0; y < info.height_px; ++y) {
      std::uint8_t* row = data + static_cast<std::size_t>(y) * info.bytes_per_line;
      for (int x = 0; x < info.width_px; ++x) std::memcpy(row + 2 * x, &value, 2);
    }
    return;
  }
  std::memset(data, static_cast<int>(info.sequence & 0xffu), bytes);
}

}  // namespace

void FakeV4l2Device::Config::print(std::FILE* out) const {
  std::fprintf(out, "FakeV4l2Device::Config: path=%s card='%s' formats=", path.c_str(), card.c_str());
  for (const FakeFormat& f : formats) {
    char name[5];
    std::fprintf(out, "%s %dx%d; ", fourcc_to_string(f.pixel_format, name), f.width_px, f.height_px);
  }
  std::fprintf(out,
               "row_padding_bytes=%u buffers=[%u, %u] frame_period_ns=%lld first_timestamp_ns=%lld latency_ns=%lld "
               "endless=%d monotonic_timestamps=%d streaming=%d capture=%d ignore_format_requests=%d "
               "g_fmt_disagrees=%d\n",
               row_padding_bytes, min_buffers, max_buffers, static_cast<long long>(frame_period_ns),
               static_cast<long long>(first_timestamp_ns), static_cast<long long>(latency_ns), endless ? 1 : 0,
               monotonic_timestamps ? 1 : 0, streaming_capability ? 1 : 0, capture_capability ? 1 : 0,
               ignore_format_requests ? 1 : 0, g_fmt_disagrees ? 1 : 0);
}

FakeV4l2Device::FakeV4l2Device(Config config, FakeClock* clock)
    : config_(std::move(config)), clock_(clock ? clock : &own_clock_), painter_(default_painter) {
  for (unsigned long request : kCountedRequests) call_counts_.emplace_back(request, 0);
  next_timestamp_ns_ = config_.first_timestamp_ns;
  if (!config_.formats.empty()) {
    const FakeFormat& f = config_.formats.front();
    fill_pix(f.pixel_format, f.width_px, f.height_px, &format_);
  }
}

FakeV4l2Device::~FakeV4l2Device() = default;

void FakeV4l2Device::push(const FakeEvent& event) { script_.push_back(event); }

void FakeV4l2Device::push_frames(int count) {
  for (int i = 0; i < count; ++i) push(FakeEventKind::kFrame);
}

void FakeV4l2Device::reappear() { vanished_ = false; }

std::uint64_t FakeV4l2Device::calls(unsigned long request) const {
  for (const auto& c : call_counts_) {
    if (c.first == request) return c.second;
  }
  return 0;
}

int FakeV4l2Device::queued_count() const { return static_cast<int>(queue_order_.size()); }

void FakeV4l2Device::fill_pix(std::uint32_t pixel_format, int width, int height, v4l2_pix_format* pix) const {
  *pix = v4l2_pix_format{};
  pix->width = static_cast<std::uint32_t>(width);
  pix->height = static_cast<std::uint32_t>(height);
  pix->pixelformat = pixel_format;
  pix->field = V4L2_FIELD_NONE;
  pix->bytesperline = static_cast<std::uint32_t>(width * fake_bytes_per_pixel(pixel_format)) +
                      config_.row_padding_bytes;
  pix->sizeimage = pix->bytesperline * pix->height;
  pix->colorspace = V4L2_COLORSPACE_SRGB;
}

// Like a driver: an unknown pixel format becomes the first one offered, the size the nearest offered one.
bool FakeV4l2Device::choose_format(v4l2_pix_format* pix) const {
  if (config_.formats.empty()) return false;
  if (config_.ignore_format_requests) {
    *pix = format_;
    return true;
  }
  std::uint32_t pixel_format = config_.formats.front().pixel_format;
  for (const FakeFormat& f : config_.formats) {
    if (f.pixel_format == pix->pixelformat) pixel_format = f.pixel_format;
  }
  const FakeFormat* best = nullptr;
  long best_distance = 0;
  for (const FakeFormat& f : config_.formats) {
    if (f.pixel_format != pixel_format) continue;
    const long d = std::labs(static_cast<long>(f.width_px) - static_cast<long>(pix->width)) +
                   std::labs(static_cast<long>(f.height_px) - static_cast<long>(pix->height));
    if (!best || d < best_distance) {
      best = &f;
      best_distance = d;
    }
  }
  fill_pix(best->pixel_format, best->width_px, best->height_px, pix);
  return true;
}

int FakeV4l2Device::sys_open(const char* path, int /*flags*/) {
  if (vanished_ || config_.path != path) return -ENOENT;
  if (fd_open_ && !fd_dead_) return -EBUSY;
  if (fd_open_) {
    // The node was unplugged while open: the old file keeps its mappings; the new node starts afresh.
    for (Buffer& b : buffers_) {
      if (b.mappings > 0) orphans_.push_back(std::move(b));
    }
    buffers_.clear();
    ++fd_;
  }
  fd_open_ = true;
  fd_dead_ = false;
  streaming_ = false;
  return fd_;
}

int FakeV4l2Device::sys_close(int fd) {
  if (fd >= kFirstFd && fd < fd_) return 0;  // an older, dead file of this node
  if (!fd_open_ || fd != fd_) return -EBADF;
  streaming_ = false;
  queue_order_.clear();
  for (Buffer& b : buffers_) {
    if (b.mappings > 0) orphans_.push_back(std::move(b));
  }
  buffers_.clear();
  fd_open_ = false;
  fd_dead_ = false;
  ++fd_;
  return 0;
}

int FakeV4l2Device::check_fd(int fd) const {
  if (fd >= kFirstFd && fd < fd_) return -ENODEV;
  if (!fd_open_ || fd != fd_) return -EBADF;
  if (fd_dead_) return -ENODEV;
  return 0;
}

int FakeV4l2Device::sys_ioctl(int fd, unsigned long request, void* arg) {
  for (auto& c : call_counts_) {
    if (c.first == request) ++c.second;
  }
  const int r = check_fd(fd);
  if (r < 0) return r;
  return ioctl_locked(request, arg);
}

void FakeV4l2Device::free_buffers() {
  buffers_.clear();
  queue_order_.clear();
}

int FakeV4l2Device::oldest_done() const {
  int best = -1;
  for (int i = 0; i < static_cast<int>(buffers_.size()); ++i) {
    if (buffers_[i].state == BufState::kDone &&
        (best < 0 || done_order_[static_cast<std::size_t>(i)] < done_order_[static_cast<std::size_t>(best)])) {
      best = i;
    }
  }
  return best;
}

int FakeV4l2Device::ioctl_locked(unsigned long request, void* arg) {
  switch (request) {
    case VIDIOC_QUERYCAP: {
      auto* cap = static_cast<v4l2_capability*>(arg);
      *cap = v4l2_capability{};
      std::snprintf(reinterpret_cast<char*>(cap->driver), sizeof(cap->driver), "qsg_fake");
      std::snprintf(reinterpret_cast<char*>(cap->card), sizeof(cap->card), "%s", config_.card.c_str());
      std::snprintf(reinterpret_cast<char*>(cap->bus_info), sizeof(cap->bus_info), "platform:qsg_fake");
      std::uint32_t caps = 0;
      if (config_.capture_capability) caps |= V4L2_CAP_VIDEO_CAPTURE;
      if (config_.streaming_capability) caps |= V4L2_CAP_STREAMING;
      cap->device_caps = caps;
      cap->capabilities = caps | V4L2_CAP_DEVICE_CAPS;
      return 0;
    }
    case VIDIOC_ENUM_FMT: {
      auto* desc = static_cast<v4l2_fmtdesc*>(arg);
      if (desc->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      std::uint32_t distinct = 0;
      for (std::size_t i = 0; i < config_.formats.size(); ++i) {
        bool seen = false;
        for (std::size_t j = 0; j < i; ++j) seen |= config_.formats[j].pixel_format == config_.formats[i].pixel_format;
        if (seen) continue;
        if (distinct == desc->index) {
          desc->pixelformat = config_.formats[i].pixel_format;
          std::snprintf(reinterpret_cast<char*>(desc->description), sizeof(desc->description), "fake format");
          return 0;
        }
        ++distinct;
      }
      return -EINVAL;
    }
    case VIDIOC_TRY_FMT:
    case VIDIOC_S_FMT: {
      auto* fmt = static_cast<v4l2_format*>(arg);
      if (fmt->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      if (request == VIDIOC_S_FMT && (streaming_ || !buffers_.empty())) return -EBUSY;
      if (!choose_format(&fmt->fmt.pix)) return -EINVAL;
      if (request == VIDIOC_S_FMT) format_ = fmt->fmt.pix;
      return 0;
    }
    case VIDIOC_G_FMT: {
      auto* fmt = static_cast<v4l2_format*>(arg);
      if (fmt->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      fmt->fmt.pix = format_;
      if (config_.g_fmt_disagrees) fmt->fmt.pix.width /= 2;
      return 0;
    }
    case VIDIOC_REQBUFS: {
      auto* req = static_cast<v4l2_requestbuffers*>(arg);
      if (req->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || req->memory != V4L2_MEMORY_MMAP) return -EINVAL;
      if (streaming_) return -EBUSY;
      for (const Buffer& b : buffers_) {
        if (b.mappings > 0) return -EBUSY;
      }
      free_buffers();
      if (req->count == 0) return 0;
      const std::uint32_t n = std::min(std::max(req->count, config_.min_buffers), config_.max_buffers);
      buffers_.resize(n);
      for (Buffer& b : buffers_) b.memory.assign(format_.sizeimage, 0);
      queue_order_.reserve(n);
      done_order_.assign(n, 0);
      req->count = n;
      return 0;
    }
    case VIDIOC_QUERYBUF:
    case VIDIOC_QBUF: {
      auto* b = static_cast<v4l2_buffer*>(arg);
      if (b->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || b->memory != V4L2_MEMORY_MMAP) return -EINVAL;
      if (b->index >= buffers_.size()) return -EINVAL;
      Buffer& buf = buffers_[b->index];
      if (request == VIDIOC_QBUF) {
        if (buf.state != BufState::kDequeued) return -EINVAL;
        buf.state = BufState::kQueued;
        queue_order_.push_back(static_cast<int>(b->index));
      }
      b->length = static_cast<std::uint32_t>(buf.memory.size());
      b->m.offset = b->index * kOffsetStride;
      b->flags = (buf.mappings > 0 ? V4L2_BUF_FLAG_MAPPED : 0u) |
                 (buf.state == BufState::kQueued ? V4L2_BUF_FLAG_QUEUED : 0u) |
                 (buf.state == BufState::kDone ? V4L2_BUF_FLAG_DONE : 0u);
      return 0;
    }
    case VIDIOC_DQBUF: {
      auto* b = static_cast<v4l2_buffer*>(arg);
      if (b->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || b->memory != V4L2_MEMORY_MMAP) return -EINVAL;
      if (!streaming_) return -EINVAL;
      skip_modifiers();
      // A frame already done came before any fault still in the script.
      if (const FakeEvent* e = oldest_done() >= 0 ? nullptr : head()) {
        if (e->kind == FakeEventKind::kDqbufEagain || e->kind == FakeEventKind::kDqbufEintr ||
            e->kind == FakeEventKind::kDqbufEio) {
          consume();
          return e->kind == FakeEventKind::kDqbufEagain ? -EAGAIN
                 : e->kind == FakeEventKind::kDqbufEintr ? -EINTR
                                                          : -EIO;
        }
      }
      advance();
      if (vanished_) return -ENODEV;
      const int index = oldest_done();
      if (index < 0) return -EAGAIN;
      Buffer& buf = buffers_[static_cast<std::size_t>(index)];
      buf.state = BufState::kDequeued;
      *b = buf.done;
      return 0;
    }
    case VIDIOC_STREAMON: {
      if (*static_cast<int*>(arg) != V4L2_BUF_TYPE_VIDEO_CAPTURE || buffers_.empty()) return -EINVAL;
      if (!streaming_) sequence_ = 0;
      streaming_ = true;
      return 0;
    }
    case VIDIOC_STREAMOFF: {
      if (*static_cast<int*>(arg) != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      streaming_ = false;
      for (Buffer& b : buffers_) b.state = BufState::kDequeued;
      queue_order_.clear();
      return 0;
    }
    default: return -ENOTTY;
  }
}

void* FakeV4l2Device::sys_mmap(std::size_t length, int /*prot*/, int /*flags*/, int fd, std::int64_t offset,
                               int* error) {
  const int r = check_fd(fd);
  if (r < 0) {
    *error = -r;
    return nullptr;
  }
  if (offset < 0 || offset % kOffsetStride != 0 || static_cast<std::size_t>(offset / kOffsetStride) >= buffers_.size()) {
    *error = EINVAL;
    return nullptr;
  }
  Buffer& b = buffers_[static_cast<std::size_t>(offset / kOffsetStride)];
  if (length == 0 || length > b.memory.size()) {
    *error = EINVAL;
    return nullptr;
  }
  ++b.mappings;
  ++live_mappings_;
  *error = 0;
  return b.memory.data();
}

int FakeV4l2Device::sys_munmap(void* address, std::size_t /*length*/) {
  for (Buffer& b : buffers_) {
    if (b.memory.data() == address && b.mappings > 0) {
      --b.mappings;
      --live_mappings_;
      return 0;
    }
  }
  for (std::size_t i = 0; i < orphans_.size(); ++i) {
    if (orphans_[i].memory.data() == address && orphans_[i].mappings > 0) {
      --live_mappings_;
      if (--orphans_[i].mappings == 0) orphans_.erase(orphans_.begin() + static_cast<std::ptrdiff_t>(i));
      return 0;
    }
  }
  return -EINVAL;
}

const FakeEvent* FakeV4l2Device::head() {
  if (cursor_ < script_.size()) return &script_[cursor_];
  if (config_.endless) return &synthetic_frame_;
  return nullptr;
}

void FakeV4l2Device::consume() {
  if (cursor_ < script_.size()) ++cursor_;
}

void FakeV4l2Device::skip_modifiers() {
  for (const FakeEvent* e = head(); e && (e->kind == FakeEventKind::kGap || e->kind == FakeEventKind::kBackwards);
       e = head()) {
    if (e->kind == FakeEventKind::kGap) {
      sequence_ += e->count;
      next_timestamp_ns_ += static_cast<std::int64_t>(e->count) * config_.frame_period_ns;
    } else {
      pending_back_ns_ = e->back_ns;
    }
    consume();
  }
}

bool FakeV4l2Device::advance() {
  for (;;) {
    if (oldest_done() >= 0) return true;
    const FakeEvent* e = head();
    if (!e || vanished_) return false;
    switch (e->kind) {
      case FakeEventKind::kGap:
      case FakeEventKind::kBackwards:
        skip_modifiers();
        continue;
      case FakeEventKind::kVanish:
        vanished_ = true;
        fd_dead_ = fd_open_;
        streaming_ = false;
        consume();
        return false;
      case FakeEventKind::kStall:
      case FakeEventKind::kPollEintr:
      case FakeEventKind::kDqbufEagain:
      case FakeEventKind::kDqbufEintr:
      case FakeEventKind::kDqbufEio: return false;
      case FakeEventKind::kFrame:
      case FakeEventKind::kErrorFlag:
      case FakeEventKind::kShortFrame:
      case FakeEventKind::kSequenceRepeat: break;
    }
    if (queue_order_.empty()) return false;  // no buffer to fill: the frame waits
    const int index = queue_order_.front();
    queue_order_.erase(queue_order_.begin());
    Buffer& buf = buffers_[static_cast<std::size_t>(index)];

    std::int64_t ts = next_timestamp_ns_;
    if (pending_back_ns_ >= 0 && have_timestamp_) {
      ts = last_timestamp_ns_ - pending_back_ns_;
    } else {
      next_timestamp_ns_ += config_.frame_period_ns;
    }
    pending_back_ns_ = -1;
    std::uint32_t seq = sequence_;
    if (e->kind == FakeEventKind::kSequenceRepeat && sequence_ > 0) {
      seq = sequence_ - 1;
    } else {
      ++sequence_;
    }
    have_timestamp_ = true;
    last_timestamp_ns_ = ts;

    FakeFrameInfo info;
    info.sequence = seq;
    info.timestamp_ns = ts;
    info.pixel_format = format_.pixelformat;
    info.width_px = static_cast<int>(format_.width);
    info.height_px = static_cast<int>(format_.height);
    info.bytes_per_line = format_.bytesperline;
    if (painter_) painter_(info, buf.memory.data(), buf.memory.size());

    v4l2_buffer& d = buf.done;
    d = v4l2_buffer{};
    d.index = static_cast<std::uint32_t>(index);
    d.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    d.memory = V4L2_MEMORY_MMAP;
    d.bytesused = e->kind == FakeEventKind::kShortFrame ? format_.sizeimage / 2 : format_.sizeimage;
    d.flags = V4L2_BUF_FLAG_MAPPED |
              (config_.monotonic_timestamps ? V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC : V4L2_BUF_FLAG_TIMESTAMP_UNKNOWN) |
              (e->kind == FakeEventKind::kErrorFlag ? V4L2_BUF_FLAG_ERROR : 0u);
    d.field = V4L2_FIELD_NONE;
    d.timestamp.tv_sec = static_cast<decltype(d.timestamp.tv_sec)>(ts / 1'000'000'000);
    d.timestamp.tv_usec = static_cast<decltype(d.timestamp.tv_usec)>((ts % 1'000'000'000) / 1'000);
    d.sequence = seq;
    d.m.offset = static_cast<std::uint32_t>(index) * kOffsetStride;
    d.length = static_cast<std::uint32_t>(buf.memory.size());
    buf.state = BufState::kDone;
    done_order_[static_cast<std::size_t>(index)] = ++done_counter_;
    ++frames_delivered_;
    clock_->now_ns = std::max(clock_->now_ns, ts + config_.latency_ns);
    consume();
    return true;
  }
}

int FakeV4l2Device::sys_poll(int fd, short /*events*/, int timeout_ms, short* revents) {
  const int r = check_fd(fd);
  if (r == -EBADF) {
    *revents = POLLNVAL;
    return 1;
  }
  const std::int64_t timeout_ns = static_cast<std::int64_t>(timeout_ms > 0 ? timeout_ms : 0) * 1'000'000;
  if (r < 0) {
    *revents = POLLERR | POLLHUP;
    return 1;
  }
  if (!streaming_) {
    *revents = POLLERR;
    return 1;
  }
  skip_modifiers();
  if (oldest_done() < 0) {
    if (const FakeEvent* e = head()) {
      if (e->kind == FakeEventKind::kPollEintr) {
        consume();
        return -EINTR;
      }
      if (e->kind == FakeEventKind::kStall) {
        consume();
        clock_->now_ns += timeout_ns;
        return 0;
      }
      if (e->kind == FakeEventKind::kDqbufEagain || e->kind == FakeEventKind::kDqbufEintr ||
          e->kind == FakeEventKind::kDqbufEio) {
        *revents = POLLIN | POLLRDNORM;
        return 1;
      }
    }
  }
  if (advance()) {
    *revents = POLLIN | POLLRDNORM;
    return 1;
  }
  if (vanished_) {
    *revents = POLLERR | POLLHUP;
    return 1;
  }
  clock_->now_ns += timeout_ns;  // waited the whole timeout for nothing
  return 0;
}

}  // namespace qsg::v4l2
