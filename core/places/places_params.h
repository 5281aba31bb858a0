// places::Config, declared once: every field's key, unit, range, origin and doc (core/params/params.h).
#pragma once

#include "core/params/params.h"
#include "core/places/places.h"

namespace qsg::places {

const params::Table<Config>& params_table();

}  // namespace qsg::places
