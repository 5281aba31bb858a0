// V4L2 capture against the fake node: negotiation, streaming, timeouts, every scripted fault, no per-frame allocation.
#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include <string>

#include "drivers/v4l2/fake_v4l2_device.h"
#include "drivers/v4l2/v4l2_capture.h"
#include "tests/drivers/v4l2/fake_setup.h"
#include "tests/support/allocation_counter.h"

namespace qsg::testing {
namespace {

using drivers::ReadStatus;
using v4l2::CapturedFrame;
using v4l2::FakeEventKind;
using v4l2::FakeV4l2Device;
using v4l2::V4l2Capture;

constexpr std::int64_t kTimeoutNs = 100'000'000;

TEST(V4l2Capture, NegotiatesFormatAndMapsEveryBuffer) {
  FakeV4l2Device::Config fc = small_colour_node();
  fc.row_padding_bytes = 16;
  FakeV4l2Device fake(fc);
  V4l2Capture cap(fake);
  std::string error;
  ASSERT_TRUE(cap.open(small_capture(), &error)) << error;
  EXPECT_EQ(cap.format().pixel_format, v4l2::kPixelFormatYuyv);
  EXPECT_EQ(cap.format().width_px, kTestWidth);
  EXPECT_EQ(cap.format().height_px, kTestHeight);
  EXPECT_EQ(cap.format().bytes_per_line, static_cast<std::uint32_t>(kTestWidth * 2 + 16));
  EXPECT_EQ(cap.format().size_image_bytes, cap.format().bytes_per_line * kTestHeight);
  EXPECT_EQ(cap.buffer_count(), 4);
  EXPECT_EQ(fake.live_mappings(), 4);
  EXPECT_EQ(fake.calls(VIDIOC_QUERYBUF), 4u);
  cap.close();
  EXPECT_EQ(fake.live_mappings(), 0);
  EXPECT_FALSE(fake.is_open());
}

TEST(V4l2Capture, RefusesAPixelFormatTheDriverDoesNotOffer) {
  FakeV4l2Device fake(small_colour_node());
  V4l2Capture cap(fake);
  std::string error;
  EXPECT_FALSE(cap.open(small_capture(v4l2::kPixelFormatZ16), &error));
  EXPECT_TRUE(contains(error, "/dev/video0")) << error;
  EXPECT_TRUE(contains(error, "Z16")) << error;
  EXPECT_TRUE(contains(error, "VIDIOC_S_FMT")) << error;
  EXPECT_TRUE(contains(error, "YUYV, RGB3")) << "the error lists what the device offers: " << error;
  EXPECT_FALSE(fake.is_open()) << "a refused open leaves nothing open";
  EXPECT_EQ(fake.live_mappings(), 0);
  EXPECT_FALSE(cap.is_open());
}

TEST(V4l2Capture, RefusesASizeTheDriverAdjusts) {
  FakeV4l2Device fake(small_colour_node());
  V4l2Capture cap(fake);
  V4l2Capture::Config c = small_capture();
  c.width_px = 640;
  c.height_px = 480;
  std::string error;
  EXPECT_FALSE(cap.open(c, &error));
  EXPECT_TRUE(contains(error, "640x480")) << error;
  EXPECT_TRUE(contains(error, "320x240")) << "names the driver's answer: " << error;
}

TEST(V4l2Capture, RefusesAFormatThatDoesNotStick) {
  FakeV4l2Device::Config fc = small_colour_node();
  fc.g_fmt_disagrees = true;
  FakeV4l2Device fake(fc);
  V4l2Capture cap(fake);
  std::string error;
  EXPECT_FALSE(cap.open(small_capture(), &error));
  EXPECT_TRUE(contains(error, "did not stick")) << error;
}

TEST(V4l2Capture, RefusesNodesThatCannotCaptureOrStream) {
  FakeV4l2Device::Config fc = small_colour_node();
  fc.streaming_capability = false;
  FakeV4l2Device no_streaming(fc);
  V4l2Capture cap(no_streaming);
  std::string error;
  EXPECT_FALSE(cap.open(small_capture(), &error));
  EXPECT_TRUE(contains(error, "V4L2_CAP_STREAMING")) << error;

  fc = small_colour_node();
  fc.capture_capability = false;
  FakeV4l2Device output_only(fc);
  V4l2Capture cap2(output_only);
  EXPECT_FALSE(cap2.open(small_capture(), &error));
  EXPECT_TRUE(contains(error, "not a single-planar video capture node")) << error;
}

TEST(V4l2Capture, MissingDeviceAndBadConfigGiveClearErrors) {
  FakeV4l2Device fake(small_colour_node());
  V4l2Capture cap(fake);
  std::string error;
  EXPECT_FALSE(cap.open(small_capture(v4l2::kPixelFormatYuyv, "/dev/video9"), &error));
  EXPECT_TRUE(contains(error, "/dev/video9") && contains(error, "cannot open")) << error;

  V4l2Capture::Config c = small_capture();
  c.buffer_count = 1;
  EXPECT_FALSE(cap.open(c, &error));
  EXPECT_TRUE(contains(error, "buffer_count")) << error;
  c = small_capture(v4l2::make_fourcc('M', 'J', 'P', 'G'));
  EXPECT_FALSE(cap.open(c, &error));
  EXPECT_TRUE(contains(error, "MJPG")) << error;
  EXPECT_EQ(cap.next(nullptr, 0), ReadStatus::kDisconnected) << "next() without open() is refused, not a crash";
}

TEST(V4l2Capture, StreamsScriptedFramesInOrder) {
  FakeV4l2Device fake(small_colour_node());
  fake.push_frames(10);
  V4l2Capture cap(fake);
  std::string error;
  ASSERT_TRUE(cap.open(small_capture(), &error)) << error;
  ASSERT_TRUE(cap.start(&error)) << error;
  EXPECT_TRUE(fake.is_streaming());
  EXPECT_EQ(fake.queued_count(), 4);
  CapturedFrame f;
  std::int64_t prev_ns = 0;
  for (std::uint64_t i = 0; i < 10; ++i) {
    ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk) << "frame " << i << ": " << cap.last_error();
    EXPECT_EQ(f.sequence, i);
    EXPECT_EQ(f.driver_sequence, i);
    EXPECT_EQ(f.flags, 0u);
    EXPECT_EQ(f.bytes_used, static_cast<std::uint32_t>(kTestWidth * kTestHeight * 2));
    EXPECT_EQ(f.data[0], static_cast<std::uint8_t>(i)) << "the buffer holds this frame's pixels";
    // V4L2 stamps with a timeval: microsecond resolution.
    EXPECT_EQ(f.sample_time_ns, (1'000'000'000 + static_cast<std::int64_t>(i) * 33'333'333) / 1000 * 1000);
    if (i > 0) {
      EXPECT_GT(f.sample_time_ns, prev_ns);
    }
    EXPECT_GE(f.dequeue_time_ns, f.sample_time_ns);
    prev_ns = f.sample_time_ns;
    EXPECT_TRUE(cap.release(f));
  }
  EXPECT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kTimeout) << "script exhausted";
  EXPECT_EQ(cap.counters().driver.delivered, 10u);
  EXPECT_EQ(cap.counters().driver.stalls, 1u);
  EXPECT_EQ(cap.counters().driver.dropped, 0u);
  cap.close();
  EXPECT_EQ(fake.live_mappings(), 0);
}

TEST(V4l2Capture, TimeoutWaitsOnTheDeviceClockNotTheWallClock) {
  FakeV4l2Device fake(small_colour_node());
  fake.push(FakeEventKind::kStall);
  fake.push_frames(1);
  V4l2Capture cap(fake);
  std::string error;
  ASSERT_TRUE(cap.open(small_capture(), &error) && cap.start(&error)) << error;
  const std::int64_t before_ns = fake.monotonic_ns();
  CapturedFrame f;
  EXPECT_EQ(cap.next(&f, 50'000'000), ReadStatus::kTimeout);
  EXPECT_EQ(fake.monotonic_ns() - before_ns, 50'000'000) << "poll got the whole timeout";
  EXPECT_EQ(cap.next(&f, 0), ReadStatus::kOk) << "the frame after a stall still comes";
}

TEST(V4l2Capture, EagainAndEintrAreRetried) {
  FakeV4l2Device fake(small_colour_node());
  fake.push(FakeEventKind::kPollEintr);
  fake.push_frames(1);
  fake.push(FakeEventKind::kDqbufEagain);
  fake.push_frames(1);
  fake.push(FakeEventKind::kDqbufEintr);
  fake.push_frames(1);
  V4l2Capture cap(fake);
  std::string error;
  ASSERT_TRUE(cap.open(small_capture(), &error) && cap.start(&error)) << error;
  CapturedFrame f;
  for (std::uint64_t i = 0; i < 3; ++i) {
    ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk) << i << ": " << cap.last_error();
    EXPECT_EQ(f.sequence, i);
    cap.release(f);
  }
  EXPECT_EQ(cap.counters().eintr_retries, 2u);
  EXPECT_EQ(cap.counters().eagain_retries, 1u);
  EXPECT_EQ(cap.counters().driver.bad_frames, 0u);
}

TEST(V4l2Capture, RetriesAreBounded) {
  FakeV4l2Device fake(small_colour_node());
  for (int i = 0; i < 5; ++i) fake.push(FakeEventKind::kDqbufEagain);
  fake.push_frames(1);
  V4l2Capture cap(fake);
  V4l2Capture::Config c = small_capture();
  c.max_retries = 2;
  std::string error;
  ASSERT_TRUE(cap.open(c, &error) && cap.start(&error)) << error;
  CapturedFrame f;
  EXPECT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kTimeout) << "3 attempts, 3 EAGAINs";
  EXPECT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(cap.counters().eagain_retries, 5u);
}

TEST(V4l2Capture, EnodevMidStreamIsCountedAndKeepsReturnedFramesIntact) {
  FakeV4l2Device fake(small_colour_node());
  fake.push_frames(3);
  fake.push(FakeEventKind::kVanish);
  fake.push_frames(2);
  V4l2Capture cap(fake);
  std::string error;
  ASSERT_TRUE(cap.open(small_capture(), &error) && cap.start(&error)) << error;
  CapturedFrame f0, f1, f2;
  ASSERT_EQ(cap.next(&f0, kTimeoutNs), ReadStatus::kOk);
  ASSERT_EQ(cap.next(&f1, kTimeoutNs), ReadStatus::kOk);
  ASSERT_EQ(cap.next(&f2, kTimeoutNs), ReadStatus::kOk);
  cap.release(f2);
  CapturedFrame f;
  EXPECT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kDisconnected);
  EXPECT_TRUE(cap.disconnected());
  EXPECT_EQ(cap.counters().driver.disconnects, 1u);
  EXPECT_TRUE(contains(cap.last_error(), "ENODEV") && contains(cap.last_error(), "/dev/video0")) << cap.last_error();
  // The held frames are still mapped and unchanged.
  EXPECT_EQ(fake.live_mappings(), 4);
  EXPECT_EQ(f0.data[0], 0u);
  EXPECT_EQ(f1.data[kTestWidth * kTestHeight * 2 - 1], 1u);
  EXPECT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kDisconnected) << "sticky until reopened";
  EXPECT_EQ(cap.counters().driver.disconnects, 1u) << "one disconnect, counted once";
  EXPECT_FALSE(cap.release(f0)) << "releasing into a vanished device is refused quietly";

  EXPECT_FALSE(cap.reopen(&error)) << "still unplugged";
  EXPECT_TRUE(contains(error, "cannot open")) << error;
  fake.reappear();
  ASSERT_TRUE(cap.reopen(&error)) << error;
  EXPECT_EQ(cap.counters().driver.reconnects, 1u);
  EXPECT_EQ(fake.live_mappings(), 4) << "old mappings released, new ones made";
  ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk) << cap.last_error();
  EXPECT_TRUE(f.flags & messages::kFrameAfterReconnect);
  EXPECT_EQ(f.sequence, 3u) << "sequence continues across the reconnect although the driver restarted at 0";
  EXPECT_EQ(f.driver_sequence, 0u);
  cap.release(f);
  ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(f.flags, 0u);
  EXPECT_EQ(f.sequence, 4u);
}

TEST(V4l2Capture, SequenceGapsAreCountedAsDropped) {
  FakeV4l2Device fake(small_colour_node());
  fake.push_frames(2);
  fake.push_gap(3);
  fake.push_frames(1);
  V4l2Capture cap(fake);
  std::string error;
  ASSERT_TRUE(cap.open(small_capture(), &error) && cap.start(&error)) << error;
  CapturedFrame f;
  ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk);
  cap.release(f);
  ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk);
  cap.release(f);
  ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(f.sequence, 5u);
  EXPECT_EQ(f.dropped_before, 3u);
  EXPECT_TRUE(f.flags & messages::kFrameSequenceGap);
  EXPECT_EQ(cap.counters().driver.dropped, 3u);
}

TEST(V4l2Capture, BackwardTimestampsAreRejectedAndCounted) {
  FakeV4l2Device fake(small_colour_node());
  fake.push_frames(2);
  fake.push_backwards(5'000'000);
  fake.push_frames(2);
  V4l2Capture cap(fake);
  std::string error;
  ASSERT_TRUE(cap.open(small_capture(), &error) && cap.start(&error)) << error;
  CapturedFrame f;
  std::int64_t last_ns = 0;
  for (int i = 0; i < 2; ++i) {
    ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk);
    last_ns = f.sample_time_ns;
    cap.release(f);
  }
  EXPECT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kBadFrame);
  EXPECT_TRUE(contains(cap.last_error(), "not after")) << cap.last_error();
  EXPECT_EQ(fake.queued_count(), 4) << "the rejected buffer went back to the driver";
  ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk);
  EXPECT_GT(f.sample_time_ns, last_ns);
  EXPECT_EQ(f.sequence, 3u);
  EXPECT_TRUE(f.flags & messages::kFrameSequenceGap) << "frame 2 was never delivered";
  EXPECT_EQ(cap.counters().driver.timestamps_backwards, 1u);
  EXPECT_EQ(cap.counters().driver.bad_frames, 1u);
  EXPECT_EQ(cap.counters().driver.dropped, 0u) << "the driver lost nothing";
}

TEST(V4l2Capture, CorruptShortAndRepeatedFramesAreRejected) {
  FakeV4l2Device fake(small_colour_node());
  fake.push_frames(1);
  fake.push(FakeEventKind::kErrorFlag);
  fake.push(FakeEventKind::kShortFrame);
  fake.push(FakeEventKind::kSequenceRepeat);
  fake.push(FakeEventKind::kDqbufEio);
  fake.push_frames(1);
  V4l2Capture cap(fake);
  std::string error;
  ASSERT_TRUE(cap.open(small_capture(), &error) && cap.start(&error)) << error;
  CapturedFrame f;
  ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk);
  cap.release(f);
  EXPECT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kBadFrame);
  EXPECT_TRUE(contains(cap.last_error(), "V4L2_BUF_FLAG_ERROR")) << cap.last_error();
  EXPECT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kBadFrame);
  EXPECT_TRUE(contains(cap.last_error(), "bytes")) << cap.last_error();
  EXPECT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kBadFrame);
  EXPECT_TRUE(contains(cap.last_error(), "sequence")) << cap.last_error();
  EXPECT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kBadFrame);
  EXPECT_TRUE(contains(cap.last_error(), "DQBUF")) << cap.last_error();
  ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(f.sequence, 3u);
  const v4l2::CaptureCounters& c = cap.counters();
  EXPECT_EQ(c.flagged_errors, 1u);
  EXPECT_EQ(c.short_frames, 1u);
  EXPECT_EQ(c.sequence_errors, 1u);
  EXPECT_EQ(c.io_errors, 1u);
  EXPECT_EQ(c.driver.bad_frames, 3u);
  EXPECT_EQ(fake.queued_count(), 3) << "every rejected buffer was requeued; one is held";
}

TEST(V4l2Capture, LateAndUnknownClockFramesAreHandled) {
  FakeV4l2Device::Config fc = small_colour_node();
  fc.latency_ns = 150'000'000;
  FakeV4l2Device late(fc);
  late.push_frames(1);
  V4l2Capture cap(late);
  std::string error;
  ASSERT_TRUE(cap.open(small_capture(), &error) && cap.start(&error)) << error;
  CapturedFrame f;
  ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk);
  EXPECT_TRUE(f.flags & messages::kFrameLate);
  EXPECT_EQ(cap.counters().driver.late, 1u);

  fc = small_colour_node();
  fc.monotonic_timestamps = false;
  FakeV4l2Device unknown(fc);
  unknown.push_frames(1);
  V4l2Capture cap2(unknown);
  ASSERT_TRUE(cap2.open(small_capture(), &error) && cap2.start(&error)) << error;
  ASSERT_EQ(cap2.next(&f, kTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(f.sample_time_ns, f.dequeue_time_ns) << "a non-monotonic stamp is replaced by the dequeue time";
}

TEST(V4l2Capture, HoldingEveryBufferStallsWithoutCrashing) {
  FakeV4l2Device fake(small_colour_node());
  fake.push_frames(6);
  V4l2Capture cap(fake);
  std::string error;
  ASSERT_TRUE(cap.open(small_capture(), &error) && cap.start(&error)) << error;
  CapturedFrame held[4];
  for (auto& h : held) ASSERT_EQ(cap.next(&h, kTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(cap.buffers_held(), 4);
  CapturedFrame f;
  EXPECT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kTimeout) << "no buffer to fill";
  cap.release(held[0]);
  ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(f.sequence, 4u);
}

TEST(V4l2Capture, StopAndStartContinueTheSequence) {
  FakeV4l2Device fake(small_colour_node());
  fake.push_frames(4);
  V4l2Capture cap(fake);
  std::string error;
  ASSERT_TRUE(cap.open(small_capture(), &error) && cap.start(&error)) << error;
  CapturedFrame kept, f;
  ASSERT_EQ(cap.next(&kept, kTimeoutNs), ReadStatus::kOk);
  ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk);
  cap.release(f);
  cap.stop();
  EXPECT_FALSE(fake.is_streaming());
  EXPECT_EQ(kept.data[0], 0u) << "a held frame survives STREAMOFF";
  ASSERT_TRUE(cap.start(&error)) << error;
  EXPECT_EQ(fake.queued_count(), 3) << "the held buffer is not queued";
  ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk);
  EXPECT_EQ(f.driver_sequence, 0u);
  EXPECT_EQ(f.sequence, 2u);
  EXPECT_EQ(f.flags, 0u);
  cap.release(f);
  cap.release(kept);
  EXPECT_EQ(fake.queued_count(), 4);
}

TEST(V4l2Capture, NoAllocationPerFrameAfterStart) {
  FakeV4l2Device::Config fc = small_colour_node();
  fc.endless = true;
  FakeV4l2Device fake(fc);
  V4l2Capture cap(fake);
  std::string error;
  ASSERT_TRUE(cap.open(small_capture(), &error) && cap.start(&error)) << error;
  CapturedFrame f;
  ASSERT_EQ(cap.next(&f, kTimeoutNs), ReadStatus::kOk);
  cap.release(f);
  int ok = 0;
  EXPECT_NO_ALLOCATIONS(for (int i = 0; i < 50; ++i) {
    if (cap.next(&f, kTimeoutNs) == ReadStatus::kOk) {
      ++ok;
      cap.release(f);
    }
  });
  EXPECT_EQ(ok, 50);
}

}  // namespace
}  // namespace qsg::testing
