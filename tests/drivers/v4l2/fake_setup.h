// Shared set-up of the V4L2 tests: small fake nodes (160x120 keeps each test fast, also under qemu).
#pragma once

#include <cstring>
#include <memory>

#include "drivers/v4l2/fake_v4l2_device.h"
#include "drivers/v4l2/v4l2_capture.h"

namespace qsg::testing {

inline constexpr int kTestWidth = 160;
inline constexpr int kTestHeight = 120;

inline v4l2::FakeV4l2Device::Config small_colour_node(const char* path = "/dev/video0") {
  v4l2::FakeV4l2Device::Config c;
  c.path = path;
  c.formats = {{v4l2::FakeV4l2Device::kYuyv, kTestWidth, kTestHeight},
               {v4l2::FakeV4l2Device::kYuyv, 320, 240},
               {v4l2::FakeV4l2Device::kRgb24, kTestWidth, kTestHeight}};
  c.endless = false;
  return c;
}

inline v4l2::FakeV4l2Device::Config small_depth_node(const char* path = "/dev/video1") {
  v4l2::FakeV4l2Device::Config c;
  c.path = path;
  c.card = "quadsg fake depth";
  c.formats = {{v4l2::FakeV4l2Device::kZ16, kTestWidth, kTestHeight}};
  c.endless = false;
  return c;
}

inline v4l2::V4l2Capture::Config small_capture(std::uint32_t pixel_format = v4l2::kPixelFormatYuyv,
                                               const char* path = "/dev/video0") {
  v4l2::V4l2Capture::Config c;
  c.device = path;
  c.pixel_format = pixel_format;
  c.width_px = kTestWidth;
  c.height_px = kTestHeight;
  c.buffer_count = 4;
  return c;
}

inline bool contains(const std::string& text, const char* part) { return text.find(part) != std::string::npos; }

}  // namespace qsg::testing
