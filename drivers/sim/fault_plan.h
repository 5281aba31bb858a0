// Scripted and random faults for simulated sources: a plan (events by frame sequence number plus seeded random
// rates), its text/JSON file formats, and decorators that inject it into any RgbdSource or OdometrySource.
//
// Plan text format (one directive per line, '#' comments):
//   seed 42
//   rate drop 0.01                      # probability per frame of a fault kind (stall/unplug: per frame slot)
//   random stall_reads=3 unplug_reads=10 delay_ms=50 back_ms=10 region=32x24   # sizes of random faults
//   at 10 drop
//   at 12 stall reads=3                 # 3 reads return kTimeout before frame 12 is delivered
//   at 15 late delay_ms=80              # publish time of frame 15 delayed by 80 ms (kFrameLate)
//   at 20 backwards back_ms=5           # sample time 5 ms before the previous frame's (kFrameTimestampBackwards)
//   at 25 depth_nan rect=10,20,40,30    # x,y,width,height in pixels; also depth_zero, depth_saturated
//   at 30 wrong_size                    # the read returns kBadFrame, the frame is discarded
//   at 40 unplug reads=5                # 5 reads return kDisconnected, the next frame has kFrameAfterReconnect
//   at 50 dropout samples=20            # 20 consecutive messages lost from 50 on (an odometry or camera dropout)
//   at 60 pose_jump offset_m=2,0,0 samples=3   # odometry: 3 samples from 60 on shifted by (2, 0, 0) m
//   random from=100 until=400           # random faults only for messages 100..399 (default: always)
// JSON: {"seed": 42, "rates": {"drop": 0.01}, "random": {"stall_reads": 3, "region": [32, 24], "from": 100},
//        "events": [{"at": 12, "fault": "stall", "reads": 3},
//                   {"at": 25, "fault": "depth_nan", "rect": [10, 20, 40, 30]},
//                   {"at": 60, "fault": "pose_jump", "offset_m": [2, 0, 0], "samples": 3}]}
// pose_jump has no random rate (a jump needs an offset); dropout's random length is random.dropout_samples.
//
// Events are keyed by the inner source's frame sequence number (simulated sources and replays count from 0): a
// frame fault (drop, late, backwards, depth, wrong_size) hits the first inner frame whose sequence is >= the
// event's; a read fault (stall, unplug) starts on the read that would deliver that frame (the one after the frame
// with sequence - 1). While stalled or unplugged the inner source is not read, so no frame is lost to a stall or an
// unplug.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "drivers/sources.h"

namespace qsg::sim {

enum class FaultKind : std::uint8_t {
  kDrop,
  kStall,
  kLate,
  kTimestampBackwards,
  kDepthNan,
  kDepthZero,
  kDepthSaturated,
  kWrongSize,
  kUnplug,
  kDropout,   // `samples` consecutive messages lost
  kPoseJump,  // odometry: `samples` consecutive poses shifted by `offset_m` (ignored on frames)
};
inline constexpr int kNumFaultKinds = 11;
// Name used in plan files: drop, stall, late, backwards, depth_nan, depth_zero, depth_saturated, wrong_size, unplug,
// dropout, pose_jump.
const char* to_string(FaultKind kind);
bool fault_kind_from_string(const std::string& name, FaultKind* kind);

struct PixelRect {
  int x_px = 0;
  int y_px = 0;
  int width_px = 0;
  int height_px = 0;
};

struct FaultEvent {
  std::uint64_t sequence = 0;
  FaultKind kind = FaultKind::kDrop;
  int reads = 1;                       // stall: reads returning kTimeout; unplug: reads returning kDisconnected
  std::int64_t delay_ns = 50'000'000;  // late: added to the publish time
  std::int64_t back_ns = 10'000'000;   // backwards: sample time this far before the previous delivered frame's
  PixelRect rect;                      // depth_nan / depth_zero / depth_saturated (clipped to the frame)
  int samples = 1;                     // dropout, pose_jump: how many consecutive messages
  double offset_m[3] = {0.0, 0.0, 0.0};  // pose_jump: added to world_t_body
  int line_number = 0;                 // where the plan file declared it (0: built in code)
};

// Seeded random faults: each kind fires with its probability per frame, independently.
struct FaultRandom {
  std::uint64_t seed = 1;
  std::array<double, kNumFaultKinds> rate{};  // indexed by FaultKind; 0 = never
  int stall_reads = 3;
  int unplug_reads = 10;
  std::int64_t delay_ns = 50'000'000;
  std::int64_t back_ns = 10'000'000;
  int region_width_px = 32;
  int region_height_px = 32;
  int dropout_samples = 10;
  // Random faults fire only on messages whose sequence is in [from, until) (a transient fault's window).
  std::uint64_t from = 0;
  std::uint64_t until = std::numeric_limits<std::uint64_t>::max();
};

struct FaultPlan {
  std::vector<FaultEvent> events;  // any order; the decorators sort them
  FaultRandom random;
  bool has_random_faults() const;
  void print(std::FILE* out) const;
};

// Parsers; errors name `origin` (the file) and the line (text) or the field path (JSON, e.g. events[2].reads).
bool parse_fault_plan_text(const std::string& text, const std::string& origin, FaultPlan* plan, std::string* error);
bool parse_fault_plan_json(const std::string& text, const std::string& origin, FaultPlan* plan, std::string* error);
// Reads a plan file: JSON when the name ends in .json, the text format otherwise.
bool load_fault_plan(const std::string& path, FaultPlan* plan, std::string* error);

// Faults fired per kind, next to the decorator's DriverCounters (which also fold in the inner source's). A fault
// that hits a frame which is also dropped or discarded fires (and is tallied) without effect.
using FaultTally = std::array<std::uint64_t, kNumFaultKinds>;

// The plan's clock: decides, read by read, which faults fire. Shared by the decorators; no allocation after
// construction.
class FaultScheduler {
 public:
  struct FrameFaults {
    bool drop = false;
    bool wrong_size = false;
    std::int64_t late_ns = 0;   // > 0: delay the publish time
    std::int64_t back_ns = 0;   // > 0: move the sample time back
    bool depth = false;
    FaultKind depth_kind = FaultKind::kDepthNan;
    PixelRect rect;
    bool jump = false;
    double jump_m[3] = {0.0, 0.0, 0.0};
    bool any() const { return drop || wrong_size || late_ns > 0 || back_ns > 0 || depth || jump; }
  };

  explicit FaultScheduler(const FaultPlan& plan);
  // Called at the start of every read: kTimeout or kDisconnected when a stall or unplug is in progress (the read
  // must return it without reading the inner source), kOk to go on and read a frame.
  drivers::ReadStatus before_read();
  // Called for each frame the inner source delivered; depth faults only when has_depth (width/height place
  // random depth regions).
  FrameFaults on_frame(std::uint64_t sequence, bool has_depth, int width_px, int height_px);
  // True once for the first frame after an unplug ended.
  bool take_reconnect();
  const FaultTally& tally() const { return tally_; }
  std::uint64_t disconnects() const { return disconnects_; }

 private:
  double uniform();
  bool fires(FaultKind kind);
  bool in_window(std::uint64_t sequence) const { return sequence >= random_.from && sequence < random_.until; }

  std::vector<FaultEvent> read_events_;   // stall, unplug; sorted by sequence
  std::vector<FaultEvent> frame_events_;  // the rest; sorted by sequence
  std::size_t read_cursor_ = 0;
  std::size_t frame_cursor_ = 0;
  FaultRandom random_;
  bool random_enabled_ = false;
  std::uint64_t rng_state_ = 0;
  std::uint64_t next_expected_ = 0;  // sequence the next inner frame should carry
  bool slot_drawn_ = false;          // random read faults drawn for the current frame slot
  int pending_timeouts_ = 0;
  int pending_disconnects_ = 0;
  bool reconnect_pending_ = false;
  int pending_dropout_ = 0;     // messages a dropout still drops
  int pending_jump_ = 0;        // poses a jump still shifts, by jump_m_
  double jump_m_[3] = {0.0, 0.0, 0.0};
  std::uint64_t disconnects_ = 0;
  FaultTally tally_{};
};

// The state and read loop both decorators share: stalls and unplugs before a read, then drops, wrong sizes, late
// and backwards times, sequence gaps and reconnect flags on what the inner source delivered.
class FaultInjector {
 public:
  explicit FaultInjector(const FaultPlan& plan) : scheduler_(plan) {}
  // Reads `message` from `inner` with the plan's faults. `apply_extra(message, faults, own_counters)` applies what
  // only one message kind has (depth regions on frames). Defined in fault_plan.cc, for the two decorators.
  template <typename Source, typename Message, typename Extra>
  drivers::ReadStatus read(Source& inner, Message& message, std::int64_t timeout_ns, Extra&& apply_extra);
  const drivers::DriverCounters& counters() const { return counters_; }
  const FaultTally& tally() const { return scheduler_.tally(); }
  // A fault is open from the first read or message it hits until the next message delivered clean; then it has
  // ended, at that message's sample time (the data clock). Recovery is measured from there.
  std::uint64_t faults_ended() const { return faults_ended_; }
  std::int64_t last_fault_end_ns() const { return last_fault_end_ns_; }
  bool fault_open() const { return fault_open_; }
  // Folds the inner source's counts in (also before the first read).
  void refresh(const drivers::DriverCounters& inner);

 private:
  drivers::ReadStatus finish(drivers::ReadStatus status, const drivers::DriverCounters& inner);

  FaultScheduler scheduler_;
  drivers::DriverCounters own_;       // faults injected here, and delivered
  drivers::DriverCounters counters_;  // own_ + the inner source's fault counts
  bool have_last_ = false;
  bool gap_pending_ = false;
  bool fault_open_ = false;
  std::uint64_t faults_ended_ = 0;
  std::int64_t last_fault_end_ns_ = 0;
  std::uint64_t last_sequence_ = 0;
  std::int64_t last_sample_time_ns_ = 0;
};

// Decorators: same interface as the inner source, faults injected per the plan, every fault counted in
// counters() (the inner source's counts folded in; delivered = frames this decorator delivered) and per kind in
// injected(). A drop skips the frame and the read goes on to the next one; the next delivered frame carries
// kFrameSequenceGap. Depth faults on odometry plans are ignored by the odometry decorator.
class FaultInjectingRgbdSource : public drivers::RgbdSource {
 public:
  FaultInjectingRgbdSource(drivers::RgbdSource& inner, const FaultPlan& plan);
  const char* name() const override { return "fault_injecting_rgbd"; }
  messages::CameraIntrinsics intrinsics() const override { return inner_.intrinsics(); }
  drivers::ReadStatus read(messages::RgbdFrame& frame, std::int64_t timeout_ns) override;
  const drivers::DriverCounters& counters() const override { return injector_.counters(); }
  const FaultTally& injected() const { return injector_.tally(); }
  const FaultInjector& injector() const { return injector_; }
  const char* inner_name() const { return inner_.name(); }

 private:
  drivers::RgbdSource& inner_;
  FaultInjector injector_;
};

class FaultInjectingOdometrySource : public drivers::OdometrySource {
 public:
  FaultInjectingOdometrySource(drivers::OdometrySource& inner, const FaultPlan& plan);
  const char* name() const override { return "fault_injecting_odometry"; }
  drivers::ReadStatus read(messages::OdometrySample& sample, std::int64_t timeout_ns) override;
  const drivers::DriverCounters& counters() const override { return injector_.counters(); }
  const FaultTally& injected() const { return injector_.tally(); }
  const FaultInjector& injector() const { return injector_; }
  const char* inner_name() const { return inner_.name(); }

 private:
  drivers::OdometrySource& inner_;
  FaultInjector injector_;
};

}  // namespace qsg::sim
