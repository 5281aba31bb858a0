// reconstruction::Config, declared once: every field's key, unit, range, origin and doc (core/params/params.h).
#pragma once

#include "core/params/params.h"
#include "core/reconstruction/semantic_tsdf.h"

namespace qsg::reconstruction {

const params::Table<Config>& params_table();

}  // namespace qsg::reconstruction
