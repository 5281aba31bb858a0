// Fault-injecting decorators: each scripted fault has exactly its documented effect and count; random faults are
// seeded and deterministic; steady-state reads do not allocate.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "drivers/sim/fault_plan.h"
#include "tests/drivers/sim/memory_sources.h"
#include "tests/support/allocation_counter.h"

namespace qsg::sim {
namespace {

using drivers::ReadStatus;
using testing::MemoryOdometrySource;
using testing::MemoryRgbdSource;

FaultPlan plan_from(const char* text) {
  FaultPlan plan;
  std::string error;
  EXPECT_TRUE(parse_fault_plan_text(text, "test", &plan, &error)) << error;
  return plan;
}

struct Rig {
  explicit Rig(const char* plan_text, std::uint64_t frames = 20)
      : inner(32, 24, frames), source(inner, plan_from(plan_text)), frame(std::make_unique<messages::RgbdFrame>()) {}
  ReadStatus read() { return source.read(*frame, 0); }
  MemoryRgbdSource inner;
  FaultInjectingRgbdSource source;
  std::unique_ptr<messages::RgbdFrame> frame;
};

TEST(FaultInjection, NoPlanPassesFramesThroughUntouched) {
  Rig rig("");
  for (std::uint64_t i = 0; i < 20; ++i) {
    ASSERT_EQ(rig.read(), ReadStatus::kOk);
    EXPECT_EQ(rig.frame->sequence, i);
    EXPECT_EQ(rig.frame->flags, 0u);
    EXPECT_EQ(rig.frame->publish_time_ns - rig.frame->sample_time_ns, 1'000'000);
  }
  EXPECT_EQ(rig.read(), ReadStatus::kEndOfStream);
  EXPECT_EQ(rig.read(), ReadStatus::kEndOfStream);
  EXPECT_EQ(rig.source.counters().delivered, 20u);
  EXPECT_EQ(rig.source.intrinsics().width, 32);
}

TEST(FaultInjection, DropSkipsTheFrameAndFlagsTheGap) {
  Rig rig("at 3 drop");
  for (std::uint64_t expected : {0, 1, 2, 4, 5}) {
    ASSERT_EQ(rig.read(), ReadStatus::kOk);
    EXPECT_EQ(rig.frame->sequence, expected);
    EXPECT_EQ((rig.frame->flags & messages::kFrameSequenceGap) != 0, expected == 4) << expected;
  }
  EXPECT_EQ(rig.source.counters().dropped, 1u);
  EXPECT_EQ(rig.source.injected()[static_cast<int>(FaultKind::kDrop)], 1u);
}

TEST(FaultInjection, StallReturnsTimeoutForNReadsThenTheFrame) {
  Rig rig("at 2 stall reads=3");
  const ReadStatus expected[] = {ReadStatus::kOk, ReadStatus::kOk, ReadStatus::kTimeout, ReadStatus::kTimeout,
                                 ReadStatus::kTimeout, ReadStatus::kOk};
  for (ReadStatus s : expected) EXPECT_EQ(rig.read(), s);
  EXPECT_EQ(rig.frame->sequence, 2u);  // no frame lost to the stall
  EXPECT_EQ(rig.frame->flags, 0u);
  EXPECT_EQ(rig.source.counters().stalls, 3u);
}

TEST(FaultInjection, LateDelaysThePublishTime) {
  Rig rig("at 1 late delay_ms=80");
  ASSERT_EQ(rig.read(), ReadStatus::kOk);
  ASSERT_EQ(rig.read(), ReadStatus::kOk);
  EXPECT_EQ(rig.frame->sequence, 1u);
  EXPECT_EQ(rig.frame->publish_time_ns - rig.frame->sample_time_ns, 1'000'000 + 80'000'000);
  EXPECT_TRUE(rig.frame->flags & messages::kFrameLate);
  ASSERT_EQ(rig.read(), ReadStatus::kOk);
  EXPECT_EQ(rig.frame->flags, 0u);
  EXPECT_EQ(rig.source.counters().late, 1u);
}

TEST(FaultInjection, BackwardsMovesTheSampleTimeBeforeThePreviousFrame) {
  Rig rig("at 2 backwards back_ms=5");
  ASSERT_EQ(rig.read(), ReadStatus::kOk);
  ASSERT_EQ(rig.read(), ReadStatus::kOk);
  const std::int64_t previous = rig.frame->sample_time_ns;
  ASSERT_EQ(rig.read(), ReadStatus::kOk);
  EXPECT_EQ(rig.frame->sample_time_ns, previous - 5'000'000);
  EXPECT_LE(rig.frame->sample_time_ns, rig.frame->publish_time_ns);
  EXPECT_TRUE(rig.frame->flags & messages::kFrameTimestampBackwards);
  EXPECT_EQ(rig.source.counters().timestamps_backwards, 1u);
}

TEST(FaultInjection, DepthRegionsAreFilledInsideTheRectOnly) {
  Rig rig("at 0 depth_nan rect=2,3,4,5\nat 1 depth_zero rect=30,20,10,10\nat 2 depth_saturated rect=0,0,1,1");
  ASSERT_EQ(rig.read(), ReadStatus::kOk);
  const messages::RgbdFrame& f = *rig.frame;
  int nan = 0;
  for (int v = 0; v < 24; ++v) {
    for (int u = 0; u < 32; ++u) {
      const bool inside = u >= 2 && u < 6 && v >= 3 && v < 8;
      const float d = f.depth_m[v * 32 + u];
      if (inside) {
        EXPECT_TRUE(std::isnan(d)) << u << "," << v;
      } else {
        EXPECT_EQ(d, 1.0f) << u << "," << v;
      }
      nan += std::isnan(d) ? 1 : 0;
    }
  }
  EXPECT_EQ(nan, 20);
  EXPECT_TRUE(f.flags & messages::kFrameInvalidDepthRegion);
  ASSERT_EQ(rig.read(), ReadStatus::kOk);  // rect clipped at the frame's corner: 2 x 4 pixels
  int zero = 0;
  for (int i = 0; i < f.pixels(); ++i) zero += f.depth_m[i] == 0.0f ? 1 : 0;
  EXPECT_EQ(zero, 2 * 4);
  EXPECT_EQ(f.depth_m[23 * 32 + 31], 0.0f);
  ASSERT_EQ(rig.read(), ReadStatus::kOk);
  EXPECT_EQ(f.depth_m[0], 65535.0f * 0.001f);
  EXPECT_EQ(f.depth_m[1], 1.002f);
  EXPECT_EQ(rig.source.counters().invalid_depth_frames, 3u);
}

TEST(FaultInjection, WrongSizeIsABadFrameAndTheNextFrameShowsTheGap) {
  Rig rig("at 2 wrong_size");
  EXPECT_EQ(rig.read(), ReadStatus::kOk);
  EXPECT_EQ(rig.read(), ReadStatus::kOk);
  EXPECT_EQ(rig.read(), ReadStatus::kBadFrame);
  ASSERT_EQ(rig.read(), ReadStatus::kOk);
  EXPECT_EQ(rig.frame->sequence, 3u);
  EXPECT_TRUE(rig.frame->flags & messages::kFrameSequenceGap);
  EXPECT_EQ(rig.source.counters().bad_frames, 1u);
}

TEST(FaultInjection, UnplugDisconnectsForNReadsThenFlagsTheReconnect) {
  Rig rig("at 2 unplug reads=4");
  EXPECT_EQ(rig.read(), ReadStatus::kOk);
  EXPECT_EQ(rig.read(), ReadStatus::kOk);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(rig.read(), ReadStatus::kDisconnected) << i;
  EXPECT_EQ(rig.source.counters().disconnects, 1u);
  EXPECT_EQ(rig.source.counters().reconnects, 0u);
  ASSERT_EQ(rig.read(), ReadStatus::kOk);
  EXPECT_EQ(rig.frame->sequence, 2u);
  EXPECT_EQ(rig.frame->flags, static_cast<std::uint32_t>(messages::kFrameAfterReconnect));
  ASSERT_EQ(rig.read(), ReadStatus::kOk);
  EXPECT_EQ(rig.frame->flags, 0u);
  EXPECT_EQ(rig.source.counters().reconnects, 1u);
}

TEST(FaultInjection, SeveralFaultsOnOneFrameCombine) {
  Rig rig("at 1 late delay_ms=10\nat 1 depth_zero rect=0,0,2,2\nat 1 stall reads=1");
  EXPECT_EQ(rig.read(), ReadStatus::kOk);
  EXPECT_EQ(rig.read(), ReadStatus::kTimeout);
  ASSERT_EQ(rig.read(), ReadStatus::kOk);
  EXPECT_EQ(rig.frame->flags, static_cast<std::uint32_t>(messages::kFrameLate | messages::kFrameInvalidDepthRegion));
}

TEST(FaultInjection, InnerCountersAreFoldedIn) {
  Rig rig("at 1 drop");
  rig.inner.mutable_counters().missing_files = 2;
  rig.inner.mutable_counters().dropped = 5;
  ASSERT_EQ(rig.read(), ReadStatus::kOk);
  ASSERT_EQ(rig.read(), ReadStatus::kOk);
  EXPECT_EQ(rig.source.counters().missing_files, 2u);
  EXPECT_EQ(rig.source.counters().dropped, 6u);
  EXPECT_EQ(rig.source.counters().delivered, 2u);
}

TEST(FaultInjection, FaultsOnADroppedFrameAreLostWithIt) {
  Rig rig("at 2 drop\nat 2 late delay_ms=1");
  for (std::uint64_t expected : {0, 1, 3, 4}) {
    ASSERT_EQ(rig.read(), ReadStatus::kOk);
    EXPECT_EQ(rig.frame->sequence, expected);
    EXPECT_EQ(rig.frame->flags & messages::kFrameLate, 0u);
  }
  EXPECT_EQ(rig.source.counters().late, 0u);
  EXPECT_EQ(rig.source.injected()[static_cast<int>(FaultKind::kLate)], 1u);  // fired, without effect
}

TEST(FaultInjection, EventsForSequencesTheInnerSkippedHitTheNextFrame) {
  // The inner decorator drops frames 5 and 6, so the outer one never sees them: its late event for 5 lands on
  // frame 7 and its stall for 6 on the read after frame 7 (the first read that finds next-expected >= 6).
  MemoryRgbdSource memory(32, 24, 20);
  FaultInjectingRgbdSource inner(memory, plan_from("at 5 drop\nat 6 drop"));
  FaultInjectingRgbdSource outer(inner, plan_from("at 5 late delay_ms=2\nat 6 stall reads=1"));
  auto frame = std::make_unique<messages::RgbdFrame>();
  for (std::uint64_t expected : {0, 1, 2, 3, 4}) {
    ASSERT_EQ(outer.read(*frame, 0), ReadStatus::kOk);
    EXPECT_EQ(frame->sequence, expected);
  }
  ASSERT_EQ(outer.read(*frame, 0), ReadStatus::kOk);  // 5 and 6 dropped inside: frame 7 takes the late event
  EXPECT_EQ(frame->sequence, 7u);
  EXPECT_EQ(frame->flags, static_cast<std::uint32_t>(messages::kFrameLate | messages::kFrameSequenceGap));
  EXPECT_EQ(outer.read(*frame, 0), ReadStatus::kTimeout);  // the stall for 6 fires before the next frame
  ASSERT_EQ(outer.read(*frame, 0), ReadStatus::kOk);
  EXPECT_EQ(frame->sequence, 8u);
  EXPECT_EQ(outer.counters().dropped, 2u);  // the inner decorator's drops, folded in
}

TEST(FaultInjection, RandomFaultsAreSeededAndNearTheirRates) {
  const char* plan = "seed 7\nrate drop 0.1\nrate late 0.2\nrate stall 0.05\nrate depth_nan 0.1\nrandom region=4x4";
  Rig a(plan, 2000);
  Rig b(plan, 2000);
  std::vector<std::uint32_t> flags_a;
  int timeouts = 0;
  for (;;) {
    const ReadStatus sa = a.read();
    const ReadStatus sb = b.read();
    ASSERT_EQ(sa, sb);
    if (sa == ReadStatus::kEndOfStream) break;
    if (sa == ReadStatus::kTimeout) ++timeouts;
    if (sa != ReadStatus::kOk) continue;
    ASSERT_EQ(a.frame->sequence, b.frame->sequence);
    ASSERT_EQ(a.frame->flags, b.frame->flags);
    flags_a.push_back(a.frame->flags);
  }
  const drivers::DriverCounters& c = a.source.counters();
  EXPECT_EQ(c.delivered + c.dropped, 2000u);
  EXPECT_NEAR(static_cast<double>(c.dropped), 200.0, 60.0);
  EXPECT_NEAR(static_cast<double>(c.late), 0.2 * c.delivered, 0.2 * c.delivered * 0.25);
  EXPECT_NEAR(static_cast<double>(c.invalid_depth_frames), 0.1 * c.delivered, 0.1 * c.delivered * 0.35);
  EXPECT_EQ(static_cast<int>(c.stalls), timeouts);
  EXPECT_EQ(c.stalls % 3, 0u);  // default stall_reads
  EXPECT_GT(c.stalls, 0u);

  Rig other("seed 8\nrate drop 0.1\nrate late 0.2\nrate stall 0.05\nrate depth_nan 0.1\nrandom region=4x4", 2000);
  while (other.read() != ReadStatus::kEndOfStream) {
  }
  EXPECT_NE(other.source.counters().late, c.late) << "a different seed should give a different fault sequence";
}

TEST(FaultInjection, DropRateOfOneTimesOutInsteadOfSpinning) {
  Rig rig("rate drop 1", 1'000'000);
  EXPECT_EQ(rig.read(), ReadStatus::kTimeout);
  EXPECT_EQ(rig.source.counters().stalls, 1u);
  EXPECT_GT(rig.source.counters().dropped, 0u);
}

TEST(FaultInjection, SteadyStateReadsDoNotAllocate) {
  Rig rig(
      "seed 3\nrate drop 0.05\nrate stall 0.05\nrate late 0.05\nrate backwards 0.05\nrate depth_nan 0.05\n"
      "rate depth_zero 0.05\nrate depth_saturated 0.05\nrate wrong_size 0.05\nrate unplug 0.02\n"
      "at 5 drop\nat 6 stall reads=2\nat 7 late\nat 8 backwards\nat 9 depth_nan rect=0,0,4,4\nat 10 wrong_size\n"
      "at 11 unplug reads=2\nrate dropout 0.01\nrandom dropout_samples=3\nat 12 dropout samples=2",
      400);
  int ok = 0;
  EXPECT_NO_ALLOCATIONS(for (int i = 0; i < 600; ++i) ok += rig.read() == ReadStatus::kOk ? 1 : 0);
  EXPECT_GT(ok, 150);
  for (int k = 0; k < kNumFaultKinds; ++k) {
    if (static_cast<FaultKind>(k) == FaultKind::kPoseJump) continue;  // odometry only, scripted only
    EXPECT_GT(rig.source.injected()[k], 0u) << to_string(static_cast<FaultKind>(k));
  }
}

TEST(FaultInjection, DropoutLosesConsecutiveFramesAndTheFaultEndsAtTheNextCleanOne) {
  Rig rig("at 4 dropout samples=3");
  std::vector<std::uint64_t> sequences;
  while (rig.read() == ReadStatus::kOk) {
    sequences.push_back(rig.frame->sequence);
    if (rig.frame->sequence == 7) {
      EXPECT_TRUE((rig.frame->flags & messages::kFrameSequenceGap) != 0);
      EXPECT_EQ(rig.source.injector().faults_ended(), 1u);
      EXPECT_EQ(rig.source.injector().last_fault_end_ns(), rig.frame->sample_time_ns);
    } else if (rig.frame->sequence < 4) {
      EXPECT_EQ(rig.source.injector().faults_ended(), 0u);
    }
  }
  EXPECT_EQ(sequences, (std::vector<std::uint64_t>{0, 1, 2, 3, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19}));
  EXPECT_EQ(rig.source.counters().dropped, 3u);
  EXPECT_EQ(rig.source.injected()[static_cast<int>(FaultKind::kDropout)], 1u);
  EXPECT_FALSE(rig.source.injector().fault_open());
}

TEST(FaultInjection, RandomFaultsFireOnlyInsideTheirWindow) {
  Rig rig("seed 5\nrate drop 0.5\nrandom from=5 until=10", 20);
  std::vector<std::uint64_t> sequences;
  while (rig.read() == ReadStatus::kOk) sequences.push_back(rig.frame->sequence);
  for (std::uint64_t s = 0; s < 20; ++s) {
    const bool delivered = std::find(sequences.begin(), sequences.end(), s) != sequences.end();
    if (s < 5 || s >= 10) {
      EXPECT_TRUE(delivered) << s;
    }
  }
  EXPECT_GT(rig.source.counters().dropped, 0u);
  EXPECT_EQ(rig.source.counters().delivered + rig.source.counters().dropped, 20u);
  // The fault ends with the first clean frame after the window's last drop.
  EXPECT_EQ(rig.source.injector().faults_ended() > 0, true);
  EXPECT_LE(rig.source.injector().last_fault_end_ns(), static_cast<std::int64_t>(10) * 33'333'333);
}

TEST(OdometryFaultInjection, PoseJumpShiftsItsSamplesOnlyAndIsIgnoredOnFrames) {
  MemoryOdometrySource inner(10);
  FaultInjectingOdometrySource source(inner, plan_from("at 3 pose_jump offset_m=5,-1,0.5 samples=2"));
  messages::OdometrySample s;
  for (std::uint64_t i = 0; i < 10; ++i) {
    ASSERT_EQ(source.read(s, 0), ReadStatus::kOk);
    const bool jumped = i == 3 || i == 4;
    const Eigen::Vector3d expected(0.1 * static_cast<double>(i) + (jumped ? 5.0 : 0.0), jumped ? -1.0 : 0.0,
                                   jumped ? 0.5 : 0.0);
    EXPECT_LT((s.world_t_body_m - expected).norm(), 1e-12) << i;
  }
  EXPECT_EQ(source.injected()[static_cast<int>(FaultKind::kPoseJump)], 1u);
  EXPECT_EQ(source.injector().faults_ended(), 1u);
  EXPECT_EQ(source.injector().last_fault_end_ns(), 5 * 10'000'000);

  Rig rig("at 3 pose_jump offset_m=5,0,0");
  while (rig.read() == ReadStatus::kOk) EXPECT_EQ(rig.frame->flags, 0u);
  EXPECT_EQ(rig.source.counters().delivered, 20u);
  EXPECT_EQ(rig.source.injector().faults_ended(), 0u);
}

TEST(OdometryFaultInjection, SameFaultsOnSamplesAndDepthFaultsIgnored) {
  MemoryOdometrySource inner(20);
  FaultInjectingOdometrySource source(
      inner, plan_from("at 1 drop\nat 2 late delay_ms=3\nat 3 depth_nan rect=0,0,1,1\nat 4 unplug reads=2\n"
                       "at 5 wrong_size\nat 7 backwards back_ms=1"));
  messages::OdometrySample s;
  std::vector<ReadStatus> statuses;
  std::vector<std::uint64_t> sequences;
  std::vector<std::uint32_t> flags;
  statuses.reserve(16);
  sequences.reserve(16);
  flags.reserve(16);
  EXPECT_NO_ALLOCATIONS(for (int i = 0; i < 12; ++i) {
    const ReadStatus st = source.read(s, 0);
    statuses.push_back(st);
    if (st == ReadStatus::kOk) {
      sequences.push_back(s.sequence);
      flags.push_back(s.flags);
    }
  });
  const std::vector<ReadStatus> expected = {ReadStatus::kOk, ReadStatus::kOk, ReadStatus::kOk,
                                            ReadStatus::kDisconnected, ReadStatus::kDisconnected, ReadStatus::kOk,
                                            ReadStatus::kBadFrame, ReadStatus::kOk, ReadStatus::kOk,
                                            ReadStatus::kOk, ReadStatus::kOk, ReadStatus::kOk};
  EXPECT_EQ(statuses, expected);
  EXPECT_EQ(sequences, (std::vector<std::uint64_t>{0, 2, 3, 4, 6, 7, 8, 9, 10}));
  EXPECT_EQ(flags[1], static_cast<std::uint32_t>(messages::kFrameSequenceGap | messages::kFrameLate));
  EXPECT_EQ(flags[2], 0u);  // depth fault ignored on odometry
  EXPECT_EQ(flags[3], static_cast<std::uint32_t>(messages::kFrameAfterReconnect));
  EXPECT_EQ(flags[4], static_cast<std::uint32_t>(messages::kFrameSequenceGap));
  EXPECT_EQ(flags[5], static_cast<std::uint32_t>(messages::kFrameTimestampBackwards));
  const drivers::DriverCounters& c = source.counters();
  EXPECT_EQ(c.dropped, 1u);
  EXPECT_EQ(c.late, 1u);
  EXPECT_EQ(c.invalid_depth_frames, 0u);
  EXPECT_EQ(c.disconnects, 1u);
  EXPECT_EQ(c.reconnects, 1u);
  EXPECT_EQ(c.bad_frames, 1u);
  EXPECT_EQ(c.timestamps_backwards, 1u);
  EXPECT_EQ(c.delivered, 9u);
}

}  // namespace
}  // namespace qsg::sim
