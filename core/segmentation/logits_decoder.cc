// Argmax / softmax-confidence decoding of segmentation logits and nearest-neighbour upsampling to the frame.
#include "core/segmentation/logits_decoder.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace qsg::segmentation {
namespace {

// exp(x) for x <= 0 to ~3e-6 relative, branch-free so the softmax loop vectorises (std::exp does not, and was 3/4
// of the post-processing time). exp(x) = 2^i * 2^f with i = round(x log2 e), |f| <= 0.5, 2^f by its degree-5
// Taylor series. Below -87 (and NaN) returns exp(-87) ~ 1.6e-38: negligible against the winner's 1.
inline float exp_nonpositive(float x) {
  x = std::max(-87.0f, x);  // (-87 < x) ? x : -87, so NaN becomes -87
  x = std::min(0.0f, x);    // +inf (from an all -inf pixel, flagged anyway) must not reach the int conversion
  const float t = x * 1.44269504f;
  const int i = static_cast<int>(t - 0.5f);  // t <= 0: truncation of t - 0.5 rounds t to nearest
  const float f = (t - static_cast<float>(i)) * 0.693147181f;
  const float poly =
      1.0f + f * (1.0f + f * (0.5f + f * (1.0f / 6.0f + f * (1.0f / 24.0f + f * (1.0f / 120.0f)))));
  const std::int32_t bits = (i + 127) << 23;
  float scale;
  std::memcpy(&scale, &bits, sizeof(scale));
  return poly * scale;
}

}  // namespace

float exp_nonpositive_for_test(float x) { return exp_nonpositive(x); }

bool LogitsDecoder::init(const LabelMap& map, int num_classes, int logits_width_px, int logits_height_px,
                         float min_confidence, semantics::Label low_confidence_label, std::string* error) {
  const auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  num_classes_ = 0;
  if (num_classes < 1 || num_classes > kMaxNetworkClasses)
    return fail("network class count " + std::to_string(num_classes) + " outside 1.." +
                std::to_string(kMaxNetworkClasses));
  if (!map.check_class_count(num_classes, error)) return false;
  if (logits_width_px <= 0 || logits_height_px <= 0 || logits_width_px > 8192 || logits_height_px > 8192)
    return fail("logits size " + std::to_string(logits_width_px) + "x" + std::to_string(logits_height_px) +
                " outside 1..8192");
  if (!(min_confidence >= 0.0f && min_confidence < 1.0f))
    return fail("min_confidence " + std::to_string(min_confidence) + " outside [0, 1)");
  if (low_confidence_label >= semantics::kNumObjectLabels)
    return fail("low_confidence_label " + std::to_string(low_confidence_label) + " is not an mpcat40 label");

  width_px_ = logits_width_px;
  height_px_ = logits_height_px;
  min_confidence_ = min_confidence;
  low_label_ = low_confidence_label;
  for (int c = 0; c < num_classes; ++c) class_to_label_[static_cast<std::size_t>(c)] = map.label(c);
  const std::size_t pixels = static_cast<std::size_t>(width_px_) * static_cast<std::size_t>(height_px_);
  max_logit_.assign(pixels, 0.0f);
  exp_sum_.assign(min_confidence_ > 0.0f ? pixels : 0, 0.0f);
  best_class_.assign(pixels, 0);
  has_nan_.assign(pixels, 0);
  net_labels_.assign(pixels, low_label_);
  last_low_confidence_pixels_ = 0;
  num_classes_ = num_classes;
  return true;
}

bool LogitsDecoder::decode(const float* logits, messages::RgbdFrame& frame) {
  if (num_classes_ == 0 || !frame.intrinsics.valid()) return false;
  const std::size_t pixels = max_logit_.size();
  float* max_logit = max_logit_.data();
  std::int32_t* best = best_class_.data();
  std::int32_t* has_nan = has_nan_.data();

  // Class-major passes read the NCHW planes sequentially. Ties go to the lower class; NaN never wins, but a pixel
  // with any NaN logit (a broken output) gets the low-confidence label.
  std::fill(max_logit, max_logit + pixels, -std::numeric_limits<float>::infinity());
  std::fill(best, best + pixels, 0);
  std::fill(has_nan, has_nan + pixels, 0);
  for (int c = 0; c < num_classes_; ++c) {
    const float* plane = logits + static_cast<std::size_t>(c) * pixels;
    // Arithmetic instead of conditional stores, so that GCC vectorises the loop.
    for (std::size_t p = 0; p < pixels; ++p) {
      const float v = plane[p];
      const float m = max_logit[p];
      const std::int32_t wins = static_cast<std::int32_t>(v > m);
      max_logit[p] = std::max(m, v);  // keeps m when v is NaN
      best[p] += (c - best[p]) * wins;
      has_nan[p] |= static_cast<std::int32_t>(v != v);
    }
  }

  semantics::Label* net = net_labels_.data();
  std::uint64_t low = 0;
  if (min_confidence_ > 0.0f) {
    // p(best) = 1 / sum_c exp(l_c - l_max) >= min_confidence  <=>  sum <= 1 / min_confidence.
    float* sum = exp_sum_.data();
    std::fill(sum, sum + pixels, 0.0f);
    for (int c = 0; c < num_classes_; ++c) {
      const float* plane = logits + static_cast<std::size_t>(c) * pixels;
      for (std::size_t p = 0; p < pixels; ++p) sum[p] += exp_nonpositive(plane[p] - max_logit[p]);
    }
    const float max_sum = 1.0f / min_confidence_;
    for (std::size_t p = 0; p < pixels; ++p) {
      const bool confident = has_nan[p] == 0 && max_logit[p] > -std::numeric_limits<float>::infinity() &&
                             sum[p] <= max_sum;
      low += confident ? 0 : 1;
      net[p] = confident ? class_to_label_[static_cast<std::size_t>(best[p])] : low_label_;
    }
  } else {
    for (std::size_t p = 0; p < pixels; ++p) {
      const bool usable = has_nan[p] == 0 && max_logit[p] > -std::numeric_limits<float>::infinity();
      low += usable ? 0 : 1;
      net[p] = usable ? class_to_label_[static_cast<std::size_t>(best[p])] : low_label_;
    }
  }
  last_low_confidence_pixels_ = low;

  // Nearest neighbour on pixel centres: frame pixel x samples logits column floor((x + 0.5) * lw / w).
  const int w = frame.width();
  const int h = frame.height();
  const auto nearest = [](int i, int out_size, int in_size) {
    return static_cast<int>((2 * static_cast<std::int64_t>(i) + 1) * in_size /
                            (2 * static_cast<std::int64_t>(out_size)));
  };
  for (int x = 0; x < w; ++x) column_of_x_[static_cast<std::size_t>(x)] = nearest(x, w, width_px_);
  for (int y = 0; y < h; ++y) {
    const int row = nearest(y, h, height_px_);
    const semantics::Label* src = net + static_cast<std::size_t>(row) * static_cast<std::size_t>(width_px_);
    std::uint16_t* dst = frame.labels.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(w);
    for (int x = 0; x < w; ++x) dst[x] = src[column_of_x_[static_cast<std::size_t>(x)]];
  }
  frame.has_labels = true;
  return true;
}

}  // namespace qsg::segmentation
