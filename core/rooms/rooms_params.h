// rooms::Config, declared once: every field's key, unit, range, origin and doc (core/params/params.h).
#pragma once

#include "core/params/params.h"
#include "core/rooms/room_finder.h"

namespace qsg::rooms {

const params::Table<Config>& params_table();

}  // namespace qsg::rooms
