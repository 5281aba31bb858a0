#include "core/frontend/frontend_params.h"

namespace qsg::frontend {

const params::Table<Config>& params_table() {
  static const params::Table<Config> table = [] {
    params::Table<Config> t;
    t.flag("connect_interlayer", &Config::connect_interlayer, params::Origin::kPaper,
           "objects and agents get their nearest active place as parent");
    t.add("reparent_untracked_every", &Config::reparent_untracked_every, "cycles", params::in(0, 1000000),
          params::Origin::kRefinement,
          "objects out of the window get the nearest place of the whole graph every this many cycles (0: off)");
    return t;
  }();
  return table;
}

}  // namespace qsg::frontend
