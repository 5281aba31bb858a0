// objects::Config's scalar settings, declared once: key, unit, range, origin and doc (core/params/params.h). The
// per-label table (LabelTable: tolerance, vertex counts, size priors) stays in code (default_label_params()).
#pragma once

#include "core/objects/object_layer.h"
#include "core/params/params.h"

namespace qsg::objects {

const params::Table<Config>& params_table();

}  // namespace qsg::objects
