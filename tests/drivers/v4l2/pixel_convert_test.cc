// Pixel conversions: YUYV colours against BT.601 reference values, strides dropped, Z16 scale and no-return pixels.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "drivers/v4l2/pixel_convert.h"

namespace qsg::testing {
namespace {

TEST(PixelConvert, YuyvGivesBt601Colours) {
  // One row of 4 pixels: white, black, then a pair sharing a red chroma, plus 4 bytes of row padding.
  const std::vector<std::uint8_t> row = {235, 128, 16, 128, 81, 90, 81, 240, 0xEE, 0xEE, 0xEE, 0xEE};
  std::vector<std::uint8_t> rgb(4 * 3, 7);
  v4l2::yuyv_to_rgb(row.data(), 12, 4, 1, rgb.data());
  EXPECT_EQ(rgb[0], 255);
  EXPECT_EQ(rgb[1], 255);
  EXPECT_EQ(rgb[2], 255);
  EXPECT_EQ(rgb[3], 0);
  EXPECT_EQ(rgb[4], 0);
  EXPECT_EQ(rgb[5], 0);
  // BT.601 red is Y=81, Cb=90, Cr=240.
  EXPECT_GE(rgb[6], 250);
  EXPECT_LE(rgb[7], 5);
  EXPECT_LE(rgb[8], 5);
}

TEST(PixelConvert, Rgb24DropsRowPadding) {
  const std::vector<std::uint8_t> src = {1, 2, 3, 4, 5, 6, 99, 99, 7, 8, 9, 10, 11, 12, 99, 99};
  std::vector<std::uint8_t> rgb(12, 0);
  v4l2::rgb24_to_rgb(src.data(), 8, 2, 2, rgb.data());
  EXPECT_EQ(rgb, (std::vector<std::uint8_t>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12}));
}

TEST(PixelConvert, Z16ScalesAndMarksNoReturn) {
  // 2x2 little-endian: 1000, 0 | 65535, 1, with 2 bytes of padding per row.
  const std::vector<std::uint8_t> src = {0xE8, 0x03, 0x00, 0x00, 0xAA, 0xAA, 0xFF, 0xFF, 0x01, 0x00, 0xAA, 0xAA};
  std::vector<float> depth(4, -1.0f);
  const int invalid = v4l2::z16_to_metres(src.data(), 6, 2, 2, 0.001f, depth.data());
  EXPECT_EQ(invalid, 1);
  EXPECT_FLOAT_EQ(depth[0], 1.0f);
  EXPECT_EQ(depth[1], 0.0f);
  EXPECT_FLOAT_EQ(depth[2], 65.535f);
  EXPECT_FLOAT_EQ(depth[3], 0.001f);
}

}  // namespace
}  // namespace qsg::testing
