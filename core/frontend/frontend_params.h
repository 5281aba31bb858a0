// The frontend's own switches, declared once (core/params/params.h). Its stages' tables are beside them:
// core/places/places_params.h, core/objects/objects_params.h, core/agents/agents_params.h.
#pragma once

#include "core/agents/agents_params.h"
#include "core/frontend/frontend.h"
#include "core/params/params.h"

namespace qsg::frontend {

const params::Table<Config>& params_table();  // Config's own fields (not its stages')

}  // namespace qsg::frontend
