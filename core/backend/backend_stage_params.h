// LoopClosureConfig, declared once (core/params/params.h): the app's "loop_closure" section, its own fields and
// its detector's and deformation graph's tables (loop_closure/detector_params.h, backend_params.h) in one.
#pragma once

#include "core/backend/backend_stage.h"
#include "core/params/params.h"

namespace qsg::backend {

const params::Table<LoopClosureConfig>& loop_closure_params_table();

}  // namespace qsg::backend
