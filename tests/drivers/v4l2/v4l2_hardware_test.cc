// The capture against a real kernel V4L2 node through the real system calls. Runs only when QSG_V4L2_DEVICE names
// a capture node (e.g. vivid's /dev/video0 in a VM: YUYV 640x480); otherwise every test skips and says why.
// QSG_V4L2_FRAMES sets how many frames to stream (default 30); vivid under qemu gives about 5 per second.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "drivers/v4l2/v4l2_capture.h"

namespace qsg::testing {
namespace {

using drivers::ReadStatus;
using v4l2::CapturedFrame;
using v4l2::V4l2Capture;

const char* device_or_null() {
  const char* d = std::getenv("QSG_V4L2_DEVICE");
  return (d && *d) ? d : nullptr;
}

#define QSG_REQUIRE_V4L2_DEVICE(var)                                                                     \
  const char* var = device_or_null();                                                                    \
  if (!var) GTEST_SKIP() << "QSG_V4L2_DEVICE is not set; set it to a capture node (e.g. /dev/video0 with " \
                            "the vivid module loaded) to run the V4L2 hardware tests"

int frames_to_stream() {
  const char* n = std::getenv("QSG_V4L2_FRAMES");
  const int v = n ? std::atoi(n) : 30;
  return v > 1 ? v : 30;
}

V4l2Capture::Config vivid_config(const char* device) {
  V4l2Capture::Config c;
  c.device = device;
  c.pixel_format = v4l2::kPixelFormatYuyv;
  c.width_px = 640;
  c.height_px = 480;
  c.buffer_count = 4;
  c.max_latency_ns = 2'000'000'000;  // emulated machines are slow; lateness is not what this suite checks
  return c;
}

TEST(V4l2Hardware, MissingNodeGivesAClearError) {
  // Runs everywhere: the real open() on a path that does not exist.
  V4l2Capture cap;
  V4l2Capture::Config c = vivid_config("/dev/qsg-no-such-video-node");
  std::string error;
  EXPECT_FALSE(cap.open(c, &error));
  EXPECT_NE(error.find("/dev/qsg-no-such-video-node"), std::string::npos) << error;
  EXPECT_NE(error.find("cannot open"), std::string::npos) << error;
}

TEST(V4l2Hardware, NegotiatesYuyv640x480) {
  QSG_REQUIRE_V4L2_DEVICE(device);
  V4l2Capture cap;
  std::string error;
  ASSERT_TRUE(cap.open(vivid_config(device), &error)) << error;
  EXPECT_EQ(cap.format().pixel_format, v4l2::kPixelFormatYuyv);
  EXPECT_EQ(cap.format().width_px, 640);
  EXPECT_EQ(cap.format().height_px, 480);
  EXPECT_GE(cap.format().bytes_per_line, 640u * 2u);
  EXPECT_GE(cap.format().size_image_bytes, cap.format().bytes_per_line * 480u);
  EXPECT_GE(cap.buffer_count(), 2);
  std::printf("%s: YUYV 640x480 bytesperline %u sizeimage %u, %d buffers\n", device, cap.format().bytes_per_line,
              cap.format().size_image_bytes, cap.buffer_count());
}

TEST(V4l2Hardware, RefusesAFormatTheDriverCannotGive) {
  QSG_REQUIRE_V4L2_DEVICE(device);
  V4l2Capture cap;
  V4l2Capture::Config c = vivid_config(device);
  c.pixel_format = v4l2::kPixelFormatZ16;  // vivid has no depth format
  std::string error;
  EXPECT_FALSE(cap.open(c, &error));
  EXPECT_NE(error.find("Z16"), std::string::npos) << error;
  std::printf("refusal as reported: %s\n", error.c_str());
}

TEST(V4l2Hardware, StreamsFramesWithIncreasingSequenceAndTime) {
  QSG_REQUIRE_V4L2_DEVICE(device);
  V4l2Capture cap;
  std::string error;
  ASSERT_TRUE(cap.open(vivid_config(device), &error)) << error;
  ASSERT_TRUE(cap.start(&error)) << error;
  const int want = frames_to_stream();
  CapturedFrame f;
  bool have_prev = false;
  std::uint64_t prev_sequence = 0;
  std::int64_t prev_time_ns = 0;
  std::int64_t first_time_ns = 0;
  int ok = 0;
  for (int attempt = 0; attempt < want * 3 && ok < want; ++attempt) {
    const ReadStatus s = cap.next(&f, 2'000'000'000);
    if (s != ReadStatus::kOk) {
      ASSERT_NE(s, ReadStatus::kDisconnected) << cap.last_error();
      continue;
    }
    ++ok;
    EXPECT_GE(f.bytes_used, cap.format().size_image_bytes);
    EXPECT_GT(f.sample_time_ns, 0);
    EXPECT_GE(f.dequeue_time_ns, f.sample_time_ns);
    if (have_prev) {
      EXPECT_GT(f.sequence, prev_sequence);
      EXPECT_GT(f.sample_time_ns, prev_time_ns);
    } else {
      first_time_ns = f.sample_time_ns;
    }
    have_prev = true;
    prev_sequence = f.sequence;
    prev_time_ns = f.sample_time_ns;
    ASSERT_TRUE(cap.release(f)) << cap.last_error();
  }
  EXPECT_EQ(ok, want);
  const v4l2::CaptureCounters& c = cap.counters();
  EXPECT_EQ(c.driver.timestamps_backwards, 0u);
  EXPECT_EQ(c.sequence_errors, 0u);
  const double span_s = static_cast<double>(prev_time_ns - first_time_ns) * 1e-9;
  std::printf("%s: %d frames, last sequence %llu, %.2f fps, dropped %llu, stalls %llu, late %llu, eintr %llu, "
              "eagain %llu\n",
              device, ok, static_cast<unsigned long long>(prev_sequence), span_s > 0 ? (ok - 1) / span_s : 0.0,
              static_cast<unsigned long long>(c.driver.dropped), static_cast<unsigned long long>(c.driver.stalls),
              static_cast<unsigned long long>(c.driver.late), static_cast<unsigned long long>(c.eintr_retries),
              static_cast<unsigned long long>(c.eagain_retries));
}

TEST(V4l2Hardware, CloseAndReopenStreamsAgain) {
  QSG_REQUIRE_V4L2_DEVICE(device);
  V4l2Capture cap;
  std::string error;
  ASSERT_TRUE(cap.open(vivid_config(device), &error) && cap.start(&error)) << error;
  CapturedFrame f;
  ASSERT_EQ(cap.next(&f, 2'000'000'000), ReadStatus::kOk) << cap.last_error();
  const std::uint64_t before = f.sequence;
  ASSERT_TRUE(cap.reopen(&error)) << error;
  ASSERT_EQ(cap.next(&f, 2'000'000'000), ReadStatus::kOk) << cap.last_error();
  EXPECT_GT(f.sequence, before);
  EXPECT_TRUE(f.flags & messages::kFrameAfterReconnect);
}

}  // namespace
}  // namespace qsg::testing
