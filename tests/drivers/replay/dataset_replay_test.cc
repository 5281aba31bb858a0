// The replay facade: format detection on scratch folders, the camera taken from calibration.json (else config
// keys, else the format's default with a notice), wrong-size frames refused naming both sizes, a simulator-style
// 320x240 TUM folder replayed with its own camera, and the three shared samples (skipped when ../shared/data is
// absent) opened with their own cameras and back-projecting consistently.
#include "drivers/replay/dataset_replay.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "drivers/replay/camera_calibration.h"
#include "tests/drivers/replay/geometry_check.h"
#include "tests/drivers/replay/replay_test_util.h"
#include "tests/support/test_data.h"

namespace qsg::replay {
namespace {

using drivers::ReadStatus;
using testing::fresh_dir;
using testing::write_file;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

std::string printed(const DatasetReplay& replay) {
  std::FILE* f = std::tmpfile();
  replay.print(f);
  std::rewind(f);
  std::string text;
  char buffer[512];
  while (std::fgets(buffer, sizeof(buffer), f) != nullptr) text += buffer;
  std::fclose(f);
  return text;
}

// A TUM folder as qsg_simulate writes it (TumWriter), `frames` frames of width x height 0.1 s apart, with poses.
std::string write_tum(const std::string& name, int width, int height, int frames, double fx) {
  const std::string dir = fresh_dir(name);
  auto frame = std::make_unique<messages::RgbdFrame>();
  TumWriter writer;
  std::string error;
  EXPECT_TRUE(writer.open(dir, TumWriter::Config{}, &error)) << error;
  for (int i = 0; i < frames; ++i) {
    const std::int64_t t = 1'000'000'000LL + i * 100'000'000LL;
    testing::fill_synthetic_frame(*frame, width, height, i, t, false);
    frame->intrinsics.fx = frame->intrinsics.fy = fx;
    frame->intrinsics.cx = 0.5 * width - 0.5;
    frame->intrinsics.cy = 0.5 * height - 0.5;
    EXPECT_TRUE(writer.write_frame(*frame, &error)) << error;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(0.1 * i, 0.0, 0.0);
    EXPECT_TRUE(writer.write_pose(StampedPose::from_isometry(t, pose), &error)) << error;
  }
  EXPECT_TRUE(writer.close(&error)) << error;
  return dir;
}

// Numbered frames (depth/<i>.png 16-bit, color/<i>.png) and a pose list, 8x6.
std::string write_pose_list(const std::string& dir, int frames) {
  std::filesystem::create_directories(dir + "/depth");
  std::filesystem::create_directories(dir + "/color");
  for (int i = 1; i <= frames; ++i) {
    EXPECT_TRUE(cv::imwrite(dir + "/depth/" + std::to_string(i) + ".png", cv::Mat(6, 8, CV_16UC1, cv::Scalar(5000))));
    EXPECT_TRUE(cv::imwrite(dir + "/color/" + std::to_string(i) + ".png", cv::Mat(6, 8, CV_8UC3, cv::Scalar(1, 2, 3))));
  }
  std::string poses;
  for (int i = 0; i < frames; ++i) poses += std::to_string(0.1 * i) + " 0 0 0 0 0 1\n";
  write_file(dir + "/pose.txt", poses);
  return dir;
}

TEST(DatasetReplayDetect, FindsEachFormatInScratchFolders) {
  DatasetFormat format;
  std::string frames, error;
  const std::string tum = write_tum("detect_tum", 16, 8, 2, 20.0);
  ASSERT_TRUE(detect_dataset_format(tum, &format, &frames, &error)) << error;
  EXPECT_EQ(format, DatasetFormat::kTum);
  EXPECT_EQ(frames, tum);

  // Redwood: depth/ and color/ with a trajectory.log, here and in Open3D's RGBD/ subfolder.
  const std::string redwood = fresh_dir("detect_redwood");
  write_file(redwood + "/depth/0.png", "x");
  write_file(redwood + "/color/0.jpg", "x");
  write_file(redwood + "/trajectory.log", "");
  ASSERT_TRUE(detect_dataset_format(redwood, &format, &frames, &error)) << error;
  EXPECT_EQ(format, DatasetFormat::kRedwood);
  const std::string open3d = fresh_dir("detect_open3d");
  write_file(open3d + "/RGBD/depth/0.png", "x");
  write_file(open3d + "/RGBD/color/0.jpg", "x");
  write_file(open3d + "/RGBD/rgbd.match", "depth/0.png color/0.jpg\n");
  ASSERT_TRUE(detect_dataset_format(open3d, &format, &frames, &error)) << error;
  EXPECT_EQ(format, DatasetFormat::kRedwood);
  EXPECT_EQ(frames, open3d + "/RGBD");

  const std::string poses = fresh_dir("detect_pose_list");
  write_pose_list(poses, 2);
  ASSERT_TRUE(detect_dataset_format(poses, &format, &frames, &error)) << error;
  EXPECT_EQ(format, DatasetFormat::kPoseList);

  // Nothing recognisable, or no folder at all: the error says what was looked for.
  const std::string empty = fresh_dir("detect_empty");
  write_file(empty + "/depth/0.png", "x");
  EXPECT_FALSE(detect_dataset_format(empty, &format, &frames, &error));
  EXPECT_TRUE(contains(error, empty + ": no dataset found (looked for rgb.txt and depth.txt: TUM")) << error;
  EXPECT_FALSE(detect_dataset_format(empty + "/nothing", &format, &frames, &error));
  EXPECT_TRUE(contains(error, empty + "/nothing: not a folder")) << error;
  DatasetReplay replay;
  DatasetReplayConfig config;
  config.path = empty;
  EXPECT_FALSE(replay.open(config, &error));
  EXPECT_TRUE(contains(error, "no dataset found")) << error;
  EXPECT_EQ(replay.size(), 0u);
}

TEST(DatasetReplayDetect, ForcedFormatAndBadConfigAreClearErrors) {
  const std::string tum = write_tum("forced_format", 16, 8, 2, 20.0);
  DatasetReplay replay;
  DatasetReplayConfig config;
  config.path = tum;
  config.format = "pose_list";
  std::string error;
  EXPECT_FALSE(replay.open(config, &error));
  EXPECT_TRUE(contains(error, tum + "/pose.txt: cannot open")) << error;
  config.format = "tum";
  ASSERT_TRUE(replay.open(config, &error)) << error;
  EXPECT_STREQ(replay.format_name(), "tum");
  config.format = "rosbag";
  EXPECT_FALSE(replay.open(config, &error));
  EXPECT_TRUE(contains(error, "format: expected auto, tum, redwood or pose_list, got 'rosbag'")) << error;
  config.format = "auto";
  config.fx = -3.0;
  EXPECT_FALSE(replay.open(config, &error));
  EXPECT_TRUE(contains(error, "fx must be 0")) << error;
  config.fx = 0.0;
  config.depth_scale_m = std::nan("");
  EXPECT_FALSE(replay.open(config, &error));
  EXPECT_TRUE(contains(error, "depth_scale_m must be 0")) << error;
  config.depth_scale_m = 0.0;
  config.frame_period_s = 0.0;
  EXPECT_FALSE(replay.open(config, &error));
  EXPECT_TRUE(contains(error, "frame_period_s")) << error;
}

// qsg_simulate's output at 320x240 (its default size) replays with the camera that rendered it, not TUM's.
TEST(DatasetReplay, SimulatorStyleTumFolderReplaysWithItsOwnCamera) {
  const double fx = 525.0 * 320.0 / 640.0;
  const std::string dir = write_tum("round_trip", 320, 240, 3, fx);
  ASSERT_TRUE(std::filesystem::exists(dir + "/calibration.json"));
  DatasetReplay replay;
  DatasetReplayConfig config;
  config.path = dir;
  std::string error;
  ASSERT_TRUE(replay.open(config, &error)) << error;
  EXPECT_STREQ(replay.format_name(), "tum");
  EXPECT_EQ(replay.size(), 3u);
  const messages::CameraIntrinsics k = replay.intrinsics();
  EXPECT_EQ(k.width, 320);
  EXPECT_EQ(k.height, 240);
  EXPECT_EQ(k.fx, fx);
  EXPECT_EQ(k.fy, fx);
  EXPECT_EQ(k.cx, 159.5);
  EXPECT_EQ(k.cy, 119.5);
  EXPECT_EQ(replay.depth_scale_m(), 1.0f / 5000.0f);
  EXPECT_FALSE(replay.used_default_camera());
  EXPECT_EQ(replay.camera_source(), "calibration " + dir + "/calibration.json");
  EXPECT_FALSE(contains(printed(replay), "NOTICE")) << printed(replay);
  ASSERT_EQ(replay.ground_truth().size(), 3u);
  EXPECT_EQ(replay.ground_truth()[2].world_t_body_m, Eigen::Vector3d(0.2, 0.0, 0.0));

  auto frame = std::make_unique<messages::RgbdFrame>();
  auto expected = std::make_unique<messages::RgbdFrame>();
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(replay.camera().read(*frame, 0), ReadStatus::kOk);
    testing::fill_synthetic_frame(*expected, 320, 240, i, 0, false);
    EXPECT_EQ(frame->intrinsics.fx, fx);
    EXPECT_EQ(frame->depth_scale_m, 1.0f / 5000.0f);
    // A known pixel: its stored depth, and the point it back-projects to with the simulator's camera.
    const int u = 250, v = 30, p = v * 320 + u;
    EXPECT_FLOAT_EQ(frame->depth_m[p], expected->depth_m[p]);
    const double z = frame->depth_m[p];
    EXPECT_NEAR((u - k.cx) * z / k.fx, (250 - 159.5) * expected->depth_m[p] / 262.5, 1e-6);
    EXPECT_NEAR((v - k.cy) * z / k.fy, (30 - 119.5) * expected->depth_m[p] / 262.5, 1e-6);
  }
  EXPECT_EQ(replay.camera().read(*frame, 0), ReadStatus::kEndOfStream);
  EXPECT_EQ(replay.position(), 3u);
}

TEST(DatasetReplay, WithoutCalibrationTheDefaultCameraIsUsedWithANotice) {
  const std::string dir = write_tum("defaults", 640, 480, 1, 500.0);
  std::remove((dir + "/calibration.json").c_str());
  DatasetReplay replay;
  DatasetReplayConfig config;
  config.path = dir;
  std::string error;
  ASSERT_TRUE(replay.open(config, &error)) << error;
  const messages::CameraIntrinsics k = replay.intrinsics();
  EXPECT_EQ(k.fx, 525.0);
  EXPECT_EQ(k.fy, 525.0);
  EXPECT_EQ(k.cx, 319.5);
  EXPECT_EQ(k.cy, 239.5);
  EXPECT_EQ(replay.depth_scale_m(), 1.0f / 5000.0f);
  EXPECT_TRUE(replay.used_default_camera());
  const std::string text = printed(replay);
  EXPECT_TRUE(contains(text, "NOTICE: no calibration file (looked for " + dir + "/calibration.json)")) << text;
  EXPECT_TRUE(contains(text, "the TUM default camera")) << text;
}

TEST(DatasetReplay, ConfigKeysOverrideTheCalibrationFile) {
  const std::string dir = write_tum("overrides", 16, 8, 1, 20.0);
  DatasetReplay replay;
  DatasetReplayConfig config;
  config.path = dir;
  config.fx = 30.0;
  config.depth_scale_m = 0.001;
  std::string error;
  ASSERT_TRUE(replay.open(config, &error)) << error;
  EXPECT_EQ(replay.intrinsics().fx, 30.0);
  EXPECT_EQ(replay.intrinsics().fy, 20.0) << "the rest from calibration.json";
  EXPECT_EQ(replay.depth_scale_m(), 0.001f);
  EXPECT_EQ(replay.camera_source(), "calibration " + dir + "/calibration.json; fx, depth_scale_m from config");
  // Without a calibration file, a camera given whole by the config takes its size from the frames.
  std::remove((dir + "/calibration.json").c_str());
  config.fy = -31.0;
  config.cx = 7.5;
  config.cy = 3.5;
  ASSERT_TRUE(replay.open(config, &error)) << error;
  EXPECT_EQ(replay.intrinsics().width, 16);
  EXPECT_EQ(replay.intrinsics().height, 8);
  EXPECT_EQ(replay.intrinsics().fy, -31.0);
  EXPECT_EQ(replay.camera_source(), "config");
  EXPECT_FALSE(replay.used_default_camera());
  // A calibration file named by the config, anywhere.
  const std::string other = fresh_dir("overrides_file");
  write_file(other + "/cam.json", R"({"width": 16, "height": 8, "fx": 11, "fy": 12, "cx": 8, "cy": 4, "depth_scale": 1000})");
  DatasetReplayConfig named;
  named.path = dir;
  named.calibration = other + "/cam.json";
  ASSERT_TRUE(replay.open(named, &error)) << error;
  EXPECT_EQ(replay.intrinsics().fy, 12.0);
  EXPECT_EQ(replay.depth_scale_m(), 0.001f);
  named.calibration = other + "/absent.json";
  EXPECT_FALSE(replay.open(named, &error));
  EXPECT_TRUE(contains(error, other + "/absent.json: cannot open")) << error;
}

TEST(DatasetReplay, FramesOfAnotherSizeAreRefusedNamingBothSizes) {
  // The simulator's 320x240 frames written before calibration files existed: TUM's default is for 640x480.
  const std::string dir = write_tum("size_default", 320, 240, 1, 262.5);
  std::remove((dir + "/calibration.json").c_str());
  DatasetReplay replay;
  DatasetReplayConfig config;
  config.path = dir;
  std::string error;
  EXPECT_FALSE(replay.open(config, &error));
  EXPECT_TRUE(contains(error, "depth image '" + dir + "/depth/1.000000.png' is 320x240")) << error;
  EXPECT_TRUE(contains(error, "are for 640x480 images")) << error;
  EXPECT_TRUE(contains(error, "the TUM default camera")) << error;
  // A calibration file that disagrees with the frames.
  write_file(dir + "/calibration.json", R"({"width": 640, "height": 360, "fx": 500, "fy": 500, "cx": 320, "cy": 180})");
  EXPECT_FALSE(replay.open(config, &error));
  EXPECT_TRUE(contains(error, "is 320x240 but the intrinsics (calibration " + dir + "/calibration.json) are for 640x360"))
      << error;
  // The same for a pose list.
  const std::string poses = write_pose_list(fresh_dir("size_pose_list"), 2);
  write_file(poses + "/calibration.json", R"({"width": 16, "height": 6, "fx": 10, "fy": 10, "cx": 8, "cy": 3})");
  config.path = poses;
  EXPECT_FALSE(replay.open(config, &error));
  EXPECT_TRUE(contains(error, "depth image '" + poses + "/depth/1.png' is 8x6 but the intrinsics")) << error;
  EXPECT_TRUE(contains(error, "are for 16x6 images")) << error;
  write_file(poses + "/calibration.json", R"({"width": 8, "height": 6, "fx": 10, "fy": -10, "cx": 4, "cy": 3})");
  ASSERT_TRUE(replay.open(config, &error)) << error;
  EXPECT_EQ(replay.size(), 2u);
  EXPECT_EQ(replay.depth_scale_m(), 1.0f / 5000.0f) << "pose lists default to 5000 units per metre";
  EXPECT_TRUE(replay.used_default_camera()) << "no depth scale given";
  EXPECT_TRUE(contains(printed(replay), "NOTICE: no depth scale")) << printed(replay);
  auto frame = std::make_unique<messages::RgbdFrame>();
  ASSERT_EQ(replay.camera().read(*frame, 0), ReadStatus::kOk);
  EXPECT_EQ(frame->depth_m[0], 1.0f);
  EXPECT_EQ(frame->intrinsics.fy, -10.0);
}

// ---- The shared samples ------------------------------------------------------------------------------------------

std::string sample_dir(const std::string& marker, const std::string& name) {
  const std::string file = testing::shared_data_file(marker);
  return file.empty() ? std::string() : testing::shared_data_dir() + "/rgbd/" + name;
}

struct SampleFrames {
  std::vector<std::unique_ptr<messages::RgbdFrame>> frames;
};

void read_all(DatasetReplay& replay, SampleFrames* out) {
  for (;;) {
    auto frame = std::make_unique<messages::RgbdFrame>();
    if (replay.camera().read(*frame, 0) != ReadStatus::kOk) break;
    out->frames.push_back(std::move(frame));
  }
}

// Median valid depth of a frame, and the share of pixels with a return.
void depth_stats(const messages::RgbdFrame& f, double* median_m, double* valid_share) {
  std::vector<float> d;
  for (int i = 0; i < f.pixels(); ++i)
    if (f.depth_m[i] > 0.0f) d.push_back(f.depth_m[i]);
  *valid_share = static_cast<double>(d.size()) / f.pixels();
  if (d.empty()) return;
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  *median_m = d[d.size() / 2];
}

TEST(DatasetReplaySamples, RedwoodOpensWithOpen3dsPrimeSenseFile) {
  const std::string dir = sample_dir("rgbd/redwood_open3d/RGBD/trajectory.log", "redwood_open3d");
  if (dir.empty()) GTEST_SKIP() << "shared data rgbd/redwood_open3d not found ($QSG_SHARED_DATA, ../shared/data)";
  DatasetReplay replay;
  DatasetReplayConfig config;
  config.path = dir;  // the folder above RGBD/, as Open3D ships it
  std::string error;
  ASSERT_TRUE(replay.open(config, &error)) << error;
  EXPECT_STREQ(replay.format_name(), "redwood");
  EXPECT_EQ(replay.frames_folder(), dir + "/RGBD");
  EXPECT_EQ(replay.size(), 5u);
  EXPECT_EQ(replay.ground_truth().size(), 5u);
  // camera_primesense.json (525), not the folder's camera.json (415.7, the synthetic depth image's camera).
  EXPECT_EQ(replay.camera_source(), "calibration " + dir + "/camera_primesense.json");
  const messages::CameraIntrinsics k = replay.intrinsics();
  EXPECT_EQ(k.fx, 525.0);
  EXPECT_EQ(k.fy, 525.0);
  EXPECT_EQ(k.cx, 319.5);
  EXPECT_EQ(k.cy, 239.5);
  EXPECT_EQ(replay.depth_scale_m(), 0.001f);
  SampleFrames s;
  read_all(replay, &s);
  ASSERT_EQ(s.frames.size(), 5u);
  double median = 0.0, valid = 0.0;
  depth_stats(*s.frames[0], &median, &valid);
  EXPECT_GT(median, 0.5);
  EXPECT_LT(median, 4.0);
  EXPECT_GT(valid, 0.5);
  // Real frames agree through the ground truth to millimetres (the data README: about 8 mm).
  const testing::ReprojectionStats r =
      testing::reprojection_error(*s.frames[4], replay.ground_truth()[4].world_T_body(), *s.frames[0],
                                  replay.ground_truth()[0].world_T_body(), 8);
  EXPECT_GT(r.compared, 1000);
  EXPECT_LT(r.median_abs_m, 0.015);
  std::printf("redwood: median depth %.2f m, frame 4 -> 0 median |error| %.4f m over %d pixels\n", median,
              r.median_abs_m, r.compared);
}

TEST(DatasetReplaySamples, IclNuimOpensWithTheShippedCalibrationAndNegativeFy) {
  const std::string dir = sample_dir("rgbd/icl_nuim_livingroom5/pose.txt", "icl_nuim_livingroom5");
  if (dir.empty()) GTEST_SKIP() << "shared data rgbd/icl_nuim_livingroom5 not found ($QSG_SHARED_DATA, ../shared/data)";
  DatasetReplay replay;
  DatasetReplayConfig config;
  config.path = dir;
  config.calibration = std::string(QSG_SOURCE_DIR) + "/drivers/replay/calibration/icl_nuim.json";
  std::string error;
  ASSERT_TRUE(replay.open(config, &error)) << error;
  EXPECT_STREQ(replay.format_name(), "pose_list");
  EXPECT_EQ(replay.size(), 5u);
  EXPECT_EQ(replay.ground_truth().size(), 5u);
  EXPECT_FALSE(replay.used_default_camera());
  const messages::CameraIntrinsics k = replay.intrinsics();
  EXPECT_EQ(k.fx, 481.2);
  EXPECT_EQ(k.fy, -480.0);
  EXPECT_EQ(k.cx, 319.5);
  EXPECT_EQ(k.cy, 239.5);
  EXPECT_EQ(replay.depth_scale_m(), 1.0f / 5000.0f);
  SampleFrames s;
  read_all(replay, &s);
  ASSERT_EQ(s.frames.size(), 5u);
  double median = 0.0, valid = 0.0;
  depth_stats(*s.frames[2], &median, &valid);
  EXPECT_GT(median, 0.5);
  EXPECT_LT(median, 6.0);
  EXPECT_GT(valid, 0.9) << "a synthetic render has depth almost everywhere";
  // Synthetic: frames agree to millimetres through the poses with fy negative.
  const testing::ReprojectionStats r =
      testing::reprojection_error(*s.frames[2], replay.ground_truth()[2].world_T_body(), *s.frames[0],
                                  replay.ground_truth()[0].world_T_body(), 8);
  EXPECT_GT(r.compared, 1000);
  EXPECT_LT(r.median_abs_m, 0.015);

  // The same camera from config keys alone (the data README's numbers), with the size from the frames.
  DatasetReplayConfig keys;
  keys.path = dir;
  keys.fx = 481.2;
  keys.fy = -480.0;
  keys.cx = 319.5;
  keys.cy = 239.5;
  keys.depth_scale_m = 1.0 / 5000.0;
  DatasetReplay by_keys;
  ASSERT_TRUE(by_keys.open(keys, &error)) << error;
  EXPECT_EQ(by_keys.intrinsics().width, 640);
  EXPECT_EQ(by_keys.intrinsics().fy, -480.0);
  EXPECT_EQ(by_keys.camera_source(), "config");
  EXPECT_FALSE(by_keys.used_default_camera());
}

TEST(DatasetReplaySamples, Kinect5OpensWithPgmDepthInMillimetres) {
  const std::string dir = sample_dir("rgbd/kinect5/pose.txt", "kinect5");
  if (dir.empty()) GTEST_SKIP() << "shared data rgbd/kinect5 not found ($QSG_SHARED_DATA, ../shared/data)";
  DatasetReplay replay;
  DatasetReplayConfig config;
  config.path = dir;
  config.calibration = std::string(QSG_SOURCE_DIR) + "/drivers/replay/calibration/slambook2_kinect.json";
  std::string error;
  ASSERT_TRUE(replay.open(config, &error)) << error;
  EXPECT_STREQ(replay.format_name(), "pose_list");
  EXPECT_EQ(replay.size(), 5u);
  const messages::CameraIntrinsics k = replay.intrinsics();
  EXPECT_EQ(k.fx, 518.0);
  EXPECT_EQ(k.fy, 519.0);
  EXPECT_EQ(k.cx, 325.5);
  EXPECT_EQ(k.cy, 253.5);
  EXPECT_EQ(replay.depth_scale_m(), 0.001f);
  SampleFrames s;
  read_all(replay, &s);
  ASSERT_EQ(s.frames.size(), 5u) << "the .pgm depth images decode";
  const cv::Mat raw = cv::imread(dir + "/depth/1.pgm", cv::IMREAD_UNCHANGED);
  ASSERT_EQ(raw.type(), CV_16UC1);
  // A known pixel: the file's millimetres, and the 3D point through the Kinect's camera.
  const int u = 400, v = 300;
  const std::uint16_t mm = raw.at<std::uint16_t>(v, u);
  ASSERT_GT(mm, 0);
  const float z = s.frames[0]->depth_m[v * 640 + u];
  EXPECT_EQ(z, static_cast<float>(mm) * 0.001f);
  const Eigen::Vector3d p((u - k.cx) * z / k.fx, (v - k.cy) * z / k.fy, z);
  EXPECT_NEAR(p.x(), (400 - 325.5) * mm * 0.001 / 518.0, 1e-6);
  EXPECT_NEAR(p.y(), (300 - 253.5) * mm * 0.001 / 519.0, 1e-6);
  double median = 0.0, valid = 0.0;
  depth_stats(*s.frames[0], &median, &valid);
  EXPECT_GT(median, 0.5);
  EXPECT_LT(median, 5.0);
  // Approximate poses (2-4 cm): the closest frames (4 onto 3) agree to a few centimetres.
  const testing::ReprojectionStats r =
      testing::reprojection_error(*s.frames[4], replay.ground_truth()[4].world_T_body(), *s.frames[3],
                                  replay.ground_truth()[3].world_T_body(), 8);
  EXPECT_GT(r.compared, 1000);
  EXPECT_LT(r.median_abs_m, 0.05);
  std::printf("kinect5: pixel (%d, %d) at (%.3f, %.3f, %.3f) m, median depth %.2f m, frame 4 -> 3 median |error| "
              "%.4f m\n",
              u, v, p.x(), p.y(), p.z(), median, r.median_abs_m);
  // Without a camera the pose list's default (525, 5000 units per metre) applies, with a notice: wrong for this
  // Kinect, which is why the shipped calibration or the config keys are needed.
  DatasetReplayConfig bare;
  bare.path = dir;
  DatasetReplay defaults;
  ASSERT_TRUE(defaults.open(bare, &error)) << error;
  EXPECT_TRUE(defaults.used_default_camera());
  EXPECT_TRUE(contains(printed(defaults), "NOTICE: no calibration file")) << printed(defaults);
  SampleFrames wrong;
  read_all(defaults, &wrong);
  ASSERT_EQ(wrong.frames.size(), 5u);
  const testing::ReprojectionStats w =
      testing::reprojection_error(*wrong.frames[4], replay.ground_truth()[4].world_T_body(), *wrong.frames[3],
                                  replay.ground_truth()[3].world_T_body(), 8);
  EXPECT_GT(w.median_abs_m, 3 * r.median_abs_m) << "the check tells the right camera from the default one";
}

}  // namespace
}  // namespace qsg::replay
