// SegmentationWorker: fixed slots, one worker thread (or the loop's, in lockstep), per-frame wall and CPU time.
#include "firmware_app/segmentation_worker.h"

#include "firmware_app/runtime/stage_marker.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>

namespace qsg::app {
namespace {

std::int64_t thread_cpu_us() {
  timespec t{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1000000 + t.tv_nsec / 1000;
}

std::int64_t wall_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

SegmentationWorker::~SegmentationWorker() { stop(); }

bool SegmentationWorker::init(std::unique_ptr<segmentation::Segmenter> segmenter, std::uint32_t slots,
                              const SegmentationWorkerConfig& config, std::string* error) {
  if (segmenter == nullptr || !segmenter->ready())
    return *error = "segmentation worker: the segmenter is not initialised", false;
  if (slots < 2 || slots > 16) return *error = "segmentation worker: slots must be in 2..16 (budget queue 'segmentation')", false;
  if (!(config.min_interval_s >= 0.0) || !(config.max_age_s > 0.0))
    return *error = "segmentation worker: min_interval_s must be >= 0 and max_age_s > 0", false;
  config_ = config;
  segmenter_ = std::move(segmenter);
  slots_.resize(slots);
  for (Slot& s : slots_) s.frame = std::make_unique<messages::RgbdFrame>();
  state_ = std::make_unique<std::atomic<int>[]>(slots);
  for (std::uint32_t i = 0; i < slots; ++i) state_[i].store(kFree);
  if (config_.threaded) thread_ = std::thread([this] { thread_main(); });
  return true;
}

void SegmentationWorker::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

bool SegmentationWorker::idle() const {
  for (std::size_t i = 0; i < slots_.size(); ++i) {
    const int s = state_[i].load(std::memory_order_acquire);
    if (s == kQueued || s == kWorking) return false;
  }
  return true;
}

bool SegmentationWorker::offer(const messages::RgbdFrame& frame, const Eigen::Isometry3d& world_T_camera) {
  if (!initialized()) return false;
  std::size_t free_slot = slots_.size();
  bool busy = false;
  std::uint32_t used = 0;
  for (std::size_t i = 0; i < slots_.size(); ++i) {
    const int s = state_[i].load(std::memory_order_acquire);
    busy = busy || s == kQueued || s == kWorking;
    used += s != kFree ? 1 : 0;
    if (s == kFree && free_slot == slots_.size()) free_slot = i;
  }
  busy = busy || (config_.lockstep_busy_from_cost && frame.sample_time_ns < busy_until_ns_);
  const bool too_soon = have_taken_ && static_cast<double>(frame.sample_time_ns - last_taken_ns_) * 1e-9 <
                                           config_.min_interval_s;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.offered;
    if (busy || free_slot == slots_.size()) {
      ++counters_.busy;
      return false;
    }
    if (too_soon) {
      ++counters_.too_soon;
      return false;
    }
    ++counters_.taken;
  }
  // The slot is free: only this thread writes it until it is queued.
  Slot& slot = slots_[free_slot];
  messages::RgbdFrame& f = *slot.frame;
  const std::size_t n = static_cast<std::size_t>(std::max(0, frame.pixels()));
  f.sequence = frame.sequence;
  f.sample_time_ns = frame.sample_time_ns;
  f.publish_time_ns = frame.publish_time_ns;
  f.intrinsics = frame.intrinsics;
  f.depth_scale_m = frame.depth_scale_m;
  f.flags = frame.flags;
  f.has_labels = false;
  std::memcpy(f.depth_m.data(), frame.depth_m.data(), n * sizeof(float));
  std::memcpy(f.rgb.data(), frame.rgb.data(), 3 * n);
  slot.world_T_camera = world_T_camera;
  slot.order = next_order_++;
  last_taken_ns_ = frame.sample_time_ns;
  have_taken_ = true;
  slots_high_water_.store(std::max(slots_high_water_.load(), used + 1));
  {
    std::lock_guard<std::mutex> lock(mutex_);
    state_[free_slot].store(kQueued, std::memory_order_release);
  }
  if (config_.threaded) wake_.notify_one();
  return true;
}

void SegmentationWorker::segment_slot(std::size_t i) {
  messages::RgbdFrame& f = *slots_[i].frame;
  const std::int64_t c0 = thread_cpu_us(), w0 = wall_us();
  std::string error;
  runtime::stage_begin(config_.stage_marker, static_cast<std::uint64_t>(f.sample_time_ns));
  const bool ok = segmenter_->segment(f, &error);
  runtime::stage_end(config_.stage_marker, static_cast<std::uint64_t>(f.sample_time_ns));
  const std::int64_t cpu = thread_cpu_us() - c0, wall = wall_us() - w0;
  if (config_.lockstep_busy_from_cost && !config_.threaded) busy_until_ns_ = f.sample_time_ns + cpu * 1000;
  if (observer_ != nullptr) observer_(observer_user_, cpu, wall);
  std::lock_guard<std::mutex> lock(mutex_);
  wall_.record(wall, config_.budget_us);
  cpu_.record(cpu, config_.budget_us);
  if (ok) {
    ++counters_.labelled;
  } else {
    f.has_labels = false;
    ++counters_.failed;
    if (!logged_failure_) {
      std::fprintf(stderr, "segmentation: frame %llu not labelled (%s); logged once, counted as failed\n",
                   static_cast<unsigned long long>(f.sequence), error.c_str());
      logged_failure_ = true;
    }
  }
  state_[i].store(kLabelled, std::memory_order_release);
  finished_.notify_all();
}

bool SegmentationWorker::wait_until_idle(std::chrono::milliseconds timeout) const {
  std::unique_lock<std::mutex> lock(mutex_);
  return finished_.wait_for(lock, timeout, [&] { return idle(); });
}

void SegmentationWorker::run_pending() {
  if (!initialized() || config_.threaded) return;
  for (std::size_t i = 0; i < slots_.size(); ++i)
    if (state_[i].load() == kQueued) {
      state_[i].store(kWorking);
      segment_slot(i);
    }
}

void SegmentationWorker::thread_main() {
  for (;;) {
    std::size_t next = slots_.size();
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] {
        if (stop_) return true;
        for (std::size_t i = 0; i < slots_.size(); ++i)
          if (state_[i].load(std::memory_order_acquire) == kQueued) return true;
        return false;
      });
      for (std::size_t i = 0; i < slots_.size(); ++i)
        if (state_[i].load(std::memory_order_acquire) == kQueued) next = i;
      if (next == slots_.size()) return;  // stopping with nothing queued
      state_[next].store(kWorking, std::memory_order_release);
    }
    segment_slot(next);
  }
}

const SegmentationWorker::Slot* SegmentationWorker::labelled(std::int64_t now_data_ns) {
  if (!initialized()) return nullptr;
  for (;;) {
    std::size_t best = slots_.size();
    for (std::size_t i = 0; i < slots_.size(); ++i)
      if (state_[i].load(std::memory_order_acquire) == kLabelled &&
          (best == slots_.size() || slots_[i].order < slots_[best].order))
        best = i;
    if (best == slots_.size()) return nullptr;
    const Slot& s = slots_[best];
    const bool stale = static_cast<double>(now_data_ns - s.frame->sample_time_ns) * 1e-9 > config_.max_age_s;
    if (s.frame->has_labels && !stale) return &s;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (s.frame->has_labels) ++counters_.stale;  // failed frames are counted as failed already
    }
    state_[best].store(kFree, std::memory_order_release);
  }
}

void SegmentationWorker::release(const Slot* slot) {
  if (slot == nullptr) return;
  const std::size_t i = static_cast<std::size_t>(slot - slots_.data());
  if (i >= slots_.size()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.collected;
  }
  state_[i].store(kFree, std::memory_order_release);
}

SegmentationWorkerCounters SegmentationWorker::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counters_;
}

runtime::TaskStats SegmentationWorker::wall_stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return wall_;
}

runtime::TaskStats SegmentationWorker::cpu_stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return cpu_;
}

}  // namespace qsg::app
