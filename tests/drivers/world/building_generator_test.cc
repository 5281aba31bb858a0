// Tests of the procedural building generator: determinism, room counts, door graph, door widths, furniture rules,
// two floors with stairs.
#include "drivers/world/building_generator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <queue>
#include <set>

#include "drivers/world/world_file.h"
#include "drivers/world/world_geometry.h"
#include "drivers/world/world_query.h"

namespace qsg::world {
namespace {

using namespace semantics;

BuildingConfig config(std::uint64_t seed, int rooms, bool two_floors = false) {
  BuildingConfig c;
  c.seed = seed;
  c.num_rooms = rooms;
  c.two_floors = two_floors;
  return c;
}

// Rooms reached from room 0 by walking through doors.
std::set<int> reachable(const World& w) {
  std::vector<std::vector<int>> adj(w.rooms.size());
  for (const Door& d : w.doors) {
    adj[static_cast<std::size_t>(d.room_a)].push_back(d.room_b);
    adj[static_cast<std::size_t>(d.room_b)].push_back(d.room_a);
  }
  std::set<int> seen{0};
  std::queue<int> q;
  q.push(0);
  while (!q.empty()) {
    const int r = q.front();
    q.pop();
    for (int n : adj[static_cast<std::size_t>(r)])
      if (seen.insert(n).second) q.push(n);
  }
  return seen;
}

// The axis-aligned rectangle of a generated room.
Rect rect_of(const Room& r) {
  Rect q{1e9, 1e9, -1e9, -1e9};
  for (const Eigen::Vector2d& v : r.footprint_m.at(0)) {
    q.x0 = std::min(q.x0, v.x());
    q.y0 = std::min(q.y0, v.y());
    q.x1 = std::max(q.x1, v.x());
    q.y1 = std::max(q.y1, v.y());
  }
  return q;
}

std::multiset<Label> labels_in_room(const World& w, int room) {
  std::multiset<Label> out;
  for (const Object& o : w.objects)
    if (o.room_id == room) out.insert(o.label);
  return out;
}

TEST(BuildingGenerator, SameSeedGivesTheSameWorld) {
  const World a = generate_building(config(42, 14));
  const World b = generate_building(config(42, 14));
  std::string diff;
  EXPECT_TRUE(worlds_equal(a, b, &diff)) << diff;
  EXPECT_GT(a.shapes.size(), 100u);
}

TEST(BuildingGenerator, DifferentSeedsGiveDifferentWorlds) {
  const World a = generate_building(config(1, 14));
  const World b = generate_building(config(2, 14));
  std::string diff;
  EXPECT_FALSE(worlds_equal(a, b, &diff));
  // Not just a renamed copy: the layouts differ.
  bool layout_differs = a.rooms.size() != b.rooms.size();
  for (std::size_t i = 0; !layout_differs && i < a.rooms.size(); ++i)
    layout_differs = a.rooms[i].label != b.rooms[i].label || a.rooms[i].footprint_m[0] != b.rooms[i].footprint_m[0];
  EXPECT_TRUE(layout_differs);
}

TEST(BuildingGenerator, RoomCountMatchesConfigAndIdsAreIndices) {
  for (int n : {3, 5, 8, 12, 20, 28}) {
    const World w = generate_building(config(7, n));
    ASSERT_EQ(static_cast<int>(w.rooms.size()), n) << "num_rooms " << n;
    for (std::size_t i = 0; i < w.rooms.size(); ++i) EXPECT_EQ(w.rooms[i].id, static_cast<int>(i));
    for (std::size_t i = 0; i < w.objects.size(); ++i) EXPECT_EQ(w.objects[i].id, static_cast<int>(i));
  }
  for (int n : {8, 13, 24}) EXPECT_EQ(static_cast<int>(generate_building(config(7, n, true)).rooms.size()), n);
}

TEST(BuildingGenerator, EveryRoomIsReachableThroughDoors) {
  for (std::uint64_t seed = 1; seed <= 12; ++seed) {
    for (bool two : {false, true}) {
      const int n = two ? 16 : 6 + static_cast<int>(seed);
      const World w = generate_building(config(seed, n, two));
      EXPECT_EQ(reachable(w).size(), w.rooms.size()) << "seed " << seed << " two_floors " << two;
    }
  }
}

TEST(BuildingGenerator, DoorsAreBetweenEightyAndHundredTwentyCentimetresWide) {
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    const World w = generate_building(config(seed, 18, seed % 2 == 0));
    ASSERT_FALSE(w.doors.empty());
    for (const Door& d : w.doors) {
      EXPECT_GE(d.width_m(), 0.8 - 1e-9);
      EXPECT_LE(d.width_m(), 1.2 + 1e-9);
      EXPECT_NE(d.room_a, d.room_b);
      // The door lies on the boundary of both rooms it joins.
      const Eigen::Vector2d mid = 0.5 * (d.a_m + d.b_m);
      for (int r : {d.room_a, d.room_b}) {
        const Rect q = rect_of(w.rooms[static_cast<std::size_t>(r)]);
        EXPECT_TRUE(q.contains(mid, -1e-6)) << "door mid outside room " << r;
      }
    }
  }
}

TEST(BuildingGenerator, DoorGapsAreFreeSpace) {
  const World w = generate_building(config(5, 12));
  const FreeSpaceIndex index(w);
  for (const Door& d : w.doors) {
    const Eigen::Vector2d mid = 0.5 * (d.a_m + d.b_m);
    EXPECT_TRUE(index.is_free(Eigen::Vector3d(mid.x(), mid.y(), d.floor_z_m + 1.0), 0.3))
        << "door between " << d.room_a << " and " << d.room_b << " is blocked";
  }
}

TEST(BuildingGenerator, ObjectsStayInsideTheirRoomsAndClearOfWallsAndDoors) {
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const World w = generate_building(config(seed, 16, seed % 3 == 0));
    ASSERT_GT(w.objects.size(), 20u);
    std::vector<const BoxShape*> walls;
    for (const Shape& s : w.shapes)
      if (s.kind == ShapeKind::kBox && s.material.label == kWall) walls.push_back(&w.boxes[s.index]);
    for (const Object& o : w.objects) {
      ASSERT_GE(o.room_id, 0);
      const Room& room = w.rooms[static_cast<std::size_t>(o.room_id)];
      const Rect q = rect_of(room);
      for (const Eigen::Vector2d& v : box_footprint(o.box))
        EXPECT_TRUE(q.contains(v, 0.05 - 1e-6)) << "object " << o.id;
      EXPECT_GE(o.box.center_m.z() - o.box.half_extents_m.z(), room.floor_z_m - 1e-9);
      EXPECT_LE(o.box.center_m.z() + o.box.half_extents_m.z(), room.floor_z_m + room.height_m);
      for (const BoxShape* wall : walls) EXPECT_FALSE(boxes_overlap(o.box, *wall, -1e-6)) << "object " << o.id;
      for (const Object& other : w.objects)
        if (other.id < o.id) {
          EXPECT_FALSE(boxes_overlap(o.box, other.box, -1e-6)) << o.id << " vs " << other.id;
        }
    }
    // Nothing stands in a doorway or right in front of it.
    for (const Door& d : w.doors) {
      if (d.height_m > 2.2) continue;  // the stair top is not in a wall
      const Eigen::Vector2d dir = (d.b_m - d.a_m).normalized();
      const Eigen::Vector2d mid = 0.5 * (d.a_m + d.b_m);
      const BoxShape zone = yaw_box(Eigen::Vector3d(mid.x(), mid.y(), d.floor_z_m + 1.0),
                                    Eigen::Vector3d(d.width_m(), 1.0, 1.9), std::atan2(dir.y(), dir.x()));
      for (const Object& o : w.objects)
        EXPECT_FALSE(boxes_overlap(zone, o.box)) << "object " << o.id << " blocks a door";
    }
  }
}

TEST(BuildingGenerator, ObjectShapesCarryTheirObjectAndStayInItsBox) {
  const World w = generate_building(config(3, 12));
  std::vector<int> shapes_per_object(w.objects.size(), 0);
  for (const Shape& s : w.shapes) {
    if (s.object_id < 0) continue;
    const Object& o = w.objects[static_cast<std::size_t>(s.object_id)];
    ++shapes_per_object[static_cast<std::size_t>(s.object_id)];
    EXPECT_EQ(s.material.label, o.label);
    EXPECT_EQ(s.room_id, o.room_id);
    const Aabb sb = shape_bounds(w, s);
    Aabb ob;
    for (const Eigen::Vector2d& v : box_footprint(o.box)) {
      ob.extend(Eigen::Vector3d(v.x(), v.y(), o.box.center_m.z() - o.box.half_extents_m.z()));
      ob.extend(Eigen::Vector3d(v.x(), v.y(), o.box.center_m.z() + o.box.half_extents_m.z()));
    }
    EXPECT_TRUE((sb.min_m.array() >= ob.min_m.array() - 1e-6).all() &&
                (sb.max_m.array() <= ob.max_m.array() + 1e-6).all())
        << "a part of object " << o.id << " (" << object_label(o.label).name << ") leaves its box";
  }
  for (std::size_t i = 0; i < w.objects.size(); ++i) EXPECT_GE(shapes_per_object[i], 1) << "object " << i;
}

TEST(BuildingGenerator, FurnitureDependsOnRoomType) {
  std::map<RoomLabel, int> seen;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const World w = generate_building(config(seed, 14));
    for (const Room& r : w.rooms) {
      const std::multiset<Label> l = labels_in_room(w, r.id);
      ++seen[r.label];
      const std::string where =
          std::string(room_label_name(r.label)) + " " + std::to_string(r.id) + " seed " + std::to_string(seed);
      switch (r.label) {
        case kKitchen:
          EXPECT_TRUE(l.count(kAppliances) >= 2 && l.count(kSink) && l.count(kCabinet) && l.count(kTable)) << where;
          EXPECT_EQ(l.count(kBed) + l.count(kToilet), 0u) << where;
          break;
        case kBedroom:
          EXPECT_TRUE(l.count(kBed) && l.count(kChestOfDrawers)) << where;
          EXPECT_EQ(l.count(kToilet) + l.count(kAppliances) + l.count(kSofa), 0u) << where;
          break;
        case kBathroom:
          EXPECT_TRUE(l.count(kToilet) && l.count(kSink) && l.count(kBathtub)) << where;
          EXPECT_EQ(l.count(kBed) + l.count(kSofa) + l.count(kTable), 0u) << where;
          break;
        case kOffice:
          EXPECT_TRUE(l.count(kTable) && l.count(kChair) && l.count(kShelving) && l.count(kTvMonitor)) << where;
          break;
        case kLivingRoom:
          EXPECT_TRUE(l.count(kSofa) && l.count(kTvMonitor) && l.count(kTable) && l.count(kPlant)) << where;
          break;
        case kDiningRoom: EXPECT_TRUE(l.count(kTable) && l.count(kChair) >= 2) << where; break;
        case kHallway: EXPECT_EQ(l.size(), l.count(kPlant)) << where; break;
        default: break;
      }
    }
  }
  for (RoomLabel l : {kKitchen, kBedroom, kBathroom, kOffice, kLivingRoom, kHallway}) EXPECT_GT(seen[l], 0) << l;
}

TEST(BuildingGenerator, TwoFloorsHaveStairsAndRoomsOnBothFloors) {
  BuildingConfig c = config(11, 16, true);
  const World w = generate_building(c);
  const double storey = c.ceiling_height_m + c.slab_thickness_m;
  std::map<int, int> rooms_per_floor, stairwells_per_floor;
  for (const Room& r : w.rooms) {
    ++rooms_per_floor[r.floor_index];
    EXPECT_DOUBLE_EQ(r.floor_z_m, r.floor_index * storey);
    if (r.label == kStairwell) ++stairwells_per_floor[r.floor_index];
  }
  EXPECT_EQ(rooms_per_floor.size(), 2u);
  EXPECT_GE(rooms_per_floor[1], 4);
  EXPECT_EQ(stairwells_per_floor[0], 1);
  EXPECT_EQ(stairwells_per_floor[1], 1);
  int steps = 0;
  double top = 0.0;
  for (const Shape& s : w.shapes)
    if (s.material.label == kStairs) {
      ++steps;
      top = std::max(top, shape_bounds(w, s).max_m.z());
    }
  EXPECT_GE(steps, 10);
  EXPECT_GT(top, storey - 0.25);  // the last step is one riser below the upper floor
  EXPECT_LT(top, storey);
  // A door joins the two stairwells, at the upper floor.
  int stair_doors = 0;
  for (const Door& d : w.doors)
    if (w.rooms[static_cast<std::size_t>(d.room_a)].floor_index !=
        w.rooms[static_cast<std::size_t>(d.room_b)].floor_index)
      ++stair_doors;
  EXPECT_EQ(stair_doors, 1);
  // The slab is open above the stairs and closed elsewhere.
  const FreeSpaceIndex index(w);
  Aabb stairs;
  for (const Shape& s : w.shapes)
    if (s.material.label == kStairs) stairs.extend(shape_bounds(w, s));
  const Eigen::Vector3d above_stairs(0.5 * (stairs.min_m.x() + stairs.max_m.x()),
                                     0.5 * (stairs.min_m.y() + stairs.max_m.y()), storey - 0.05);
  EXPECT_TRUE(index.is_free(above_stairs, 0.0));
  for (const Room& r : w.rooms) {
    if (r.floor_index != 1 || r.label == kStairwell) continue;
    const Rect q = rect_of(r);
    EXPECT_FALSE(index.is_free(Eigen::Vector3d(0.5 * (q.x0 + q.x1), 0.5 * (q.y0 + q.y1), storey - 0.05), 0.0));
  }
}

TEST(BuildingGenerator, ConfigIsValidatedAndClamped) {
  BuildingConfig c;
  EXPECT_EQ(c.validate(), "");
  c.num_rooms = 1;
  EXPECT_NE(c.validate().find("num_rooms"), std::string::npos);
  EXPECT_EQ(generate_building(c).rooms.size(), 3u);
  c.num_rooms = 5;
  c.two_floors = true;
  EXPECT_NE(c.validate().find("two floors"), std::string::npos);
  EXPECT_EQ(generate_building(c).rooms.size(), 8u);
  BuildingConfig d;
  d.door_width_min_m = 1.5;
  d.door_width_max_m = 1.0;
  EXPECT_FALSE(d.validate().empty());
}

TEST(BuildingGenerator, WithoutFurnitureThereAreNoObjects) {
  BuildingConfig c = config(9, 10);
  c.furnish = false;
  const World w = generate_building(c);
  EXPECT_TRUE(w.objects.empty());
  for (const Shape& s : w.shapes) EXPECT_EQ(s.object_id, -1);
}

}  // namespace
}  // namespace qsg::world
