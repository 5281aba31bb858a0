// Pixel format conversions; see pixel_convert.h.
#include "drivers/v4l2/pixel_convert.h"

#include <cstddef>
#include <cstring>

namespace qsg::v4l2 {

namespace {

inline std::uint8_t clamp_byte(int v) { return static_cast<std::uint8_t>(v < 0 ? 0 : (v > 255 ? 255 : v)); }

// BT.601 limited range in 8.8 fixed point (the usual integer form of the standard's matrix).
inline void yuv_to_rgb(int y, int u, int v, std::uint8_t* out) {
  const int c = 298 * (y - 16) + 128;
  const int d = u - 128;
  const int e = v - 128;
  out[0] = clamp_byte((c + 409 * e) >> 8);
  out[1] = clamp_byte((c - 100 * d - 208 * e) >> 8);
  out[2] = clamp_byte((c + 516 * d) >> 8);
}

}  // namespace

void yuyv_to_rgb(const std::uint8_t* src, std::uint32_t bytes_per_line, int width_px, int height_px,
                 std::uint8_t* rgb_out) {
  for (int y = 0; y < height_px; ++y) {
    const std::uint8_t* row = src + static_cast<std::size_t>(y) * bytes_per_line;
    std::uint8_t* out = rgb_out + static_cast<std::size_t>(y) * static_cast<std::size_t>(width_px) * 3;
    for (int x = 0; x + 1 < width_px; x += 2) {
      const std::uint8_t* p = row + 2 * x;  // Y0 U Y1 V
      yuv_to_rgb(p[0], p[1], p[3], out + 3 * x);
      yuv_to_rgb(p[2], p[1], p[3], out + 3 * (x + 1));
    }
  }
}

void rgb24_to_rgb(const std::uint8_t* src, std::uint32_t bytes_per_line, int width_px, int height_px,
                  std::uint8_t* rgb_out) {
  const std::size_t row_bytes = static_cast<std::size_t>(width_px) * 3;
  for (int y = 0; y < height_px; ++y) {
    std::memcpy(rgb_out + static_cast<std::size_t>(y) * row_bytes, src + static_cast<std::size_t>(y) * bytes_per_line,
                row_bytes);
  }
}

int z16_to_metres(const std::uint8_t* src, std::uint32_t bytes_per_line, int width_px, int height_px,
                  float scale_m, float* depth_out_m) {
  int invalid = 0;
  for (int y = 0; y < height_px; ++y) {
    const std::uint8_t* row = src + static_cast<std::size_t>(y) * bytes_per_line;
    float* out = depth_out_m + static_cast<std::size_t>(y) * static_cast<std::size_t>(width_px);
    for (int x = 0; x < width_px; ++x) {
      // Z16 is little-endian; both targets (x86-64, aarch64) are too, but assemble it portably anyway.
      const unsigned raw = static_cast<unsigned>(row[2 * x]) | (static_cast<unsigned>(row[2 * x + 1]) << 8);
      out[x] = static_cast<float>(raw) * scale_m;
      invalid += raw == 0 ? 1 : 0;
    }
  }
  return invalid;
}

}  // namespace qsg::v4l2
