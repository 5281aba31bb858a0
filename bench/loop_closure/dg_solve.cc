// Re-solves a deformation problem written by the app (QSG_DUMP_DEFORMATION=FILE) offline, so a solver strategy can
// be compared on the same graph in seconds instead of re-running the mission: wall time, iterations, loop closures
// kept and, when the file carries the agents' true positions, the agents' ATE (RMSE, no alignment) before and after.
// Every figure also goes to --json (bench/figures.h).
#include <time.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "bench/figures.h"
#include "core/backend/deformation_io.h"

namespace {

using namespace qsg;

int usage(int status) {
  std::printf(
      "usage: dg_solve PROBLEM [--strategy full_gnc|agents_first (agents_first)] [--max-outer N] [--json FILE]\n"
      "                [--max-closure-sigma M] [--closure-sigma-scale F]   (what-ifs on the loop closures)\n"
      "                [--profile N]   (the error of N agents evenly spaced along the chain, before and after)\n"
      "  full_gnc:     graduated non-convexity over the whole deformation graph (agents, control points, places)\n"
      "  agents_first: GNC decides the loop closures on the agent layer, then the whole graph is solved once with\n"
      "                the kept ones, from the agents' solution (DeformationConfig::decide_on_agents)\n");
  return status;
}

// This thread's CPU time: the solve runs on one thread, so this is its cost whatever else shares the machine.
double cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double ate_rmse(const std::vector<backend::Pose3>& poses, const std::vector<Eigen::Vector3d>& truth) {
  double sum = 0.0;
  for (std::size_t k = 0; k < truth.size(); ++k) sum += (poses[k].t_m - truth[k]).squaredNorm();
  return truth.empty() ? -1.0 : std::sqrt(sum / static_cast<double>(truth.size()));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage(2);
  std::string path = argv[1], strategy = "agents_first", json;
  int max_outer = -1, profile = 0;
  double max_sigma = 0.0, sigma_scale = 1.0;
  if (path == "--help") return usage(0);
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--strategy" && has) strategy = argv[++i];
    else if (a == "--max-outer" && has) max_outer = std::atoi(argv[++i]);
    else if (a == "--profile" && has) profile = std::atoi(argv[++i]);
    else if (a == "--max-closure-sigma" && has) max_sigma = std::atof(argv[++i]);
    else if (a == "--closure-sigma-scale" && has) sigma_scale = std::atof(argv[++i]);
    else if (a == "--json" && has) json = argv[++i];
    else return usage(a == "--help" ? 0 : 2);
  }
  if (strategy != "full_gnc" && strategy != "agents_first") return usage(2);
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
  backend::DeformationConfig config;
  config.decide_on_agents = strategy == "agents_first";
  if (max_outer > 0) config.agents.solver.gnc_max_outer_iterations = max_outer;
  backend::DeformationGraph graph(config);
  const std::vector<backend::Pose3> initial = file.problem.poses;
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = cpu_seconds();
  const backend::DeformationResult r = graph.solve(file.problem);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double cpu = cpu_seconds() - cpu_start;
  r.print(stdout);
  std::vector<backend::Pose3> solved(r.agents);
  for (std::size_t k = 0; k < r.agents; ++k) solved[k] = graph.agent_pose(k);
  const double ate_before = ate_rmse(initial, file.truth_m), ate_after = ate_rmse(solved, file.truth_m);
  std::printf("dg_solve %s: %zu agents, %zu control points, %zu places, %zu edges: %.2f s CPU (%.2f s wall), "
              "%d iterations (%d GNC outer), %zu of %zu loop closures kept; agents' ATE %.3f m "
              "-> %.3f m\n",
              strategy.c_str(), r.agents, r.control_points, r.places, file.problem.edges.size(), cpu, seconds, r.solve.iterations, r.solve.gnc_outer_iterations + r.decide.gnc_outer_iterations, r.loop_closures_kept,
              r.loop_closures, ate_before, ate_after);
  if (profile > 0 && !file.truth_m.empty()) {
    std::printf("agent   error before m   error after m\n");
    for (int i = 0; i < profile; ++i) {
      const std::size_t k = (r.agents - 1) * static_cast<std::size_t>(i) / static_cast<std::size_t>(profile - 1);
      std::printf("%5zu %16.3f %15.3f\n", k, (initial[k].t_m - file.truth_m[k]).norm(),
                  (solved[k].t_m - file.truth_m[k]).norm());
    }
  }
  if (!json.empty()) {
    bench::Figures figures("deformation problem " + path + ", strategy " + strategy);
    figures.add("dg_solve.cpu_seconds", cpu, "s");
    figures.add("dg_solve.wall_seconds", seconds, "s");
    figures.add("dg_solve.agents", static_cast<double>(r.agents), "nodes");
    figures.add("dg_solve.control_points", static_cast<double>(r.control_points), "nodes");
    figures.add("dg_solve.iterations", r.solve.iterations, "iterations");
    figures.add("dg_solve.loop_closures_kept", static_cast<double>(r.loop_closures_kept), "closures");
    figures.add("dg_solve.ate_before", ate_before, "m");
    figures.add("dg_solve.ate_after", ate_after, "m");
    if (!figures.write(json)) return 1;
  }
  return r.solve.poses_updated() ? 0 : 1;
}
