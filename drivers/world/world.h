// A simulated world: geometric primitives with materials (semantic label, colour, texture), plus the truth the
// simulator knows about it (rooms with typed labels and footprints, doors, objects). Built once, then read-only.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/semantics/labels.h"

namespace qsg::world {

enum class Texture : std::uint8_t { kPlain, kChecker, kStripes, kNoise };

struct Material {
  semantics::Label label = semantics::kUnlabeled;
  std::array<std::uint8_t, 3> color{{128, 128, 128}};
  Texture texture = Texture::kPlain;
  float texture_scale_m = 0.25f;  // period of the texture pattern
};

// An oriented box: world_R_box rotates box axes into the world.
struct BoxShape {
  Eigen::Vector3d center_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond world_R_box = Eigen::Quaterniond::Identity();
  Eigen::Vector3d half_extents_m = Eigen::Vector3d::Constant(0.5);
};

// A vertical cylinder standing on base_center_m.
struct CylinderShape {
  Eigen::Vector3d base_center_m = Eigen::Vector3d::Zero();
  double radius_m = 0.25;
  double height_m = 1.0;
};

// A simple polygon (counter-clockwise, x-y plane) extruded vertically from z_min_m to z_max_m.
struct PrismShape {
  std::vector<Eigen::Vector2d> polygon_m;
  double z_min_m = 0.0;
  double z_max_m = 2.5;
};

// An infinite plane through point_m with unit normal (e.g. a ground plane under a floor-plan world).
struct PlaneShape {
  Eigen::Vector3d point_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
};

enum class ShapeKind : std::uint8_t { kBox, kCylinder, kPrism, kPlane };

// One renderable primitive: which typed array it lives in, what it looks like, what it belongs to.
struct Shape {
  ShapeKind kind = ShapeKind::kBox;
  std::uint32_t index = 0;  // into World::boxes / cylinders / prisms / planes
  Material material;
  std::int32_t object_id = -1;  // index into World::objects, or -1 for structure
  std::int32_t room_id = -1;    // room the primitive belongs to, or -1
};

using Polygon2 = std::vector<Eigen::Vector2d>;

struct Room {
  std::int32_t id = 0;
  semantics::RoomLabel label = semantics::kRoomUnknown;
  std::vector<Polygon2> footprint_m;  // one or more polygons (x-y), counter-clockwise
  double floor_z_m = 0.0;
  double height_m = 2.5;
  std::int32_t floor_index = 0;
};

// An opening in a wall between two rooms (or a room and a corridor): the segment a_m-b_m on the floor.
struct Door {
  Eigen::Vector2d a_m = Eigen::Vector2d::Zero();
  Eigen::Vector2d b_m = Eigen::Vector2d::Zero();
  double floor_z_m = 0.0;
  double height_m = 2.0;
  std::int32_t room_a = -1;
  std::int32_t room_b = -1;
  double width_m() const { return (b_m - a_m).norm(); }
};

// A piece of furniture or other object: its label and oriented box (the truth objects are scored against).
struct Object {
  std::int32_t id = 0;
  semantics::Label label = semantics::kObjects;
  BoxShape box;
  std::int32_t room_id = -1;
};

struct World {
  std::string name;
  std::vector<BoxShape> boxes;
  std::vector<CylinderShape> cylinders;
  std::vector<PrismShape> prisms;
  std::vector<PlaneShape> planes;
  std::vector<Shape> shapes;
  std::vector<Room> rooms;
  std::vector<Door> doors;
  std::vector<Object> objects;

  std::uint32_t add_box(const BoxShape& b, const Material& m, std::int32_t object_id = -1, std::int32_t room_id = -1) {
    boxes.push_back(b);
    return add_shape(ShapeKind::kBox, boxes.size() - 1, m, object_id, room_id);
  }
  std::uint32_t add_cylinder(const CylinderShape& c, const Material& m, std::int32_t object_id = -1,
                             std::int32_t room_id = -1) {
    cylinders.push_back(c);
    return add_shape(ShapeKind::kCylinder, cylinders.size() - 1, m, object_id, room_id);
  }
  std::uint32_t add_prism(const PrismShape& p, const Material& m, std::int32_t object_id = -1, std::int32_t room_id = -1) {
    prisms.push_back(p);
    return add_shape(ShapeKind::kPrism, prisms.size() - 1, m, object_id, room_id);
  }
  std::uint32_t add_plane(const PlaneShape& p, const Material& m) {
    planes.push_back(p);
    return add_shape(ShapeKind::kPlane, planes.size() - 1, m, -1, -1);
  }

 private:
  std::uint32_t add_shape(ShapeKind kind, std::size_t index, const Material& m, std::int32_t object_id,
                          std::int32_t room_id) {
    Shape s;
    s.kind = kind;
    s.index = static_cast<std::uint32_t>(index);
    s.material = m;
    s.object_id = object_id;
    s.room_id = room_id;
    shapes.push_back(s);
    return static_cast<std::uint32_t>(shapes.size() - 1);
  }
};

}  // namespace qsg::world
