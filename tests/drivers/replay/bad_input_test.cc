// Malformed datasets: open-time errors name the file and line (or field); missing and corrupt frames found during
// replay are counted and skipped, and replay goes on; nothing crashes.
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "drivers/replay/pose_list_replay.h"
#include "drivers/replay/redwood_replay.h"
#include "drivers/replay/tum_replay.h"
#include "tests/drivers/replay/replay_test_util.h"
#include "tests/support/test_data.h"

namespace qsg::replay {
namespace {

using drivers::ReadStatus;
using testing::fresh_dir;
using testing::write_file;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// A valid 3-frame TUM folder at 16x8, frames at 1.0, 1.1, 1.2 s.
std::string make_tum(const std::string& name) {
  const std::string dir = fresh_dir(name);
  auto frame = std::make_unique<messages::RgbdFrame>();
  TumWriter writer;
  std::string error;
  EXPECT_TRUE(writer.open(dir, TumWriter::Config{}, &error)) << error;
  for (int i = 0; i < 3; ++i) {
    testing::fill_synthetic_frame(*frame, 16, 8, i, 1'000'000'000LL + i * 100'000'000LL, false);
    EXPECT_TRUE(writer.write_frame(*frame, &error)) << error;
  }
  EXPECT_TRUE(writer.close(&error)) << error;
  return dir;
}

std::string open_error(const std::string& dir, const TumReplay::Config& config = TumReplay::Config{}) {
  TumReplay replay;
  std::string error;
  EXPECT_FALSE(replay.open(dir, config, &error)) << "open unexpectedly succeeded for " << dir;
  return error;
}

TEST(TumBadInput, MissingListNamesTheFile) {
  const std::string dir = make_tum("tum_missing_list");
  std::remove((dir + "/rgb.txt").c_str());
  const std::string error = open_error(dir);
  EXPECT_TRUE(contains(error, dir + "/rgb.txt: cannot open")) << error;
}

TEST(TumBadInput, BadLineNamesFileAndLine) {
  const std::string dir = make_tum("tum_bad_line");
  write_file(dir + "/depth.txt", "# depth\n1.000000 depth/1.000000.png\n1.100000 depth/1.100000.png extra\n");
  const std::string error = open_error(dir);
  EXPECT_TRUE(contains(error, dir + "/depth.txt:3: expected 2 fields 'timestamp filename', found 3")) << error;
}

TEST(TumBadInput, NonNumericTimestampNamesFileAndLine) {
  const std::string dir = make_tum("tum_bad_stamp");
  write_file(dir + "/rgb.txt", "1.000000 rgb/1.000000.png\n1.1O0000 rgb/1.100000.png\n");
  const std::string error = open_error(dir);
  EXPECT_TRUE(contains(error, dir + "/rgb.txt:2: timestamp '1.1O0000' is not a number")) << error;
}

TEST(TumBadInput, BadGroundTruthNamesLineAndField) {
  const std::string dir = make_tum("tum_bad_gt");
  write_file(dir + "/groundtruth.txt", "# gt\n1.0 0 0 0 0 0 0 1\n1.1 0 0 zero 0 0 0 1\n");
  EXPECT_TRUE(contains(open_error(dir), dir + "/groundtruth.txt:3: field 4 'zero' is not a finite number"));
  write_file(dir + "/groundtruth.txt", "1.0 0 0 0 0 0 0\n");
  EXPECT_TRUE(contains(open_error(dir), dir + "/groundtruth.txt:1: expected 8 fields"));
  write_file(dir + "/groundtruth.txt", "1.0 0 0 0 0 0 0 0\n");
  EXPECT_TRUE(contains(open_error(dir), dir + "/groundtruth.txt:1: quaternion (qx qy qz qw) is not of unit length"));
  std::remove((dir + "/groundtruth.txt").c_str());
  TumReplay::Config config;
  config.require_groundtruth = true;
  EXPECT_TRUE(contains(open_error(dir, config), "groundtruth.txt: cannot open"));
}

TEST(TumBadInput, ListedFileMissingAtOpenNamesListLineAndFile) {
  const std::string dir = make_tum("tum_missing_file_open");
  std::remove((dir + "/rgb/1.100000.png").c_str());
  const std::string error = open_error(dir);
  EXPECT_TRUE(contains(error, dir + "/rgb.txt:5: listed file '" + dir + "/rgb/1.100000.png' not found")) << error;
}

TEST(TumBadInput, MissingAndCorruptFramesAreCountedAndSkipped) {
  const std::string dir = make_tum("tum_missing_file_replay");
  TumReplay replay;
  TumReplay::Config config;
  config.check_files_at_open = false;
  std::string error;
  ASSERT_TRUE(replay.open(dir, config, &error)) << error;
  // Damage the files after open, as a disk or a copy would.
  std::remove((dir + "/depth/1.000000.png").c_str());
  write_file(dir + "/rgb/1.100000.png", "not a png at all");
  auto frame = std::make_unique<messages::RgbdFrame>();
  ASSERT_EQ(replay.read(*frame, 0), ReadStatus::kOk);
  EXPECT_EQ(frame->sequence, 2u);
  EXPECT_TRUE(frame->flags & messages::kFrameSequenceGap);
  EXPECT_EQ(replay.read(*frame, 0), ReadStatus::kEndOfStream);
  EXPECT_EQ(replay.counters().missing_files, 1u);
  EXPECT_EQ(replay.counters().bad_frames, 1u);
  EXPECT_EQ(replay.counters().delivered, 1u);
  EXPECT_TRUE(contains(replay.last_error(), dir + "/rgb/1.100000.png: colour image cannot be decoded"))
      << replay.last_error();
}

TEST(TumBadInput, WrongSizeOrTypeFramesAreBadFrames) {
  const std::string dir = make_tum("tum_wrong_size");
  {
    // Frame 1's depth replaced by a 32x8 image, frame 2's by an 8-bit one.
    auto big = std::make_unique<messages::RgbdFrame>();
    testing::fill_synthetic_frame(*big, 32, 8, 0, 0, false);
    TumWriter writer;
    std::string error;
    ASSERT_TRUE(writer.open(dir + "/big", TumWriter::Config{}, &error)) << error;
    ASSERT_TRUE(writer.write_frame(*big, &error)) << error;
    ASSERT_TRUE(writer.close(&error)) << error;
    std::rename((dir + "/big/depth/0.000000.png").c_str(), (dir + "/depth/1.100000.png").c_str());
    std::rename((dir + "/rgb/1.000000.png").c_str(), (dir + "/depth/1.200000.png").c_str());  // 8-bit colour
  }
  TumReplay replay;
  std::string error;
  TumReplay::Config config;
  config.check_files_at_open = false;
  ASSERT_TRUE(replay.open(dir, config, &error)) << error;
  EXPECT_EQ(replay.intrinsics().width, 16);  // from the first frame
  auto frame = std::make_unique<messages::RgbdFrame>();
  EXPECT_EQ(replay.read(*frame, 0), ReadStatus::kEndOfStream);  // frame 0 lost its colour image above
  EXPECT_EQ(replay.counters().bad_frames, 2u);
  EXPECT_EQ(replay.counters().missing_files, 1u);
  EXPECT_EQ(replay.counters().delivered, 0u);
  EXPECT_EQ(replay.read(*frame, 0), ReadStatus::kEndOfStream);
}

TEST(TumBadInput, EmptyListsGiveAnEmptyReplay) {
  const std::string dir = fresh_dir("tum_empty");
  write_file(dir + "/rgb.txt", "# nothing\n");
  write_file(dir + "/depth.txt", "");
  TumReplay replay;
  std::string error;
  ASSERT_TRUE(replay.open(dir, TumReplay::Config{}, &error)) << error;
  auto frame = std::make_unique<messages::RgbdFrame>();
  EXPECT_EQ(replay.read(*frame, 0), ReadStatus::kEndOfStream);
}

TEST(TumBadInput, FramesLargerThanTheBuffersAreRefusedAtOpen) {
  const std::string dir = fresh_dir("tum_too_big");
  write_file(dir + "/rgb.txt", "1.0 big.png\n");
  write_file(dir + "/depth.txt", "# depth\n1.0 big.png\n");
  ASSERT_TRUE(cv::imwrite(dir + "/big.png", cv::Mat(4, messages::kMaxFrameWidth + 1, CV_16UC1, cv::Scalar(7))));
  const std::string error = open_error(dir);
  EXPECT_TRUE(contains(error, dir + "/depth.txt:2: '" + dir + "/big.png' is 641x4, larger than the 640x480 frame buffers"))
      << error;
  TumReplay::Config config;
  config.size_from_first_frame = false;
  config.intrinsics.width = 700;
  EXPECT_TRUE(contains(open_error(dir, config), "invalid intrinsics (700x480"));
}

// ---- Redwood .log, camera JSON and pose lists -------------------------------------------------------------------

std::string log_error(const std::string& text) {
  const std::string dir = fresh_dir("redwood_log");
  write_file(dir + "/t.log", text);
  std::vector<RedwoodLogEntry> log;
  std::string error;
  EXPECT_FALSE(read_redwood_log(dir + "/t.log", &log, &error)) << text;
  return error;
}

TEST(RedwoodBadInput, MatrixWithAMissingRowNamesTheLine) {
  const std::string error = log_error(
      "0 0 1\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n"
      "1 1 2\n1 0 0 0\n0 1 0 0\n0 0 0 1\n"  // row 3 missing
      "2 2 3\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  EXPECT_TRUE(contains(error, "t.log:10: expected row 4 of the 4x4 matrix of block id 1 (4 numbers), found 3 fields"))
      << error;
}

TEST(RedwoodBadInput, OtherLogErrorsNameTheLine) {
  const struct {
    const char* text;
    const char* expected;
  } cases[] = {
      {"0 0 1\n1 0 0 0\n0 1 0 0\n", "t.log:3: file ends inside the matrix of block id 0"},
      {"0 0 1\n1 0 0 0\n0 1 x 0\n0 0 1 0\n0 0 0 1\n", "t.log:3: field 3 'x' is not a finite number"},
      {"0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n", "t.log:1: expected a metadata line of 3 integers"},
      {"0 0 1\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n", "t.log:5: last matrix row must be '0 0 0 1'"},
      {"0 0 1\n2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n", "t.log:1: rotation block of matrix id 0 is not a rotation"},
      {"0 0 1\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n7\n", "t.log:6: expected a metadata line"},
  };
  for (const auto& c : cases) {
    const std::string error = log_error(c.text);
    EXPECT_TRUE(contains(error, c.expected)) << "input:\n" << c.text << "error: " << error;
  }
  std::vector<RedwoodLogEntry> log;
  std::string error;
  EXPECT_FALSE(read_redwood_log("/no/such/dir/t.log", &log, &error));
  EXPECT_EQ(error, "/no/such/dir/t.log: cannot open");
}

TEST(RedwoodBadInput, CameraJsonErrorsNameTheField) {
  const std::string dir = fresh_dir("camera_json_bad");
  const auto error_for = [&](const std::string& text) {
    write_file(dir + "/c.json", text);
    messages::CameraIntrinsics k;
    std::string error;
    EXPECT_FALSE(read_camera_intrinsics_json(dir + "/c.json", &k, &error)) << text;
    return error;
  };
  EXPECT_TRUE(contains(error_for(R"({"height": 480, "intrinsic_matrix": [1,0,0,0,1,0,0,0,1]})"), "field 'width'"));
  EXPECT_TRUE(contains(error_for(R"({"width": 640, "height": 480, "intrinsic_matrix": [1,0,0]})"),
                       "field 'intrinsic_matrix'"));
  EXPECT_TRUE(contains(error_for(R"({"width": 640, "height": 480, "intrinsic_matrix": [1,0,0,0,"a",0,0,0,1]})"),
                       "field 'intrinsic_matrix[4]': expected a number"));
  EXPECT_TRUE(contains(error_for(R"({"width": 6400, "height": 480, "intrinsic_matrix": [1,0,0,0,1,0,0,0,1]})"),
                       "larger than the frame buffers"));
  EXPECT_TRUE(contains(error_for("{\"width\": 640,"), "c.json: [json.exception.parse_error"));
}

TEST(RedwoodBadInput, MissingAndCorruptFramesAreCountedAndSkipped) {
  // Copy the five real frames, then damage two of them.
  const std::string dir = fresh_dir("redwood_damaged");
  std::filesystem::copy(testing::repo_test_data("rgbd/redwood/RGBD"), dir, std::filesystem::copy_options::recursive);
  RedwoodReplay replay;
  RedwoodReplay::Config config;
  config.check_files_at_open = false;
  std::string error;
  ASSERT_TRUE(replay.open(dir, config, &error)) << error;
  std::remove((dir + "/color/00001.jpg").c_str());
  write_file(dir + "/depth/00003.png", std::string("\x89PNG\r\n\x1a\n truncated"));
  auto frame = std::make_unique<messages::RgbdFrame>();
  std::vector<std::uint64_t> sequences;
  std::vector<std::uint32_t> flags;
  while (replay.read(*frame, 0) == ReadStatus::kOk) {
    sequences.push_back(frame->sequence);
    flags.push_back(frame->flags);
  }
  EXPECT_EQ(sequences, (std::vector<std::uint64_t>{0, 2, 4}));
  EXPECT_EQ(flags, (std::vector<std::uint32_t>{0, messages::kFrameSequenceGap, messages::kFrameSequenceGap}));
  EXPECT_EQ(replay.counters().missing_files, 1u);
  EXPECT_EQ(replay.counters().bad_frames, 1u);
  // With the check at open, the missing file is an open error naming the match list line.
  RedwoodReplay strict;
  EXPECT_FALSE(strict.open(dir, RedwoodReplay::Config{}, &error));
  EXPECT_TRUE(contains(error, dir + "/rgbd.match:2: listed file '" + dir + "/color/00001.jpg' not found")) << error;
}

TEST(RedwoodBadInput, UnpairedFoldersAreAnOpenError) {
  const std::string dir = fresh_dir("redwood_unpaired");
  write_file(dir + "/depth/0.png", "x");
  write_file(dir + "/depth/1.png", "x");
  write_file(dir + "/color/0.jpg", "x");
  RedwoodReplay replay;
  RedwoodReplay::Config config;
  config.trajectory_log.clear();
  std::string error;
  EXPECT_FALSE(replay.open(dir, config, &error));
  EXPECT_TRUE(contains(error, "depth/ holds 2 .png images but color/ holds 1")) << error;
}

TEST(PoseListBadInput, BadPoseLineNamesTheLine) {
  const std::string dir = fresh_dir("pose_list_bad");
  write_file(dir + "/pose.txt", "0 0 0 0 0 0 1\n0 0 0 0 0 1\n");
  PoseListReplay replay;
  std::string error;
  EXPECT_FALSE(replay.open(dir, PoseListReplay::Config{}, &error));
  EXPECT_TRUE(contains(error, dir + "/pose.txt:2: expected 7 fields 'tx ty tz qx qy qz qw', found 6")) << error;
  write_file(dir + "/pose.txt", "0 0 0 0 0 0 1\n");
  EXPECT_FALSE(replay.open(dir, PoseListReplay::Config{}, &error));
  EXPECT_TRUE(contains(error, dir + "/pose.txt:1: listed file '" + dir + "/depth/1.png' not found")) << error;
}

}  // namespace
}  // namespace qsg::replay
