// The pose buffer: SE(3) interpolation, every rejection kind counted, gaps not bridged, the ring's bound, and no
// allocation after init.
#include "firmware_app/runtime/pose_buffer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "tests/support/allocation_counter.h"

namespace qsg::runtime {
namespace {

constexpr std::int64_t kMs = 1'000'000;

messages::OdometrySample sample(std::uint64_t seq, std::int64_t t_ns, const Eigen::Vector3d& p,
                               double yaw_rad = 0.0) {
  messages::OdometrySample s;
  s.sequence = seq;
  s.sample_time_ns = t_ns;
  s.world_t_body_m = p;
  s.world_R_body = Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()));
  return s;
}

PoseBuffer make(std::uint32_t capacity = 16, PoseBufferConfig c = {}) {
  PoseBuffer b;
  std::string error;
  EXPECT_TRUE(b.init(capacity, c, &error)) << error;
  return b;
}

TEST(PoseBufferTest, InterpolatesOnSe3BetweenTheSamplesAroundATime) {
  PoseBuffer b = make();
  ASSERT_EQ(b.push(sample(0, 0, {0, 0, 0}, 0.0)), PoseSampleResult::kAccepted);
  ASSERT_EQ(b.push(sample(1, 400 * kMs, {1, 1, 0}, M_PI / 2)), PoseSampleResult::kAccepted);
  Eigen::Isometry3d T;
  ASSERT_EQ(b.lookup(200 * kMs, &T), PoseLookup::kOk);
  // Halfway along a constant twist: yaw 45 degrees; a quarter turn from (0,0) to (1,1) is an arc of a circle of
  // radius 1 about (0,1) (the screw's axis), whose midpoint is (sin 45, 1 - cos 45).
  EXPECT_NEAR(Eigen::AngleAxisd(T.linear()).angle(), M_PI / 4, 1e-12);
  EXPECT_NEAR(T.translation().x(), std::sin(M_PI / 4), 1e-12);
  EXPECT_NEAR(T.translation().y(), 1.0 - std::cos(M_PI / 4), 1e-12);
  // At the samples themselves: exact.
  ASSERT_EQ(b.lookup(400 * kMs, &T), PoseLookup::kOk);
  EXPECT_NEAR((T.translation() - Eigen::Vector3d(1, 1, 0)).norm(), 0.0, 1e-15);
}

TEST(PoseBufferTest, Se3InterpolationOfAPureTranslationIsLinearAndEndsMatch) {
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity(), b = Eigen::Isometry3d::Identity();
  a.translation() = Eigen::Vector3d(1, 2, 3);
  b.translation() = Eigen::Vector3d(3, 2, 1);
  EXPECT_NEAR((interpolate_se3(a, b, 0.25).translation() - Eigen::Vector3d(1.5, 2, 2.5)).norm(), 0.0, 1e-12);
  b.linear() = Eigen::AngleAxisd(2.0, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  EXPECT_TRUE(interpolate_se3(a, b, 0.0).isApprox(a, 1e-12));
  EXPECT_TRUE(interpolate_se3(a, b, 1.0).isApprox(b, 1e-12));
}

TEST(PoseBufferTest, LookupSaysWhyThereIsNoPose) {
  PoseBufferConfig c;
  c.max_gap_s = 0.2;
  PoseBuffer b = make(16, c);
  Eigen::Isometry3d T;
  EXPECT_EQ(b.lookup(0, &T), PoseLookup::kEmpty);
  b.push(sample(0, 1000 * kMs, {0, 0, 0}));
  b.push(sample(1, 1100 * kMs, {0.1, 0, 0}));
  b.push(sample(2, 1500 * kMs, {0.2, 0, 0}));  // 0.4 s later: a gap
  EXPECT_EQ(b.counters().gaps, 1u);
  EXPECT_EQ(b.lookup(999 * kMs, &T), PoseLookup::kTooOld);
  EXPECT_EQ(b.lookup(1501 * kMs, &T), PoseLookup::kNotYet);
  EXPECT_EQ(b.lookup(1300 * kMs, &T), PoseLookup::kInGap);
  EXPECT_EQ(b.lookup(1050 * kMs, &T), PoseLookup::kOk);
}

TEST(PoseBufferTest, RejectsAndCountsEveryKindOfBadSample) {
  PoseBuffer b = make();
  ASSERT_EQ(b.push(sample(10, 100 * kMs, {0, 0, 0})), PoseSampleResult::kAccepted);
  messages::OdometrySample s = sample(11, 110 * kMs, {std::numeric_limits<double>::quiet_NaN(), 0, 0});
  EXPECT_EQ(b.push(s), PoseSampleResult::kNonFinite);
  s = sample(11, 110 * kMs, {0, 0, 0});
  s.covariance(2, 2) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(b.push(s), PoseSampleResult::kNonFinite);
  s = sample(11, 110 * kMs, {0, 0, 0});
  s.world_R_body.coeffs() *= 1.01;
  EXPECT_EQ(b.push(s), PoseSampleResult::kBadQuaternion);
  EXPECT_EQ(b.push(sample(11, 90 * kMs, {0, 0, 0})), PoseSampleResult::kOutOfOrder);
  EXPECT_EQ(b.push(sample(11, 100 * kMs, {0, 0, 0})), PoseSampleResult::kDuplicate);   // same time
  EXPECT_EQ(b.push(sample(10, 120 * kMs, {0, 0, 0})), PoseSampleResult::kDuplicate);   // same sequence
  EXPECT_EQ(b.push(sample(11, 110 * kMs, {5, 0, 0})), PoseSampleResult::kPoseJump);    // 5 m in 10 ms
  // A slightly off-unit quaternion is normalised, not refused.
  s = sample(11, 110 * kMs, {0.01, 0, 0});
  s.world_R_body.coeffs() *= 1.0005;
  EXPECT_EQ(b.push(s), PoseSampleResult::kAccepted);
  EXPECT_NEAR(b.newest().q.norm(), 1.0, 1e-15);
  const PoseBufferCounters& k = b.counters();
  EXPECT_EQ(k.non_finite, 2u);
  EXPECT_EQ(k.bad_quaternion, 1u);
  EXPECT_EQ(k.out_of_order, 1u);
  EXPECT_EQ(k.duplicates, 2u);
  EXPECT_EQ(k.pose_jumps, 1u);
  EXPECT_EQ(k.accepted, 2u);
  EXPECT_EQ(b.stats().failed, k.rejected());
}

TEST(PoseBufferTest, ATimeJumpIsHeldUntilTheNextSampleConfirmsIt) {
  PoseBuffer b = make();
  b.push(sample(0, 0, {0, 0, 0}));
  b.push(sample(1, 100 * kMs, {0, 0, 0}));
  // 60 s later, alone, then the stream continues where it was: a clock fault, rejected.
  EXPECT_EQ(b.push(sample(2, 60000 * kMs, {0, 0, 0})), PoseSampleResult::kHeld);
  EXPECT_EQ(b.push(sample(3, 200 * kMs, {0, 0, 0})), PoseSampleResult::kAccepted);
  EXPECT_EQ(b.counters().time_jumps, 1u);
  EXPECT_EQ(b.size(), 3u);
  // The source was silent for 60 s and came back: the next sample confirms the new time.
  EXPECT_EQ(b.push(sample(4, 60300 * kMs, {1, 0, 0})), PoseSampleResult::kHeld);
  EXPECT_EQ(b.push(sample(5, 60400 * kMs, {1.1, 0, 0})), PoseSampleResult::kAccepted);
  EXPECT_EQ(b.counters().resyncs, 1u);
  EXPECT_EQ(b.counters().gaps, 1u);
  EXPECT_EQ(b.size(), 5u);
  Eigen::Isometry3d T;
  EXPECT_EQ(b.lookup(30000 * kMs, &T), PoseLookup::kInGap);
}

// A lone corrupt sample is a jump and nothing more; a source that steps 1.5 m and stays there (a VIO relocalizing)
// is accepted once time makes its speed plausible, and that acceptance is counted as a step, not passed silently.
TEST(PoseBufferTest, AStepTheSourceKeepsIsCountedWhenItIsAccepted) {
  PoseBuffer b = make();  // max_speed_m_per_s 10
  for (int i = 0; i < 5; ++i) ASSERT_EQ(b.push(sample(i, i * 10 * kMs, {0.01 * i, 0, 0})), PoseSampleResult::kAccepted);
  // A glitch: one sample 2 m off, then the stream where it was.
  EXPECT_EQ(b.push(sample(5, 50 * kMs, {2.05, 0, 0})), PoseSampleResult::kPoseJump);
  EXPECT_EQ(b.push(sample(6, 60 * kMs, {0.06, 0, 0})), PoseSampleResult::kAccepted);
  EXPECT_EQ(b.counters().steps, 0u);
  // A step: from 70 ms on, the source reports 1.5 m further and stays. Refused while 1.5 m in under 0.15 s is over
  // 10 m/s, then accepted, and counted.
  int refused = 0;
  for (int i = 7; i < 40; ++i) {
    const PoseSampleResult r = b.push(sample(i, i * 10 * kMs, {1.5 + 0.01 * i, 0, 0}));
    if (r == PoseSampleResult::kPoseJump) ++refused;
    else ASSERT_EQ(r, PoseSampleResult::kAccepted);
  }
  EXPECT_GT(refused, 5);
  EXPECT_EQ(b.counters().steps, 1u);
  EXPECT_EQ(b.counters().pose_jumps, 1u + static_cast<std::uint64_t>(refused));
  EXPECT_NEAR(b.newest().t_m.x(), 1.89, 1e-9);
}

TEST(PoseBufferTest, TheRingKeepsTheNewestSamplesAndNeverAllocatesAfterInit) {
  PoseBuffer b = make(8);
  EXPECT_NO_ALLOCATIONS({
    for (int i = 0; i < 100; ++i) b.push(sample(static_cast<std::uint64_t>(i), i * 10 * kMs, {0.01 * i, 0, 0}));
    Eigen::Isometry3d T;
    EXPECT_EQ(b.lookup(955 * kMs, &T), PoseLookup::kOk);
    EXPECT_NEAR(T.translation().x(), 0.955, 1e-12);
    EXPECT_EQ(b.lookup(910 * kMs, &T), PoseLookup::kTooOld);
  });
  EXPECT_EQ(b.size(), 8u);
  EXPECT_EQ(b.counters().overwritten, 92u);
  EXPECT_EQ(b.stats().high_water, 8u);
  EXPECT_EQ(b.oldest().time_ns, 920 * kMs);
}

TEST(PoseBufferTest, RefusesAnUnusableConfigOrCapacity) {
  PoseBuffer b;
  std::string error;
  PoseBufferConfig c;
  c.max_gap_s = 0.0;
  EXPECT_FALSE(b.init(16, c, &error));
  EXPECT_NE(error.find("max_gap_s"), std::string::npos);
  EXPECT_FALSE(b.init(1, PoseBufferConfig{}, &error));
  EXPECT_NE(error.find("capacity"), std::string::npos);
}

}  // namespace
}  // namespace qsg::runtime
