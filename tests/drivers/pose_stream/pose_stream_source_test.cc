// PoseStreamSource on real loopback sockets (UDP on an ephemeral port, a Unix socket in a temporary folder): what
// arrives, what is counted (gaps, duplicates, backwards times, malformed datagrams), open errors, and no
// allocation per read. Datagrams are sent before the reads, so nothing waits on another thread or sleeps.
#include "drivers/pose_stream/pose_stream_source.h"
#include "tests/support/temp_dir.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tests/support/allocation_counter.h"

namespace qsg::pose_stream {
namespace {

using ::qsg::testing::TempDir;

using drivers::ReadStatus;
constexpr std::int64_t kArrivalTimeoutNs = 2'000'000'000;  // data sent already: returns as soon as it is there


// The test's end of the socket: sends raw datagrams to a UDP port or a Unix path.
class Sender {
 public:
  explicit Sender(int udp_port) {
    fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(udp_port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    std::memcpy(&address_, &a, sizeof a);
    length_ = sizeof a;
  }
  explicit Sender(const std::string& unix_path) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::memcpy(a.sun_path, unix_path.data(), unix_path.size());
    std::memcpy(&address_, &a, sizeof a);
    length_ = sizeof a;
  }
  ~Sender() { ::close(fd_); }

  void send(const std::uint8_t* data, std::size_t size) {
    const ssize_t n = ::sendto(fd_, data, size, 0, reinterpret_cast<const sockaddr*>(&address_), length_);
    ASSERT_EQ(n, static_cast<ssize_t>(size)) << std::strerror(errno);
  }
  void send_pose(std::uint64_t sequence, std::int64_t time_ns, const char* frame_id = "odom",
                 std::uint32_t message_flags = 0) {
    messages::OdometrySample s;
    s.sequence = sequence;
    s.sample_time_ns = time_ns;
    s.world_t_body_m = Eigen::Vector3d(0.5 * static_cast<double>(sequence), -1.0, 0.25);
    s.world_R_body =
        Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * static_cast<double>(sequence), Eigen::Vector3d::UnitZ()));
    std::uint8_t b[kPoseMessageSize];
    ASSERT_TRUE(encode_pose_message(s, frame_id, b, message_flags));
    send(b, sizeof b);
  }

 private:
  int fd_ = -1;
  sockaddr_storage address_{};
  socklen_t length_ = 0;
};

// A stepped clock: every reading advances it by 1 ms, so publish times are known exactly.
struct SteppedClock {
  std::int64_t now_ns = 5'000'000'000;
  std::int64_t operator()() { return now_ns += 1'000'000; }
};

PoseStreamSource::Config udp_config(SteppedClock* clock) {
  PoseStreamSource::Config c;
  c.port = 0;
  c.clock_ns = [clock] { return (*clock)(); };
  return c;
}

// The common script: good, gap, duplicate, malformed, backwards, good; checks samples and counters.
void run_counting_script(PoseStreamSource& source, Sender& sender) {
  sender.send_pose(0, 1'000);
  sender.send_pose(1, 2'000);
  sender.send_pose(1, 2'000);  // duplicate: discarded inside the next read
  sender.send_pose(4, 5'000);  // 2 and 3 missing
  const std::uint8_t garbage[17] = {'Q', 'S', 'G', 'P', 1, 0};
  sender.send(garbage, sizeof garbage);
  sender.send_pose(5, 4'500);  // sample time went backwards
  sender.send_pose(6, 6'000);

  messages::OdometrySample s;
  ASSERT_EQ(source.read(s, kArrivalTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(s.sequence, 0u);
  EXPECT_EQ(s.sample_time_ns, 1'000);
  EXPECT_EQ(s.flags, 0u);
  EXPECT_EQ(s.world_t_body_m, Eigen::Vector3d(0.0, -1.0, 0.25));
  EXPECT_STREQ(source.last_frame_id(), "odom");
  ASSERT_EQ(source.read(s, kArrivalTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(s.sequence, 1u);
  EXPECT_EQ(s.flags, 0u);
  ASSERT_EQ(source.read(s, kArrivalTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(s.sequence, 4u);
  EXPECT_EQ(s.flags, static_cast<std::uint32_t>(messages::kFrameSequenceGap));
  EXPECT_EQ(s.world_t_body_m.x(), 2.0);
  EXPECT_EQ(source.read(s, kArrivalTimeoutNs), ReadStatus::kBadFrame);
  ASSERT_EQ(source.read(s, kArrivalTimeoutNs), ReadStatus::kOk);  // the malformed one lost nothing after it
  EXPECT_EQ(s.sequence, 5u);
  EXPECT_EQ(s.flags, static_cast<std::uint32_t>(messages::kFrameTimestampBackwards));
  ASSERT_EQ(source.read(s, kArrivalTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(s.sequence, 6u);
  EXPECT_EQ(s.flags, 0u);
  EXPECT_EQ(source.read(s, 0), ReadStatus::kTimeout);

  const drivers::DriverCounters& c = source.counters();
  EXPECT_EQ(c.delivered, 5u);
  EXPECT_EQ(c.dropped, 2u);
  EXPECT_EQ(c.timestamps_backwards, 1u);
  EXPECT_EQ(c.bad_frames, 1u);
  EXPECT_EQ(c.stalls, 1u);
  EXPECT_EQ(c.disconnects, 0u);
  const PoseStreamCounters& p = source.stream_counters();
  EXPECT_EQ(p.datagrams, 7u);
  EXPECT_EQ(p.duplicates, 1u);
  EXPECT_EQ(p.decode_failure(DecodeStatus::kWrongSize), 1u);
  EXPECT_EQ(p.decode_failure(DecodeStatus::kBadCrc), 0u);
}

TEST(PoseStreamSourceTest, ConfigCheckNamesTheProblem) {
  PoseStreamSource::Config c;
  EXPECT_EQ(c.check(), "");
  c.transport = "tcp";
  EXPECT_NE(c.check().find("tcp"), std::string::npos);
  c = {};
  c.bind_address = "localhost";  // names are not resolved: the address is said exactly
  EXPECT_NE(c.check().find("IPv4"), std::string::npos);
  c = {};
  c.port = 70000;
  EXPECT_NE(c.check().find("70000"), std::string::npos);
  c = {};
  c.transport = "unix";
  EXPECT_NE(c.check().find("unix_path"), std::string::npos);
  c.unix_path = "/tmp/" + std::string(200, 'a');
  EXPECT_NE(c.check().find("at most 107"), std::string::npos);
  c = {};
  c.frame_id = "a_frame_id_too_long";
  EXPECT_NE(c.check().find("longer"), std::string::npos);

  std::FILE* out = std::tmpfile();
  ASSERT_NE(out, nullptr);
  PoseStreamSource::Config{}.print(out);
  std::rewind(out);
  char line[512] = {};
  ASSERT_NE(std::fgets(line, sizeof line, out), nullptr);
  std::fclose(out);
  EXPECT_NE(std::string(line).find("transport=udp bind_address=127.0.0.1 port=47600"), std::string::npos) << line;
}

TEST(PoseStreamSourceTest, UdpLoopbackDeliversAndCounts) {
  SteppedClock clock;
  PoseStreamSource source;
  std::string error;
  ASSERT_TRUE(source.open(udp_config(&clock), &error)) << error;
  ASSERT_GT(source.port(), 0);
  Sender sender(source.port());
  run_counting_script(source, sender);
}

TEST(PoseStreamSourceTest, UnixSocketDeliversAndCountsAndCleansUp) {
  TempDir dir("qsg_pose_stream");
  SteppedClock clock;
  PoseStreamSource::Config config = udp_config(&clock);
  config.transport = "unix";
  config.unix_path = dir.file("poses.sock");
  PoseStreamSource source;
  std::string error;
  ASSERT_TRUE(source.open(config, &error)) << error;
  EXPECT_EQ(source.port(), 0);
  Sender sender(config.unix_path);
  run_counting_script(source, sender);
  source.close();
  EXPECT_FALSE(std::filesystem::exists(config.unix_path));
  messages::OdometrySample s;
  EXPECT_EQ(source.read(s, 0), ReadStatus::kDisconnected);
}

TEST(PoseStreamSourceTest, PublishTimeComesFromTheInjectedClock) {
  SteppedClock clock;
  PoseStreamSource::Config config = udp_config(&clock);
  config.late_after_ns = 3'000'000;
  PoseStreamSource source;
  std::string error;
  ASSERT_TRUE(source.open(config, &error)) << error;
  Sender sender(source.port());
  sender.send_pose(0, clock.now_ns);                // published 1 ms after: on time
  sender.send_pose(1, clock.now_ns - 10'000'000);   // 10 ms old: late
  messages::OdometrySample s;
  ASSERT_EQ(source.read(s, kArrivalTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(s.publish_time_ns, 5'001'000'000);
  EXPECT_EQ(s.flags, 0u);
  ASSERT_EQ(source.read(s, kArrivalTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(s.publish_time_ns, 5'002'000'000);
  EXPECT_EQ(s.flags, static_cast<std::uint32_t>(messages::kFrameLate | messages::kFrameTimestampBackwards));
  EXPECT_EQ(source.counters().late, 1u);
}

TEST(PoseStreamSourceTest, RestartsResetsAndFrameIdsAreReported) {
  SteppedClock clock;
  PoseStreamSource::Config config = udp_config(&clock);
  config.frame_id = "odom";
  PoseStreamSource source;
  std::string error;
  ASSERT_TRUE(source.open(config, &error)) << error;
  Sender sender(source.port());
  sender.send_pose(10, 1'000);
  sender.send_pose(0, 2'000);                                       // the sender started over
  sender.send_pose(1, 3'000, "odom", kPoseMessageEstimatorReset);  // its estimator reset
  sender.send_pose(2, 4'000, "map");                                // another frame: refused
  sender.send_pose(3, 5'000);
  messages::OdometrySample s;
  ASSERT_EQ(source.read(s, kArrivalTimeoutNs), ReadStatus::kOk);
  ASSERT_EQ(source.read(s, kArrivalTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(s.sequence, 0u);
  EXPECT_EQ(s.flags, static_cast<std::uint32_t>(messages::kFrameAfterReconnect));
  ASSERT_EQ(source.read(s, kArrivalTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(s.flags, static_cast<std::uint32_t>(messages::kFrameAfterReconnect));
  EXPECT_EQ(source.read(s, kArrivalTimeoutNs), ReadStatus::kBadFrame);
  ASSERT_EQ(source.read(s, kArrivalTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(s.sequence, 3u);
  EXPECT_EQ(s.flags, static_cast<std::uint32_t>(messages::kFrameSequenceGap));  // 2 never delivered
  EXPECT_EQ(source.stream_counters().sequence_restarts, 1u);
  EXPECT_EQ(source.stream_counters().estimator_resets, 1u);
  EXPECT_EQ(source.stream_counters().wrong_frame_id, 1u);
  EXPECT_EQ(source.counters().bad_frames, 1u);
  EXPECT_EQ(source.counters().dropped, 1u);
}

TEST(PoseStreamSourceTest, EveryMalformedDatagramIsCountedByReason) {
  SteppedClock clock;
  PoseStreamSource source;
  std::string error;
  ASSERT_TRUE(source.open(udp_config(&clock), &error)) << error;
  Sender sender(source.port());

  messages::OdometrySample good;
  std::uint8_t b[2 * kPoseMessageSize] = {};
  ASSERT_TRUE(encode_pose_message(good, "odom", b));
  sender.send(b, kPoseMessageSize + 8);  // a valid message with bytes after it: not cut to the valid prefix
  sender.send(b, 0);                     // empty datagram
  b[0] = 'X';
  sender.send(b, kPoseMessageSize);
  b[0] = 'Q';
  b[kOffsetVersion] = 9;
  sender.send(b, kPoseMessageSize);
  b[kOffsetVersion] = 1;
  b[200] ^= 0x10;
  sender.send(b, kPoseMessageSize);
  b[200] ^= 0x10;
  sender.send(b, kPoseMessageSize);  // intact again

  messages::OdometrySample s;
  for (int i = 0; i < 5; ++i) EXPECT_EQ(source.read(s, kArrivalTimeoutNs), ReadStatus::kBadFrame) << i;
  EXPECT_EQ(source.read(s, kArrivalTimeoutNs), ReadStatus::kOk);
  const PoseStreamCounters& p = source.stream_counters();
  EXPECT_EQ(p.decode_failure(DecodeStatus::kWrongSize), 2u);
  EXPECT_EQ(p.decode_failure(DecodeStatus::kBadMagic), 1u);
  EXPECT_EQ(p.decode_failure(DecodeStatus::kUnsupportedVersion), 1u);
  EXPECT_EQ(p.decode_failure(DecodeStatus::kBadCrc), 1u);
  EXPECT_EQ(source.counters().bad_frames, 5u);
  EXPECT_EQ(source.counters().delivered, 1u);
}

TEST(PoseStreamSourceTest, ReadsDoNotAllocate) {
  SteppedClock clock;
  PoseStreamSource source;
  std::string error;
  ASSERT_TRUE(source.open(udp_config(&clock), &error)) << error;
  Sender sender(source.port());
  for (std::uint64_t i = 0; i < 40; ++i) sender.send_pose(i % 20 == 7 ? i - 1 : i, static_cast<std::int64_t>(i) * 1000);
  const std::uint8_t garbage[3] = {1, 2, 3};
  sender.send(garbage, sizeof garbage);
  sender.send(garbage, sizeof garbage);

  messages::OdometrySample s;
  int ok = 0, bad = 0;
  EXPECT_NO_ALLOCATIONS({
    for (int i = 0; i < 45; ++i) {
      const ReadStatus status = source.read(s, i < 40 ? kArrivalTimeoutNs : 0);
      ok += status == ReadStatus::kOk;
      bad += status == ReadStatus::kBadFrame;
    }
  });
  EXPECT_EQ(ok, 38);  // two duplicates discarded
  EXPECT_EQ(bad, 2);
  EXPECT_EQ(source.stream_counters().duplicates, 2u);
}

TEST(PoseStreamSourceTest, OpenReportsBadAddressPortInUseAndLongPath) {
  PoseStreamSource first;
  std::string error;
  PoseStreamSource::Config config;
  config.port = 0;
  ASSERT_TRUE(first.open(config, &error)) << error;

  PoseStreamSource second;
  config.port = first.port();
  EXPECT_FALSE(second.open(config, &error));
  EXPECT_NE(error.find("in use"), std::string::npos) << error;
  EXPECT_NE(error.find(std::to_string(first.port())), std::string::npos) << error;

  config.bind_address = "300.1.2.3";
  EXPECT_FALSE(second.open(config, &error));
  EXPECT_NE(error.find("300.1.2.3"), std::string::npos) << error;

  config = {};
  config.port = 0;
  config.bind_address = "192.0.2.1";  // TEST-NET-1: on no interface of a test machine
  EXPECT_FALSE(second.open(config, &error));
  EXPECT_NE(error.find("192.0.2.1"), std::string::npos) << error;

  config = {};
  config.transport = "unix";
  config.unix_path = "/tmp/" + std::string(120, 'p');
  EXPECT_FALSE(second.open(config, &error));
  EXPECT_NE(error.find("bytes"), std::string::npos) << error;
  EXPECT_FALSE(second.is_open());
}

TEST(PoseStreamSourceTest, NonLoopbackBindIsExplicitAndWarned) {
  PoseStreamSource source;
  PoseStreamSource::Config config;
  config.bind_address = "0.0.0.0";
  config.port = 0;
  std::string error;
  ::testing::internal::CaptureStderr();
  const bool opened = source.open(config, &error);
  const std::string log = ::testing::internal::GetCapturedStderr();
  ASSERT_TRUE(opened) << error;
  EXPECT_NE(log.find("warning"), std::string::npos) << log;

  PoseStreamSource loopback;
  config.bind_address = "127.0.0.1";
  ::testing::internal::CaptureStderr();
  ASSERT_TRUE(loopback.open(config, &error)) << error;
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}

TEST(PoseStreamSourceTest, UnixPathStaleSocketIsReplacedOtherFilesAreNot) {
  TempDir dir("qsg_pose_stream");
  PoseStreamSource::Config config;
  config.transport = "unix";
  config.unix_path = dir.file("poses.sock");
  std::string error;

  // A socket file left by a receiver that died: bound, then its descriptor closed without unlinking.
  {
    const int fd = ::socket(AF_UNIX, SOCK_DGRAM, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::memcpy(a.sun_path, config.unix_path.data(), config.unix_path.size());
    ASSERT_EQ(::bind(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a), 0);
    ::close(fd);
  }
  PoseStreamSource source;
  ASSERT_TRUE(source.open(config, &error)) << error;

  // While it is open, a second receiver on the same path is refused rather than stealing it.
  PoseStreamSource second;
  EXPECT_FALSE(second.open(config, &error));
  EXPECT_NE(error.find("in use"), std::string::npos) << error;
  EXPECT_TRUE(std::filesystem::exists(config.unix_path));

  // A regular file at the path is left alone.
  config.unix_path = dir.file("notes.txt");
  std::ofstream(config.unix_path) << "keep me";
  EXPECT_FALSE(second.open(config, &error));
  EXPECT_NE(error.find("not a socket"), std::string::npos) << error;
  std::ifstream in(config.unix_path);
  std::string text;
  std::getline(in, text);
  EXPECT_EQ(text, "keep me");
}

}  // namespace
}  // namespace qsg::pose_stream
