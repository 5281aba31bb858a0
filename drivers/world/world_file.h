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

// Parses a world from JSON text; source_name prefixes error messages (a file name, or e.g. "<string>").
WorldResult parse_world_json(const std::string& text, const std::string& source_name);
// Reads and parses a world file.
WorldResult read_world_file(const std::string& path);

// Field-by-field exact comparison (bitwise-equal numbers); *difference names the first mismatch.
bool worlds_equal(const World& a, const World& b, std::string* difference);

}  // namespace qsg::world
