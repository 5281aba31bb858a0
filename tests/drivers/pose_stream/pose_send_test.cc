// End to end: the built qsg_pose_send streams a TUM file (written here) at full speed to a PoseStreamSource on a
// Unix socket and on UDP loopback, and every pose arrives as the file has it.
#include <spawn.h>
#include <sys/wait.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "drivers/pose_stream/pose_stream_source.h"
#include "tests/support/temp_dir.h"
#include "tests/support/emulation.h"
#include "drivers/replay/trajectory.h"

extern char** environ;

namespace qsg::pose_stream {
namespace {

using ::qsg::testing::TempDir;

using drivers::ReadStatus;

// Upper bound on one read while the sender runs; a read returns as soon as a datagram is there.
constexpr std::int64_t kReadTimeoutNs = 10'000'000'000;


// A walking-robot-like path with the digits a TUM file carries, and a comment line.
std::string write_tum_file(const TempDir& dir, int poses) {
  const std::string path = dir.file("walk.tum");
  std::FILE* f = std::fopen(path.c_str(), "w");
  EXPECT_NE(f, nullptr);
  std::fprintf(f, "# timestamp tx ty tz qx qy qz qw\n");
  for (int i = 0; i < poses; ++i) {
    const double yaw = 0.05 * i;
    std::fprintf(f, "%.6f %.4f %.4f %.4f %.7f %.7f %.7f %.7f\n", 1305031102.175304 + 0.01 * i, 0.1 * i,
                 0.3 * std::sin(0.2 * i), 0.45 + 0.01 * std::cos(1.3 * i), 0.002, -0.001, std::sin(yaw / 2),
                 std::cos(yaw / 2));
  }
  std::fclose(f);
  return path;
}

// Under qemu-user (cross builds' ctest) a test cannot start another arm64 program: without binfmt_misc the host
// kernel refuses to execute it. The sender is tested natively (default and sanitizer builds).
#define QSG_SKIP_IF_EMULATED()                                                                       \
  if (qsg::testing::running_emulated())                                                        \
  GTEST_SKIP() << "emulated: a test under qemu-user cannot start the arm64 qsg_pose_send binary"

// Starts the sender; returns its pid (or -1).
pid_t spawn_sender(std::vector<std::string> args) {
  args.insert(args.begin(), QSG_POSE_SEND_PATH);
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  if (::posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0) return -1;
  return pid;
}

int wait_exit_code(pid_t pid) {
  int status = 0;
  if (::waitpid(pid, &status, 0) != pid || !WIFEXITED(status)) return -1;
  return WEXITSTATUS(status);
}

// Reads until `expected` poses arrived (or a read fails) and compares each with the file's.
void expect_trajectory(PoseStreamSource& source, const replay::Trajectory& expected, const char* frame_id) {
  messages::OdometrySample s;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    ASSERT_EQ(source.read(s, kReadTimeoutNs), ReadStatus::kOk) << "pose " << i;
    EXPECT_EQ(s.sequence, i);
    EXPECT_EQ(s.sample_time_ns, expected[i].time_ns);
    EXPECT_LT((s.world_t_body_m - expected[i].world_t_body_m).cwiseAbs().maxCoeff(), 1e-9) << i;
    EXPECT_LT((s.world_R_body.coeffs() - expected[i].world_R_body.coeffs()).cwiseAbs().maxCoeff(), 1e-9) << i;
    EXPECT_EQ(s.flags, 0u) << i;
    EXPECT_STREQ(source.last_frame_id(), frame_id);
  }
  EXPECT_NEAR(s.covariance(0, 0), 0.02 * 0.02, 1e-15);
  EXPECT_NEAR(s.covariance(5, 5), 0.01 * 0.01, 1e-15);
  EXPECT_EQ(s.covariance(0, 1), 0.0);
}

TEST(PoseSendTest, StreamsATumFileOverAUnixSocket) {
  QSG_SKIP_IF_EMULATED();
  TempDir dir("qsg_pose_send");
  const std::string tum = write_tum_file(dir, 60);
  replay::Trajectory expected;
  std::string error;
  ASSERT_TRUE(replay::read_tum_trajectory(tum, &expected, &error)) << error;

  PoseStreamSource source;
  PoseStreamSource::Config config;
  config.transport = "unix";
  config.unix_path = dir.file("poses.sock");
  config.frame_id = "legs";
  ASSERT_TRUE(source.open(config, &error)) << error;

  // The Unix socket's queue is short: the sender blocks on a full queue while this thread reads.
  const pid_t pid = spawn_sender({tum, "--unix", config.unix_path, "--speed", "0", "--frame-id", "legs", "--sigma-t",
                                  "0.02", "--sigma-r", "0.01", "--repeat-first", "3"});
  ASSERT_GT(pid, 0);
  expect_trajectory(source, expected, "legs");
  EXPECT_EQ(wait_exit_code(pid), 0);
  messages::OdometrySample s;
  EXPECT_EQ(source.read(s, 0), ReadStatus::kTimeout);
  EXPECT_EQ(source.counters().delivered, expected.size());
  EXPECT_EQ(source.counters().dropped, 0u);
  EXPECT_EQ(source.counters().bad_frames, 0u);
  EXPECT_EQ(source.stream_counters().duplicates, 3u);
}

TEST(PoseSendTest, StreamsATumFileOverUdpLoopback) {
  QSG_SKIP_IF_EMULATED();
  TempDir dir("qsg_pose_send");
  // Few enough poses that the socket's default receive buffer holds them all.
  const std::string tum = write_tum_file(dir, 20);
  replay::Trajectory expected;
  std::string error;
  ASSERT_TRUE(replay::read_tum_trajectory(tum, &expected, &error)) << error;

  PoseStreamSource source;
  PoseStreamSource::Config config;
  config.port = 0;
  ASSERT_TRUE(source.open(config, &error)) << error;
  const pid_t pid = spawn_sender({tum, "--udp", "127.0.0.1:" + std::to_string(source.port()), "--speed", "0",
                                  "--sigma-t", "0.02", "--sigma-r", "0.01"});
  ASSERT_GT(pid, 0);
  expect_trajectory(source, expected, "odom");
  EXPECT_EQ(wait_exit_code(pid), 0);
}

TEST(PoseSendTest, RejectsBadArguments) {
  QSG_SKIP_IF_EMULATED();
  TempDir dir("qsg_pose_send");
  const std::string tum = write_tum_file(dir, 2);
  EXPECT_EQ(wait_exit_code(spawn_sender({tum})), 2);                                       // no destination
  EXPECT_EQ(wait_exit_code(spawn_sender({tum, "--udp", "127.0.0.1:1", "--unix", "/x"})), 2);  // two
  EXPECT_EQ(wait_exit_code(spawn_sender({tum, "--udp", "127.0.0.1:1", "--speed", "-1"})), 2);
  EXPECT_EQ(wait_exit_code(spawn_sender({tum, "--udp", "nocolon"})), 1);
  EXPECT_EQ(wait_exit_code(spawn_sender({dir.file("missing.tum"), "--udp", "127.0.0.1:1"})), 1);
  // Nobody listens on the Unix path: every send fails, and the exit code says so.
  EXPECT_EQ(wait_exit_code(spawn_sender({tum, "--unix", dir.file("nobody.sock"), "--speed", "0"})), 1);
}

}  // namespace
}  // namespace qsg::pose_stream
