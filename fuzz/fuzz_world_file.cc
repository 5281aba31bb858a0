// World-file reader (drivers/world/world_file): any text parses into a world within the limits or is refused with
// an error naming where; a world that parsed writes and parses again to an equal world.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "drivers/world/world_file.h"

using namespace qsg;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const world::WorldResult r = world::parse_world_json(text, "<fuzz>");
  if (!r.ok) {
    if (r.error.empty()) std::abort();
    return 0;
  }
  const world::WorldResult again = world::parse_world_json(world::world_to_json(r.world), "<written>");
  std::string difference;
  if (!again.ok || !world::worlds_equal(r.world, again.world, &difference)) std::abort();
  return 0;
}
