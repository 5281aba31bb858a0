// Turns an 8-bit RGB frame into a network's planar float input (bilinear resize, scale, per-channel
// normalisation, channel order) in one pass over caller-owned memory, without allocating per frame.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace qsg::segmentation {

enum class ColorOrder { kRgb, kBgr };
const char* color_order_name(ColorOrder order);

// out[c] = (pixel[c] * scale - mean[c]) / stddev[c], channels listed in the network's order (`order`).
struct Normalization {
  float scale = 1.0f / 255.0f;
  std::array<float, 3> mean = {0.485f, 0.456f, 0.406f};
  std::array<float, 3> stddev = {0.229f, 0.224f, 0.225f};
  ColorOrder order = ColorOrder::kRgb;
  std::string check() const;  // empty when usable, else the bad field and why
  void print(std::FILE* out) const;
};

class Preprocessor {
 public:
  // Allocates the column tables for a net_width_px x net_height_px input. False (and *error) on bad sizes.
  bool init(const Normalization& norm, int net_width_px, int net_height_px, std::string* error);

  // Resizes the row-major RGB image (3 bytes per pixel) to the network size with bilinear interpolation on pixel
  // centres (OpenCV's INTER_LINEAR convention: src = (dst + 0.5) * in/out - 0.5, clamped at the border) and writes
  // 3 planes of net_width_px * net_height_px floats (NCHW with N = 1) to `out`. No allocation.
  void run(const std::uint8_t* rgb, int width_px, int height_px, float* out);

  int net_width_px() const { return net_width_px_; }
  int net_height_px() const { return net_height_px_; }

 private:
  Normalization norm_;
  int net_width_px_ = 0;
  int net_height_px_ = 0;
  std::array<float, 3> gain_{};    // scale / stddev, per output channel
  std::array<float, 3> offset_{};  // -mean / stddev
  std::array<int, 3> source_channel_{};  // RGB byte read for each output channel
  // Per output column: left source byte offset, right source byte offset, weight of the right one.
  std::vector<int> x0_bytes_;
  std::vector<int> x1_bytes_;
  std::vector<float> wx_;
};

}  // namespace qsg::segmentation
