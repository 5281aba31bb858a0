// The app's whole configuration as one params::Schema: its own keys, the drivers' and the stages' tables, each
// section one object of the JSON config. AppConfig::load, check and print, and qsg_app --dump-config (which
// writes firmware_app/config/default.json) come from it.
#pragma once

#include "core/params/params.h"
#include "firmware_app/app_config.h"

namespace qsg::app {

const params::Schema<AppConfig>& app_schema();

// The header comment of the generated default.json.
const char* default_config_header();

}  // namespace qsg::app
