// The frontend's own switches and agents::Config, declared once (core/params/params.h). places::Config has its
// table in core/places/places_params.h.
#pragma once

#include "core/frontend/frontend.h"
#include "core/params/params.h"

namespace qsg::frontend {

const params::Table<Config>& params_table();  // Config's own fields (not its stages')

}  // namespace qsg::frontend

namespace qsg::agents {

const params::Table<Config>& params_table();

}  // namespace qsg::agents
