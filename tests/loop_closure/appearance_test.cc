#include "core/loop_closure/appearance.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace qsg::loop_closure {
namespace {

// Random descriptors on random 3D points seen from two cameras: the query's points are the match's moved by the
// inverse of the true relative pose; some have no partner and some descriptors are corrupted.
TEST(AppearanceTest, RansacRecoversTheRelativePoseDespiteWrongMatches) {
  std::mt19937 rng(4);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_real_distribution<float> xy(-1.5f, 1.5f), z(1.0f, 3.5f);
  std::normal_distribution<float> noise(0.0f, 0.005f);
  Eigen::Isometry3d match_T_query = Eigen::Isometry3d::Identity();
  match_T_query.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.1, 1.0, 0.2).normalized()).toRotationMatrix();
  match_T_query.translation() = Eigen::Vector3d(0.4, -0.1, 0.6);
  AppearanceFeatures match, query;
  for (std::size_t i = 0; i < 100; ++i) {
    for (auto& b : match.descriptors[i]) b = static_cast<std::uint8_t>(byte(rng));
    match.points_m[i] = Eigen::Vector3f(xy(rng), xy(rng), z(rng));
    query.descriptors[i] = match.descriptors[i];
    query.points_m[i] = (match_T_query.inverse() * match.points_m[i].cast<double>()).cast<float>() +
                        Eigen::Vector3f(noise(rng), noise(rng), noise(rng));
    if (i % 4 == 0) query.points_m[i] += Eigen::Vector3f(0.5f, 0.3f, -0.2f);  // a quarter matched wrongly
  }
  match.count = query.count = 100;
  const AppearanceRegistration r = register_appearance(query, match, AppearanceConfig{});
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.matches, 100u);
  EXPECT_GE(r.inliers, 70u);
  EXPECT_LE(r.inliers, 76u);
  EXPECT_LT((r.match_T_query.translation() - match_T_query.translation()).norm(), 0.01);
  EXPECT_LT(Eigen::AngleAxisd(r.match_T_query.linear().transpose() * match_T_query.linear()).angle(), 0.005);
}

// Few features with centimetres of depth noise on a shallow scene pin the tilt poorly: the 6-DOF fit is tilted off
// by tenths of a degree, while the gravity-aligned fit keeps the odometry's (here true) roll and pitch and still
// recovers yaw and translation.
TEST(AppearanceTest, GravityAlignedRansacKeepsTheOdometrysTilt) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_real_distribution<double> x(-1.0, 1.0), y(-0.3, 0.3), z(0.5, 1.7);
  std::normal_distribution<double> noise(0.0, 0.015);
  // Cameras looking along the world's x (camera z) with y down; the query yawed, pitched down and moved.
  Eigen::Matrix3d look;
  look << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Eigen::Isometry3d world_T_match = Eigen::Isometry3d::Identity();
  world_T_match.linear() = look;
  Eigen::Isometry3d world_T_query = Eigen::Isometry3d::Identity();
  world_T_query.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()).toRotationMatrix() * look *
                           Eigen::AngleAxisd(-0.1, Eigen::Vector3d::UnitX()).toRotationMatrix();
  world_T_query.translation() = Eigen::Vector3d(-0.5, 0.3, 0.05);
  const Eigen::Isometry3d truth = world_T_match.inverse() * world_T_query;
  AppearanceFeatures match, query;
  const std::uint32_t n = 16;
  for (std::uint32_t i = 0; i < n; ++i) {
    for (auto& b : match.descriptors[i]) b = static_cast<std::uint8_t>(byte(rng));
    query.descriptors[i] = match.descriptors[i];
    const Eigen::Vector3d p(3.0 + y(rng), x(rng), z(rng));  // a shallow wall 3 m ahead
    const Eigen::Vector3d jitter(noise(rng), noise(rng), noise(rng));
    match.points_m[i] = (world_T_match.inverse() * p).cast<float>();
    query.points_m[i] = (world_T_query.inverse() * p + jitter).cast<float>();
  }
  match.count = query.count = n;
  AppearanceConfig config;
  config.inlier_m = 0.06;
  const GravityPrior gravity = GravityPrior::from_poses(world_T_match, world_T_query);
  const auto tilt_error = [&](const Eigen::Isometry3d& estimate) {
    const Eigen::Vector3d up = estimate.linear() * gravity.query_up;  // the query's vertical, as estimated
    return std::acos(std::min(1.0, up.dot(gravity.match_up)));
  };
  const AppearanceRegistration free = register_appearance(query, match, config, 1);
  const AppearanceRegistration aligned = register_appearance(query, match, config, 1, &gravity);
  ASSERT_TRUE(free.ok);
  ASSERT_TRUE(aligned.ok);
  EXPECT_GT(tilt_error(free.match_T_query), 0.003) << "the 6-DOF fit's tilt (the case this pass is for)";
  EXPECT_LT(tilt_error(aligned.match_T_query), 1e-9);
  EXPECT_LT(Eigen::AngleAxisd(aligned.match_T_query.linear().transpose() * truth.linear()).angle(), 0.01);
  EXPECT_LT((aligned.match_T_query.translation() - truth.translation()).norm(), 0.03);
  config.gravity_aligned = false;  // the switch gives the 6-DOF fit back
  const AppearanceRegistration off = register_appearance(query, match, config, 1, &gravity);
  EXPECT_TRUE(off.match_T_query.isApprox(free.match_T_query));
}

TEST(AppearanceTest, UnrelatedViewsDoNotRegister) {
  std::mt19937 rng(9);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  AppearanceFeatures a, b;
  for (std::size_t i = 0; i < 128; ++i) {
    for (auto& x : a.descriptors[i]) x = static_cast<std::uint8_t>(byte(rng));
    for (auto& x : b.descriptors[i]) x = static_cast<std::uint8_t>(byte(rng));
    a.points_m[i] = Eigen::Vector3f(u(rng), u(rng), 2.0f + u(rng));
    b.points_m[i] = Eigen::Vector3f(u(rng), u(rng), 2.0f + u(rng));
  }
  a.count = b.count = 128;
  const AppearanceRegistration r = register_appearance(a, b, AppearanceConfig{});
  EXPECT_FALSE(r.ok);
  EXPECT_LT(r.matches, 12u) << "random 256-bit descriptors are ~128 bits apart: the Hamming gate refuses them";
}

// ORB on a textured image with a known depth: features come back with their pixel's depth along the optical axis.
TEST(AppearanceTest, ExtractorBackProjectsFeaturesWithDepth) {
  const int w = 320, h = 240;
  std::vector<std::uint8_t> grey(w * h);
  std::vector<float> depth(w * h, 2.0f);
  std::mt19937 rng(2);
  std::uniform_int_distribution<int> v(0, 255);
  // Blocks of random grey: corners everywhere.
  for (int by = 0; by < h; by += 8)
    for (int bx = 0; bx < w; bx += 8) {
      const auto g = static_cast<std::uint8_t>(v(rng));
      for (int y = by; y < by + 8; ++y)
        for (int x = bx; x < bx + 8; ++x) grey[y * w + x] = g;
    }
  for (int x = 0; x < w / 2; ++x)
    for (int y = 0; y < h; ++y) depth[y * w + x] = std::nanf("");  // the left half has no depth
  AppearanceExtractor extractor;
  std::string error;
  ASSERT_TRUE(extractor.init(AppearanceConfig{}, &error)) << error;
  AppearanceFeatures f;
  GreyDepthView view{grey.data(), depth.data(), w, h, 262.5, 262.5, 159.5, 119.5};
  ASSERT_TRUE(extractor.extract(view, &f));
  EXPECT_GT(f.count, 40u);
  for (std::uint32_t i = 0; i < f.count; ++i) {
    EXPECT_FLOAT_EQ(f.points_m[i].z(), 2.0f);
    EXPECT_GT(f.points_m[i].x(), -0.02f) << "no feature from the half without depth";
  }
  EXPECT_FALSE(extractor.extract(GreyDepthView{}, &f));
  EXPECT_EQ(f.count, 0u);
}

TEST(AppearanceTest, BadConfigNamesTheField) {
  AppearanceConfig c;
  c.max_features = 1000;
  AppearanceExtractor e;
  std::string error;
  EXPECT_FALSE(e.init(c, &error));
  EXPECT_NE(error.find("max_features"), std::string::npos) << error;
}

}  // namespace
}  // namespace qsg::loop_closure
