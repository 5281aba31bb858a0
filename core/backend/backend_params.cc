#include "core/backend/backend_params.h"

namespace qsg::backend {

// The agent layer's solver (PoseGraphConfig): how GNC decides the loop closures. The refinements that the public
// pose graphs with many wrong closures need (bench/results/pose_graph.md) are off here: the app's detector proposes
// few wrong closures, and its figures (bench/results/loop_closure.md) are measured without them.
const params::Table<PoseGraphConfig>& pose_graph_solver_params_table() {
  using P = PoseGraphConfig;
  constexpr auto refinement = params::Origin::kRefinement;
  static const params::Table<P> table = [&] {
    params::Table<P> t;
    t.add("solver_threshold_sigma", &P::loop_closure_loss_scale_sigma, "sigma", params::above(0, 1000),
          params::Origin::kPaper,
          "GNC-TLS: a loop closure whose whitened residual ends beyond this is an outlier, switched off");
    t.add("solver_max_iterations", &P::max_iterations, "iterations", params::in(1, 10000), params::Origin::kProject,
          "Ceres iterations of each full solve");
    t.add("solver_gnc_inner_iterations", &P::gnc_inner_iterations, "iterations", params::in(0, 1000),
          params::Origin::kProject,
          "Ceres iterations of each of GNC's weighted solves (0 only with solver_gnc_chordal_solves: the chordal "
          "estimate alone)");
    t.add("solver_gnc_max_outer_iterations", &P::gnc_max_outer_iterations, "iterations", params::in(1, 1000),
          params::Origin::kPaper, "GNC's outer iterations at most");
    t.add("solver_gnc_mu_factor", &P::gnc_mu_factor, "", params::above(1, 10), params::Origin::kPaper,
          "GNC: the surrogate's growth per outer iteration");
    t.add("solver_gnc_tls_refine_rounds", &P::gnc_tls_refine_rounds, "rounds", params::in(0, 100), refinement,
          "after GNC, rounds of the TLS fixed point (keep what the solution fits, drop the rest, solve); 0: none");
    t.flag("solver_gnc_chordal_solves", &P::gnc_chordal_solves, refinement,
           "each of GNC's weighted solves starts from the chordal estimate under its weights, not the last solve");
    t.choice("solver_chordal_weighting", &P::chordal_weighting,
             {{"anisotropic", ChordalWeighting::kAnisotropic}, {"isotropic", ChordalWeighting::kIsotropic}}, refinement,
             "the chordal estimate weighs each edge by its own axes, or by its mean precision");
    t.choice("solver_chordal_solver", &P::chordal_solver,
             {{"direct", ChordalSolver::kDirect}, {"iterative", ChordalSolver::kIterative}}, refinement,
             "the chordal estimate's linear systems: sparse LDLT, or preconditioned conjugate gradients");
    t.add("solver_gnc_cluster_trials", &P::gnc_cluster_trials, "trials", params::in(0, 100000), refinement,
          "after GNC, trials of runs of dropped closures switched on and lone kept ones off, each kept only if "
          "the TLS cost falls; 0: none");
    t.add("solver_gnc_cluster_gap_poses", &P::gnc_cluster_gap_poses, "poses", params::in(1, 100000), refinement,
          "cluster trials: closures whose two ends are each within this many poses of another's form a run");
    t.add("solver_gnc_cluster_min_closures", &P::gnc_cluster_min_closures, "closures", params::in(1, 100000),
          refinement, "cluster trials: a run is tried with at least this many closures dropped");
    t.add("solver_gnc_cluster_lone_trials", &P::gnc_cluster_lone_trials, "trials", params::in(0, 100000), refinement,
          "cluster trials: lone kept closures tried off per sweep, the largest residual first");
    t.add("solver_gnc_cluster_trial_iterations", &P::gnc_cluster_trial_iterations, "iterations", params::in(0, 10000),
          refinement, "cluster trials: Ceres iterations of a trial's solves; 0: max");
    t.flag("solver_gnc_cluster_screen", &P::gnc_cluster_screen, refinement,
           "cluster trials: a run is tried only when that many of its dropped closures pass the pairwise test");
    return t;
  }();
  return table;
}

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
    t.include(pose_graph_solver_params_table(), [](AgentGraphConfig& g) -> PoseGraphConfig& { return g.solver; });
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
