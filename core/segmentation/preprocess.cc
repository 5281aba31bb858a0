// Fused bilinear resize + normalisation of an RGB frame into a planar float network input.
#include "core/segmentation/preprocess.h"

#include <algorithm>
#include <cmath>

namespace qsg::segmentation {
namespace {

// Source coordinate of destination index `d` and its two neighbours: OpenCV INTER_LINEAR's pixel-centre mapping,
// clamped so that the border pixels are repeated (what cv::resize does for a downscale and an upscale alike).
void source_span(int d, double ratio, int source_size, int* i0, int* i1, float* w1) {
  double s = (d + 0.5) * ratio - 0.5;
  if (s < 0.0) s = 0.0;
  int lo = static_cast<int>(std::floor(s));
  double frac = s - lo;
  if (lo >= source_size - 1) {
    lo = source_size - 1;
    frac = 0.0;
  }
  *i0 = lo;
  *i1 = std::min(lo + 1, source_size - 1);
  *w1 = static_cast<float>(frac);
}

}  // namespace

const char* color_order_name(ColorOrder order) { return order == ColorOrder::kRgb ? "rgb" : "bgr"; }

std::string Normalization::check() const {
  if (!(scale > 0.0f) || !std::isfinite(scale)) return "scale must be finite and > 0";
  for (int c = 0; c < 3; ++c) {
    if (!std::isfinite(mean[static_cast<std::size_t>(c)])) return "mean[" + std::to_string(c) + "] must be finite";
    const float s = stddev[static_cast<std::size_t>(c)];
    if (!(s > 0.0f) || !std::isfinite(s)) return "stddev[" + std::to_string(c) + "] must be finite and > 0";
  }
  return {};
}

void Normalization::print(std::FILE* out) const {
  std::fprintf(out, "scale=%.6g mean=[%.4g,%.4g,%.4g] stddev=[%.4g,%.4g,%.4g] order=%s", scale, mean[0], mean[1],
               mean[2], stddev[0], stddev[1], stddev[2], color_order_name(order));
}

bool Preprocessor::init(const Normalization& norm, int net_width_px, int net_height_px, std::string* error) {
  if (const std::string bad = norm.check(); !bad.empty()) {
    if (error != nullptr) *error = "normalization: " + bad;
    return false;
  }
  if (net_width_px <= 0 || net_height_px <= 0 || net_width_px > 8192 || net_height_px > 8192) {
    if (error != nullptr)
      *error = "network input size " + std::to_string(net_width_px) + "x" + std::to_string(net_height_px) +
               " outside 1..8192";
    return false;
  }
  norm_ = norm;
  net_width_px_ = net_width_px;
  net_height_px_ = net_height_px;
  for (std::size_t c = 0; c < 3; ++c) {
    gain_[c] = norm.scale / norm.stddev[c];
    offset_[c] = -norm.mean[c] / norm.stddev[c];
    // Network channel c reads RGB byte c, or byte 2 - c when the network wants BGR.
    source_channel_[c] = norm.order == ColorOrder::kRgb ? static_cast<int>(c) : 2 - static_cast<int>(c);
  }
  x0_bytes_.assign(static_cast<std::size_t>(net_width_px), 0);
  x1_bytes_.assign(static_cast<std::size_t>(net_width_px), 0);
  wx_.assign(static_cast<std::size_t>(net_width_px), 0.0f);
  return true;
}

void Preprocessor::run(const std::uint8_t* rgb, int width_px, int height_px, float* out) {
  const int nw = net_width_px_;
  const int nh = net_height_px_;
  const std::size_t plane = static_cast<std::size_t>(nw) * static_cast<std::size_t>(nh);
  const double rx = static_cast<double>(width_px) / nw;
  const double ry = static_cast<double>(height_px) / nh;
  for (int x = 0; x < nw; ++x) {
    int i0 = 0, i1 = 0;
    source_span(x, rx, width_px, &i0, &i1, &wx_[static_cast<std::size_t>(x)]);
    x0_bytes_[static_cast<std::size_t>(x)] = 3 * i0;
    x1_bytes_[static_cast<std::size_t>(x)] = 3 * i1;
  }
  const std::size_t row_bytes = 3 * static_cast<std::size_t>(width_px);
  for (int y = 0; y < nh; ++y) {
    int y0 = 0, y1 = 0;
    float wy = 0.0f;
    source_span(y, ry, height_px, &y0, &y1, &wy);
    const std::uint8_t* r0 = rgb + static_cast<std::size_t>(y0) * row_bytes;
    const std::uint8_t* r1 = rgb + static_cast<std::size_t>(y1) * row_bytes;
    for (std::size_t c = 0; c < 3; ++c) {
      const int sc = source_channel_[c];
      const float gain = gain_[c];
      const float offset = offset_[c];
      float* dst = out + c * plane + static_cast<std::size_t>(y) * static_cast<std::size_t>(nw);
      for (int x = 0; x < nw; ++x) {
        const std::size_t xi = static_cast<std::size_t>(x);
        const float wx = wx_[xi];
        const int a = x0_bytes_[xi] + sc;
        const int b = x1_bytes_[xi] + sc;
        const float top = static_cast<float>(r0[a]) + wx * static_cast<float>(r0[b] - r0[a]);
        const float bottom = static_cast<float>(r1[a]) + wx * static_cast<float>(r1[b] - r1[a]);
        dst[x] = (top + wy * (bottom - top)) * gain + offset;
      }
    }
  }
}

}  // namespace qsg::segmentation
