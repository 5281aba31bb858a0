// Semantic segmentation at its own rate, beside the keyframe loop (issue 37).
//
// Keyframes never wait for labels: the loop integrates every keyframe's depth at once, then offers it here. When
// the worker is idle (no frame queued or in work) and at least min_interval_s of data time has passed since the
// last frame it took, the frame's RGB, depth and pose are copied into a free slot and the worker thread segments
// it; otherwise the offer is counted as skipped. Labelled frames come back to the loop, which casts their label
// votes into the TSDF from the frame's own depth and pose (SemanticTsdf::integrate_label_votes): each label lands on
// the voxels its pixel saw, with the weight it would have had in the keyframe's own integration. Labels are never
// moved to another pose (a past image's labels warped to a later view are wrong at every occlusion border), and no
// keyframe waits; the TSDF's per-voxel votes accumulate across the labelled keyframes, so a lower rate means fewer
// votes per voxel, not wrong ones. Labels older than max_age_s (data time) when they come back are dropped, counted.
//
// Bounded: a fixed number of slots (frames carved at init), no heap allocation of ours after init; OpenCV's
// forward() allocates internally (measured: bench/results/segmentation.md). In lockstep the frame taken is
// segmented on the loop's thread after the keyframe's tasks (deterministic), timed the same way.
//
// Statistics like the tick tasks': per run wall time and thread CPU time against the board's "segmentation"
// thread budget (budgets/<board>.json "threads"), overruns counted.
#pragma once

#include <Eigen/Geometry>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/segmentation/segmenter.h"
#include "core/messages/sensor_types.h"
#include "firmware_app/runtime/task_stats.h"

namespace qsg::app {

struct SegmentationWorkerConfig {
  double min_interval_s = 0.0;  // data time between two frames taken (0: whenever the worker is idle)
  double max_age_s = 2.0;       // labels coming back later than this after their frame's sample time are dropped
  bool threaded = true;         // false (lockstep): run_pending() segments on the caller's thread
  std::uint32_t budget_us = 0;  // per frame, from the board's thread budget (0: none)
  // Lockstep only (benchmarks): after segmenting a frame the worker counts as busy until that frame's time plus
  // the run's CPU time, in data time, as a worker on a core of its own would be; so the share of keyframes labelled
  // in a lockstep run is what the measured cost allows. Off: lockstep takes every frame offered (deterministic).
  bool lockstep_busy_from_cost = false;
  std::uint32_t stage_marker = 0;  // the thread's stage-marker id (runtime/stage_marker.h), set from the board's table
};

struct SegmentationWorkerCounters {
  std::uint64_t offered = 0;    // keyframes offered
  std::uint64_t taken = 0;      // copied into a slot for the worker
  std::uint64_t busy = 0;       // offered while the worker had a frame queued or in work (or no slot was free)
  std::uint64_t too_soon = 0;   // offered before min_interval_s had passed
  std::uint64_t labelled = 0;   // segmented
  std::uint64_t failed = 0;     // the segmenter refused the frame or OpenCV failed (logged once)
  std::uint64_t collected = 0;  // labelled frames whose votes the loop cast
  std::uint64_t stale = 0;      // labelled frames dropped: older than max_age_s when collected
};

class SegmentationWorker {
 public:
  struct Slot {
    std::unique_ptr<messages::RgbdFrame> frame;
    Eigen::Isometry3d world_T_camera = Eigen::Isometry3d::Identity();
    std::uint64_t order = 0;  // taken order: the loop collects the oldest labelled slot first
  };

  SegmentationWorker() = default;
  ~SegmentationWorker();
  SegmentationWorker(const SegmentationWorker&) = delete;
  SegmentationWorker& operator=(const SegmentationWorker&) = delete;

  // Takes an initialised segmenter; carves `slots` frames (>= 2: one in work, one labelled waiting for the loop).
  bool init(std::unique_ptr<segmentation::Segmenter> segmenter, std::uint32_t slots,
            const SegmentationWorkerConfig& config, std::string* error);
  bool initialized() const { return segmenter_ != nullptr; }
  void stop();  // joins the thread; a frame in work is finished first

  // Loop: offers an integrated keyframe (see above). True when taken.
  bool offer(const messages::RgbdFrame& frame, const Eigen::Isometry3d& world_T_camera);
  // Lockstep: segments the frame taken by the last offer(), on this thread. No-op when threaded.
  void run_pending();
  // Loop: the oldest labelled frame (nullptr: none); frames older than max_age_s at now_data_ns are dropped and
  // counted first. release() gives the slot back after its votes were cast.
  const Slot* labelled(std::int64_t now_data_ns);
  void release(const Slot* slot);
  // True when no frame is queued or in work (lockstep: always after run_pending()).
  bool idle() const;
  // Blocks until idle() or the timeout (false then): for shutdown and tests, never on the loop.
  bool wait_until_idle(std::chrono::milliseconds timeout) const;

  SegmentationWorkerCounters counters() const;
  // Per-frame cost of the worker: wall time and the thread's CPU time (the same TaskStats as the tick tasks).
  runtime::TaskStats wall_stats() const;
  runtime::TaskStats cpu_stats() const;
  const SegmentationWorkerConfig& config() const { return config_; }
  std::uint32_t slots() const { return static_cast<std::uint32_t>(slots_.size()); }
  std::uint32_t slots_high_water() const { return slots_high_water_.load(); }
  const segmentation::Segmenter& segmenter() const { return *segmenter_; }
  // Called after every run with its CPU and wall microseconds (from the thread that ran it). Before init().
  using RunObserver = void (*)(void* user, std::int64_t cpu_us, std::int64_t wall_us);
  void set_run_observer(RunObserver observer, void* user) {
    observer_ = observer;
    observer_user_ = user;
  }

 private:
  enum State : int { kFree = 0, kQueued = 1, kWorking = 2, kLabelled = 3 };
  void thread_main();
  void segment_slot(std::size_t i);

  SegmentationWorkerConfig config_;
  std::unique_ptr<segmentation::Segmenter> segmenter_;
  std::vector<Slot> slots_;
  std::unique_ptr<std::atomic<int>[]> state_;
  std::uint64_t next_order_ = 0;          // loop thread only
  std::int64_t last_taken_ns_ = 0;        // data time of the last frame taken (loop thread only)
  bool have_taken_ = false;
  std::int64_t busy_until_ns_ = 0;        // lockstep_busy_from_cost: data time the modelled run ends
  RunObserver observer_ = nullptr;
  void* observer_user_ = nullptr;
  std::atomic<std::uint32_t> slots_high_water_{0};

  mutable std::mutex mutex_;  // guards counters_, the stats and the wake-up
  std::condition_variable wake_;
  mutable std::condition_variable finished_;  // a frame's run ended (wait_until_idle)
  SegmentationWorkerCounters counters_;
  runtime::TaskStats wall_;
  runtime::TaskStats cpu_;
  bool logged_failure_ = false;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace qsg::app
