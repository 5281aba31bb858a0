// The deformation graph's settings the app exposes, declared once (core/params/params.h). Keys as in the app's
// "loop_closure" section (backend_stage_params.h composes it); a Config's other fields keep their ranges in its
// check().
#pragma once

#include "core/backend/agent_pose_graph.h"
#include "core/backend/deformation_graph.h"
#include "core/params/params.h"

namespace qsg::backend {

const params::Table<PoseGraphConfig>& pose_graph_solver_params_table();  // the agent layer's solver ("solver_*")
const params::Table<AgentGraphConfig>& agent_graph_params_table();       // its own fields and its solver's
const params::Table<DeformationConfig>& deformation_params_table();  // its own fields and its agents graph's

}  // namespace qsg::backend
