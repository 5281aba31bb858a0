// TelemetryWriter: lines reach the output in order; a stalled output never blocks commit(): lines beyond the slots
// are dropped and counted; an over-long line is cut and counted; stop() drains what is queued.
#include "firmware_app/runtime/telemetry_writer.h"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <string>
#include <thread>

#include "tests/support/allocation_counter.h"

namespace qsg::runtime {
namespace {

std::string read_all(int fd) {
  std::string text;
  char buf[8192];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n <= 0) break;
    text.append(buf, static_cast<std::size_t>(n));
  }
  return text;
}

TEST(TelemetryWriterTest, LinesComeOutInOrderAndStopDrains) {
  std::FILE* out = std::tmpfile();
  ASSERT_NE(out, nullptr);
  TelemetryWriter w;
  std::string error;
  ASSERT_TRUE(w.init(out, 64, &error)) << error;
  for (int i = 0; i < 50; ++i) {
    std::fprintf(w.begin(), "line %d of telemetry\n", i);
    w.commit();
  }
  w.stop();
  const TelemetryWriterStats s = w.stats();
  EXPECT_EQ(s.lines, 50u);
  EXPECT_EQ(s.written, 50u);
  EXPECT_EQ(s.dropped, 0u);
  EXPECT_EQ(s.slots, 64u);
  EXPECT_LE(s.high_water, 50u);
  std::rewind(out);
  std::string text;
  char buf[256];
  while (std::fgets(buf, sizeof buf, out) != nullptr) text += buf;
  std::fclose(out);
  std::string expected;
  for (int i = 0; i < 50; ++i) expected += "line " + std::to_string(i) + " of telemetry\n";
  EXPECT_EQ(text, expected);
}

// The output is a pipe nobody reads (a stalled terminal or log collector): commit() returns at once, the lines past
// what the pipe and the slots hold are dropped and counted, and nothing is lost once the reader catches up.
TEST(TelemetryWriterTest, AStalledOutputDropsAndCountsInsteadOfBlocking) {
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  ::fcntl(fds[1], F_SETPIPE_SZ, 4096);  // the smallest pipe where allowed (qemu-user may refuse: then the default)
  const int pipe_bytes = ::fcntl(fds[1], F_GETPIPE_SZ);
  const std::uint64_t pipe_lines = pipe_bytes > 0 ? static_cast<std::uint64_t>(pipe_bytes) / 3000 + 1 : 23;
  std::FILE* out = ::fdopen(fds[1], "w");
  ASSERT_NE(out, nullptr);
  const std::string body(3000, 'x');
  {
    TelemetryWriter w;
    std::string error;
    ASSERT_TRUE(w.init(out, 4, &error)) << error;
    std::fprintf(w.begin(), "warm %s\n", body.c_str());  // the writer takes it and blocks in the full pipe
    w.commit();
    ::qsg::testing::AllocationCounter counter;
    const int lines = 40 + static_cast<int>(pipe_lines);
    for (int i = 0; i < lines; ++i) {
      std::fprintf(w.begin(), "%d %s\n", i, body.c_str());
      w.commit();  // returns whether or not the writer is blocked
    }
    EXPECT_EQ(counter.allocations(), 0u) << "commit() allocated";
    const TelemetryWriterStats s = w.stats();
    EXPECT_EQ(s.lines, static_cast<std::uint64_t>(lines) + 1);
    // At most what the pipe holds, the line the writer is blocked on and the 4 slots got through; the rest dropped.
    EXPECT_GE(s.dropped, static_cast<std::uint64_t>(lines) + 1 - (pipe_lines + 1 + 4));
    EXPECT_EQ(s.high_water, 4u);
    std::string text;
    std::thread reader([&] { text = read_all(fds[0]); });
    w.stop();
    std::fclose(out);
    reader.join();
    const TelemetryWriterStats e = w.stats();
    EXPECT_EQ(e.written + e.dropped, static_cast<std::uint64_t>(lines) + 1);
    EXPECT_EQ(e.write_failures, 0u);
    std::size_t newlines = 0;
    for (char c : text) newlines += c == '\n' ? 1 : 0;
    EXPECT_EQ(newlines, e.written);
  }
  ::close(fds[0]);
}

TEST(TelemetryWriterTest, AnOverLongLineIsCutAndCounted) {
  std::FILE* out = std::tmpfile();
  ASSERT_NE(out, nullptr);
  TelemetryWriter w;
  std::string error;
  ASSERT_TRUE(w.init(out, 2, &error)) << error;
  const std::string huge(TelemetryWriter::kLineBytes * 2, 'y');
  std::fprintf(w.begin(), "%s\n", huge.c_str());
  w.commit();
  std::fprintf(w.begin(), "short\n");
  w.commit();
  w.stop();
  EXPECT_EQ(w.stats().truncated, 1u);
  EXPECT_EQ(w.stats().written, 2u);
  std::rewind(out);
  std::string text;
  int c;
  while ((c = std::fgetc(out)) != EOF) text += static_cast<char>(c);
  std::fclose(out);
  ASSERT_EQ(text.size(), TelemetryWriter::kLineBytes - 1 + 6);
  EXPECT_EQ(text[TelemetryWriter::kLineBytes - 2], '\n');
  EXPECT_EQ(text.substr(TelemetryWriter::kLineBytes - 1), "short\n");
}

TEST(TelemetryWriterTest, BadSetupIsRefused) {
  TelemetryWriter w;
  std::string error;
  EXPECT_FALSE(w.init(nullptr, 4, &error));
  EXPECT_FALSE(w.init(stdout, 0, &error));
  EXPECT_FALSE(w.initialized());
}

}  // namespace
}  // namespace qsg::runtime
