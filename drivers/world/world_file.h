// Reads and writes the human-editable JSON world file (format described in drivers/world/WORLD_FORMAT.md).
// write -> read reproduces a World exactly; malformed input yields an error naming the file and the JSON field.
#pragma once

#include <string>

#include "drivers/world/world.h"
#include "drivers/world/world_result.h"

namespace qsg::world {

inline constexpr int kWorldFileVersion = 1;

// The JSON text of a world: every shape written as a raw shape (in World::shapes order), plus rooms, doors, objects.
std::string world_to_json(const World& world);
// Writes world_to_json() to path. False with *error set ("<path>: <reason>") when the file cannot be written.
bool write_world_file(const World& world, const std::string& path, std::string* error);

// What a world file may ask of the simulator, checked while reading, before anything is built for the world.
// JSON nesting deeper than core/json/json_guard.h's limit (32 levels) is refused as well.
struct WorldFileLimits {
  // Every number in the file (coordinates and sizes in metres, yaw, quaternion parts) lies within +-this. A world
  // of this size still needs the planner's and the ground truth's own cell limits. Range 10 .. 100000.
  double max_abs_value_m = 1000.0;
};

// Parses a world from JSON text; source_name prefixes error messages (a file name, or e.g. "<string>").
WorldResult parse_world_json(const std::string& text, const std::string& source_name,
                             const WorldFileLimits& limits = WorldFileLimits{});
// Reads and parses a world file.
WorldResult read_world_file(const std::string& path, const WorldFileLimits& limits = WorldFileLimits{});

// Field-by-field exact comparison (bitwise-equal numbers); *difference names the first mismatch.
bool worlds_equal(const World& a, const World& b, std::string* difference);

}  // namespace qsg::world
