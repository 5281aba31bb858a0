#include "core/loop_closure/local_map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

namespace qsg::loop_closure {
namespace {

// A 6 x 4 m room (floor, four walls, a wedge and a box) and cameras at 0.5 m looking horizontally along a yaw.
Eigen::Isometry3d camera(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d forward(std::cos(yaw), std::sin(yaw), 0.0), right(std::sin(yaw), -std::cos(yaw), 0.0),
      down(0.0, 0.0, -1.0);
  T.linear().col(0) = right;
  T.linear().col(1) = down;
  T.linear().col(2) = forward;
  T.translation() = Eigen::Vector3d(x, y, 0.5);
  return T;
}

// What a camera sees of the room: random surface points in its field of view, in its frame, with normals.
DepthCloud view(const Eigen::Isometry3d& world_T_camera, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  DepthCloud c;
  const Eigen::Isometry3d camera_T_world = world_T_camera.inverse();
  for (int tries = 0; tries < 200000 && c.count < kMaxCloudPoints; ++tries) {
    Eigen::Vector3d p, n;
    switch (tries % 7) {
      case 0: p = {6 * u(rng), 4 * u(rng), 0.0}; n = {0, 0, 1}; break;
      case 1: p = {0.0, 4 * u(rng), 2 * u(rng)}; n = {1, 0, 0}; break;
      case 2: p = {6.0, 4 * u(rng), 2 * u(rng)}; n = {-1, 0, 0}; break;
      case 3: p = {6 * u(rng), 0.0, 2 * u(rng)}; n = {0, 1, 0}; break;
      case 4: p = {6 * u(rng), 4.0, 2 * u(rng)}; n = {0, -1, 0}; break;
      case 5: {  // a wedge (a chair's back) pointing at the room's middle: two slanted faces
        const double t = u(rng);
        if (u(rng) < 0.5) p = {3.0 - 0.4 * t, 2.6 + 0.4 * t, 0.9 * u(rng)}, n = Eigen::Vector3d(-1, -1, 0).normalized();
        else p = {3.0 + 0.4 * t, 2.6 + 0.4 * t, 0.9 * u(rng)}, n = Eigen::Vector3d(1, -1, 0).normalized();
        break;
      }
      default: p = {4.5, 0.5 + 0.7 * u(rng), 0.9 * u(rng)}; n = {-1, 0, 0}; break;  // a box's side
    }
    const Eigen::Vector3d q = camera_T_world * p, m = camera_T_world.linear() * n;
    if (!(q.z() > 0.3 && q.z() < 4.0 && std::abs(q.x() / q.z()) < 0.8 && std::abs(q.y() / q.z()) < 0.6)) continue;
    if (m.dot(q) > 0.0) continue;  // seen from behind
    const std::size_t i = c.count++;
    for (int k = 0; k < 3; ++k) {
      c.points_mm[i][k] = static_cast<std::int16_t>(std::lround(q[k] * 1000.0));
      c.normals[i][k] = static_cast<std::int8_t>(std::lround(m[k] * 127.0));
    }
  }
  return c;
}

LocalMapConfig enabled() {
  LocalMapConfig c;
  c.enabled = true;
  return c;
}

// The robot turns from facing the cupboard's wall to facing +x on its first pass, and on its way back turns from
// facing -x to the same wall: the two keyframes at the closure face opposite ways and share nothing, the two local
// maps share the wall they both turned through.
TEST(LocalMapTest, OppositeViewsRegisterOnTheirLocalMaps) {
  LocalMapVerifier v;
  std::string error;
  ASSERT_TRUE(v.init(enabled(), LocalMapCapacities{16, 4096}, &error)) << error;
  const Eigen::Isometry3d world_T_match = camera(3.0, 2.0, 0.0), world_T_query = camera(3.2, 1.9, M_PI);
  v.begin(world_T_match);
  for (int k = 0; k <= 4; ++k) {
    const Eigen::Isometry3d T = camera(3.0 - 0.1 * k, 2.0, k * M_PI / 8.0);
    ASSERT_TRUE(v.add(view(T, 10 + k), T));
  }
  v.finish(&v.match_cloud());
  v.begin(world_T_query);
  for (int k = 0; k <= 4; ++k) {
    const Eigen::Isometry3d T = camera(3.2 + 0.1 * k, 1.9, M_PI - k * M_PI / 8.0);
    ASSERT_TRUE(v.add(view(T, 20 + k), T));
  }
  v.finish(&v.query_cloud());
  EXPECT_GT(v.match_cloud().points.size(), 300u);
  EXPECT_LE(v.match_cloud().points.size(), 4096u);
  const Eigen::Isometry3d truth = world_T_match.inverse() * world_T_query;
  Eigen::Isometry3d coarse = truth;
  coarse.translation() += Eigen::Vector3d(0.07, -0.05, 0.03);
  coarse.linear() = coarse.linear() * Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitY()).toRotationMatrix();
  // The two keyframes alone: nothing in common.
  const IcpResult alone = refine_icp(view(world_T_query, 20), view(world_T_match, 10), coarse, IcpConfig{});
  EXPECT_FALSE(alone.ok);
  const IcpResult r = v.register_clouds(v.query_cloud(), v.match_cloud(), coarse, IcpConfig{});
  ASSERT_TRUE(r.ok) << "overlap " << r.overlap << " constraint " << r.constraint_ratio;
  const Eigen::Isometry3d e = truth.inverse() * r.match_T_query;
  EXPECT_LT(e.translation().norm(), 0.02);
  EXPECT_LT(Eigen::AngleAxisd(e.linear()).angle(), 0.005);
}

TEST(LocalMapTest, LocalMapsOfDifferentRoomsAreNotTrusted) {
  LocalMapVerifier v;
  std::string error;
  ASSERT_TRUE(v.init(enabled(), LocalMapCapacities{16, 4096}, &error)) << error;
  const Eigen::Isometry3d a = camera(3.0, 2.0, 0.3), b = camera(3.0, 2.0, 0.3);
  v.begin(a);
  ASSERT_TRUE(v.add(view(a, 1), a));
  v.finish(&v.match_cloud());
  // The query's room is the same room shifted by 1.5 m with everything in it: its clouds do not match 1.5 m away.
  Eigen::Isometry3d shifted = b;
  shifted.translation().x() += 1.5;
  v.begin(b);
  ASSERT_TRUE(v.add(view(shifted, 2), b));
  v.finish(&v.query_cloud());
  EXPECT_FALSE(v.register_clouds(v.query_cloud(), v.match_cloud(), Eigen::Isometry3d::Identity(), IcpConfig{}).ok);
}

TEST(LocalMapTest, GatherBufferIsBoundedAndConfigChecked) {
  LocalMapVerifier v;
  std::string error;
  ASSERT_TRUE(v.init(enabled(), LocalMapCapacities{2, 4096}, &error)) << error;
  const Eigen::Isometry3d T = camera(3.0, 2.0, 0.0);
  const DepthCloud c = view(T, 3);
  ASSERT_EQ(c.count, kMaxCloudPoints);
  v.begin(T);
  EXPECT_TRUE(v.add(c, T));
  EXPECT_TRUE(v.add(c, T));
  EXPECT_FALSE(v.add(c, T));  // full: refused, nothing allocated
  LocalMapConfig bad = enabled();
  bad.voxel_m = 0.0;
  EXPECT_FALSE(v.init(bad, LocalMapCapacities{2, 4096}, &error));
  EXPECT_NE(error.find("voxel_m"), std::string::npos) << error;
}

}  // namespace
}  // namespace qsg::loop_closure
