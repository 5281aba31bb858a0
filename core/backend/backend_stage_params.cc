#include "core/backend/backend_stage_params.h"

#include "core/backend/backend_params.h"
#include "core/loop_closure/detector_params.h"

namespace qsg::backend {

const params::Table<LoopClosureConfig>& loop_closure_params_table() {
  using C = LoopClosureConfig;
  using params::in;
  constexpr auto paper = params::Origin::kPaper;
  constexpr auto project = params::Origin::kProject;
  constexpr auto refinement = params::Origin::kRefinement;
  static const params::Table<C> table = [&] {
    params::Table<C> t;
    t.flag("enabled", &C::enabled, paper,
           "the backend closes loops and corrects the graph (off: the map as the odometry makes it)");
    t.add("horizon_s", &C::horizon_s, "s", in(0, 3600), project,
          "agents are described this long after the robot passed");
    t.add("describe_every_m", &C::describe_every_m, "m", params::above(0, 100), project,
          "one described agent per this much path");
    t.add("solve_interval_s", &C::solve_interval_s, "s", in(0, 3600), project,
          "the deformation graph is re-solved at most this often");
    t.add("closure_capacity", &C::closure_capacity, "closures", in(0, 1u << 20), project,
          "closures kept at most (0: the budget's); a full store folds its older half, outliers first");
    t.include(loop_closure::descriptor_params_table(),
              [](C& c) -> loop_closure::DescriptorConfig& { return c.descriptor; });
    t.include(loop_closure::detector_params_table(), [](C& c) -> loop_closure::DetectorConfig& { return c.detector; });
    t.include(loop_closure::local_map_params_table(),
              [](C& c) -> loop_closure::LocalMapConfig& { return c.detector.local_map; });
    t.include(loop_closure::appearance_params_table(),
              [](C& c) -> loop_closure::AppearanceConfig& { return c.detector.appearance; });
    t.include(loop_closure::icp_params_table(), [](C& c) -> loop_closure::IcpConfig& { return c.detector.icp; });
    t.include(loop_closure::registration_params_table(),
              [](C& c) -> loop_closure::RegistrationConfig& { return c.detector.registration; });
    t.include(deformation_params_table(), [](C& c) -> DeformationConfig& { return c.deformation; });
    t.flag("odometry_sigmas_from_source", &C::odometry_sigmas_from_source, refinement,
           "per_distance odometry edges take the source's own noise model when it has one (sim_drift's sigmas)");
    t.flag("map_in_corrected_frame", &C::map_in_corrected_frame, refinement,
           "after each solve the frontend maps the next keyframes at the odometric pose times the latest correction "
           "(map_T_odom), so revisits land on the corrected map; off: the odometry frame");
    t.flag("reconcile", &C::reconcile, paper,
           "after the final correction: objects re-boxed from the corrected mesh, revisited places merged, final doors "
           "and rooms on the corrected map (off: found as mapped and moved; bench/results/loop_closure.md)");
    t.flag("rooms_after_correction", &C::rooms_after_correction, paper,
           "after the final correction the final doors, rooms and labels are found on the corrected map, objects and "
           "places only moved (reconcile implies it; off: found as mapped and moved)");
    t.add("merge_places_within_m", &C::merge_places_within_m, "m", in(0, 5), paper,
          "after a correction, places closer than this whose free-space spheres hold each other merge (0: none)");
    return t;
  }();
  return table;
}

}  // namespace qsg::backend
