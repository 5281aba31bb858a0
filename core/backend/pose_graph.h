// SE(3) pose-graph optimization of the agent layer (odometry and loop-closure edges) for the scene-graph backend.
//
// Minimizes sum_ij rho_ij(|W_ij r_ij|^2) over world_T_i (the paper's eq. (pgo) restricted to the agent layer), where
// r_ij is the tangent-space relative-pose error of edge (i, j) and W_ij = diag(1 / sigma) (or the square root of a
// full information matrix). Odometry is plain least squares; loop closures get a robust rho: the paper's
// graduated non-convexity with a truncated least-squares loss (kGncTls), or Huber then Cauchy.
// Runs on the backend thread, not the real-time path, so it allocates. This header is Eigen-only; Ceres stays in
// pose_graph.cc.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "core/backend/chordal_init.h"
#include "core/backend/pairwise_consistency.h"
#include "core/backend/pose3.h"

namespace qsg::backend {

enum class RobustLoss : std::uint8_t {
  kNone,    // plain least squares: one wrong loop closure bends the whole map
  kHuber,   // convex, but a wrong loop closure keeps pulling with a constant force
  kCauchy,  // redescending: the pull of a residual far beyond the scale fades away
  // Graduated non-convexity with a truncated least-squares loss (Yang, Antonante, Tzoumas, Carlone, RA-L 2020), as
  // the paper solves its scene-graph optimization: weighted least squares whose loop-closure weights go from a
  // convex surrogate to 0 (beyond loop_closure_loss_scale_sigma) or 1 (within it); a wrong closure switches off.
  kGncTls,
};
const char* to_string(RobustLoss loss);

struct PoseGraphConfig {
  RobustLoss loop_closure_loss = RobustLoss::kCauchy;
  // Whitened residual norm (in standard deviations, hence dimensionless) where the loop-closure loss stops being
  // quadratic. Loose, because a correct closure starts far from consistent with a drifted trajectory.
  double loop_closure_loss_scale_sigma = 5.0;
  // With kCauchy: solve with Huber of the same scale first, then refine with Cauchy from there (a two-step
  // graduated non-convexity). Without it Cauchy can discard correct closures on a strongly drifted trajectory.
  bool huber_warm_start = true;
  int max_iterations = 50;  // per solve; the warm start adds a second solve
  // Ceres' stopping rule: |cost change| / cost below this ends a solve (Ceres' default 1e-6).
  double function_tolerance = 1e-6;
  // kGncTls: outer iterations at most (each a weighted solve of gnc_inner_iterations), the surrogate's growth per
  // outer iteration, and the Ceres iterations of each weighted solve (the last gets max_iterations, and so does the
  // first unless gnc_chordal_solves; with it, 0 makes the chordal estimate alone each weighted solve).
  int gnc_max_outer_iterations = 100;
  double gnc_mu_factor = 1.4;
  int gnc_inner_iterations = 10;
  // kGncTls, a refinement: after GNC's last solve, rounds of the truncated least-squares fixed point. The closures
  // the solution fits within the threshold are kept, the others dropped, and the graph is solved again from there,
  // until no decision changes. GNC decides from its last annealing state, whose short inner solves can leave a right
  // closure just past the threshold; the final solve then fits it, and it stays dropped. Each round can only lower
  // the TLS cost. 0: GNC's decisions as they are (bench/results/pose_graph.md).
  int gnc_tls_refine_rounds = 0;
  // kGncTls, a refinement: each of GNC's weighted solves (the first, every outer iteration's, the last) starts from
  // the chordal estimate under the current weights (chordal_init.h: global and linear, as GNC's inner solver is meant
  // to be) instead of from the previous solve's poses, so the annealing's decisions do not follow a path bent by
  // the outliers. The first solve is then one of the weighted solves (gnc_inner_iterations): it only has to give the
  // residuals the annealing starts from. Off: warm starts.
  bool gnc_chordal_solves = false;
  // kGncTls, a refinement after the TLS rounds: a local search on the truncated least-squares cost over runs of
  // closures. Right closures come in runs (a revisit closes many consecutive poses against many consecutive poses),
  // and where the odometry holds little, GNC can bend a stretch to fit a few wrong closures and drop a whole run of
  // right ones with it. Closures whose two ends are each within gnc_cluster_gap_poses of another's form a cluster.
  // Each cluster with at least gnc_cluster_min_closures switched off (the most first) has them switched on, the
  // graph solved, every closure re-decided by its residual and the graph solved again; the trial stays only if it
  // lowers the TLS cost, else the state before it is restored. Sweeps repeat while one keeps a trial; the trials in
  // all are capped at this many (each costs two solves). 0: off.
  int gnc_cluster_trials = 0;
  std::uint32_t gnc_cluster_gap_poses = 10;
  std::uint32_t gnc_cluster_min_closures = 3;
  // With gnc_cluster_trials, the other move: a lone closure (the only one kept in its cluster) switched off, the
  // same two solves, kept only if the TLS cost falls; in each sweep up to this many, the largest residual first. A
  // wrong closure the graph bent to fit has no run beside it.
  std::uint32_t gnc_cluster_lone_trials = 8;
  // With gnc_cluster_trials: Ceres iterations of each of a trial's two solves (0: max_iterations). A trial is kept
  // only when the state it reached lowers the TLS cost, so a solve cut short can only reject a trial that a longer
  // one would have kept, never keep a wrong one; the TLS rounds after a kept trial solve in full.
  int gnc_cluster_trial_iterations = 0;
  // With gnc_cluster_trials: a cluster is tried only when at least gnc_cluster_min_closures of its switched-off
  // closures agree with each other through the odometry (the pairwise test of pairwise_consistency.h, its gate
  // from `pairwise_consistency`). Random wrong closures that fall near each other agree with nothing; a run of right
  // ones does. It only skips trials, it never changes what a trial switches on. Off: every cluster is tried.
  bool gnc_cluster_screen = true;
  // With gnc_chordal_solves: the chordal estimate weighs each edge by its own axes (kAnisotropic) or by its mean
  // precision (kIsotropic, the papers' form), chordal_init.h.
  ChordalWeighting chordal_weighting = ChordalWeighting::kAnisotropic;
  // With gnc_chordal_solves: how the chordal estimate's linear systems are solved (chordal_init.h): kIterative,
  // preconditioned conjugate gradients, about as fast as a factorization on a graph without wrong closures and 9 to
  // hundreds of times faster with them (still-weighted wrong closures fill a factorization in); kDirect, sparse
  // LDLT (bench/results/pose_graph.md).
  ChordalSolver chordal_solver = ChordalSolver::kIterative;
  // Removes the gauge freedom: holds poses[0], and the lowest-index pose of any component not connected to it.
  bool fix_first_pose = true;
  // Poses [0, hold_first_poses) stay where they are (constant in the solve): the rest is solved around them.
  std::size_t hold_first_poses = 0;
  int num_threads = 1;
  // Injected clock (seconds), for benchmarks: when set, PoseGraphResult::solver_time_s is the whole call's time on
  // it (e.g. the thread's CPU time) instead of Ceres' own wall-clock time.
  double (*clock_s)() = nullptr;
  // Before the robust solve, keep only the largest set of pairwise-consistent loop closures (PCM, see
  // pairwise_consistency.h); the others get weight 0 and no residual. Off: the paper's path is GNC alone.
  bool prefilter_pairwise_consistency = false;
  PairwiseConsistencyConfig pairwise_consistency;

  // Empty when usable, else which setting is wrong (optimize_pose_graph refuses such a config the same way).
  std::string check() const;
  void print(std::FILE* out) const;
};

enum class PoseGraphStatus : std::uint8_t {
  kConverged,      // poses updated
  kMaxIterations,  // poses updated with the last (improved, usable) iterate
  kInvalidInput,   // poses untouched; message says which pose, edge or parameter is wrong
  kSolverFailed,   // poses untouched; message carries the solver's reason
};
const char* to_string(PoseGraphStatus status);

struct PoseGraphResult {
  PoseGraphStatus status = PoseGraphStatus::kInvalidInput;
  int iterations = 0;  // summed over the warm start and the final solve
  // Ceres convention: half the sum of the (robustified) squared whitened residuals, under the configured loss.
  double initial_cost = 0.0;
  double final_cost = 0.0;
  // Per edge, in input order: whitened residual norm after the solve (empty unless poses_updated()).
  std::vector<double> edge_residual_sigma;
  // Loop closures left beyond loop_closure_loss_scale_sigma: the ones the robust loss is treating as outliers.
  std::uint32_t num_loop_closures_downweighted = 0;
  // kGncTls or the pairwise prefilter: per edge, in input order, the final weight (odometry 1; a loop closure 1
  // kept or 0 rejected); kGncTls: the outer iterations run. Otherwise empty and 0.
  std::vector<double> edge_weight;
  int gnc_outer_iterations = 0;
  int gnc_refine_rounds = 0;  // kGncTls with gnc_tls_refine_rounds: the rounds that changed a decision and re-solved
  // kGncTls with gnc_cluster_trials: the trials run (runs switched on, lone closures off), the runs kept.
  int gnc_cluster_trials = 0;
  int gnc_clusters_readmitted = 0;
  int gnc_lone_dropped = 0;  // lone closures switched off by a kept trial
  int gnc_clusters_screened_out = 0;  // with gnc_cluster_screen: trials skipped, their closures not agreeing
  ChordalStats chordal;               // with gnc_chordal_solves: the chordal estimates' linear systems, summed
  // Where a solve's time goes: Ceres' own wall-clock time over its solves, or PoseGraphConfig::clock_s's.
  double solver_time_s = 0.0;
  // With prefilter_pairwise_consistency: the prefilter's tallies (its rejected closures are downweighted too).
  PairwiseConsistencyResult pairwise;
  std::string message;

  bool converged() const { return status == PoseGraphStatus::kConverged; }
  bool poses_updated() const {
    return status == PoseGraphStatus::kConverged || status == PoseGraphStatus::kMaxIterations;
  }
  void print(std::FILE* out) const;
};

// A unary pull of one pose's rotation towards a given one: residual 2 vec(q^-1 q_pose) / sigma_rad, plain least
// squares (e.g. the deformation graph's map nodes, whose rotations position-only edges hold only weakly). Ignored
// on a pose the solve holds or that no edge reaches.
struct RotationPrior {
  std::uint32_t pose = 0;
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  double sigma_rad = 1.0;
};

// Optimizes `poses` (world_T_i, indexed by the edges' from/to) in place. Quaternions need not be unit: they are
// normalized, and written back normalized. On invalid input or solver failure `poses` is left untouched and the
// result says why; it never aborts or throws on bad data.
PoseGraphResult optimize_pose_graph(const PoseGraphConfig& config, std::vector<Pose3>& poses,
                                    const std::vector<RelativePoseEdge>& edges);
// ... with rotation priors (their costs count in initial_cost and final_cost; edge_residual_sigma has edges only).
PoseGraphResult optimize_pose_graph(const PoseGraphConfig& config, std::vector<Pose3>& poses,
                                    const std::vector<RelativePoseEdge>& edges,
                                    const std::vector<RotationPrior>& rotation_priors);

}  // namespace qsg::backend
