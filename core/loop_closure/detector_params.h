// The loop-closure detector's settings the app exposes, declared once (core/params/params.h): key, unit, range,
// origin and doc. Keys as in the app's "loop_closure" section (backend/backend_stage_params.h composes it); a
// Config's other fields keep their ranges in its check().
#pragma once

#include "core/loop_closure/detector.h"
#include "core/loop_closure/scene_descriptor.h"
#include "core/params/params.h"

namespace qsg::loop_closure {

const params::Table<DescriptorConfig>& descriptor_params_table();
const params::Table<DetectorConfig>& detector_params_table();  // its own fields, not its sub-configs'
const params::Table<LocalMapConfig>& local_map_params_table();
const params::Table<AppearanceConfig>& appearance_params_table();  // the keys of its fields the app exposes
const params::Table<IcpConfig>& icp_params_table();  // the keys of its fields the app exposes
const params::Table<RegistrationConfig>& registration_params_table();

}  // namespace qsg::loop_closure
