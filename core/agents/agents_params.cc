#include "core/agents/agents_params.h"

namespace qsg::agents {

const params::Table<Config>& params_table() {
  using params::above;
  using params::in;
  constexpr auto project = params::Origin::kProject;
  static const params::Table<Config> table = [&] {
    params::Table<Config> t;
    t.add("min_translation_m", &Config::min_translation_m, "m", in(0, 100), project,
          "a keyframe this far from the last agent node becomes one");
    t.add("min_rotation_rad", &Config::min_rotation_rad, "rad", in(0, 3.1416), project, "... or turned this much");
    t.add("max_interval_s", &Config::max_interval_s, "s", above(0, 3600), project, "... or this long after it");
    t.add("fold_at_fraction", &Config::fold_at_fraction, "", in(0.5, 1), project,
          "at this share of the store, every second node of the older half is folded");
    return t;
  }();
  return table;
}

}  // namespace qsg::agents
