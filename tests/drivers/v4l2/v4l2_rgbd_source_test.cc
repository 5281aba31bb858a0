// The depth + colour pair over two fake nodes: pairing by timestamp, conversions, unpaired frames, faults,
// reconnects, configuration errors, and the RgbdSource contract.
#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <string>

#include "drivers/v4l2/fake_v4l2_device.h"
#include "drivers/v4l2/v4l2_rgbd_source.h"
#include "tests/drivers/rgbd_source_contract.h"
#include "tests/drivers/v4l2/fake_setup.h"

namespace qsg::testing {
namespace {

using drivers::ReadStatus;
using v4l2::FakeEventKind;
using v4l2::FakeV4l2Device;
using v4l2::V4l2RgbdSource;

// Depth raw = 1000 + sequence (so 1 mm steps); row 0 has no return (raw 0) when `holes`.
void paint_depth(const v4l2::FakeFrameInfo& info, std::uint8_t* data, std::size_t /*bytes*/, bool holes) {
  for (int y = 0; y < info.height_px; ++y) {
    for (int x = 0; x < info.width_px; ++x) {
      const std::uint16_t raw = (holes && y < info.height_px * 3 / 4) ? 0 : static_cast<std::uint16_t>(1000 + info.sequence);
      std::memcpy(data + static_cast<std::size_t>(y) * info.bytes_per_line + 2 * x, &raw, 2);
    }
  }
}

// Grey YUYV whose luma encodes the sequence (Y = 16 + sequence gives R = G = B ~ 1.164 * sequence).
void paint_colour(const v4l2::FakeFrameInfo& info, std::uint8_t* data, std::size_t /*bytes*/) {
  for (int y = 0; y < info.height_px; ++y) {
    std::uint8_t* row = data + static_cast<std::size_t>(y) * info.bytes_per_line;
    for (int x = 0; x < info.width_px; x += 2) {
      row[2 * x] = static_cast<std::uint8_t>(16 + info.sequence % 200);
      row[2 * x + 1] = 128;
      row[2 * x + 2] = static_cast<std::uint8_t>(16 + info.sequence % 200);
      row[2 * x + 3] = 128;
    }
  }
}

// Two fake nodes on one clock plus the source reading them; colour frames lag depth by colour_offset_ns.
struct FakeRgbdCamera {
  explicit FakeRgbdCamera(bool endless, std::int64_t colour_offset_ns = 3'000'000,
                          std::uint32_t colour_format = FakeV4l2Device::kYuyv, bool holes = false)
      : depth(depth_config(endless), &clock),
        colour(colour_config(endless, colour_offset_ns), &clock),
        source(depth, colour) {
    depth.set_painter([holes](const v4l2::FakeFrameInfo& i, std::uint8_t* d, std::size_t b) {
      paint_depth(i, d, b, holes);
    });
    if (colour_format == FakeV4l2Device::kYuyv) colour.set_painter(paint_colour);
    config.depth = small_capture(v4l2::kPixelFormatZ16, "/dev/video1");
    config.colour = small_capture(colour_format, "/dev/video0");
    config.intrinsics = messages::CameraIntrinsics{kTestWidth, kTestHeight, 131.25, 131.25, 79.5, 59.5};
  }
  static FakeV4l2Device::Config depth_config(bool endless) {
    FakeV4l2Device::Config c = small_depth_node();
    c.endless = endless;
    return c;
  }
  static FakeV4l2Device::Config colour_config(bool endless, std::int64_t offset_ns) {
    FakeV4l2Device::Config c = small_colour_node();
    c.endless = endless;
    c.first_timestamp_ns += offset_ns;
    return c;
  }
  bool init(std::string* error) { return source.init(config, error); }

  v4l2::FakeClock clock;
  FakeV4l2Device depth;
  FakeV4l2Device colour;
  V4l2RgbdSource source;
  V4l2RgbdSource::Config config;
};

std::shared_ptr<drivers::RgbdSource> make_pair(std::uint32_t colour_format, bool faults, std::string* reason);

class V4l2RgbdSourceTest : public ::testing::Test {
 protected:
  std::unique_ptr<messages::RgbdFrame> frame_ = std::make_unique<messages::RgbdFrame>();
};

TEST_F(V4l2RgbdSourceTest, PairsFramesByTimestampAndConvertsThem) {
  FakeRgbdCamera cam(/*endless=*/false);
  cam.depth.push_frames(5);
  cam.colour.push_frames(5);
  std::string error;
  ASSERT_TRUE(cam.init(&error)) << error;
  for (std::uint64_t i = 0; i < 5; ++i) {
    ASSERT_EQ(cam.source.read(*frame_, 100'000'000), ReadStatus::kOk) << i << ": " << cam.source.last_error();
    EXPECT_EQ(frame_->sequence, i);
    EXPECT_EQ(frame_->width(), kTestWidth);
    EXPECT_EQ(frame_->height(), kTestHeight);
    EXPECT_EQ(frame_->intrinsics.fx, 131.25);
    EXPECT_FLOAT_EQ(frame_->depth_m[0], (1000.0f + static_cast<float>(i)) * 0.001f);
    EXPECT_FLOAT_EQ(frame_->depth_m[frame_->pixels() - 1], (1000.0f + static_cast<float>(i)) * 0.001f);
    // Y = 16 + i maps to about 1.164 * i: the colour frame of the same index was paired.
    EXPECT_NEAR(frame_->rgb[0], 1.164 * static_cast<double>(i), 1.0);
    EXPECT_EQ(frame_->rgb[0], frame_->rgb[1]);
    EXPECT_EQ(frame_->sample_time_ns, (1'000'000'000 + static_cast<std::int64_t>(i) * 33'333'333) / 1000 * 1000);
    EXPECT_GE(frame_->publish_time_ns, frame_->sample_time_ns);
    EXPECT_EQ(frame_->flags, 0u);
    EXPECT_FALSE(frame_->has_labels);
  }
  EXPECT_EQ(cam.source.read(*frame_, 10'000'000), ReadStatus::kTimeout);
  EXPECT_EQ(cam.source.counters().delivered, 5u);
  EXPECT_EQ(cam.source.counters().stalls, 1u);
  EXPECT_EQ(cam.source.pair_counters().unpaired_depth, 0u);
  EXPECT_EQ(cam.source.pair_counters().unpaired_colour, 0u);
}

TEST_F(V4l2RgbdSourceTest, DropsADepthFrameWhoseColourWasLost) {
  FakeRgbdCamera cam(/*endless=*/false);
  cam.depth.push_frames(4);
  cam.colour.push_frames(1);
  cam.colour.push_gap(1);  // colour frame 1 never arrives
  cam.colour.push_frames(2);
  std::string error;
  ASSERT_TRUE(cam.init(&error)) << error;
  ASSERT_EQ(cam.source.read(*frame_, 100'000'000), ReadStatus::kOk);
  EXPECT_EQ(frame_->sequence, 0u);
  ASSERT_EQ(cam.source.read(*frame_, 100'000'000), ReadStatus::kOk);
  EXPECT_EQ(frame_->sequence, 2u) << "depth frame 1 has no partner";
  EXPECT_TRUE(frame_->flags & messages::kFrameSequenceGap);
  EXPECT_NEAR(frame_->rgb[0], 1.164 * 2.0, 1.0) << "paired with colour frame 2";
  EXPECT_EQ(cam.source.pair_counters().unpaired_depth, 1u);
  EXPECT_EQ(cam.source.counters().dropped, 1u);
  ASSERT_EQ(cam.source.read(*frame_, 100'000'000), ReadStatus::kOk);
  EXPECT_EQ(frame_->sequence, 3u);
  EXPECT_EQ(frame_->flags, 0u);
}

TEST_F(V4l2RgbdSourceTest, StreamsThatNeverAlignTimeOutWithoutSpinning) {
  FakeRgbdCamera cam(/*endless=*/true, /*colour_offset_ns=*/16'000'000);  // half a period apart
  std::string error;
  ASSERT_TRUE(cam.init(&error)) << error;
  for (int i = 0; i < 3; ++i) EXPECT_EQ(cam.source.read(*frame_, 100'000'000), ReadStatus::kTimeout);
  EXPECT_EQ(cam.source.counters().delivered, 0u);
  EXPECT_GT(cam.source.pair_counters().unpaired_depth + cam.source.pair_counters().unpaired_colour, 0u);
}

TEST_F(V4l2RgbdSourceTest, RgbColourAndDepthHolesAreHandled) {
  FakeRgbdCamera cam(/*endless=*/true, 1'000'000, FakeV4l2Device::kRgb24, /*holes=*/true);
  std::string error;
  ASSERT_TRUE(cam.init(&error)) << error;
  ASSERT_EQ(cam.source.read(*frame_, 100'000'000), ReadStatus::kOk) << cam.source.last_error();
  EXPECT_EQ(frame_->depth_m[0], 0.0f) << "raw 0 = no return = 0 m";
  EXPECT_FLOAT_EQ(frame_->depth_m[frame_->pixels() - 1], 1.0f);
  EXPECT_TRUE(frame_->flags & messages::kFrameInvalidDepthRegion) << "3/4 of the pixels have no return";
  EXPECT_EQ(cam.source.counters().invalid_depth_frames, 1u);
  EXPECT_EQ(frame_->rgb[0], 0u) << "the default painter fills RGB24 frame 0 with zeros";
}

TEST_F(V4l2RgbdSourceTest, DisconnectIsStickyUntilTheDeviceIsBack) {
  FakeRgbdCamera cam(/*endless=*/true);
  cam.depth.push_frames(2);
  cam.depth.push(FakeEventKind::kVanish);
  std::string error;
  ASSERT_TRUE(cam.init(&error)) << error;
  ASSERT_EQ(cam.source.read(*frame_, 100'000'000), ReadStatus::kOk);
  ASSERT_EQ(cam.source.read(*frame_, 100'000'000), ReadStatus::kOk);
  EXPECT_EQ(cam.source.read(*frame_, 100'000'000), ReadStatus::kDisconnected);
  EXPECT_TRUE(contains(cam.source.last_error(), "/dev/video1")) << cam.source.last_error();
  EXPECT_EQ(cam.source.read(*frame_, 100'000'000), ReadStatus::kDisconnected);
  cam.clock.now_ns += 2'000'000'000;  // past the reconnect interval, still unplugged
  EXPECT_EQ(cam.source.read(*frame_, 100'000'000), ReadStatus::kDisconnected);
  EXPECT_TRUE(contains(cam.source.last_error(), "cannot open")) << cam.source.last_error();
  EXPECT_EQ(cam.source.counters().disconnects, 1u);
  cam.depth.reappear();
  EXPECT_EQ(cam.source.read(*frame_, 100'000'000), ReadStatus::kDisconnected) << "waits out the interval";
  cam.clock.now_ns += 2'000'000'000;
  // The colour node kept streaming: a few of its frames are older than anything depth will give and are skipped.
  ReadStatus s = ReadStatus::kTimeout;
  for (int i = 0; i < 5 && s != ReadStatus::kOk; ++i) s = cam.source.read(*frame_, 100'000'000);
  ASSERT_EQ(s, ReadStatus::kOk) << cam.source.last_error();
  EXPECT_TRUE(frame_->flags & messages::kFrameAfterReconnect);
  EXPECT_EQ(frame_->sequence, 2u);
  EXPECT_EQ(cam.source.counters().reconnects, 1u);
  EXPECT_EQ(cam.source.pair_counters().reconnect_attempts, 2u);
}

TEST_F(V4l2RgbdSourceTest, ConfigurationErrorsNameTheNode) {
  std::string error;
  {
    FakeRgbdCamera cam(true);
    cam.config.colour.width_px = 320;
    cam.config.colour.height_px = 240;
    EXPECT_FALSE(cam.init(&error));
    EXPECT_TRUE(contains(error, "same width and height")) << error;
  }
  {
    FakeRgbdCamera cam(true);
    cam.config.depth.pixel_format = v4l2::kPixelFormatYuyv;
    EXPECT_FALSE(cam.init(&error));
    EXPECT_TRUE(contains(error, "depth: pixel_format must be Z16")) << error;
  }
  {
    FakeRgbdCamera cam(true);
    cam.config.colour.device = "/dev/video7";
    EXPECT_FALSE(cam.init(&error));
    EXPECT_TRUE(contains(error, "colour node") && contains(error, "/dev/video7")) << error;
    EXPECT_FALSE(cam.depth.is_open()) << "the depth node is closed again";
  }
  {
    FakeRgbdCamera cam(true);
    EXPECT_EQ(cam.source.read(*frame_, 0), ReadStatus::kDisconnected) << "read before init";
  }
}

// The contract runs on endless fake pairs; each case keeps both fakes and the clock alive with the source.
std::shared_ptr<drivers::RgbdSource> make_pair(std::uint32_t colour_format, bool faults, std::string* reason) {
  auto cam = std::make_shared<FakeRgbdCamera>(/*endless=*/true, 2'000'000, colour_format);
  if (faults) {
    cam->depth.push_frames(3);
    cam->depth.push_gap(2);
    cam->depth.push(FakeEventKind::kDqbufEagain);
    cam->depth.push_frames(2);
    cam->depth.push_backwards(1'000'000);
    cam->depth.push_frames(2);
    cam->depth.push(FakeEventKind::kErrorFlag);
    cam->depth.push(FakeEventKind::kStall);
    cam->colour.push_frames(4);
    cam->colour.push(FakeEventKind::kPollEintr);
    cam->colour.push_gap(1);
    cam->colour.push(FakeEventKind::kShortFrame);
  }
  if (!cam->init(reason)) return nullptr;
  return std::shared_ptr<drivers::RgbdSource>(cam, &cam->source);
}

TEST_F(V4l2RgbdSourceTest, FaultyPairCountsEveryFault) {
  std::string reason;
  std::shared_ptr<drivers::RgbdSource> source = make_pair(FakeV4l2Device::kYuyv, true, &reason);
  ASSERT_TRUE(source) << reason;
  int ok = 0, bad = 0, timeouts = 0;
  for (int i = 0; i < 30; ++i) {
    const ReadStatus s = source->read(*frame_, 100'000'000);
    ok += s == ReadStatus::kOk;
    bad += s == ReadStatus::kBadFrame;
    timeouts += s == ReadStatus::kTimeout;
  }
  const drivers::DriverCounters& c = source->counters();
  EXPECT_EQ(c.delivered, static_cast<std::uint64_t>(ok));
  EXPECT_EQ(c.timestamps_backwards, 1u);
  EXPECT_EQ(c.bad_frames, 3u) << "backwards + error flag (depth) + short (colour)";
  EXPECT_EQ(bad, 3);
  EXPECT_EQ(timeouts, 1) << "the depth stall";
  EXPECT_GE(c.dropped, 2u) << "at least the depth gap of 2";
  const auto* pair = static_cast<const V4l2RgbdSource*>(source.get());
  EXPECT_EQ(pair->depth_capture().counters().eagain_retries, 1u);
  EXPECT_EQ(pair->colour_capture().counters().eintr_retries, 1u);
}

}  // namespace

INSTANTIATE_TEST_SUITE_P(
    V4l2Pair, RgbdSourceContract,
    ::testing::Values(
        RgbdContractCase{"yuyv", [](std::string* r) { return make_pair(FakeV4l2Device::kYuyv, false, r); },
                         /*finite=*/false, /*max_reads=*/60},
        RgbdContractCase{"rgb24", [](std::string* r) { return make_pair(FakeV4l2Device::kRgb24, false, r); },
                         /*finite=*/false, /*max_reads=*/60},
        RgbdContractCase{"yuyv_faults", [](std::string* r) { return make_pair(FakeV4l2Device::kYuyv, true, r); },
                         /*finite=*/false, /*max_reads=*/60}),
    rgbd_contract_case_name);

}  // namespace qsg::testing
