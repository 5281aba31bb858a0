// The outcome of building or loading a World from outside input: the world, or an error naming the input and the
// place in it that is wrong.
#pragma once

#include <string>

#include "drivers/world/world.h"

namespace qsg::world {

struct WorldResult {
  bool ok = false;
  World world;
  std::string error;  // empty when ok; otherwise "<file>: <where>: <what>"
};

}  // namespace qsg::world
