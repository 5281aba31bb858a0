// Pose-list replay on slambook2's ICL-NUIM (synthetic, negative fy) and Kinect samples from ../shared/data
// (skipped when absent): depth equals the stored 16-bit values times the scale, poses equal pose.txt, and the
// synthetic frames agree geometrically.
#include "drivers/replay/pose_list_replay.h"

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <memory>
#include <opencv2/imgcodecs.hpp>

#include "tests/drivers/replay/geometry_check.h"
#include "tests/drivers/replay/replay_test_util.h"
#include "tests/support/test_data.h"

namespace qsg::replay {
namespace {

using drivers::ReadStatus;

PoseListReplay::Config icl_config() {
  PoseListReplay::Config c;
  c.intrinsics.fx = 481.2;
  c.intrinsics.fy = -480.0;
  c.intrinsics.cx = 319.5;
  c.intrinsics.cy = 239.5;
  c.depth_scale_m = 1.0f / 5000.0f;
  return c;
}

PoseListReplay::Config kinect_config() {
  PoseListReplay::Config c;
  c.intrinsics.fx = 518.0;
  c.intrinsics.fy = 519.0;
  c.intrinsics.cx = 325.5;
  c.intrinsics.cy = 253.5;
  c.depth_scale_m = 0.001f;
  c.depth_ext = ".pgm";
  return c;
}

TEST(PoseListReplay, IclNuimFramesAndPoses) {
  QSG_REQUIRE_SHARED_DATA(pose_file, "rgbd/icl_nuim_livingroom5/pose.txt");
  const std::string dir = pose_file.substr(0, pose_file.size() - std::string("/pose.txt").size());
  PoseListReplay replay;
  std::string error;
  ASSERT_TRUE(replay.open(dir, icl_config(), &error)) << error;
  ASSERT_EQ(replay.size(), 5u);
  ASSERT_EQ(replay.trajectory().size(), 5u);
  EXPECT_EQ(replay.intrinsics().fy, -480.0);
  // First pose line: 0.000466347 0.00895357 -2.24935 -0.00101358 0.00052453 -0.000231475 0.999999
  EXPECT_EQ(replay.trajectory()[0].world_t_body_m, Eigen::Vector3d(0.000466347, 0.00895357, -2.24935));
  const Eigen::Quaterniond q0(0.999999, -0.00101358, 0.00052453, -0.000231475);
  EXPECT_LT(replay.trajectory()[0].world_R_body.angularDistance(q0.normalized()), 1e-12);

  std::vector<std::unique_ptr<messages::RgbdFrame>> frames;
  for (int i = 0; i < 5; ++i) {
    frames.push_back(std::make_unique<messages::RgbdFrame>());
    ASSERT_EQ(replay.read(*frames.back(), 0), ReadStatus::kOk) << replay.last_error();
  }
  EXPECT_EQ(replay.read(*frames[0], 0), ReadStatus::kEndOfStream);
  const cv::Mat raw = cv::imread(dir + "/depth/5.png", cv::IMREAD_UNCHANGED);
  ASSERT_EQ(raw.type(), CV_16UC1);
  for (int v = 0; v < 480; v += 13) {
    for (int u = 0; u < 640; u += 11) {
      ASSERT_EQ(frames[4]->depth_m[v * 640 + u], static_cast<float>(raw.at<std::uint16_t>(v, u)) * (1.0f / 5000.0f));
    }
  }
  // Synthetic render: frames that overlap most (4 and 2 onto 0) agree to millimetres through the camera-to-world
  // poses with the negative fy; with fy's sign flipped they do not (the check can fail).
  for (int i : {2, 4}) {
    const Eigen::Isometry3d world_T_i = replay.trajectory()[i].world_T_body();
    const Eigen::Isometry3d world_T_0 = replay.trajectory()[0].world_T_body();
    const testing::ReprojectionStats s = testing::reprojection_error(*frames[i], world_T_i, *frames[0], world_T_0, 8);
    EXPECT_GT(s.compared, 1000) << i;
    EXPECT_LT(s.median_abs_m, 0.015) << "ICL frame " << i << " -> 0";
    frames[i]->intrinsics.fy = 480.0;
    frames[0]->intrinsics.fy = 480.0;
    const testing::ReprojectionStats flipped = testing::reprojection_error(*frames[i], world_T_i, *frames[0], world_T_0, 8);
    frames[i]->intrinsics.fy = -480.0;
    frames[0]->intrinsics.fy = -480.0;
    EXPECT_GT(flipped.median_abs_m, 5 * s.median_abs_m) << "ICL frame " << i << " -> 0 with +fy";
    std::printf("icl frame %d -> 0: %d pixels, median |depth error| %.4f m (%.4f m with +fy)\n", i, s.compared,
                s.median_abs_m, flipped.median_abs_m);
  }
}

// Reads a binary 16-bit PGM by hand (big-endian samples, as the format specifies), independently of OpenCV.
bool read_pgm16(const std::string& path, int* width, int* height, std::vector<std::uint16_t>* pixels) {
  std::ifstream in(path, std::ios::binary);
  std::string magic;
  int maxval = 0;
  in >> magic >> *width >> *height >> maxval;
  in.get();  // the single whitespace byte before the samples
  if (!in || magic != "P5" || maxval < 256) return false;
  std::vector<unsigned char> bytes(static_cast<std::size_t>(*width) * *height * 2);
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!in) return false;
  pixels->resize(bytes.size() / 2);
  for (std::size_t i = 0; i < pixels->size(); ++i) {
    (*pixels)[i] = static_cast<std::uint16_t>(bytes[2 * i] << 8 | bytes[2 * i + 1]);
  }
  return true;
}

TEST(PoseListReplay, KinectPgmDepthMatchesTheFileBytes) {
  QSG_REQUIRE_SHARED_DATA(pose_file, "rgbd/kinect5/pose.txt");
  const std::string dir = pose_file.substr(0, pose_file.size() - std::string("/pose.txt").size());
  PoseListReplay replay;
  std::string error;
  ASSERT_TRUE(replay.open(dir, kinect_config(), &error)) << error;
  ASSERT_EQ(replay.size(), 5u);
  // Last line has no newline at the end of the file: -1.55819 -0.301094 1.6215 -0.02707 -0.250946 -0.0412848 0.966741
  EXPECT_EQ(replay.trajectory()[4].world_t_body_m, Eigen::Vector3d(-1.55819, -0.301094, 1.6215));
  auto frame = std::make_unique<messages::RgbdFrame>();
  ASSERT_EQ(replay.read(*frame, 0), ReadStatus::kOk) << replay.last_error();
  int w = 0, h = 0;
  std::vector<std::uint16_t> raw;
  ASSERT_TRUE(read_pgm16(dir + "/depth/1.pgm", &w, &h, &raw));
  ASSERT_EQ(w, 640);
  ASSERT_EQ(h, 480);
  int mismatch = 0;
  int valid = 0;
  for (int i = 0; i < w * h; ++i) {
    mismatch += frame->depth_m[i] != static_cast<float>(raw[i]) * 0.001f ? 1 : 0;
    valid += raw[i] > 0 ? 1 : 0;
  }
  EXPECT_EQ(mismatch, 0);
  EXPECT_GT(valid, w * h / 2);
  std::printf("kinect frame 1: centre depth %.3f m, %d valid pixels\n", frame->depth_m[240 * 640 + 320], valid);
}

}  // namespace
}  // namespace qsg::replay
