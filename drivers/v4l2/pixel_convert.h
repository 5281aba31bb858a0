// Conversions from V4L2 buffers (rows bytes_per_line apart) into RgbdFrame's packed buffers. None allocates.
#pragma once

#include <cstdint>

namespace qsg::v4l2 {

// YUYV 4:2:2 (BT.601, limited range: what webcams and vivid deliver) to 8-bit RGB. width_px must be even.
void yuyv_to_rgb(const std::uint8_t* src, std::uint32_t bytes_per_line, int width_px, int height_px,
                 std::uint8_t* rgb_out);
// RGB24 rows to packed RGB (drops row padding).
void rgb24_to_rgb(const std::uint8_t* src, std::uint32_t bytes_per_line, int width_px, int height_px,
                  std::uint8_t* rgb_out);
// Z16 (little-endian 16-bit depth units) to metres: raw * scale_m; raw 0 means no return and becomes 0.
// Returns the number of pixels without a return.
int z16_to_metres(const std::uint8_t* src, std::uint32_t bytes_per_line, int width_px, int height_px,
                  float scale_m, float* depth_out_m);

}  // namespace qsg::v4l2
