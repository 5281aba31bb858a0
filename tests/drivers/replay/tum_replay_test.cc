// TUM RGB-D replay and writer: frames written then replayed come back exactly (depth to 1/5000 m), association
// follows the TUM tool, a real TUM frame decodes to its stored values, backwards stamps are flagged.
#include "drivers/replay/tum_replay.h"

#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <opencv2/imgcodecs.hpp>

#include "tests/drivers/replay/replay_test_util.h"
#include "tests/support/test_data.h"

namespace qsg::replay {
namespace {

using drivers::ReadStatus;
using testing::fresh_dir;
using testing::write_file;

constexpr int kW = 160;
constexpr int kH = 120;

TEST(TumWriter, FramesReplayExactly) {
  const std::string dir = fresh_dir("tum_round_trip");
  auto written = std::make_unique<messages::RgbdFrame>();
  auto read = std::make_unique<messages::RgbdFrame>();
  TumWriter writer;
  std::string error;
  ASSERT_TRUE(writer.open(dir, TumWriter::Config{}, &error)) << error;
  const std::int64_t t0 = 1'700'000'000'123'456'000LL;  // epoch-sized stamps, whole microseconds
  for (int i = 0; i < 4; ++i) {
    testing::fill_synthetic_frame(*written, kW, kH, i, t0 + i * 33'334'000LL, /*labels=*/i != 2);
    ASSERT_TRUE(writer.write_frame(*written, &error)) << error;
    StampedPose pose;
    pose.time_ns = written->sample_time_ns;
    pose.world_t_body_m = Eigen::Vector3d(0.25 * i, 1.0, -0.5);
    pose.world_R_body = Eigen::Quaterniond(Eigen::AngleAxisd(0.05 * i, Eigen::Vector3d::UnitY()));
    ASSERT_TRUE(writer.write_pose(pose, &error)) << error;
  }
  ASSERT_TRUE(writer.close(&error)) << error;
  EXPECT_EQ(writer.stats().frames, 4u);
  EXPECT_EQ(writer.stats().poses, 4u);
  EXPECT_EQ(writer.stats().depth_out_of_range_px, 4u);  // the 20 m pixel of each frame

  TumReplay replay;
  TumReplay::Config config;
  config.intrinsics.fx = 200.0;
  config.intrinsics.fy = 201.0;
  config.intrinsics.cx = (kW - 1) / 2.0;
  config.intrinsics.cy = (kH - 1) / 2.0;
  ASSERT_TRUE(replay.open(dir, config, &error)) << error;
  EXPECT_EQ(replay.size(), 4u);
  EXPECT_EQ(replay.intrinsics().width, kW);  // from the first depth image
  EXPECT_EQ(replay.intrinsics().height, kH);
  for (int i = 0; i < 4; ++i) {
    testing::fill_synthetic_frame(*written, kW, kH, i, t0 + i * 33'334'000LL, i != 2);
    ASSERT_EQ(replay.read(*read, 0), ReadStatus::kOk) << replay.last_error();
    EXPECT_EQ(read->sequence, static_cast<std::uint64_t>(i));
    EXPECT_EQ(read->sample_time_ns, written->sample_time_ns);
    EXPECT_EQ(read->publish_time_ns, written->sample_time_ns);
    EXPECT_EQ(read->flags, 0u);
    EXPECT_EQ(read->intrinsics.fx, 200.0);
    EXPECT_EQ(read->intrinsics.fy, 201.0);
    EXPECT_EQ(read->depth_scale_m, 1.0f / 5000.0f);
    int depth_mismatch = 0;
    for (int p = 0; p < kW * kH; ++p) {
      const long raw = testing::expected_raw_depth(written->depth_m[p]);
      // Replay's documented conversion, compared exactly, and the quantised value it came from.
      depth_mismatch += read->depth_m[p] != static_cast<float>(raw) * (1.0f / 5000.0f) ? 1 : 0;
      depth_mismatch += std::lround(static_cast<double>(read->depth_m[p]) * 5000.0) != raw ? 1 : 0;
    }
    EXPECT_EQ(depth_mismatch, 0) << "frame " << i;
    EXPECT_EQ(read->depth_m[0], 0.0f);  // 0, NaN, beyond range and negative all become "no return"
    EXPECT_EQ(read->depth_m[1], 0.0f);
    EXPECT_EQ(read->depth_m[2], 0.0f);
    EXPECT_EQ(read->depth_m[3], 0.0f);
    EXPECT_EQ(std::memcmp(read->rgb.data(), written->rgb.data(), kW * kH * 3), 0) << "frame " << i;
    EXPECT_EQ(read->has_labels, i != 2);
    if (i != 2) {
      EXPECT_EQ(std::memcmp(read->labels.data(), written->labels.data(), kW * kH * 2), 0) << "frame " << i;
    }
  }
  EXPECT_EQ(replay.read(*read, 0), ReadStatus::kEndOfStream);
  EXPECT_EQ(replay.counters().delivered, 4u);

  // Ground truth, as a trajectory and as an odometry source.
  ASSERT_EQ(replay.ground_truth().size(), 4u);
  messages::OdometrySample s;
  for (int i = 0; i < 4; ++i) {
    ASSERT_EQ(replay.ground_truth_odometry().read(s, 0), ReadStatus::kOk);
    EXPECT_EQ(s.sample_time_ns, t0 + i * 33'334'000LL);
    EXPECT_LT((s.world_t_body_m - Eigen::Vector3d(0.25 * i, 1.0, -0.5)).norm(), 1e-9);
  }
  EXPECT_EQ(replay.ground_truth_odometry().read(s, 0), ReadStatus::kEndOfStream);
  StampedPose mid;
  ASSERT_TRUE(replay.ground_truth_at(t0 + 33'334'000LL / 2, &mid));
  EXPECT_NEAR(mid.world_t_body_m.x(), 0.125, 1e-9);
}

TEST(TumWriter, ListsAreInTheTumLayout) {
  const std::string dir = fresh_dir("tum_layout");
  auto frame = std::make_unique<messages::RgbdFrame>();
  testing::fill_synthetic_frame(*frame, 16, 8, 0, 1'305'031'102'175'304'000LL, true);
  TumWriter writer;
  std::string error;
  ASSERT_TRUE(writer.open(dir, TumWriter::Config{}, &error)) << error;
  ASSERT_TRUE(writer.write_frame(*frame, &error)) << error;
  ASSERT_TRUE(writer.close(&error)) << error;
  std::vector<ListedFile> rgb, depth, labels;
  ASSERT_TRUE(read_tum_list(dir, "rgb.txt", &rgb, &error)) << error;
  ASSERT_TRUE(read_tum_list(dir, "depth.txt", &depth, &error)) << error;
  ASSERT_TRUE(read_tum_list(dir, "labels.txt", &labels, &error)) << error;
  ASSERT_EQ(rgb.size(), 1u);
  EXPECT_EQ(rgb[0].path, dir + "/rgb/1305031102.175304.png");
  EXPECT_EQ(depth[0].path, dir + "/depth/1305031102.175304.png");
  EXPECT_EQ(labels[0].path, dir + "/labels/1305031102.175304.png");
  EXPECT_EQ(rgb[0].time_ns, 1'305'031'102'175'304'000LL);
  const cv::Mat d = cv::imread(depth[0].path, cv::IMREAD_UNCHANGED);  // as third-party tools read it
  ASSERT_EQ(d.type(), CV_16UC1);
  EXPECT_EQ(d.at<std::uint16_t>(0, 5), testing::expected_raw_depth(frame->depth_m[5]));
  const cv::Mat c = cv::imread(rgb[0].path, cv::IMREAD_COLOR);
  EXPECT_EQ(c.at<cv::Vec3b>(1, 2)[2], frame->rgb[3 * (16 + 2) + 0]);  // OpenCV's BGR = our RGB reversed
}

TEST(TumAssociation, MatchesTheTumAssociateTool) {
  // rgb at 30 Hz; depth offset by 10 ms with one depth stamp far from any colour stamp.
  const std::vector<std::int64_t> depth = {10'000'000, 43'000'000, 500'000'000, 76'000'000};
  const std::vector<std::int64_t> rgb = {0, 33'000'000, 66'000'000, 99'000'000};
  const auto m = associate_timestamps(depth, rgb, 20'000'000);
  // 43 is 10 from 33 and 23 from 66 -> 33; 76 -> 66 (10), 10 -> 0 (10); 500 unmatched. In depth-file order.
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0], std::make_pair(std::size_t{0}, std::size_t{0}));
  EXPECT_EQ(m[1], std::make_pair(std::size_t{1}, std::size_t{1}));
  EXPECT_EQ(m[2], std::make_pair(std::size_t{3}, std::size_t{2}));
  // Greedy by smallest difference: 50 is closer to 48 than 45 is, so 45 loses 48 and takes nothing in 2 ms.
  const auto g = associate_timestamps({45, 50}, {48}, 5);
  ASSERT_EQ(g.size(), 1u);
  EXPECT_EQ(g[0], std::make_pair(std::size_t{1}, std::size_t{0}));
  // The window is exclusive, as in the tool (abs(a - b) < max_difference).
  EXPECT_TRUE(associate_timestamps({0}, {5}, 5).empty());
  EXPECT_EQ(associate_timestamps({0}, {4}, 5).size(), 1u);
}

TEST(TumReplay, AssociatesColourAndDepthWithinTheWindow) {
  const std::string dir = fresh_dir("tum_associate");
  auto frame = std::make_unique<messages::RgbdFrame>();
  testing::fill_synthetic_frame(*frame, 16, 8, 0, 0, false);
  TumWriter writer;
  std::string error;
  ASSERT_TRUE(writer.open(dir, TumWriter::Config{}, &error)) << error;
  ASSERT_TRUE(writer.write_frame(*frame, &error)) << error;
  ASSERT_TRUE(writer.close(&error)) << error;
  // Hand-written lists reusing the one image pair: colour 15 ms after depth pairs, 25 ms after does not.
  write_file(dir + "/depth.txt", "# depth\n1.000 depth/0.000000.png\n2.000 depth/0.000000.png\n");
  write_file(dir + "/rgb.txt", "# rgb\n1.015 rgb/0.000000.png\n2.025 rgb/0.000000.png\n");
  TumReplay replay;
  ASSERT_TRUE(replay.open(dir, TumReplay::Config{}, &error)) << error;
  ASSERT_EQ(replay.size(), 1u);
  EXPECT_EQ(replay.frames()[0].sample_time_ns, 1'000'000'000LL);  // the depth stamp
  EXPECT_EQ(replay.frames()[0].rgb_line, 2);
  TumReplay::Config wide;
  wide.max_time_difference_s = 0.03;
  ASSERT_TRUE(replay.open(dir, wide, &error)) << error;
  EXPECT_EQ(replay.size(), 2u);
}

TEST(TumReplay, FlagsAndCountsTimestampsGoingBackwards) {
  const std::string dir = fresh_dir("tum_backwards");
  auto frame = std::make_unique<messages::RgbdFrame>();
  testing::fill_synthetic_frame(*frame, 16, 8, 0, 0, false);
  TumWriter writer;
  std::string error;
  ASSERT_TRUE(writer.open(dir, TumWriter::Config{}, &error)) << error;
  ASSERT_TRUE(writer.write_frame(*frame, &error)) << error;
  ASSERT_TRUE(writer.close(&error)) << error;
  write_file(dir + "/depth.txt",
             "1.0 depth/0.000000.png\n1.1 depth/0.000000.png\n1.05 depth/0.000000.png\n1.2 depth/0.000000.png\n");
  write_file(dir + "/rgb.txt",
             "1.0 rgb/0.000000.png\n1.1 rgb/0.000000.png\n1.05 rgb/0.000000.png\n1.2 rgb/0.000000.png\n");
  TumReplay replay;
  ASSERT_TRUE(replay.open(dir, TumReplay::Config{}, &error)) << error;
  std::vector<std::uint32_t> flags;
  while (replay.read(*frame, 0) == ReadStatus::kOk) flags.push_back(frame->flags);
  ASSERT_EQ(flags.size(), 4u);  // flagged, not dropped
  EXPECT_EQ(flags[2], static_cast<std::uint32_t>(messages::kFrameTimestampBackwards));
  EXPECT_EQ(flags[3], 0u);
  EXPECT_EQ(replay.counters().timestamps_backwards, 1u);
}

TEST(TumReplay, DecodesARealTumFrameToItsStoredValues) {
  QSG_REQUIRE_SHARED_DATA(depth_png, "rgbd/redwood_open3d/RGBD/other_formats/TUM_depth.png");
  QSG_REQUIRE_SHARED_DATA(color_png, "rgbd/redwood_open3d/RGBD/other_formats/TUM_color.png");
  const std::string dir = fresh_dir("tum_real");
  write_file(dir + "/depth.txt", "# one real TUM frame, absolute paths\n1305031102.160407 " + depth_png + "\n");
  write_file(dir + "/rgb.txt", "1305031102.175304 " + color_png + "\n");
  TumReplay replay;
  std::string error;
  ASSERT_TRUE(replay.open(dir, TumReplay::Config{}, &error)) << error;
  auto frame = std::make_unique<messages::RgbdFrame>();
  ASSERT_EQ(replay.read(*frame, 0), ReadStatus::kOk) << replay.last_error();
  EXPECT_EQ(frame->width(), 640);
  EXPECT_EQ(frame->height(), 480);
  EXPECT_EQ(frame->intrinsics.fx, 525.0);
  EXPECT_EQ(frame->intrinsics.cy, 239.5);
  EXPECT_EQ(frame->sample_time_ns, 1305031102160407000LL);
  const cv::Mat raw = cv::imread(depth_png, cv::IMREAD_UNCHANGED);
  ASSERT_EQ(raw.type(), CV_16UC1);
  int valid = 0;
  for (int v = 0; v < 480; v += 7) {
    for (int u = 0; u < 640; u += 5) {
      const std::uint16_t r = raw.at<std::uint16_t>(v, u);
      ASSERT_EQ(frame->depth_m[v * 640 + u], static_cast<float>(r) * (1.0f / 5000.0f)) << u << "," << v;
      valid += r > 0 ? 1 : 0;
    }
  }
  EXPECT_GT(valid, 1000);  // a real depth image, mostly valid
  const cv::Mat bgr = cv::imread(color_png, cv::IMREAD_COLOR);
  EXPECT_EQ(frame->rgb[3 * (100 * 640 + 200) + 0], bgr.at<cv::Vec3b>(100, 200)[2]);
  EXPECT_EQ(frame->rgb[3 * (100 * 640 + 200) + 2], bgr.at<cv::Vec3b>(100, 200)[0]);
  // The centre pixel of the TUM sample sees a surface about a metre or two away.
  EXPECT_GT(frame->depth_m[240 * 640 + 320], 0.3f);
  EXPECT_LT(frame->depth_m[240 * 640 + 320], 5.0f);
}

TEST(TumReplay, ConfigPrintsEveryParameter) {
  char buffer[2048] = {};
  std::FILE* out = fmemopen(buffer, sizeof(buffer) - 1, "w");
  ASSERT_NE(out, nullptr);
  TumReplay::Config{}.print(out);
  TumWriter::Config{}.print(out);
  std::fclose(out);
  const std::string text(buffer);
  EXPECT_NE(text.find("fx=525"), std::string::npos) << text;
  EXPECT_NE(text.find("max_time_difference_s=0.02"), std::string::npos) << text;
  EXPECT_NE(text.find("depth_scale_m=0.0002"), std::string::npos) << text;
}

}  // namespace
}  // namespace qsg::replay
