// Trajectory formats: TUM round trip, real TUM trajectories, interpolation, and exact playback as odometry.
#include "drivers/replay/trajectory.h"

#include <gtest/gtest.h>

#include <fstream>

#include "tests/drivers/replay/replay_test_util.h"
#include "tests/support/allocation_counter.h"
#include "tests/support/test_data.h"

namespace qsg::replay {
namespace {

Trajectory sample_trajectory() {
  Trajectory t;
  for (int i = 0; i < 6; ++i) {
    StampedPose p;
    p.time_ns = 1305031102175304000LL + i * 33'333'000LL;
    p.world_t_body_m = Eigen::Vector3d(0.1 * i, -0.2 * i, 1.5 + 0.01 * i);
    p.world_R_body = Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d(1, 2, 3).normalized()));
    t.push_back(p);
  }
  return t;
}

TEST(TumTrajectory, WriteThenReadRoundTrips) {
  const std::string dir = testing::fresh_dir("tum_trajectory");
  const Trajectory written = sample_trajectory();
  std::string error;
  ASSERT_TRUE(write_tum_trajectory(dir + "/gt.txt", written, &error)) << error;
  Trajectory read;
  ASSERT_TRUE(read_tum_trajectory(dir + "/gt.txt", &read, &error)) << error;
  ASSERT_EQ(read.size(), written.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    EXPECT_EQ(read[i].time_ns, written[i].time_ns);
    EXPECT_LT((read[i].world_t_body_m - written[i].world_t_body_m).norm(), 1e-9);
    EXPECT_LT(read[i].world_R_body.angularDistance(written[i].world_R_body), 1e-8);
  }
}

TEST(TumTrajectory, ReadsTheRealFreiburgTrajectory) {
  QSG_REQUIRE_SHARED_DATA(path, "trajectories/groundtruth.txt");
  Trajectory t;
  std::string error;
  ASSERT_TRUE(read_tum_trajectory(path, &t, &error)) << error;
  EXPECT_EQ(t.size(), 612u);  // `wc -l` says 611: the last line has no newline
  EXPECT_EQ(t[0].time_ns, 1305031526672100070LL);  // 8 decimals, kept exactly
  for (std::size_t i = 1; i < t.size(); ++i) EXPECT_GT(t[i].time_ns, t[i - 1].time_ns);
  for (const StampedPose& p : t) EXPECT_NEAR(p.world_R_body.norm(), 1.0, 1e-12);
}

TEST(TumTrajectory, ParsesFieldsAsWritten) {
  const std::string dir = testing::fresh_dir("tum_fields");
  testing::write_file(dir + "/gt.txt", "# comment\n1305031102.175304 1.5 -2.25 0.125 0 0 0.6 0.8\n");
  Trajectory t;
  std::string error;
  ASSERT_TRUE(read_tum_trajectory(dir + "/gt.txt", &t, &error)) << error;
  ASSERT_EQ(t.size(), 1u);
  EXPECT_EQ(t[0].time_ns, 1305031102175304000LL);
  EXPECT_EQ(t[0].world_t_body_m, Eigen::Vector3d(1.5, -2.25, 0.125));
  EXPECT_DOUBLE_EQ(t[0].world_R_body.z(), 0.6);
  EXPECT_DOUBLE_EQ(t[0].world_R_body.w(), 0.8);
}

// The strict reader stops at the first malformed line (a dataset's ground truth); the skipping one (a robot's
// estimate) keeps every good line and counts the others, naming the first.
TEST(TumTrajectory, TheSkippingReaderCountsMalformedLines) {
  const std::string dir = testing::fresh_dir("tum_skipping");
  std::ofstream(dir + "/est.txt") << "# t tx ty tz qx qy qz qw\n"
                                     "1.0 0 0 0 0 0 0 1\n"
                                     "1.1 0 0 0 0 0 1\n"        // 7 fields
                                     "1.2 1 0 0 0 0 0 1\n"
                                     "1.3 inf 0 0 0 0 0 1\n"    // not finite
                                     "1.4 1 1 0 0.5 0 0 0.5\n"  // |q| = 0.71
                                     "x 1 1 0 0 0 0 1\n"        // timestamp
                                     "1.6 1 1 1 0 0 0 1\n";
  std::string error;
  Trajectory t;
  EXPECT_FALSE(read_tum_trajectory(dir + "/est.txt", &t, &error));
  EXPECT_NE(error.find("est.txt:3"), std::string::npos) << error;
  TumSkipped skipped;
  ASSERT_TRUE(read_tum_trajectory_skipping(dir + "/est.txt", &t, &skipped, &error)) << error;
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[1].time_ns, 1'200'000'000);
  EXPECT_EQ(t[2].time_ns, 1'600'000'000);
  EXPECT_EQ(skipped.lines, 4u);
  EXPECT_NE(skipped.first_reason.find("est.txt:3: expected 8 fields"), std::string::npos) << skipped.first_reason;
  EXPECT_FALSE(read_tum_trajectory_skipping(dir + "/missing.txt", &t, &skipped, &error)) << "an unreadable file";
}

TEST(Trajectory, InterpolatesBetweenSamples) {
  Trajectory t(2);
  t[0].time_ns = 1000;
  t[1].time_ns = 3000;
  t[1].world_t_body_m = Eigen::Vector3d(2.0, 0.0, -4.0);
  t[1].world_R_body = Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()));
  StampedPose p;
  ASSERT_TRUE(interpolate_pose(t, 1500, 10'000, &p));
  EXPECT_LT((p.world_t_body_m - Eigen::Vector3d(0.5, 0.0, -1.0)).norm(), 1e-12);
  EXPECT_NEAR(p.world_R_body.angularDistance(Eigen::Quaterniond::Identity()), 0.1, 1e-12);
  ASSERT_TRUE(interpolate_pose(t, 3000, 10'000, &p));
  EXPECT_EQ(p.world_t_body_m, t[1].world_t_body_m);
  EXPECT_FALSE(interpolate_pose(t, 999, 10'000, &p));
  EXPECT_FALSE(interpolate_pose(t, 3001, 10'000, &p));
  EXPECT_FALSE(interpolate_pose(t, 2000, 1'000, &p));  // samples too far apart
}

TEST(TrajectoryOdometry, PlaysPosesBackExactlyThenEnds) {
  const Trajectory t = sample_trajectory();
  TrajectoryOdometry::Config config;
  config.publish_latency_ns = 5'000'000;
  TrajectoryOdometry odom(t, config, "gt");
  messages::OdometrySample s;
  std::size_t n = 0;
  EXPECT_NO_ALLOCATIONS(while (odom.read(s, 0) == drivers::ReadStatus::kOk) {
    EXPECT_EQ(s.sequence, n);
    EXPECT_EQ(s.sample_time_ns, t[n].time_ns);
    EXPECT_EQ(s.publish_time_ns, t[n].time_ns + 5'000'000);
    EXPECT_EQ(s.world_t_body_m, t[n].world_t_body_m);
    EXPECT_EQ(s.world_R_body.coeffs(), t[n].world_R_body.coeffs());
    EXPECT_EQ(s.flags, 0u);
    ++n;
  });
  EXPECT_EQ(n, t.size());
  EXPECT_EQ(odom.read(s, 0), drivers::ReadStatus::kEndOfStream);
  EXPECT_EQ(odom.counters().delivered, t.size());
  EXPECT_STREQ(odom.name(), "gt");
}

TEST(TrajectoryOdometry, FlagsTimeGoingBackwards) {
  Trajectory t = sample_trajectory();
  t[3].time_ns = t[1].time_ns;
  TrajectoryOdometry odom(t);
  messages::OdometrySample s;
  for (int i = 0; i < 4; ++i) ASSERT_EQ(odom.read(s, 0), drivers::ReadStatus::kOk);
  EXPECT_TRUE(s.flags & messages::kFrameTimestampBackwards);
  EXPECT_EQ(odom.counters().timestamps_backwards, 1u);
  ASSERT_EQ(odom.read(s, 0), drivers::ReadStatus::kOk);
  EXPECT_EQ(s.flags, 0u);
}

}  // namespace
}  // namespace qsg::replay
