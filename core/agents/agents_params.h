// agents::Config's sparsification policy, declared once: key, unit, range, origin and doc (core/params/params.h).
#pragma once

#include "core/agents/agent_layer.h"
#include "core/params/params.h"

namespace qsg::agents {

const params::Table<Config>& params_table();

}  // namespace qsg::agents
