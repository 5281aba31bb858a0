// Preprocessor: hand-computed bilinear + normalisation reference on tiny images, channel order, agreement with
// cv::resize(INTER_LINEAR), and no allocation per frame.
#include "core/segmentation/preprocess.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "tests/support/allocation_counter.h"

namespace qsg::segmentation {
namespace {

constexpr float kMean[3] = {0.485f, 0.456f, 0.406f};
constexpr float kStd[3] = {0.229f, 0.224f, 0.225f};

float normalised(float value, int channel) { return (value / 255.0f - kMean[channel]) / kStd[channel]; }

TEST(Preprocess, SameSizeIsPerChannelNormalisationInRgbPlanes) {
  // 3 x 2 image; pixel i has RGB (10 i, 100 + i, 250 - 5 i).
  std::vector<std::uint8_t> rgb;
  for (int i = 0; i < 6; ++i) {
    rgb.push_back(static_cast<std::uint8_t>(10 * i));
    rgb.push_back(static_cast<std::uint8_t>(100 + i));
    rgb.push_back(static_cast<std::uint8_t>(250 - 5 * i));
  }
  Preprocessor pre;
  std::string error;
  ASSERT_TRUE(pre.init(Normalization{}, 3, 2, &error)) << error;
  std::vector<float> out(3 * 6, -99.0f);
  pre.run(rgb.data(), 3, 2, out.data());
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(out[static_cast<std::size_t>(i)], normalised(10.0f * i, 0), 1e-5f) << i;
    EXPECT_NEAR(out[static_cast<std::size_t>(6 + i)], normalised(100.0f + i, 1), 1e-5f) << i;
    EXPECT_NEAR(out[static_cast<std::size_t>(12 + i)], normalised(250.0f - 5 * i, 2), 1e-5f) << i;
  }
  // e.g. pixel 0 red: (0 / 255 - 0.485) / 0.229 = -2.11790...
  EXPECT_NEAR(out[0], -2.117904f, 1e-5f);
}

TEST(Preprocess, TwoByTwoUpscaledToFourByFourMatchesHandComputedBilinear) {
  // Red: [0 100; 200 40]; green constant 10; blue 255 - red.
  const std::uint8_t red[4] = {0, 100, 200, 40};
  std::vector<std::uint8_t> rgb;
  for (std::uint8_t r : red) {
    rgb.push_back(r);
    rgb.push_back(10);
    rgb.push_back(static_cast<std::uint8_t>(255 - r));
  }
  // Destination x = 0..3 samples source x = clamp((x + 0.5) / 2 - 0.5) = 0, 0.25, 0.75, 1 (same for rows), so:
  //   row 0 (top row only):         0    25     75    100
  //   row 1 (0.25 of the way down): 50   58.75  76.25  85
  //   row 2 (0.75):                 150  126.25 78.75  55
  //   row 3 (bottom row only):      200  160    80     40
  const float expected_red[16] = {0, 25, 75, 100, 50, 58.75f, 76.25f, 85, 150, 126.25f, 78.75f, 55, 200, 160, 80, 40};
  Preprocessor pre;
  std::string error;
  ASSERT_TRUE(pre.init(Normalization{}, 4, 4, &error)) << error;
  std::vector<float> out(3 * 16);
  pre.run(rgb.data(), 2, 2, out.data());
  for (int i = 0; i < 16; ++i) {
    const std::size_t p = static_cast<std::size_t>(i);
    EXPECT_NEAR(out[p], normalised(expected_red[i], 0), 1e-5f) << i;
    EXPECT_NEAR(out[16 + p], normalised(10.0f, 1), 1e-5f) << i;
    EXPECT_NEAR(out[32 + p], normalised(255.0f - expected_red[i], 2), 1e-5f) << i;
  }

  // A BGR network reads blue into plane 0 and red into plane 2, each with its own plane's mean and std.
  Normalization bgr;
  bgr.order = ColorOrder::kBgr;
  ASSERT_TRUE(pre.init(bgr, 4, 4, &error)) << error;
  pre.run(rgb.data(), 2, 2, out.data());
  for (int i = 0; i < 16; ++i) {
    const std::size_t p = static_cast<std::size_t>(i);
    EXPECT_NEAR(out[p], normalised(255.0f - expected_red[i], 0), 1e-5f) << i;
    EXPECT_NEAR(out[32 + p], normalised(expected_red[i], 2), 1e-5f) << i;
  }
}

// Our resize follows cv::resize(INTER_LINEAR); OpenCV uses 11-bit fixed-point weights on 8-bit images, so allow
// one grey level.
void expect_matches_cv_resize(int src_w, int src_h, int net_w, int net_h) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> byte(0, 255);
  cv::Mat src(src_h, src_w, CV_8UC3);
  for (int i = 0; i < src_w * src_h * 3; ++i) src.data[i] = static_cast<std::uint8_t>(byte(rng));
  cv::Mat resized;
  cv::resize(src, resized, cv::Size(net_w, net_h), 0, 0, cv::INTER_LINEAR);

  Preprocessor pre;
  std::string error;
  ASSERT_TRUE(pre.init(Normalization{}, net_w, net_h, &error)) << error;
  std::vector<float> out(static_cast<std::size_t>(3 * net_w * net_h));
  pre.run(src.data, src_w, src_h, out.data());
  float worst = 0.0f;
  for (int y = 0; y < net_h; ++y)
    for (int x = 0; x < net_w; ++x)
      for (int c = 0; c < 3; ++c) {
        const float ref = normalised(resized.at<cv::Vec3b>(y, x)[c], c);
        const float got = out[static_cast<std::size_t>((c * net_h + y) * net_w + x)];
        worst = std::max(worst, std::abs(got - ref) * kStd[c] * 255.0f);  // in grey levels
      }
  EXPECT_LE(worst, 1.0f) << src_w << "x" << src_h << " -> " << net_w << "x" << net_h;
}

TEST(Preprocess, AgreesWithCvResizeDownAndUp) {
  expect_matches_cv_resize(160, 120, 64, 48);  // 2.5x down
  expect_matches_cv_resize(160, 120, 96, 96);  // non-uniform, as 640x480 -> 384x384
  expect_matches_cv_resize(40, 30, 64, 48);    // up
}

TEST(Preprocess, RunDoesNotAllocate) {
  std::vector<std::uint8_t> rgb(160 * 120 * 3, 128);
  Preprocessor pre;
  std::string error;
  ASSERT_TRUE(pre.init(Normalization{}, 96, 96, &error)) << error;
  std::vector<float> out(3 * 96 * 96);
  EXPECT_NO_ALLOCATIONS(pre.run(rgb.data(), 160, 120, out.data()));
}

TEST(Preprocess, BadParametersAreRefused) {
  Preprocessor pre;
  std::string error;
  Normalization zero_std;
  zero_std.stddev[1] = 0.0f;
  EXPECT_FALSE(pre.init(zero_std, 4, 4, &error));
  EXPECT_NE(error.find("stddev[1]"), std::string::npos) << error;
  EXPECT_FALSE(pre.init(Normalization{}, 0, 4, &error));
  EXPECT_NE(error.find("0x4"), std::string::npos) << error;
}

}  // namespace
}  // namespace qsg::segmentation
