// Turns a network's per-class logits into the frame's scene-graph labels: argmax (and softmax confidence) at
// network resolution, class -> mpcat40 through the LabelMap, nearest-neighbour up to the frame size. Buffers are
// sized once in init(); decode() does not allocate.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/segmentation/label_map.h"
#include "core/semantics/labels.h"
#include "core/messages/sensor_types.h"

namespace qsg::segmentation {

// The decoder's exp approximation for x <= 0, exposed so a test can bound its error.
float exp_nonpositive_for_test(float x);

class LogitsDecoder {
 public:
  // `min_confidence`: softmax probability of the winning class below which a pixel gets `low_confidence_label`
  // (0 disables the softmax). The label map must have `num_classes` classes.
  bool init(const LabelMap& map, int num_classes, int logits_width_px, int logits_height_px, float min_confidence,
            semantics::Label low_confidence_label, std::string* error);

  // `logits`: num_classes planes of logits_width_px * logits_height_px floats (NCHW, N = 1). Writes the first
  // width x height entries of frame.labels and sets has_labels. False (frame untouched) when not initialised or
  // the frame's intrinsics are invalid.
  bool decode(const float* logits, messages::RgbdFrame& frame);

  // Labels at network resolution of the last decode (row-major logits_width_px x logits_height_px).
  const std::vector<semantics::Label>& network_labels() const { return net_labels_; }
  // Pixels (at network resolution) of the last decode that fell below min_confidence or had a NaN logit.
  std::uint64_t last_low_confidence_pixels() const { return last_low_confidence_pixels_; }
  int num_classes() const { return num_classes_; }
  int logits_width_px() const { return width_px_; }
  int logits_height_px() const { return height_px_; }

 private:
  int num_classes_ = 0;
  int width_px_ = 0;
  int height_px_ = 0;
  float min_confidence_ = 0.0f;
  semantics::Label low_label_ = semantics::kUnlabeled;
  std::array<semantics::Label, kMaxNetworkClasses> class_to_label_{};
  std::vector<float> max_logit_;
  std::vector<float> exp_sum_;
  std::vector<std::int32_t> best_class_;  // int32 like the floats, so the argmax loop vectorises
  std::vector<std::int32_t> has_nan_;
  std::vector<semantics::Label> net_labels_;
  std::array<int, messages::kMaxFrameWidth> column_of_x_{};  // logits column sampled by each frame column
  std::uint64_t last_low_confidence_pixels_ = 0;
};

}  // namespace qsg::segmentation
