// DepthNoise: config checks, per-pixel determinism and independence from evaluation order, quantisation and the
// grazing-angle dropout ramp.
#include "drivers/render/depth_noise.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace qsg::render {
namespace {

TEST(DepthNoise, ConfigCheckNamesTheField) {
  DepthNoiseConfig c;
  EXPECT_EQ(c.check(), "");
  c.sigma_quadratic_per_m = -0.1;
  EXPECT_NE(c.check().find("sigma_quadratic_per_m"), std::string::npos);
  c = {};
  c.dropout_probability = 1.5;
  EXPECT_NE(c.check().find("dropout_probability"), std::string::npos);
  c = {};
  c.grazing_full_deg = 95.0;
  EXPECT_NE(c.check().find("grazing"), std::string::npos);
}

TEST(DepthNoise, DeterministicPerSeedFrameAndPixelInAnyOrder) {
  DepthNoiseConfig c;
  c.enabled = true;
  DepthNoise a, b;
  a.configure(c, 1);
  b.configure(c, 1);
  const std::uint64_t key = a.frame_key(10);
  std::vector<float> forward, backward(1000);
  for (std::uint32_t p = 0; p < 1000; ++p) forward.push_back(a.apply(key, p, 2.0, 1.0, 0.001));
  for (std::uint32_t p = 1000; p-- > 0;) backward[p] = b.apply(b.frame_key(10), p, 2.0, 1.0, 0.001);
  EXPECT_EQ(forward, backward);
  DepthNoise other;
  other.configure(c, 2);
  int differ_seed = 0, differ_frame = 0;
  for (std::uint32_t p = 0; p < 1000; ++p) {
    differ_seed += other.apply(other.frame_key(10), p, 2.0, 1.0, 0.001) != forward[p];
    differ_frame += a.apply(a.frame_key(11), p, 2.0, 1.0, 0.001) != forward[p];
  }
  EXPECT_GT(differ_seed, 800);
  EXPECT_GT(differ_frame, 800);
}

TEST(DepthNoise, SigmaGrowsWithSquareOfDepthAndOutputIsQuantised) {
  DepthNoiseConfig c;
  c.enabled = true;
  DepthNoise n;
  n.configure(c, 3);
  EXPECT_NEAR(n.sigma_m(0.0), 0.0012, 1e-12);
  EXPECT_NEAR(n.sigma_m(4.0), 0.0012 + 0.0019 * 16.0, 1e-12);
  for (std::uint32_t p = 0; p < 500; ++p) {
    const float z = n.apply(n.frame_key(0), p, 1.5, 1.0, 0.001);
    ASSERT_GT(z, 0.0f);
    ASSERT_NEAR(z / 0.001, std::round(z / 0.001), 1e-3);
    ASSERT_NEAR(z, 1.5, 6.0 * n.sigma_m(1.5));
  }
}

TEST(DepthNoise, DropoutRampsWithIncidenceAngle) {
  DepthNoiseConfig c;
  c.enabled = true;
  c.grazing_start_deg = 60.0;
  c.grazing_full_deg = 80.0;
  DepthNoise n;
  n.configure(c, 4);
  auto drop_rate = [&](double angle_deg) {
    int dropped = 0;
    const double cos_incidence = std::cos(angle_deg * 3.14159265358979323846 / 180.0);
    for (std::uint32_t p = 0; p < 4000; ++p) dropped += n.apply(n.frame_key(1), p, 2.0, cos_incidence, 0.001) == 0.0f;
    return dropped / 4000.0;
  };
  EXPECT_EQ(drop_rate(30.0), 0.0);
  EXPECT_NEAR(drop_rate(65.0), 0.25, 0.04);
  EXPECT_NEAR(drop_rate(70.0), 0.5, 0.04);
  EXPECT_EQ(drop_rate(85.0), 1.0);
}

}  // namespace
}  // namespace qsg::render
