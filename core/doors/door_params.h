// rooms::DoorConfig, declared once: every field's key, unit, range, origin and doc (core/params/params.h).
// Its capacities (max_cells, bypass_max_places) are not settings: they belong in budgets/ (issue 32).
#pragma once

#include "core/params/params.h"
#include "core/doors/door_detector.h"

namespace qsg::rooms {

const params::Table<DoorConfig>& door_params_table();

}  // namespace qsg::rooms
