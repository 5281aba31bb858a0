// LogitsDecoder on synthetic logits: argmax and class mapping, ties, softmax threshold, NaN, nearest-neighbour
// upsampling at integer and non-integer ratios, and no allocation per frame.
#include "core/segmentation/logits_decoder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "tests/support/allocation_counter.h"

namespace qsg::segmentation {
namespace {

using semantics::kChair;
using semantics::kSofa;
using semantics::kTable;
using semantics::kUnlabeled;

// Three classes: 0 -> chair, 1 -> table, 2 -> sofa.
LabelMap three_class_map() {
  LabelMap map;
  std::string error;
  EXPECT_TRUE(map.parse(R"({"network": "synthetic", "classes": [{"name": "c", "label": "chair"},
                                {"name": "t", "label": "table"}, {"name": "s", "label": "sofa"}]})",
                        "synthetic", &error))
      << error;
  return map;
}

std::unique_ptr<messages::RgbdFrame> frame_of(int w, int h) {
  auto frame = std::make_unique<messages::RgbdFrame>();
  frame->intrinsics.width = w;
  frame->intrinsics.height = h;
  frame->has_labels = false;
  return frame;
}

// 4 x 2 logits, 3 classes, each pixel's triple listed row-major; stored class-major (NCHW).
std::vector<float> planar(const std::vector<std::array<float, 3>>& pixels) {
  std::vector<float> out(3 * pixels.size());
  for (std::size_t p = 0; p < pixels.size(); ++p)
    for (std::size_t c = 0; c < 3; ++c) out[c * pixels.size() + p] = pixels[p][c];
  return out;
}

const float kNaN = std::numeric_limits<float>::quiet_NaN();

TEST(LogitsDecoder, ArgmaxMapsClassesAndUpsamplesByTwo) {
  const LabelMap map = three_class_map();
  LogitsDecoder decoder;
  std::string error;
  ASSERT_TRUE(decoder.init(map, 3, 4, 2, 0.0f, kUnlabeled, &error)) << error;
  const std::vector<float> logits = planar({{5, 1, 0}, {0, 2, 1}, {0, 1, 3}, {1, 1, 0},     // tie 0/1 -> class 0
                                            {-1, -2, -0.5f}, {kNaN, 0, 1}, {kNaN, kNaN, kNaN}, {0, 0, 0}});
  auto frame = frame_of(8, 4);
  ASSERT_TRUE(decoder.decode(logits.data(), *frame));
  EXPECT_TRUE(frame->has_labels);
  // Any NaN logit makes the pixel low-confidence (kUnlabeled here), with or without the softmax threshold.
  const semantics::Label expected_net[8] = {kChair, kTable, kSofa, kChair, kSofa, kUnlabeled, kUnlabeled, kChair};
  for (int p = 0; p < 8; ++p) EXPECT_EQ(decoder.network_labels()[static_cast<std::size_t>(p)], expected_net[p]) << p;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 8; ++x)
      EXPECT_EQ(frame->labels[static_cast<std::size_t>(y * 8 + x)], expected_net[(y / 2) * 4 + x / 2]) << x << "," << y;
  EXPECT_EQ(decoder.last_low_confidence_pixels(), 2u);
}

TEST(LogitsDecoder, NearestNeighbourOnPixelCentresAtNonIntegerRatio) {
  const LabelMap map = three_class_map();
  LogitsDecoder decoder;
  std::string error;
  ASSERT_TRUE(decoder.init(map, 3, 4, 2, 0.0f, kUnlabeled, &error)) << error;
  // Row 0: chair table sofa chair; row 1: table sofa chair table.
  const std::vector<float> logits =
      planar({{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 0}, {0, 1, 0}});
  auto frame = frame_of(6, 3);
  ASSERT_TRUE(decoder.decode(logits.data(), *frame));
  // Frame column x samples logits column floor((x + 0.5) * 4 / 6): 0 1 1 2 3 3; rows floor((y + 0.5) * 2 / 3): 0 1 1.
  const semantics::Label expected[18] = {kChair, kTable, kTable, kSofa,  kChair, kChair,   // row 0 of logits
                                         kTable, kSofa,  kSofa,  kChair, kTable, kTable,   // row 1
                                         kTable, kSofa,  kSofa,  kChair, kTable, kTable};  // row 1
  for (int i = 0; i < 18; ++i) EXPECT_EQ(frame->labels[static_cast<std::size_t>(i)], expected[i]) << i;
}

TEST(LogitsDecoder, SoftmaxThresholdMarksUncertainPixels) {
  const LabelMap map = three_class_map();
  LogitsDecoder decoder;
  std::string error;
  ASSERT_TRUE(decoder.init(map, 3, 2, 1, 0.5f, kUnlabeled, &error)) << error;
  // p(best) of {1, 1.1, 0.9} = e^1.1 / (e^1 + e^1.1 + e^0.9) = 0.367 < 0.5; of {10, 0, 0} = 0.99991.
  const std::vector<float> logits = planar({{1, 1.1f, 0.9f}, {10, 0, 0}});
  auto frame = frame_of(2, 1);
  ASSERT_TRUE(decoder.decode(logits.data(), *frame));
  EXPECT_EQ(frame->labels[0], kUnlabeled);
  EXPECT_EQ(frame->labels[1], kChair);
  EXPECT_EQ(decoder.last_low_confidence_pixels(), 1u);

  // Just either side of the threshold: two classes with p = 0.5 +- 0.01 (logit gap ln(0.51 / 0.49)).
  LogitsDecoder strict;
  ASSERT_TRUE(strict.init(map, 3, 2, 1, 0.5f, semantics::kMisc, &error)) << error;
  const float gap = std::log(0.51f / 0.49f);
  const std::vector<float> close = planar({{gap, 0, -100}, {0, gap, -100}});
  ASSERT_TRUE(strict.decode(close.data(), *frame));
  EXPECT_EQ(frame->labels[0], kChair);
  EXPECT_EQ(frame->labels[1], kTable);
  LogitsDecoder stricter;
  ASSERT_TRUE(stricter.init(map, 3, 2, 1, 0.52f, semantics::kMisc, &error)) << error;
  ASSERT_TRUE(stricter.decode(close.data(), *frame));
  EXPECT_EQ(frame->labels[0], semantics::kMisc);
  EXPECT_EQ(frame->labels[1], semantics::kMisc);

  // NaN logits are never confident.
  const std::vector<float> nan = planar({{kNaN, 0, 0}, {kNaN, kNaN, kNaN}});
  ASSERT_TRUE(decoder.decode(nan.data(), *frame));
  EXPECT_EQ(frame->labels[0], kUnlabeled);
  EXPECT_EQ(frame->labels[1], kUnlabeled);
}

TEST(LogitsDecoder, FastExpMatchesStdExp) {
  double worst = 0.0;
  for (float x = 0.0f; x >= -80.0f; x -= 0.0137f) {
    const double ref = std::exp(static_cast<double>(x));
    worst = std::max(worst, std::abs(exp_nonpositive_for_test(x) - ref) / ref);
  }
  EXPECT_LT(worst, 1e-5);
  EXPECT_EQ(exp_nonpositive_for_test(0.0f), 1.0f);
  EXPECT_LT(exp_nonpositive_for_test(-200.0f), 1e-37f);
  EXPECT_LT(exp_nonpositive_for_test(std::numeric_limits<float>::quiet_NaN()), 1e-37f);
}

TEST(LogitsDecoder, DecodeDoesNotAllocate) {
  // 21 classes as the real network, at a small size (buffers are sized in init, whatever the size), softmax on.
  LabelMap map;
  std::string error;
  std::string json = R"({"network": "synthetic21", "classes": [)";
  for (int c = 0; c < 21; ++c)
    json += std::string(c ? "," : "") + R"({"name": "k)" + std::to_string(c) + R"(", "label": "chair"})";
  ASSERT_TRUE(map.parse(json + "]}", "synthetic21", &error)) << error;
  LogitsDecoder decoder;
  ASSERT_TRUE(decoder.init(map, 21, 96, 96, 0.3f, kUnlabeled, &error)) << error;
  std::vector<float> logits(21u * 96u * 96u);
  for (std::size_t i = 0; i < logits.size(); ++i) logits[i] = static_cast<float>((i * 2654435761u) % 1000u) * 0.01f;
  auto frame = frame_of(160, 120);
  ASSERT_TRUE(decoder.decode(logits.data(), *frame));  // warm-up: nothing may be lazily sized
  bool ok = false;
  EXPECT_NO_ALLOCATIONS(ok = decoder.decode(logits.data(), *frame));
  EXPECT_TRUE(ok);
}

TEST(LogitsDecoder, RefusesBadSetupAndBadFrames) {
  const LabelMap map = three_class_map();
  LogitsDecoder decoder;
  std::string error;
  EXPECT_FALSE(decoder.init(map, 4, 4, 2, 0.0f, kUnlabeled, &error));
  EXPECT_NE(error.find("synthetic"), std::string::npos) << error;
  EXPECT_NE(error.find("outputs 4"), std::string::npos) << error;
  EXPECT_FALSE(decoder.init(map, 3, 4, 2, 1.0f, kUnlabeled, &error));
  EXPECT_NE(error.find("min_confidence"), std::string::npos) << error;
  EXPECT_FALSE(decoder.init(map, 3, 4, 2, 0.0f, semantics::kNumObjectLabels, &error));
  EXPECT_NE(error.find("low_confidence_label"), std::string::npos) << error;

  const std::vector<float> logits(3 * 8, 0.0f);
  auto frame = frame_of(8, 4);
  EXPECT_FALSE(decoder.decode(logits.data(), *frame));  // never initialised successfully
  ASSERT_TRUE(decoder.init(map, 3, 4, 2, 0.0f, kUnlabeled, &error)) << error;
  frame->intrinsics.width = messages::kMaxFrameWidth + 1;
  EXPECT_FALSE(decoder.decode(logits.data(), *frame));
  EXPECT_FALSE(frame->has_labels);
}

}  // namespace
}  // namespace qsg::segmentation
