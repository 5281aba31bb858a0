#include "core/loop_closure/depth_cloud.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace qsg::loop_closure {
namespace {

// A corner of a room seen by a camera: floor, two walls and a box on the floor, sampled at random points.
void add_point(DepthCloud* c, const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
  const std::size_t i = c->count++;
  for (int k = 0; k < 3; ++k) {
    c->points_mm[i][k] = static_cast<std::int16_t>(std::lround(p[k] * 1000.0));
    c->normals[i][k] = static_cast<std::int8_t>(std::lround(n[k] * 127.0));
  }
}

DepthCloud corner(const Eigen::Isometry3d& camera_T_world, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 3.0), v(0.0, 2.0);
  DepthCloud c;
  for (int i = 0; i < 500; ++i) {
    Eigen::Vector3d p, n;
    switch (i % 4) {
      case 0: p = {u(rng), u(rng), 0.0}; n = {0, 0, 1}; break;      // floor
      case 1: p = {0.0, u(rng), v(rng)}; n = {1, 0, 0}; break;      // wall x = 0
      case 2: p = {u(rng), 0.0, v(rng)}; n = {0, 1, 0}; break;      // wall y = 0
      default: p = {1.5, 1.0 + 0.5 * u(rng) / 3.0, 0.5 * v(rng) / 2.0}; n = {1, 0, 0}; break;  // a box face
    }
    add_point(&c, camera_T_world * p, camera_T_world.linear() * n);
  }
  return c;
}

Eigen::Isometry3d pose(double x, double y, double z, double yaw, double pitch) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

// The grid ICP looks neighbours up in must find what trying every point finds, for every gate up to its cell
// (including points on cell borders and query points far from any), or ICP's result would depend on the index.
TEST(DepthCloudTest, TheGridIndexFindsWhatTryingEveryPointFinds) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  const double cell = 0.3;
  std::vector<Eigen::Vector3d> points(kMaxCloudPoints);
  for (std::size_t j = 0; j < points.size(); ++j)
    points[j] = j % 8 == 0 ? Eigen::Vector3d(std::round(u(rng) / cell) * cell, u(rng), 0.6)  // on a cell border
                           : Eigen::Vector3d(u(rng), u(rng), 0.5 * u(rng) + 3.0);
  GridIndex::Cell cells[kMaxCloudPoints];
  const std::size_t n = GridIndex::build(points.data(), kMaxCloudPoints, cell, cells, kMaxCloudPoints);
  ASSERT_EQ(n, kMaxCloudPoints);
  const GridIndex grid(cells, n, points.data(), cell);
  const BruteForceIndex brute(points.data(), kMaxCloudPoints);
  std::size_t found = 0, missed = 0;
  for (int i = 0; i < 4000; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), 0.75 * u(rng) + 2.5);
    for (const double gate : {0.05, 0.2, 0.3}) {
      std::uint32_t a = 0, b = 0;
      const bool in_grid = grid.nearest(p, gate * gate, &a);
      ASSERT_EQ(in_grid, brute.nearest(p, gate * gate, &b)) << "query " << i << ", gate " << gate;
      if (in_grid) {
        ASSERT_EQ(a, b) << "query " << i << ", gate " << gate;
      }
      (in_grid ? found : missed) += 1;
    }
  }
  EXPECT_GT(found, 1000u);  // both outcomes exercised
  EXPECT_GT(missed, 1000u);
}

TEST(DepthCloudTest, IcpRefinesACoarseEstimateToTheDepthsPrecision) {
  const Eigen::Isometry3d world_T_match = pose(2.5, 2.5, 0.5, 3.9, 0.1), world_T_query = pose(2.2, 2.8, 0.5, 4.1, 0.1);
  const DepthCloud match = corner(world_T_match.inverse(), 1), query = corner(world_T_query.inverse(), 2);
  const Eigen::Isometry3d truth = world_T_match.inverse() * world_T_query;  // match_T_query
  const Eigen::Isometry3d coarse = truth * pose(0.08, -0.06, 0.02, 0.03, 0.0);  // what object centroids give
  const IcpResult r = refine_icp(query, match, coarse, IcpConfig{});
  ASSERT_TRUE(r.ok) << "overlap " << r.overlap;
  const Eigen::Isometry3d error = truth.inverse() * r.match_T_query;
  EXPECT_LT(error.translation().norm(), 0.01);
  EXPECT_LT(Eigen::AngleAxisd(error.linear()).angle(), 0.003);
  EXPECT_GT(r.overlap, 0.8);
  EXPECT_EQ(r.refusal, IcpRefusal::kNone);
  // The same fit is not trusted when the correction it needed (about 10 cm) is beyond the bound.
  IcpConfig tight;
  tight.max_correction_m = 0.05;
  const IcpResult bounded = refine_icp(query, match, coarse, tight);
  EXPECT_FALSE(bounded.ok);
  EXPECT_EQ(bounded.refusal, IcpRefusal::kCorrection);
}

double tilt_deg(const Eigen::Isometry3d& world_T_match, const Eigen::Isometry3d& error) {
  const Eigen::AngleAxisd aa(error.linear());
  return (world_T_match.linear() * aa.axis() * aa.angle()).head<2>().norm() * 180.0 / M_PI;
}

// Odometry with an IMU knows the two views' tilt; the coarse estimate (a RANSAC pose, say) is 2 degrees off in
// roll. Gravity aligned, ICP keeps the odometry's tilt exactly and finds yaw and translation.
TEST(DepthCloudTest, GravityAlignedIcpKeepsTheOdometrysTiltAndEstimatesYawAndTranslation) {
  const Eigen::Isometry3d world_T_match = pose(2.5, 2.5, 0.5, 3.9, 0.1), world_T_query = pose(2.2, 2.8, 0.5, 4.1, 0.1);
  const DepthCloud match = corner(world_T_match.inverse(), 1), query = corner(world_T_query.inverse(), 2);
  const Eigen::Isometry3d truth = world_T_match.inverse() * world_T_query;
  Eigen::Isometry3d coarse = truth * pose(0.08, -0.06, 0.0, 0.03, 0.0);
  coarse.linear() = coarse.linear() * Eigen::AngleAxisd(0.035, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const GravityPrior gravity = GravityPrior::from_poses(world_T_match, world_T_query);
  const IcpResult r = refine_icp(query, match, coarse, IcpConfig{}, &gravity);
  ASSERT_TRUE(r.ok) << "overlap " << r.overlap << " constraint " << r.constraint_ratio;
  const Eigen::Isometry3d error = truth.inverse() * r.match_T_query;
  EXPECT_LT(tilt_deg(world_T_match, error), 1e-6);
  EXPECT_LT(error.translation().norm(), 0.01);
  EXPECT_LT(Eigen::AngleAxisd(error.linear()).angle(), 0.003);

  IcpConfig full;  // the same without the prior's use: 6 DOF
  full.gravity_aligned = false;
  const IcpResult r6 = refine_icp(query, match, coarse, full, &gravity);
  EXPECT_GT(tilt_deg(world_T_match, truth.inverse() * r6.match_T_query), 1e-6) << "6 DOF estimates the tilt";
}

// Object centroids can put the coarse estimate 0.2 m off; gravity-aligned ICP still gets to the depth's precision.
TEST(DepthCloudTest, IcpConvergesFromTwoDecimetresOff) {
  const Eigen::Isometry3d world_T_match = pose(2.5, 2.5, 0.5, 3.9, 0.1), world_T_query = pose(2.2, 2.8, 0.5, 4.1, 0.1);
  const DepthCloud match = corner(world_T_match.inverse(), 1), query = corner(world_T_query.inverse(), 2);
  const Eigen::Isometry3d truth = world_T_match.inverse() * world_T_query;
  const GravityPrior gravity = GravityPrior::from_poses(world_T_match, world_T_query);
  for (const Eigen::Vector3d& off :
       {Eigen::Vector3d(0.2, 0.0, 0.0), Eigen::Vector3d(0.0, -0.2, 0.0), Eigen::Vector3d(0.14, 0.14, 0.0)}) {
    const Eigen::Isometry3d coarse = truth * pose(off.x(), off.y(), off.z(), 0.02, 0.0);
    const IcpResult r = refine_icp(query, match, coarse, IcpConfig{}, &gravity);
    ASSERT_TRUE(r.ok) << off.transpose() << ": overlap " << r.overlap;
    const Eigen::Isometry3d error = truth.inverse() * r.match_T_query;
    EXPECT_LT(error.translation().norm(), 0.01) << off.transpose();
    EXPECT_LT(Eigen::AngleAxisd(error.linear()).angle(), 0.003) << off.transpose();
  }
}

// A wall and the floor pin two directions of translation, not the third: ICP could slide along it.
TEST(DepthCloudTest, AWallAndAFloorAloneAreDegenerate) {
  DepthCloud a, b;
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> u(0.0, 3.0);
  for (DepthCloud* c : {&a, &b})
    for (int i = 0; i < 400; ++i) {
      if (i % 2 == 0) add_point(c, Eigen::Vector3d(u(rng), u(rng), 0.0), Eigen::Vector3d(0, 0, 1));
      else add_point(c, Eigen::Vector3d(0.0, u(rng), u(rng) / 1.5), Eigen::Vector3d(1, 0, 0));
    }
  const IcpResult r = refine_icp(a, b, Eigen::Isometry3d::Identity(), IcpConfig{});
  EXPECT_GT(r.overlap, 0.8);
  EXPECT_LT(r.constraint_ratio, 0.05);
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.refusal, IcpRefusal::kDegenerate);
}

TEST(DepthCloudTest, CloudsThatDoNotOverlapAreNotTrusted) {
  const DepthCloud match = corner(pose(0, 0, 0, 0, 0).inverse(), 1);
  const DepthCloud query = corner(pose(20, 0, 0, 0, 0).inverse(), 2);  // another room, 20 m away
  const IcpResult r = refine_icp(query, match, Eigen::Isometry3d::Identity(), IcpConfig{});
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.refusal, IcpRefusal::kNoOverlap);
}

TEST(DepthCloudTest, ADepthImageOfAPlaneGivesPointsWithTheirNormal) {
  const int w = 64, h = 48;
  std::vector<float> depth(w * h, 2.0f);
  for (int x = 0; x < 8; ++x) depth[x] = std::nanf("");
  GreyDepthView v{nullptr, depth.data(), w, h, 50.0, 50.0, 31.5, 23.5};
  DepthCloud c;
  ASSERT_TRUE(make_depth_cloud(v, 4.0, &c));
  EXPECT_GT(c.count, 100u);
  for (std::uint32_t i = 0; i < c.count; ++i) {
    EXPECT_EQ(c.points_mm[i][2], 2000);
    EXPECT_EQ(c.normals[i][2], -127) << "the plane faces the camera";
  }
  EXPECT_FALSE(make_depth_cloud(GreyDepthView{}, 4.0, &c));
}

}  // namespace
}  // namespace qsg::loop_closure
