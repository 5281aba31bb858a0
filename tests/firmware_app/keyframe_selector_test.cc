// Keyframe selection by time and motion; timestamps going backwards and bad poses are rejected and counted.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "firmware_app/runtime/keyframe_selector.h"

namespace qsg::runtime {
namespace {

Eigen::Isometry3d pose(double x, double yaw = 0.0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().x() = x;
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

constexpr std::int64_t kMs = 1000000;

TEST(KeyframeSelectorTest, SelectsByMotionTimeAndRateLimit) {
  KeyframeSelector s;  // 0.1 s min, 1 s max, 0.1 m, 0.1 rad
  EXPECT_TRUE(s.offer(0, pose(0.0))) << "the first frame is a keyframe";
  EXPECT_FALSE(s.offer(50 * kMs, pose(1.0))) << "too soon, however far";
  EXPECT_TRUE(s.offer(150 * kMs, pose(0.2))) << "moved enough";
  EXPECT_FALSE(s.offer(300 * kMs, pose(0.25))) << "moved too little";
  EXPECT_TRUE(s.offer(400 * kMs, pose(0.25, 0.2))) << "turned enough";
  EXPECT_FALSE(s.offer(1300 * kMs, pose(0.25, 0.2))) << "standing still for 0.9 s";
  EXPECT_TRUE(s.offer(1401 * kMs, pose(0.25, 0.2))) << "standing still for more than 1 s";
  EXPECT_EQ(s.counters().selected, 4u);
  EXPECT_EQ(s.counters().offered, 7u);
}

TEST(KeyframeSelectorTest, BackwardsTimeAndBadPosesAreRejectedAndCounted) {
  KeyframeSelector s;
  ASSERT_TRUE(s.offer(1000 * kMs, pose(0.0)));
  EXPECT_FALSE(s.offer(900 * kMs, pose(5.0)));
  EXPECT_FALSE(s.offer(1000 * kMs, pose(5.0)));
  EXPECT_EQ(s.counters().backwards, 2u);
  Eigen::Isometry3d bad = pose(1.0);
  bad.translation().y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(s.offer(1200 * kMs, bad));
  EXPECT_EQ(s.counters().invalid, 1u);
  EXPECT_TRUE(s.offer(1200 * kMs, pose(1.0))) << "the stream goes on";
  KeyframeConfig config;
  config.max_interval_s = 0.05;
  EXPECT_FALSE(config.check().empty());
}

}  // namespace
}  // namespace qsg::runtime
