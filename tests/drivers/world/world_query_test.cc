// Tests of world queries: shape distances, box overlap, bounds, room lookup, and the free-space grid against a
// brute-force reference.
#include "drivers/world/world_query.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "drivers/world/building_generator.h"
#include "drivers/world/world_geometry.h"

namespace qsg::world {
namespace {

// Slow, obviously-correct reference: the minimum distance over every shape.
double brute_force_distance(const World& w, const Eigen::Vector3d& p) {
  double best = 1e300;
  for (const Shape& s : w.shapes) best = std::min(best, distance_to_shape(w, s, p));
  return best;
}

World mixed_world() {
  World w;
  Material m;
  m.label = semantics::kWall;
  w.add_box(yaw_box({0.0, 0.0, 1.0}, {2.0, 1.0, 2.0}, 0.7), m);
  CylinderShape c;
  c.base_center_m = {3.0, 0.0, 0.0};
  c.radius_m = 0.5;
  c.height_m = 1.5;
  w.add_cylinder(c, m);
  PrismShape p;
  p.polygon_m = {{-3.0, -1.0}, {-1.5, -1.0}, {-1.5, 1.0}, {-2.2, 0.2}, {-3.0, 1.0}};  // non-convex
  p.z_min_m = 0.2;
  p.z_max_m = 2.0;
  w.add_prism(p, m);
  BoxShape tilted;
  tilted.center_m = {0.0, 3.0, 1.0};
  tilted.half_extents_m = {0.8, 0.3, 0.2};
  tilted.world_R_box = Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d(1.0, 1.0, 0.0).normalized()));
  w.add_box(tilted, m);
  return w;
}

TEST(WorldQuery, DistancesToEachShapeKind) {
  const World w = mixed_world();
  EXPECT_EQ(distance_to_shape(w, w.shapes[0], {0.0, 0.0, 1.0}), 0.0);
  EXPECT_NEAR(distance_to_shape(w, w.shapes[0], {0.0, 0.0, 3.0}), 1.0, 1e-12);
  EXPECT_NEAR(distance_to_shape(w, w.shapes[1], {5.0, 0.0, 0.5}), 1.5, 1e-12);
  EXPECT_NEAR(distance_to_shape(w, w.shapes[1], {3.0, 0.0, 2.5}), 1.0, 1e-12);
  EXPECT_EQ(distance_to_shape(w, w.shapes[2], {-2.8, -0.5, 1.0}), 0.0);
  // In the notch: the nearest edge runs from (-1.5, 1) to (-2.2, 0.2).
  EXPECT_NEAR(distance_to_shape(w, w.shapes[2], {-2.2, 0.8, 1.0}), 0.3951, 1e-3);
  EXPECT_NEAR(distance_to_shape(w, w.shapes[2], {-2.0, 0.0, 3.0}), 1.0, 1e-12);
  PlaneShape ground;
  World g;
  g.add_plane(ground, Material());
  EXPECT_EQ(distance_to_shape(g, g.shapes[0], {1.0, 2.0, -3.0}), 0.0);  // below the plane is solid
  EXPECT_NEAR(distance_to_shape(g, g.shapes[0], {1.0, 2.0, 0.4}), 0.4, 1e-12);
}

TEST(WorldQuery, BoxOverlapSeparatingAxes) {
  const BoxShape a = axis_box(0, 0, 0, 1, 1, 1);
  EXPECT_TRUE(boxes_overlap(a, axis_box(0.9, 0.9, 0.9, 2, 2, 2)));
  EXPECT_FALSE(boxes_overlap(a, axis_box(1.1, 0, 0, 2, 1, 1)));
  EXPECT_TRUE(boxes_overlap(a, axis_box(1.1, 0, 0, 2, 1, 1), 0.06));
  // A diamond whose corner points at the box but does not reach it.
  const BoxShape diamond = yaw_box({2.0, 0.5, 0.5}, {1.0, 1.0, 1.0}, 0.25 * 3.14159265358979);
  EXPECT_FALSE(boxes_overlap(a, diamond));  // corner at x = 2 - 0.707
  const BoxShape near = yaw_box({1.6, 0.5, 0.5}, {1.0, 1.0, 1.0}, 0.25 * 3.14159265358979);
  EXPECT_TRUE(boxes_overlap(a, near));
  // Stacked boxes touch but do not overlap once shrunk by a hair.
  EXPECT_FALSE(boxes_overlap(a, axis_box(0, 0, 1, 1, 1, 2), -1e-9));
}

TEST(WorldQuery, BoundsAndPolygons) {
  const World w = mixed_world();
  const Aabb b = world_bounds(w);
  EXPECT_NEAR(b.min_m.x(), -3.0, 1e-12);
  EXPECT_NEAR(b.max_m.x(), 3.5, 1e-12);
  EXPECT_NEAR(b.min_m.z(), 0.0, 1e-12);
  const Polygon2 square = Rect{0, 0, 2, 1}.polygon();
  EXPECT_DOUBLE_EQ(polygon_signed_area(square), 2.0);
  EXPECT_TRUE(point_in_polygon(square, {1.0, 0.5}));
  EXPECT_FALSE(point_in_polygon(square, {2.5, 0.5}));
  EXPECT_TRUE(shape_bounds(w, Shape{ShapeKind::kPlane, 0, Material(), -1, -1}).empty());
}

TEST(WorldQuery, RoomAtFindsRoomsOnTheRightFloor) {
  BuildingConfig c;
  c.num_rooms = 10;
  c.two_floors = true;
  const World w = generate_building(c);
  for (const Room& r : w.rooms) {
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    for (const Eigen::Vector2d& v : r.footprint_m[0]) centre += v;
    centre /= static_cast<double>(r.footprint_m[0].size());
    EXPECT_EQ(room_at(w, centre.x(), centre.y(), r.floor_z_m + 1.0), r.id);
  }
  const Aabb b = world_bounds(w);
  EXPECT_EQ(room_at(w, b.min_m.x() - 1.0, 0.0, 1.0), -1);
  EXPECT_EQ(room_at(w, 1.0, 0.5, b.max_m.z() + 1.0), -1);
}

TEST(WorldQuery, FreeSpaceIndexAgreesWithBruteForce) {
  BuildingConfig c;
  c.num_rooms = 8;
  c.seed = 3;
  World w = generate_building(c);
  const World extra = mixed_world();  // rotated boxes, cylinders and prisms too
  for (const Shape& s : extra.shapes) {
    if (s.kind == ShapeKind::kBox) w.add_box(extra.boxes[s.index], s.material);
    if (s.kind == ShapeKind::kCylinder) w.add_cylinder(extra.cylinders[s.index], s.material);
    if (s.kind == ShapeKind::kPrism) w.add_prism(extra.prisms[s.index], s.material);
  }
  FreeSpaceIndex::Config ic;
  ic.cell_size_m = 0.4;
  ic.max_clearance_m = 0.35;
  const FreeSpaceIndex index(w, ic);
  EXPECT_EQ(index.num_shapes(), w.shapes.size());
  const Aabb b = world_bounds(w);
  Rng rng(5);
  int free_count = 0;
  for (int i = 0; i < 3000; ++i) {
    // Braces evaluate left to right, so the sample is the same with every compiler.
    const Eigen::Vector3d p{rng.uniform(b.min_m.x() - 1.0, b.max_m.x() + 1.0),
                            rng.uniform(b.min_m.y() - 1.0, b.max_m.y() + 1.0),
                            rng.uniform(b.min_m.z() - 0.5, b.max_m.z() + 0.5)};
    const double d = brute_force_distance(w, p);
    for (double r : {0.0, 0.2, 0.35, 0.8}) {
      if (std::abs(d - r) < 1e-9) continue;  // exactly on the boundary either answer is right
      const bool expect_free = r > 0.0 ? d >= r : d > 0.0;
      ASSERT_EQ(index.is_free(p, r), expect_free) << "point " << p.transpose() << " r " << r << " d " << d;
      free_count += expect_free;
    }
    EXPECT_NEAR(index.clearance(p, 0.3), std::min(d, 0.3), 1e-9);
    EXPECT_NEAR(index.clearance(p, 1.0), std::min(d, 1.0), 1e-9);
  }
  EXPECT_GT(free_count, 1000);  // the sample exercised both answers
  EXPECT_LT(free_count, 11000);
}

TEST(WorldQuery, PlanesBlockEverythingBehindThem) {
  World w;
  PlaneShape ground;
  ground.point_m = {0.0, 0.0, 0.0};
  w.add_plane(ground, Material());
  const FreeSpaceIndex index(w);
  EXPECT_FALSE(index.is_free({100.0, -50.0, -0.1}, 0.0));
  EXPECT_FALSE(index.is_free({100.0, -50.0, 0.1}, 0.2));
  EXPECT_TRUE(index.is_free({100.0, -50.0, 0.3}, 0.2));
  EXPECT_NEAR(index.clearance({3.0, 3.0, 0.25}, 1.0), 0.25, 1e-12);
}

TEST(WorldQuery, EmptyWorldIsFreeEverywhere) {
  const FreeSpaceIndex index{World()};
  EXPECT_TRUE(index.is_free({0.0, 0.0, 0.0}, 1.0));
  EXPECT_DOUBLE_EQ(index.clearance({0.0, 0.0, 0.0}, 2.0), 2.0);
  EXPECT_TRUE(world_bounds(World()).empty());
}

}  // namespace
}  // namespace qsg::world
