// Re-solves a deformation problem written by the app (QSG_DUMP_DEFORMATION=FILE) offline, so a solver strategy can
// be compared on the same graph in seconds instead of re-running the mission: wall time, iterations, loop closures
// kept and, when the file carries the agents' true positions, the agents' ATE (RMSE) before and after, without
// alignment (as mapped: the map starts at the true start) and after SE(3) alignment (Umeyama, as the TUM benchmark and
// evo define ATE). What-ifs on the same graph: the odometry edges re-weighted (--odometry per_distance), closures
// dropped or re-weighted, oracle closures from the truth (--oracle R: what closures everywhere the robot revisits
// would give), the error per stretch of the chain (--segments N: one per tour) and along it (--profile N).
// Every figure also goes to --json (bench/figures.h).

#include <chrono>
#include <cmath>
#include <cstdio>
#include <algorithm>
#include <cstdlib>
#include <string>

#include "bench/figures.h"
#include "bench/thread_cpu.h"
#include "core/backend/deformation_io.h"
#include "core/metrics/trajectory_error.h"

namespace {

using namespace qsg;

int usage(int status) {
  std::printf(
      "usage: dg_solve PROBLEM [--strategy full_gnc|agents_first (agents_first)] [--max-outer N] [--json FILE]\n"
      "                [--max-closure-sigma M] [--closure-sigma-scale F]   (what-ifs on the loop closures)\n"
      "                [--agent-spacing M]  (one agent node per M m of path: DeformationConfig::agent_spacing_m)\n"
      "                [--whole-tolerance F]  (the whole graph's stopping rule: whole_function_tolerance)\n"
      "                [--agent-turn RAD]  (with --agent-spacing: a node also per RAD of rotation, 0.2)\n"
      "                [--hold-agents 0|1]  (the map solved around the agents' solution, held: DeformationConfig::hold_agents,\n"
      "                                      on by default)\n"
      "                [--profile N]   (the error of N agents evenly spaced along the chain, before and after)\n"
      "                [--oracle-sigma M RAD] (the oracle closures' sigmas: 0.01 m, 0.002 rad)\n"
      "                [--oracle-pairs all|within|across] (with --segments: oracle closures within a segment\n"
      "                                 (tour) only, or between segments only)\n"
      "                [--oracle-min-path M] (oracle pairs at least M m of true path apart)\n"
      "                [--least-squares]  (every closure kept: no GNC)\n"
      "                [--exact-closures]  (the app's closures, same pairs and sigmas, measuring the true relative\n"
      "                                     pose: what their errors cost; needs the true orientations)\n"
      "                [--agents-only]  (the agent layer alone: no control points or places)\n"
      "                [--reduced 0|1]  (on by default: GNC decides on the agent graph reduced to the closures, then the\n"
      "                                  chain is solved with the decisions: DeformationConfig::reduced_decisions)\n"
      "                [--segments N]  (ATE of N equal stretches of the chain, by agent index: one per tour)\n"
      "                [--odometry as_dumped|per_distance] [--sigma-t M] [--sigma-yaw RAD] [--sigma-tilt RAD]\n"
      "                                (per_distance: odometry edges re-weighted by AgentGraphConfig's random walk,\n"
      "                                 over the straight distance between consecutive agents)\n"
      "                [--oracle R] [--oracle-only] [--oracle-gap N]  (a closure with the true relative pose from\n"
      "                                 every 4th agent to the nearest one at least N agents (32) older within R m;\n"
      "                                 needs the true orientations in the file; --oracle-only drops the app's)\n"
      "  full_gnc:     graduated non-convexity over the whole deformation graph (agents, control points, places)\n"
      "  agents_first: GNC decides the loop closures on the agent layer, then the whole graph is solved once with\n"
      "                the kept ones, from the agents' solution (DeformationConfig::decide_on_agents)\n");
  return status;
}

// ATE RMSE of agents [lo, hi) against the truth: as mapped (no alignment) or after SE(3) alignment.
double ate_rmse(const std::vector<backend::Pose3>& poses, const std::vector<Eigen::Vector3d>& truth, bool aligned,
                std::size_t lo = 0, std::size_t hi = ~std::size_t{0}) {
  hi = std::min(hi, truth.size());
  if (lo + 3 > hi) return -1.0;
  std::vector<metrics::TimedPose> ref, est;
  for (std::size_t k = lo; k < hi; ++k) {
    ref.push_back({static_cast<std::int64_t>(k), truth[k], Eigen::Quaterniond::Identity()});
    est.push_back({static_cast<std::int64_t>(k), poses[k].t_m, poses[k].q});
  }
  metrics::TrajectoryErrorConfig c;
  c.max_time_difference_ns = 0;
  c.alignment = aligned ? metrics::Alignment::kSE3 : metrics::Alignment::kNone;
  const metrics::TrajectoryError e = metrics::evaluate_trajectory(ref, est, c);
  return e.ok ? e.ate_rmse_m : -1.0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage(2);
  std::string path = argv[1], strategy = "agents_first", json;
  int max_outer = -1, profile = 0, segments = 0, oracle_gap = 32;
  double agent_spacing_m = 0.0, whole_tolerance = 0.0, agent_turn_rad = 0.2;
  bool hold_agents = backend::DeformationConfig{}.hold_agents;
  double max_sigma = 0.0, sigma_scale = 1.0, oracle_m = 0.0;
  bool oracle_only = false, agents_only = false, least_squares = false, exact_closures = false;
  bool reduced = backend::DeformationConfig{}.reduced_decisions;
  double oracle_sigma_t = 0.01, oracle_sigma_rot = 0.002;
  std::string oracle_pairs = "all";
  double oracle_min_path_m = 0.0;
  std::string odometry = "as_dumped";
  backend::AgentGraphConfig weighting;
  if (path == "--help") return usage(0);
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--strategy" && has) strategy = argv[++i];
    else if (a == "--max-outer" && has) max_outer = std::atoi(argv[++i]);
    else if (a == "--agent-spacing" && has) agent_spacing_m = std::atof(argv[++i]);
    else if (a == "--whole-tolerance" && has) whole_tolerance = std::atof(argv[++i]);
    else if (a == "--agent-turn" && has) agent_turn_rad = std::atof(argv[++i]);
    else if (a == "--hold-agents" && has) hold_agents = std::atoi(argv[++i]) != 0;
    else if (a == "--profile" && has) profile = std::atoi(argv[++i]);
    else if (a == "--segments" && has) segments = std::atoi(argv[++i]);
    else if (a == "--odometry" && has) odometry = argv[++i];
    else if (a == "--sigma-t" && has) weighting.sigma_t_m_per_sqrt_m = std::atof(argv[++i]);
    else if (a == "--sigma-yaw" && has) weighting.sigma_yaw_rad_per_sqrt_m = std::atof(argv[++i]);
    else if (a == "--sigma-tilt" && has) weighting.sigma_tilt_rad_per_sqrt_m = std::atof(argv[++i]);
    else if (a == "--oracle" && has) oracle_m = std::atof(argv[++i]);
    else if (a == "--oracle-gap" && has) oracle_gap = std::atoi(argv[++i]);
    else if (a == "--oracle-only") oracle_only = true;
    else if (a == "--agents-only") agents_only = true;
    else if (a == "--reduced" && has) reduced = std::atoi(argv[++i]) != 0;
    else if (a == "--least-squares") least_squares = true;
    else if (a == "--exact-closures") exact_closures = true;
    else if (a == "--oracle-pairs" && has) oracle_pairs = argv[++i];
    else if (a == "--oracle-min-path" && has) oracle_min_path_m = std::atof(argv[++i]);
    else if (a == "--oracle-sigma" && i + 2 < argc) {
      oracle_sigma_t = std::atof(argv[++i]);
      oracle_sigma_rot = std::atof(argv[++i]);
    }
    else if (a == "--max-closure-sigma" && has) max_sigma = std::atof(argv[++i]);
    else if (a == "--closure-sigma-scale" && has) sigma_scale = std::atof(argv[++i]);
    else if (a == "--json" && has) json = argv[++i];
    else return usage(a == "--help" ? 0 : 2);
  }
  if (strategy != "full_gnc" && strategy != "agents_first") return usage(2);
  if (odometry != "as_dumped" && odometry != "per_distance") return usage(2);
  if (!weighting.check().empty()) {
    std::fprintf(stderr, "dg_solve: %s\n", weighting.check().c_str());
    return 2;
  }
  backend::DeformationProblemFile file;
  std::string error;
  if (!backend::read_deformation_problem(path, &file, &error)) {
    std::fprintf(stderr, "dg_solve: %s\n", error.c_str());
    return 1;
  }
  // What-if: loop closures whose translation sigma is above --max-closure-sigma dropped; those left scaled.
  backend::DeformationProblem& p = file.problem;
  if (max_sigma > 0.0 || sigma_scale != 1.0) {
    std::vector<backend::RelativePoseEdge> edges;
    std::size_t kept = 0;
    for (std::size_t k = 0; k < p.edges.size(); ++k) {
      backend::RelativePoseEdge e = p.edges[k];
      const bool closure = k >= p.first_closure && k < p.first_closure + p.result.loop_closures;
      if (closure && max_sigma > 0.0 && e.sigma_t_m.maxCoeff() > max_sigma) continue;
      if (closure) {
        e.sigma_t_m *= sigma_scale;
        e.sigma_rot_rad *= sigma_scale;
        ++kept;
      }
      edges.push_back(e);
    }
    p.edges = std::move(edges);
    p.result.loop_closures = kept;
  }
  // The true relative pose of agents i and j (files that carry the true orientations).
  const auto true_between = [&file](std::size_t i, std::size_t j) {
    return backend::between(backend::Pose3{file.truth_m[i], file.truth_q[i]},
                            backend::Pose3{file.truth_m[j], file.truth_q[j]});
  };
  // What-if: the app's closures measuring the truth (the same pairs and sigmas).
  if (exact_closures) {
    if (file.truth_q.size() != p.result.agents) {
      std::fprintf(stderr, "dg_solve: --exact-closures needs the agents' true orientations in the file\n");
      return 2;
    }
    for (std::size_t k = p.first_closure; k < p.first_closure + p.result.loop_closures; ++k) {
      backend::RelativePoseEdge& e = p.edges[k];
      e.measured_from_T_to = true_between(e.from, e.to);
    }
  }
  // What-if: the odometry edges (the chain's, before the first closure, between consecutive agents) re-weighted.
  std::size_t reweighted = 0;
  if (odometry == "per_distance") {
    for (std::size_t k = 0; k < p.first_closure; ++k) {
      backend::RelativePoseEdge& e = p.edges[k];
      if (e.from >= p.result.agents || e.to != e.from + 1) continue;
      const backend::Pose3 &a = p.poses[e.from], &b = p.poses[e.to];
      e = backend::per_distance_odometry_edge(e.from, e.to, a, b, (b.t_m - a.t_m).norm(), weighting);
      ++reweighted;
    }
    std::printf("dg_solve: %zu odometry edges re-weighted per distance\n", reweighted);
  }
  // What-if: oracle closures from the truth, in place of (--oracle-only) or beside the app's.
  if (oracle_m > 0.0) {
    if (file.truth_q.size() != p.result.agents) {
      std::fprintf(stderr, "dg_solve: --oracle needs the agents' true orientations in the file\n");
      return 2;
    }
    std::vector<backend::RelativePoseEdge> edges(p.edges.begin(), p.edges.begin() + static_cast<std::ptrdiff_t>(p.first_closure));
    std::size_t closures = 0;
    if (!oracle_only)
      for (std::size_t k = p.first_closure; k < p.first_closure + p.result.loop_closures; ++k, ++closures)
        edges.push_back(p.edges[k]);
    const std::size_t A = p.result.agents, gap = static_cast<std::size_t>(std::max(1, oracle_gap));
    std::vector<double> along(A, 0.0);  // path along the truth
    for (std::size_t k = 1; k < A; ++k) along[k] = along[k - 1] + (file.truth_m[k] - file.truth_m[k - 1]).norm();
    for (std::size_t j = gap; j < A; j += 4) {
      std::size_t best = A;
      double best_d = oracle_m;
      for (std::size_t i = 0; i + gap <= j; ++i) {
        if (along[j] - along[i] < oracle_min_path_m) continue;
        if (segments > 0 && oracle_pairs != "all") {
          const bool same = i * segments / A == j * segments / A;
          if (same != (oracle_pairs == "within")) continue;
        }
        const double d = (file.truth_m[i] - file.truth_m[j]).norm();
        if (d < best_d) best_d = d, best = i;
      }
      if (best == A) continue;
      backend::ChainLoopClosure c;
      c.a = static_cast<std::uint32_t>(best);
      c.b = static_cast<std::uint32_t>(j);
      c.a_T_b = true_between(best, j);
      c.sigma_t_m.setConstant(oracle_sigma_t);
      c.sigma_rot_rad.setConstant(oracle_sigma_rot);
      edges.push_back(backend::loop_closure_edge(c));
      ++closures;
    }
    for (std::size_t k = p.first_closure + p.result.loop_closures; k < p.edges.size(); ++k) edges.push_back(p.edges[k]);
    std::printf("dg_solve: %zu loop closures with the oracle's (within %.2f m, %zu agents apart)\n", closures, oracle_m,
                gap);
    p.edges = std::move(edges);
    p.result.loop_closures = closures;
  }
  // What-if: the agent layer alone (no control points or places: what the mesh's edges add to the agents' solution).
  if (agents_only) {
    const std::size_t A = p.result.agents;
    std::vector<backend::RelativePoseEdge> edges;
    for (std::size_t k = 0; k < p.edges.size(); ++k)
      if (p.edges[k].from < A && p.edges[k].to < A) edges.push_back(p.edges[k]);
    p.edges = std::move(edges);
    p.poses.resize(A);
    p.originals.clear();
    p.times_ns.clear();
    p.place_ids.clear();
    p.result.control_points = p.result.places = 0;
  }
  backend::DeformationConfig config;
  config.decide_on_agents = strategy == "agents_first";
  if (max_outer > 0) config.agents.solver.gnc_max_outer_iterations = max_outer;
  config.agent_spacing_m = agent_spacing_m;
  config.agent_turn_rad = agent_turn_rad;
  config.hold_agents = hold_agents;
  config.reduced_decisions = reduced;
  config.agents.solver.clock_s = &bench::thread_cpu_seconds;  // where the time goes, on the thread's CPU
  if (whole_tolerance > 0.0) config.whole_function_tolerance = whole_tolerance;
  if (least_squares) config.agents.solver.loop_closure_loss = backend::RobustLoss::kNone;
  backend::DeformationGraph graph(config);
  const std::vector<backend::Pose3> initial = file.problem.poses;
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = bench::thread_cpu_seconds();
  const backend::DeformationResult r = graph.solve(file.problem);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double cpu = bench::thread_cpu_seconds() - cpu_start;
  r.print(stdout);
  std::vector<backend::Pose3> solved(r.agents);
  for (std::size_t k = 0; k < r.agents; ++k) solved[k] = graph.agent_pose(k);
  const double ate_before = ate_rmse(initial, file.truth_m, false), ate_after = ate_rmse(solved, file.truth_m, false);
  const double ate_before_se3 = ate_rmse(initial, file.truth_m, true), ate_after_se3 = ate_rmse(solved, file.truth_m, true);
  std::printf("dg_solve %s: %zu agents, %zu control points, %zu places, %zu edges: %.2f s CPU (%.2f s wall), "
              "%d iterations (%d GNC outer), %zu of %zu loop closures kept; agents' ATE %.3f m "
              "-> %.3f m (ratio %.2f) as mapped, %.3f m -> %.3f m (ratio %.2f) after SE(3) alignment\n",
              strategy.c_str(), r.agents, r.control_points, r.places, file.problem.edges.size(), cpu, seconds, r.solve.iterations, r.solve.gnc_outer_iterations + r.decide.gnc_outer_iterations, r.loop_closures_kept,
              r.loop_closures, ate_before, ate_after, ate_after / ate_before, ate_before_se3, ate_after_se3,
              ate_after_se3 / ate_before_se3);
  std::printf("dg_solve: CPU of the decision %.3f s (%d GNC outer iterations, %zu agents%s), the agent layer's "
              "solve with it %.3f s, the map's %.3f s\n",
              r.decide.solver_time_s, r.decide.gnc_outer_iterations, r.agents_decided > 0 ? r.agents_decided : r.agents_solved,
              r.agents_decided > 0 ? " reduced" : "", r.decide_chain.solver_time_s, r.solve.solver_time_s);
  if (segments > 0 && !file.truth_m.empty()) {
    std::printf("segment  agents       ATE before m  after m  ratio | SE(3) before m  after m  ratio\n");
    for (int s = 0; s < segments; ++s) {
      const std::size_t lo = r.agents * static_cast<std::size_t>(s) / static_cast<std::size_t>(segments);
      const std::size_t hi = r.agents * static_cast<std::size_t>(s + 1) / static_cast<std::size_t>(segments);
      const double b = ate_rmse(initial, file.truth_m, false, lo, hi), a = ate_rmse(solved, file.truth_m, false, lo, hi);
      const double bs = ate_rmse(initial, file.truth_m, true, lo, hi), as = ate_rmse(solved, file.truth_m, true, lo, hi);
      std::printf("%7d  %5zu-%-5zu %12.3f %8.3f %6.2f | %14.3f %8.3f %6.2f\n", s + 1, lo, hi, b, a, a / b, bs, as, as / bs);
    }
  }
  if (profile > 0 && !file.truth_m.empty()) {
    std::printf("agent   error before m   error after m\n");
    for (int i = 0; i < profile; ++i) {
      const std::size_t k = (r.agents - 1) * static_cast<std::size_t>(i) / static_cast<std::size_t>(profile - 1);
      std::printf("%5zu %16.3f %15.3f\n", k, (initial[k].t_m - file.truth_m[k]).norm(),
                  (solved[k].t_m - file.truth_m[k]).norm());
    }
  }
  if (!json.empty()) {
    bench::Figures figures("deformation problem " + path + ", strategy " + strategy +
                           (reduced ? ", reduced decisions" : ""));
    figures.add("dg_solve.cpu_seconds", cpu, "s");
    figures.add("dg_solve.wall_seconds", seconds, "s");
    figures.add("dg_solve.agents", static_cast<double>(r.agents), "nodes");
    figures.add("dg_solve.control_points", static_cast<double>(r.control_points), "nodes");
    figures.add("dg_solve.iterations", r.solve.iterations, "iterations");
    figures.add("dg_solve.loop_closures_kept", static_cast<double>(r.loop_closures_kept), "closures");
    figures.add("dg_solve.decide_cpu_seconds", r.decide.solver_time_s, "s");
    figures.add("dg_solve.chain_cpu_seconds", r.decide_chain.solver_time_s, "s");
    figures.add("dg_solve.map_cpu_seconds", r.solve.solver_time_s, "s");
    figures.add("dg_solve.ate_before", ate_before, "m");
    figures.add("dg_solve.ate_after", ate_after, "m");
    figures.add("dg_solve.ate_before_se3", ate_before_se3, "m");
    figures.add("dg_solve.ate_after_se3", ate_after_se3, "m");
    if (!figures.write(json)) return 1;
  }
  return r.solve.poses_updated() ? 0 : 1;
}
