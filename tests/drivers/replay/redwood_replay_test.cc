// Redwood replay on the five real frames in tests/data/rgbd/redwood: intrinsics from the Open3D JSON, depth equal
// to the stored millimetres, poses equal to the .log matrices, and frames that agree geometrically.
#include "drivers/replay/redwood_replay.h"

#include <gtest/gtest.h>

#include <memory>
#include <opencv2/imgcodecs.hpp>

#include "tests/drivers/replay/geometry_check.h"
#include "tests/drivers/replay/replay_test_util.h"
#include "tests/support/test_data.h"

namespace qsg::replay {
namespace {

using drivers::ReadStatus;

std::string redwood_dir() { return testing::repo_test_data("rgbd/redwood/RGBD"); }

RedwoodReplay::Config redwood_config() {
  RedwoodReplay::Config config;
  config.camera_json = "../camera_primesense.json";
  return config;
}

TEST(CameraJson, ReadsOpen3dIntrinsicsColumnMajor) {
  messages::CameraIntrinsics k;
  std::string error;
  ASSERT_TRUE(read_camera_intrinsics_json(testing::repo_test_data("rgbd/redwood/camera_primesense.json"), &k, &error))
      << error;
  EXPECT_EQ(k.width, 640);
  EXPECT_EQ(k.height, 480);
  EXPECT_EQ(k.fx, 525.0);
  EXPECT_EQ(k.fy, 525.0);
  EXPECT_EQ(k.cx, 319.5);
  EXPECT_EQ(k.cy, 239.5);
  // Column-major: a matrix with distinct entries shows which index is which.
  const std::string dir = testing::fresh_dir("camera_json");
  testing::write_file(dir + "/cam.json",
                      R"({"width": 320, "height": 240, "intrinsic_matrix": [300, 0, 0, 0, 310, 0, 160.5, 120.25, 1]})");
  ASSERT_TRUE(read_camera_intrinsics_json(dir + "/cam.json", &k, &error)) << error;
  EXPECT_EQ(k.fx, 300.0);
  EXPECT_EQ(k.fy, 310.0);
  EXPECT_EQ(k.cx, 160.5);
  EXPECT_EQ(k.cy, 120.25);
}

TEST(RedwoodLog, ParsesTheMatricesAsWritten) {
  std::vector<RedwoodLogEntry> log;
  std::string error;
  ASSERT_TRUE(read_redwood_log(redwood_dir() + "/trajectory.log", &log, &error)) << error;
  ASSERT_EQ(log.size(), 5u);
  EXPECT_EQ(log[0].id[0], 0);
  EXPECT_EQ(log[0].id[2], 1);
  EXPECT_EQ(log[4].id[0], 4);
  EXPECT_EQ(log[4].line_number, 21);
  // Values copied from the file's text.
  EXPECT_EQ(log[0].world_T_camera(0, 0), -0.2739592186924325);
  EXPECT_EQ(log[0].world_T_camera(1, 3), 0.5730122438481298);
  EXPECT_EQ(log[0].world_T_camera(2, 3), 2.1264800183565487);
  EXPECT_EQ(log[3].world_T_camera(1, 0), 3.342375514333952e-18);
  EXPECT_EQ(log[4].world_T_camera(2, 2), 0.2582346102545956);
  EXPECT_EQ(log[4].world_T_camera.row(3), Eigen::RowVector4d(0, 0, 0, 1));

  // odometry.log: tab-separated metadata and a different number layout.
  ASSERT_TRUE(read_redwood_log(redwood_dir() + "/odometry.log", &log, &error)) << error;
  ASSERT_EQ(log.size(), 5u);
  EXPECT_EQ(log[1].world_T_camera(0, 3), 1.99962);
  EXPECT_EQ(log[1].world_T_camera(0, 1), 3.08668e-005);
  EXPECT_EQ(log[0].world_T_camera(2, 3), -0.3);
}

TEST(RedwoodReplay, ReadsTheRealFramesWithTheirStoredValues) {
  RedwoodReplay replay;
  std::string error;
  ASSERT_TRUE(replay.open(redwood_dir(), redwood_config(), &error)) << error;
  ASSERT_EQ(replay.size(), 5u);
  EXPECT_EQ(replay.intrinsics().fx, 525.0);
  EXPECT_EQ(replay.intrinsics().width, 640);
  auto frame = std::make_unique<messages::RgbdFrame>();
  for (int i = 0; i < 5; ++i) {
    ASSERT_EQ(replay.read(*frame, 0), ReadStatus::kOk) << replay.last_error();
    EXPECT_EQ(frame->sequence, static_cast<std::uint64_t>(i));
    EXPECT_EQ(frame->sample_time_ns, i * 33'333'333LL);
    EXPECT_EQ(frame->depth_scale_m, 0.001f);
    EXPECT_EQ(frame->flags, 0u);
  }
  EXPECT_EQ(replay.read(*frame, 0), ReadStatus::kEndOfStream);
  // Frame 4's depth equals the stored 16-bit millimetres times the scale, everywhere.
  const cv::Mat raw = cv::imread(redwood_dir() + "/depth/00004.png", cv::IMREAD_UNCHANGED);
  ASSERT_EQ(raw.type(), CV_16UC1);
  int mismatch = 0;
  int valid = 0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const std::uint16_t r = raw.at<std::uint16_t>(v, u);
      mismatch += frame->depth_m[v * 640 + u] != static_cast<float>(r) * 0.001f ? 1 : 0;
      valid += r > 0 ? 1 : 0;
    }
  }
  EXPECT_EQ(mismatch, 0);
  EXPECT_GT(valid, 640 * 480 / 2);
  EXPECT_EQ(frame->depth_m[240 * 640 + 320], static_cast<float>(raw.at<std::uint16_t>(240, 320)) * 0.001f);
  const cv::Mat bgr = cv::imread(redwood_dir() + "/color/00004.jpg", cv::IMREAD_COLOR);
  EXPECT_EQ(frame->rgb[3 * (240 * 640 + 320) + 0], bgr.at<cv::Vec3b>(240, 320)[2]);
  EXPECT_EQ(frame->rgb[3 * (240 * 640 + 320) + 1], bgr.at<cv::Vec3b>(240, 320)[1]);
  EXPECT_EQ(frame->rgb[3 * (240 * 640 + 320) + 2], bgr.at<cv::Vec3b>(240, 320)[0]);
}

TEST(RedwoodReplay, WorksWithoutTheMatchListBySortingTheFolders) {
  RedwoodReplay::Config config = redwood_config();
  config.match_list = "no_such_match_file";
  RedwoodReplay replay;
  std::string error;
  ASSERT_TRUE(replay.open(redwood_dir(), config, &error)) << error;
  ASSERT_EQ(replay.size(), 5u);
  EXPECT_EQ(replay.frames()[3].depth_path, redwood_dir() + "/depth/00003.png");
  EXPECT_EQ(replay.frames()[3].rgb_path, redwood_dir() + "/color/00003.jpg");
}

TEST(RedwoodReplay, TrajectoryPosesEqualTheLogMatrices) {
  RedwoodReplay replay;
  std::string error;
  ASSERT_TRUE(replay.open(redwood_dir(), redwood_config(), &error)) << error;
  ASSERT_EQ(replay.trajectory().size(), 5u);
  messages::OdometrySample s;
  for (int i = 0; i < 5; ++i) {
    const Eigen::Matrix4d file = replay.log()[i].world_T_camera;
    EXPECT_LT((replay.trajectory()[i].world_T_body().matrix() - file).cwiseAbs().maxCoeff(), 1e-12) << i;
    ASSERT_EQ(replay.trajectory_odometry().read(s, 0), ReadStatus::kOk);
    EXPECT_EQ(s.sample_time_ns, i * 33'333'333LL);
    EXPECT_EQ(s.world_t_body_m, Eigen::Vector3d(file.topRightCorner<3, 1>()));
  }
  EXPECT_EQ(replay.trajectory_odometry().read(s, 0), ReadStatus::kEndOfStream);
}

TEST(RedwoodReplay, FramesAgreeThroughTheirPoses) {
  RedwoodReplay replay;
  std::string error;
  ASSERT_TRUE(replay.open(redwood_dir(), redwood_config(), &error)) << error;
  auto first = std::make_unique<messages::RgbdFrame>();
  auto last = std::make_unique<messages::RgbdFrame>();
  ASSERT_EQ(replay.read(*first, 0), ReadStatus::kOk);
  for (int i = 1; i < 5; ++i) ASSERT_EQ(replay.read(*last, 0), ReadStatus::kOk);
  const testing::ReprojectionStats good = testing::reprojection_error(
      *last, replay.trajectory()[4].world_T_body(), *first, replay.trajectory()[0].world_T_body(), 8);
  EXPECT_GT(good.compared, 1000);
  EXPECT_LT(good.median_abs_m, 0.015) << "frames 4 and 0 should agree to about a centimetre";
  // The inverse convention (world-to-camera) would not agree: the check can fail.
  const testing::ReprojectionStats wrong = testing::reprojection_error(
      *last, replay.trajectory()[4].world_T_body().inverse(), *first, replay.trajectory()[0].world_T_body().inverse(), 8);
  EXPECT_TRUE(wrong.compared < 100 || wrong.median_abs_m > 3 * good.median_abs_m)
      << wrong.compared << " " << wrong.median_abs_m;
  std::printf("redwood frame 4 -> 0: %d pixels compared, median |depth error| %.4f m\n", good.compared,
              good.median_abs_m);
}

}  // namespace
}  // namespace qsg::replay
