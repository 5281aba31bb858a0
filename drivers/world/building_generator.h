// Procedural buildings: typed rooms along corridors, joined by doors, furnished by room type, optionally with a
// second floor reached by stairs. Deterministic for a seed.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

#include "drivers/world/world.h"

namespace qsg::world {

// Layout: on each floor a straight corridor (one or more hallway rooms joined by doors) runs along x; a strip of
// rooms lies on each side of it. Some rooms are split in depth into a front room (door to the corridor) and a back
// room reached through it (closet off a bedroom, laundry off a kitchen, ...); some neighbours get an extra door,
// which makes loops. With two floors a stairwell sits at the west end of the north strip on both floors; a straight
// flight of kStairs steps climbs along its west wall through an opening in the slab. The stair top is recorded as a
// Door between the two stairwell rooms, so the door graph alone connects every room.
struct BuildingConfig {
  std::string name = "building";
  std::uint64_t seed = 1;
  int num_rooms = 12;            // every room counted: hallways, stairwells, the rest; at least 3 (8 with two floors)
  double room_size_min_m = 3.0;  // edge lengths of ordinary rooms (closets and bathrooms are smaller)
  double room_size_max_m = 5.5;
  double ceiling_height_m = 2.5;
  double wall_thickness_m = 0.1;
  double hallway_width_min_m = 1.4;
  double hallway_width_max_m = 2.0;
  double max_hallway_length_m = 14.0;  // longer corridors are cut into several hallway rooms
  double door_width_min_m = 0.8;
  double door_width_max_m = 1.2;
  double door_height_m = 2.0;
  bool two_floors = false;
  double slab_thickness_m = 0.2;  // between floors: ceiling (lower half) + floor (upper half)
  double annex_probability = 0.35;
  double extra_door_probability = 0.25;
  bool furnish = true;
  double robot_clearance_m = 0.2;  // furniture never cuts the free path of this radius between a room's doors

  void print(std::FILE* out) const;
  // Empty when the config is usable; otherwise what is wrong. generate_building() clamps bad values instead.
  std::string validate() const;
};

// Rooms get ids 0..n-1 (equal to their index); objects likewise. Every shape of an object carries its object_id;
// every structural shape of a room (its floor, ceiling, inner half of its walls, lintels) carries its room_id.
World generate_building(const BuildingConfig& config);

}  // namespace qsg::world
