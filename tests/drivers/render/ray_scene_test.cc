// RayScene: BVH-accelerated nearest hits against the brute-force face-by-face reference on random worlds and
// rays (including axis-parallel ones), normals, hints, and an empty world.
#include "drivers/render/ray_scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tests/drivers/render/reference_raycast.h"

namespace qsg::render {
namespace {

constexpr double kPi = 3.14159265358979323846;

world::Material label_material(int i) {
  world::Material m;
  m.label = static_cast<semantics::Label>(i % semantics::kNumObjectLabels);
  return m;
}

// Random boxes (half of them rotated), cylinders, convex and concave (L, U and star) prisms, and a ground plane.
world::World random_world(std::uint32_t seed, int num_shapes) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(-10.0, 10.0), size(0.1, 1.5), unit(0.0, 1.0);
  world::World w;
  w.name = "random";
  world::PlaneShape ground;
  ground.point_m = {0.0, 0.0, -3.0};
  ground.normal = {0.05, -0.02, 1.0};
  w.add_plane(ground, label_material(0));
  for (int i = 0; i < num_shapes; ++i) {
    const Eigen::Vector3d c(pos(rng), pos(rng), 0.3 * pos(rng));
    switch (i % 4) {
      case 0: {
        world::BoxShape b;
        b.center_m = c;
        b.half_extents_m = {size(rng), size(rng), size(rng)};
        if (i % 8 == 0) b.world_R_box = Eigen::Quaterniond::UnitRandom();
        w.add_box(b, label_material(i));
        break;
      }
      case 1: {
        world::CylinderShape cyl;
        cyl.base_center_m = c;
        cyl.radius_m = size(rng);
        cyl.height_m = 2.0 * size(rng);
        w.add_cylinder(cyl, label_material(i));
        break;
      }
      default: {
        world::PrismShape p;
        p.z_min_m = c.z();
        p.z_max_m = c.z() + 2.0 * size(rng);
        const double s = size(rng);
        if (i % 4 == 2) {
          // Star: alternating radii make a concave outline.
          const int spikes = 3 + static_cast<int>(unit(rng) * 5);
          const double phase = unit(rng);
          for (int k = 0; k < 2 * spikes; ++k) {
            const double r = (k % 2 == 0 ? 1.0 : 0.4) * s;
            const double a = phase + k * kPi / spikes;
            p.polygon_m.emplace_back(c.x() + r * std::cos(a), c.y() + r * std::sin(a));
          }
        } else {
          // U shape.
          const double x = c.x(), y = c.y();
          p.polygon_m = {
              {x, y},         {x + 3 * s, y},     {x + 3 * s, y + 2 * s}, {x + 2 * s, y + 2 * s}, {x + 2 * s, y + s},
              {x + s, y + s}, {x + s, y + 2 * s}, {x, y + 2 * s}};
        }
        w.add_prism(p, label_material(i));
        break;
      }
    }
  }
  return w;
}

// A point is usable as a ray origin when it is outside every solid (inside one, a split concave prism would show
// its internal faces, which the reference does not have).
bool outside_all(const world::World& w, const Eigen::Vector3d& p) {
  // A point inside a closed solid sees it in every direction; test a few directions against the reference.
  const Eigen::Vector3d dirs[3] = {{0.31, 0.52, 0.79}, {-0.6, 0.1, -0.79}, {0.05, -0.99, 0.1}};
  for (std::size_t s = 0; s < w.shapes.size(); ++s) {
    if (w.shapes[s].kind == world::ShapeKind::kPlane) continue;
    bool seen_every_way = true;
    for (int k = 0; k < 3 && seen_every_way; ++k)
      seen_every_way = std::isfinite(testing::reference_shape_t(w, s, p, dirs[k], 0.0));
    if (seen_every_way) return false;
  }
  return true;
}

TEST(RayScene, RandomRaysMatchBruteForceReference) {
  const world::World w = random_world(7, 120);
  RayScene scene;
  std::string error;
  ASSERT_TRUE(scene.build(w, &error)) << error;
  EXPECT_GT(scene.stats().num_primitives, 120u);  // concave prisms were split
  EXPECT_EQ(scene.stats().num_planes, 1u);
  EXPECT_LE(scene.stats().bvh_depth, Bvh::kMaxDepth);

  std::mt19937 rng(99);
  std::uniform_real_distribution<double> pos(-12.0, 12.0), dir(-1.0, 1.0);
  int hits = 0, tested = 0;
  for (int i = 0; i < 1500; ++i) {
    const Eigen::Vector3d o(pos(rng), pos(rng), 0.4 * pos(rng));
    if (!outside_all(w, o)) continue;
    Eigen::Vector3d d(dir(rng), dir(rng), dir(rng));
    // Every fourth ray is axis-parallel in one or two components (zero direction components).
    if (i % 4 == 1) d.z() = 0.0;
    if (i % 8 == 3) d.x() = d.y() = 0.0;
    if (d.norm() < 1e-3) continue;
    d *= 0.5 + dir(rng) * 0.4;  // not unit: the scene must not assume it
    const double t_max = 30.0;
    const testing::ReferenceHit ref = testing::reference_raycast(w, o, d, 1e-6, t_max);
    RayHit hit;
    const bool found = scene.intersect(o, d, 1e-6, t_max, &hit);
    ++tested;
    ASSERT_EQ(found, ref.shape >= 0) << "ray " << i << " ref t " << ref.t;
    if (!found) continue;
    ++hits;
    ASSERT_NEAR(hit.t, ref.t, 1e-7 * (1.0 + ref.t)) << "ray " << i;
    if (ref.second_t - ref.t > 1e-7) {
      ASSERT_EQ(static_cast<int>(hit.shape), ref.shape) << "ray " << i;
    }
    ASSERT_NEAR(hit.normal.norm(), 1.0, 1e-9);
    EXPECT_EQ(scene.material(hit.shape).label, w.shapes[hit.shape].material.label);
    // A hint (right or wrong) never changes the answer.
    RayHit hinted;
    ASSERT_TRUE(scene.intersect(o, d, 1e-6, t_max, &hinted, hit.primitive));
    ASSERT_EQ(hinted.t, hit.t);
    ASSERT_TRUE(scene.intersect(o, d, 1e-6, t_max, &hinted, static_cast<std::uint32_t>(i % 50)));
    ASSERT_EQ(hinted.t, hit.t);
  }
  EXPECT_GT(tested, 1000);
  EXPECT_GT(hits, tested / 3);
}

TEST(RayScene, NormalsPointOutOfTheSurfaceHit) {
  world::World w;
  world::BoxShape b;
  b.center_m = {5.0, 0.0, 0.0};
  b.world_R_box = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  w.add_box(b, label_material(1));
  world::CylinderShape c;
  c.base_center_m = {0.0, 5.0, -0.5};
  w.add_cylinder(c, label_material(2));
  RayScene scene;
  std::string error;
  ASSERT_TRUE(scene.build(w, &error)) << error;
  RayHit hit;
  ASSERT_TRUE(scene.intersect(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), 0.0, 100.0, &hit));
  EXPECT_LT(hit.normal.dot(Eigen::Vector3d::UnitX()), 0.0);
  EXPECT_NEAR(hit.normal.dot(b.world_R_box * Eigen::Vector3d::UnitX()), -1.0, 1e-12);
  ASSERT_TRUE(scene.intersect(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitY(), 0.0, 100.0, &hit));
  EXPECT_NEAR(hit.t, 4.75, 1e-12);
  EXPECT_TRUE(hit.normal.isApprox(-Eigen::Vector3d::UnitY(), 1e-12));
  // From inside a solid the ray sees its inside surface (the normal still points out).
  ASSERT_TRUE(scene.intersect(Eigen::Vector3d(5.0, 0.0, 0.0), Eigen::Vector3d::UnitZ(), 0.0, 100.0, &hit));
  EXPECT_NEAR(hit.t, 0.5, 1e-12);
  EXPECT_TRUE(hit.normal.isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
}

TEST(RayScene, EmptyWorldAndPlanesOnly) {
  world::World w;
  RayScene scene;
  std::string error;
  ASSERT_TRUE(scene.build(w, &error)) << error;
  RayHit hit;
  EXPECT_FALSE(scene.intersect(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), 0.0, 100.0, &hit));
  world::PlaneShape p;
  p.point_m = {0.0, 0.0, -2.0};
  w.add_plane(p, label_material(3));
  ASSERT_TRUE(scene.build(w, &error)) << error;
  EXPECT_FALSE(scene.intersect(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), 0.0, 100.0, &hit));
  ASSERT_TRUE(scene.intersect(Eigen::Vector3d::Zero(), Eigen::Vector3d(1.0, 0.0, -1.0), 0.0, 100.0, &hit));
  EXPECT_NEAR(hit.t, 2.0, 1e-12);
  EXPECT_EQ(hit.primitive, kNoPrimitive);
  EXPECT_FALSE(scene.intersect(Eigen::Vector3d::Zero(), Eigen::Vector3d(1.0, 0.0, -1.0), 0.0, 1.5, &hit));
}

// Regression (issue 36): a box of 1e308 m made the BVH build divide infinities and crash. Shapes beyond the
// scene's float limit are refused by name and leave the scene empty.
TEST(RayScene, ShapesBeyondTheFloatLimitAreRefusedByName) {
  world::World w;
  world::BoxShape b;
  b.center_m = {0.0, 0.0, 0.0};
  b.half_extents_m = {5e307, 5e307, 0.5};
  w.add_box(b, label_material(1));
  RayScene scene;
  std::string error;
  EXPECT_FALSE(scene.build(w, &error));
  EXPECT_NE(error.find("shapes[0]"), std::string::npos) << error;
  EXPECT_NE(error.find("exceed the ray scene's limit of +-1e+06 m"), std::string::npos) << error;
  EXPECT_FALSE(scene.built());
  world::World cylinder;
  world::CylinderShape c;
  c.base_center_m = {2e6, 0.0, 0.0};
  c.radius_m = 1.0;
  c.height_m = 1.0;
  cylinder.add_cylinder(c, label_material(1));
  EXPECT_FALSE(scene.build(cylinder, &error));
  EXPECT_NE(error.find("limit of +-1e+06 m"), std::string::npos) << error;
  b.half_extents_m = {1000.0, 1000.0, 0.5};  // large but within the limit
  world::World ok;
  ok.add_box(b, label_material(1));
  EXPECT_TRUE(scene.build(ok, &error)) << error;
}

}  // namespace
}  // namespace qsg::render
