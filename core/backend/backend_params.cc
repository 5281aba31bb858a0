#include "core/backend/backend_params.h"

namespace qsg::backend {

const params::Table<AgentGraphConfig>& agent_graph_params_table() {
  using G = AgentGraphConfig;
  constexpr auto refinement = params::Origin::kRefinement;
  static const params::Table<G> table = [&] {
    params::Table<G> t;
    t.choice("odometry_weighting", &G::odometry_weighting,
             {{"per_distance", OdometryWeighting::kPerDistance},
              {"covariance_growth", OdometryWeighting::kCovarianceGrowth}},
             refinement,
             "odometry edges: a random walk per metre in each node's frame, or the growth of the reported "
             "world-frame covariance (bench/results/loop_closure.md)");
    t.add("odometry_sigma_t_m_per_sqrt_m", &G::sigma_t_m_per_sqrt_m, "m", params::above(0, 10), refinement,
          "per_distance: translation random walk per sqrt(m) of path");
    t.add("odometry_sigma_yaw_rad_per_sqrt_m", &G::sigma_yaw_rad_per_sqrt_m, "rad", params::above(0, 10), refinement,
          "per_distance: rotation about the vertical per sqrt(m)");
    t.add("odometry_sigma_tilt_rad_per_sqrt_m", &G::sigma_tilt_rad_per_sqrt_m, "rad", params::above(0, 10),
          refinement, "per_distance: roll and pitch per sqrt(m)");
    t.add("odometry_step_sigma_t_m", &G::step_sigma_t_m, "m", params::above(0, 10), params::Origin::kProject,
          "the edge across a step the odometry kept (odometry.steps): at least this translation sigma");
    t.add("odometry_step_sigma_rot_rad", &G::step_sigma_rot_rad, "rad", params::above(0, 10), params::Origin::kProject,
          "... and this rotation sigma");
    return t;
  }();
  return table;
}

const params::Table<DeformationConfig>& deformation_params_table() {
  static const params::Table<DeformationConfig> table = [] {
    params::Table<DeformationConfig> t;
    t.add("sigma_position_m", &DeformationConfig::sigma_position_m, "m", params::above(0, 10),
          params::Origin::kProject, "the deformation graph's relative-position edges");
    t.add("agent_spacing_m", &DeformationConfig::agent_spacing_m, "m", params::in(0, 100),
          params::Origin::kProject,
          "one agent node of the solved graph per this much path (and at every closure); 0: every keyframe");
    t.add("agent_turn_rad", &DeformationConfig::agent_turn_rad, "rad", params::above(0, 3.2),
          params::Origin::kProject, "agent_spacing_m > 0: an agent node also after this much rotation");
    t.flag("hold_agents", &DeformationConfig::hold_agents, params::Origin::kRefinement,
          "the map is solved around the agent layer's solution, held (trajectory first, then the map)");
    t.add("settle_tolerance_m", &DeformationConfig::settle_tolerance_m, "m", params::in(0, 1),
          params::Origin::kRefinement,
          "control points the new solution moves less than this stay at the last solve's pose, held; 0: all solved");
    t.add("settle_hops", &DeformationConfig::settle_hops, "edges", params::in(0, 16), params::Origin::kRefinement,
          "settle_tolerance_m: map nodes this many edges from a moving one are solved too");
    t.flag("incremental_decisions", &DeformationConfig::incremental_decisions, params::Origin::kRefinement,
           "a solve keeps the last one's closure decisions and starts from its solution; GNC decides the new ones");
    t.flag("reduced_decisions", &DeformationConfig::reduced_decisions, params::Origin::kRefinement,
           "GNC decides closures on the agent graph reduced to their agents, then the chain is solved with them");
    t.add("place_rotation_sigma_rad", &DeformationConfig::place_rotation_sigma_rad, "rad", params::in(0, 100),
          params::Origin::kRefinement,
          "a prior pulls each place's rotation towards the one the map's solve starts it with (its agent's "
          "correction): a loose stopping rule lands them where a tight one does; 0: none, the paper's problem");
    t.add("control_rotation_sigma_rad", &DeformationConfig::control_rotation_sigma_rad, "rad", params::in(0, 100),
          params::Origin::kRefinement, "... and each mesh control point's; 0: none");
    t.include(agent_graph_params_table(), [](DeformationConfig& d) -> AgentGraphConfig& { return d.agents; });
    return t;
  }();
  return table;
}

}  // namespace qsg::backend
