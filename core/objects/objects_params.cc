#include "core/objects/objects_params.h"

namespace qsg::objects {

const params::Table<Config>& params_table() {
  using params::in;
  constexpr auto paper = params::Origin::kPaper;
  constexpr auto refinement = params::Origin::kRefinement;
  constexpr auto project = params::Origin::kProject;
  static const params::Table<Config> table = [&] {
    params::Table<Config> t;
    t.flag("merge_overlapping", &Config::merge_overlapping, paper,
           "objects of one label merge when either's centre lies in the other's box (new clusters too)");
    t.flag("merge_intersecting", &Config::merge_intersecting, refinement,
           "objects of one label merge when their boxes intersect (Hydra's overlap merge)");
    t.flag("merge_by_size_prior", &Config::merge_by_size_prior, refinement,
           "changed objects merge with neighbours of their label within the label's size prior");
    t.add("index_cell_m", &Config::index_cell_m, "m", in(0.25, 50), project,
          "cell of the grid indexing box centres for the merge search (speed only)");
    t.add("max_keys_per_object", &Config::max_keys_per_object, "", in(1, 1000000), project,
          "mesh-vertex keys an object keeps at most (a reservoir sample of its surface)");
    t.add("archive_after_s", &Config::archive_after_s, "s", in(0, 86400), paper,
          "an object out of the active window that no vertex changed for this long is archived: a revisit stays "
          "apart until the finish joins the visits in the corrected map (objects::merge_revisits; 0: merged as "
          "mapped)");
    t.add("archive_below_use", &Config::archive_below_use, "", in(0, 1), project,
          "revisits are kept apart only while the object and key stores are below this share of their capacity; "
          "past it they merge as mapped (the stores' policy when filling)");
    t.flag("finish_keeps_concurrent_apart", &Config::finish_keeps_concurrent_apart, refinement,
           "the finish's merge never joins objects the layer held at the same time (it kept them apart itself)");
    return t;
  }();
  return table;
}

}  // namespace qsg::objects
