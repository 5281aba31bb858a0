// Re-solves the sequence of deformation problems one mission wrote (QSG_DUMP_DEFORMATION=DIR/dg_%d.txt keeps every
// solve's), in order, as the app's backend solved them: one DeformationGraph carries each solution into the next
// solve. Two of them side by side: the full solve (every map node solved and every closure decided, each time) and
// the bounded one (the shipped defaults: control points the new closures did not move stay held, earlier closure
// decisions are carried). Per solve: the path so far, the graph's size, the thread CPU of each, the control points
// held, how far the bounded solve's map nodes are from the full solve's (the price of holding them), the closures
// kept and the agents' ATE of each. Every figure also goes to --json (bench/figures.h).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench/figures.h"
#include "bench/thread_cpu.h"
#include "core/backend/deformation_graph.h"
#include "core/backend/deformation_io.h"

namespace {

using namespace qsg;

int usage(int status) {
  std::fprintf(status == 0 ? stdout : stderr,
               "usage: dg_sequence PROBLEM... [--settle M] [--hops N] [--incremental 0|1] [--whole-tolerance F]\n"
               "                   [--agent-spacing M (0)] [--bounded-whole-tolerance F]\n"
               "                   [--bounded-only] [--reduced 0|1] [--compare-reduced] [--json FILE]\n"
               "                   [--place-rotation-sigma R] [--control-rotation-sigma R] [--bounded-prior-only]\n"
               "  the bounded side: DeformationConfig's defaults; --settle, --hops: settle_tolerance_m, settle_hops;\n"
               "  --incremental: incremental_decisions (it keeps the last solve's closure decisions)\n"
               "  --bounded-whole-tolerance F: the bounded side's stopping rule only (with --settle 0: how far the\n"
               "                 full solve's own nodes move with its stopping rule)\n"
               "  --bounded-only: the bounded solve alone, with its iterations (where a slow solve's time goes)\n"
               "  --reduced: the bounded side's reduced_decisions (on by default: GNC on the agent graph reduced)\n"
               "  --compare-reduced: the bounded solve without and with reduced_decisions, side by side (no full\n"
               "                 solve): CPU of the solve and of its decision, the chain's and the map's solves, the\n"
               "                 closures each keeps and where they differ, ATE of each\n"
               "  --place-rotation-sigma, --control-rotation-sigma R: both sides' place_rotation_sigma_rad and\n"
               "                 control_rotation_sigma_rad (the map nodes' rotation priors; 0: none);\n"
               "                 --bounded-prior-only: the bounded side's only (how far the priors move the map)\n"
               "  PROBLEM...: one mission's solves in the order the app made them (QSG_DUMP_DEFORMATION with %%d)\n");
  return status;
}

struct Timed {
  backend::DeformationResult result;
  double cpu_s = 0.0;
};

// Mean, 99th percentile and largest of a set of distances.
// One dumped problem, and the odometric path its chain covers; false (printed) when it cannot be read.
bool read_problem(const std::string& path, backend::DeformationProblemFile* file, double* path_m) {
  std::string error;
  if (!backend::read_deformation_problem(path, file, &error)) {
    std::fprintf(stderr, "dg_sequence: %s\n", error.c_str());
    return false;
  }
  const backend::DeformationProblem& p = file->problem;
  *path_m = 0.0;
  for (std::size_t k = 1; k < p.result.agents; ++k) *path_m += (p.poses[k].t_m - p.poses[k - 1].t_m).norm();
  return true;
}

struct Spread {
  std::vector<double> values;
  double mean = 0.0, p99 = 0.0, max = 0.0;
  void add(double v) { values.push_back(v); }
  void finish() {
    if (values.empty()) return;
    for (double v : values) mean += v / static_cast<double>(values.size());
    std::sort(values.begin(), values.end());
    max = values.back();
    p99 = values[std::min(values.size() - 1, values.size() * 99 / 100)];
  }
};

Timed solve(backend::DeformationGraph* graph, const backend::DeformationProblem& problem) {
  const double start = bench::thread_cpu_seconds();
  Timed t;
  t.result = graph->solve(problem);
  t.cpu_s = bench::thread_cpu_seconds() - start;
  return t;
}

// The map nodes against the truth carried from the agent each hangs from (the first agent edge to it, else its
// place's control point's): true_T_odometric of that agent applied to the node's odometric position, what it would
// be had the agent been where it truly was. Needs the file's true orientations; empty spreads without them.
void map_truth_error(const backend::DeformationGraph& g, const backend::DeformationProblemFile& file, Spread* control,
                     Spread* places) {
  const backend::DeformationProblem& p = file.problem;
  const std::size_t A = p.result.agents, C = p.result.control_points;
  if (file.truth_q.size() != A || g.num_map_nodes() != p.originals.size()) return;
  std::vector<std::int64_t> anchor(p.poses.size(), -1);
  for (const backend::RelativePoseEdge& e : p.edges)
    if (e.from < A && e.to >= A && anchor[e.to] < 0) anchor[e.to] = e.from;
  for (const backend::RelativePoseEdge& e : p.edges)
    if (e.from >= A && e.to >= A && anchor[e.from] < 0 && anchor[e.to] >= 0) anchor[e.from] = anchor[e.to];
  for (std::size_t i = 0; i < p.originals.size(); ++i) {
    const std::int64_t a = anchor[A + i];
    if (a < 0) continue;
    const backend::Pose3& odo = p.poses[static_cast<std::size_t>(a)];
    const Eigen::Quaterniond& tq = file.truth_q[static_cast<std::size_t>(a)];
    const Eigen::Vector3d truth = file.truth_m[static_cast<std::size_t>(a)] + tq * (odo.q.conjugate() * (p.originals[i] - odo.t_m));
    (i < C ? control : places)->add((g.map_node_pose(i).t_m - truth).norm());
  }
  control->finish();
  places->finish();
}

// The agents against the truth, as mapped (no alignment), when the file has it; -1 otherwise.
double agent_ate(const backend::DeformationGraph& g, const std::vector<Eigen::Vector3d>& truth_m) {
  double sum = 0.0;
  for (std::size_t k = 0; k < truth_m.size(); ++k) sum += (g.agent_pose(k).t_m - truth_m[k]).squaredNorm();
  return truth_m.empty() ? -1.0 : std::sqrt(sum / static_cast<double>(truth_m.size()));
}

// --compare-reduced: the bounded solve as configured (reduced_decisions off) and the same with it on, side by side.
int compare_reduced_decisions(const std::vector<std::string>& paths, backend::DeformationConfig config,
                              const std::string& json) {
  constexpr double kBudgetS = 1.5;  // host_sim's threads.backend.solve_budget_us
  config.reduced_decisions = false;
  config.agents.solver.clock_s = &bench::thread_cpu_seconds;  // each solve's share of the thread's CPU
  backend::DeformationConfig reduced_config = config;
  reduced_config.reduced_decisions = true;
  backend::DeformationGraph base(config), reduced(reduced_config);
  bench::Figures figures("deformation problems " + paths.front() + " .. " + paths.back() + " (" +
                         std::to_string(paths.size()) + " solves), the bounded solve (shipped defaults) without and "
                         "with reduced_decisions, one core");
  std::printf("solve  path_m  agents closures  cpu_base_s cpu_red_s  | base: decide_s map_s | reduced: agents "
              "decide_s chain_s map_s | kept base/red differ | ate_base ate_red\n");
  Spread cpu_base, cpu_red;
  double decide_base = 0.0, map_base = 0.0, decide_red = 0.0, chain_red = 0.0, map_red = 0.0;
  int over_base = 0, over_red = 0, again_base = 0, again_red = 0, solves_differ = 0, closures_differ = 0;
  double ate_diff_max = 0.0;
  for (std::size_t s = 0; s < paths.size(); ++s) {
    backend::DeformationProblemFile file;
    double path_m = 0.0;
    if (!read_problem(paths[s], &file, &path_m)) return 1;
    const backend::DeformationProblem& p = file.problem;
    const Timed a = solve(&base, p), b = solve(&reduced, p);
    if (!a.result.solve.poses_updated() || !b.result.solve.poses_updated()) {
      std::fprintf(stderr, "dg_sequence: solve %zu failed (%s / %s)\n", s, a.result.solve.message.c_str(),
                   b.result.solve.message.c_str());
      return 1;
    }
    std::size_t differ = 0;
    for (std::size_t c = 0; c < a.result.loop_closure_weight.size() && c < b.result.loop_closure_weight.size(); ++c)
      differ += (a.result.loop_closure_weight[c] > 0.5) != (b.result.loop_closure_weight[c] > 0.5) ? 1 : 0;
    const double ate_a = agent_ate(base, file.truth_m), ate_b = agent_ate(reduced, file.truth_m);
    const backend::DeformationResult &ra = a.result, &rb = b.result;
    std::printf("%5zu %7.1f %7zu %5zu  %9.3f %9.3f  | %7.3f %6.3f%s | %6zu %7.3f %7.3f %6.3f%s | %4zu %4zu %3zu | %7.4f "
                "%7.4f\n",
                s, path_m, p.result.agents, p.result.loop_closures, a.cpu_s, b.cpu_s, ra.decide.solver_time_s,
                ra.solve.solver_time_s, ra.decided_again ? " again" : "      ", rb.agents_decided,
                rb.decide.solver_time_s, rb.decide_chain.solver_time_s, rb.solve.solver_time_s,
                rb.decided_again ? " again" : "      ", ra.loop_closures_kept, rb.loop_closures_kept, differ, ate_a,
                ate_b);
    std::fflush(stdout);
    char key[48];
    std::snprintf(key, sizeof key, "dg_sequence.s%03zu.", s);
    const std::string k = key;
    figures.add(k + "path", path_m, "m");
    figures.add(k + "cpu_base", a.cpu_s, "s");
    figures.add(k + "cpu_reduced", b.cpu_s, "s");
    figures.add(k + "decide_time_base", ra.decide.solver_time_s, "s");
    figures.add(k + "map_time_base", ra.solve.solver_time_s, "s");
    figures.add(k + "decide_time_reduced", rb.decide.solver_time_s, "s");
    figures.add(k + "chain_time_reduced", rb.decide_chain.solver_time_s, "s");
    figures.add(k + "map_time_reduced", rb.solve.solver_time_s, "s");
    figures.add(k + "agents_decided_reduced", static_cast<double>(rb.agents_decided), "agents");
    figures.add(k + "kept_base", static_cast<double>(ra.loop_closures_kept), "closures");
    figures.add(k + "kept_reduced", static_cast<double>(rb.loop_closures_kept), "closures");
    figures.add(k + "closures_differ", static_cast<double>(differ), "closures");
    figures.add(k + "ate_base", ate_a, "m");
    figures.add(k + "ate_reduced", ate_b, "m");
    cpu_base.add(a.cpu_s);
    cpu_red.add(b.cpu_s);
    over_base += a.cpu_s > kBudgetS ? 1 : 0;
    over_red += b.cpu_s > kBudgetS ? 1 : 0;
    again_base += ra.decided_again ? 1 : 0;
    again_red += rb.decided_again ? 1 : 0;
    solves_differ += differ > 0 ? 1 : 0;
    closures_differ += static_cast<int>(differ);
    decide_base += ra.decide.solver_time_s;
    map_base += ra.solve.solver_time_s;
    decide_red += rb.decide.solver_time_s;
    chain_red += rb.decide_chain.solver_time_s;
    map_red += rb.solve.solver_time_s;
    if (ate_a >= 0.0 && ate_b >= 0.0) ate_diff_max = std::max(ate_diff_max, std::abs(ate_a - ate_b));
  }
  cpu_base.finish();
  cpu_red.finish();
  std::printf("dg_sequence: %zu solves; CPU per solve base mean %.3f p99 %.3f max %.3f s, %d over %.1f s (%d decided "
              "again); reduced mean %.3f p99 %.3f max %.3f s, %d over (%d decided again)\n"
              "  CPU: base decide %.1f s, map %.1f s; reduced decide %.1f s, chain %.1f s, map %.1f s; closures "
              "decided differently %d in %d solves; largest ATE difference %.4f m\n",
              paths.size(), cpu_base.mean, cpu_base.p99, cpu_base.max, over_base, kBudgetS, again_base, cpu_red.mean,
              cpu_red.p99, cpu_red.max, over_red, again_red, decide_base, map_base, decide_red, chain_red, map_red,
              closures_differ, solves_differ, ate_diff_max);
  const std::pair<const char*, const Spread*> sides[] = {{"base", &cpu_base}, {"reduced", &cpu_red}};
  for (const auto& [name, spread] : sides) {
    const std::string k = std::string("dg_sequence.cpu_") + name;
    figures.add(k + "_mean", spread->mean, "s");
    figures.add(k + "_p99", spread->p99, "s");
    figures.add(k + "_max", spread->max, "s");
  }
  figures.add("dg_sequence.over_budget_base", over_base, "solves");
  figures.add("dg_sequence.over_budget_reduced", over_red, "solves");
  figures.add("dg_sequence.decided_again_base", again_base, "solves");
  figures.add("dg_sequence.decided_again_reduced", again_red, "solves");
  figures.add("dg_sequence.decide_time_base", decide_base, "s");
  figures.add("dg_sequence.map_time_base", map_base, "s");
  figures.add("dg_sequence.decide_time_reduced", decide_red, "s");
  figures.add("dg_sequence.chain_time_reduced", chain_red, "s");
  figures.add("dg_sequence.map_time_reduced", map_red, "s");
  figures.add("dg_sequence.closures_differ", closures_differ, "closures");
  figures.add("dg_sequence.solves_differ", solves_differ, "solves");
  figures.add("dg_sequence.ate_diff_max", ate_diff_max, "m");
  if (!json.empty() && !figures.write(json)) return 1;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> paths;
  std::string json;
  double settle_m = backend::DeformationConfig{}.settle_tolerance_m;
  int hops = static_cast<int>(backend::DeformationConfig{}.settle_hops);
  double whole_tolerance = 0.0, agent_spacing_m = 0.0, bounded_tolerance = 0.0;
  bool incremental = backend::DeformationConfig{}.incremental_decisions;
  bool bounded_only = false, compare_reduced = false, bounded_prior_only = false;
  double place_rotation_sigma = 0.0, control_rotation_sigma = 0.0;
  bool reduced = backend::DeformationConfig{}.reduced_decisions;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--help") return usage(0);
    if (a == "--settle" && has) settle_m = std::atof(argv[++i]);
    else if (a == "--hops" && has) hops = std::atoi(argv[++i]);
    else if (a == "--whole-tolerance" && has) whole_tolerance = std::atof(argv[++i]);
    else if (a == "--agent-spacing" && has) agent_spacing_m = std::atof(argv[++i]);
    else if (a == "--incremental" && has) incremental = std::atoi(argv[++i]) != 0;
    else if (a == "--bounded-whole-tolerance" && has) bounded_tolerance = std::atof(argv[++i]);
    else if (a == "--bounded-only") bounded_only = true;
    else if (a == "--reduced" && has) reduced = std::atoi(argv[++i]) != 0;
    else if (a == "--compare-reduced") compare_reduced = true;
    else if (a == "--place-rotation-sigma" && has) place_rotation_sigma = std::atof(argv[++i]);
    else if (a == "--control-rotation-sigma" && has) control_rotation_sigma = std::atof(argv[++i]);
    else if (a == "--bounded-prior-only") bounded_prior_only = true;
    else if (a == "--json" && has) json = argv[++i];
    else if (!a.empty() && a[0] == '-') return usage(2);
    else paths.push_back(a);
  }
  if (paths.empty()) return usage(2);
  backend::DeformationConfig full_config;  // every map node solved, every closure decided, each time
  full_config.settle_tolerance_m = 0.0;
  full_config.incremental_decisions = false;
  if (whole_tolerance > 0.0) full_config.whole_function_tolerance = whole_tolerance;
  full_config.agent_spacing_m = agent_spacing_m;
  full_config.place_rotation_sigma_rad = place_rotation_sigma;
  full_config.control_rotation_sigma_rad = control_rotation_sigma;
  backend::DeformationConfig settled_config = full_config;
  if (bounded_prior_only) full_config.place_rotation_sigma_rad = full_config.control_rotation_sigma_rad = 0.0;
  settled_config.settle_tolerance_m = settle_m;
  settled_config.settle_hops = static_cast<std::uint32_t>(std::max(0, hops));
  settled_config.incremental_decisions = incremental;
  if (bounded_tolerance > 0.0) settled_config.whole_function_tolerance = bounded_tolerance;
  settled_config.reduced_decisions = reduced;
  if (compare_reduced) return compare_reduced_decisions(paths, settled_config, json);
  if (std::string why = settled_config.check(); !why.empty()) {
    std::fprintf(stderr, "dg_sequence: %s\n", why.c_str());
    return 2;
  }
  backend::DeformationGraph full(full_config), settled(settled_config);
  bench::Figures figures("deformation problems " + paths.front() + " .. " + paths.back() + " (" +
                         std::to_string(paths.size()) + " solves), settle " + std::to_string(settle_m) + " m, " +
                         std::to_string(hops) + " hops, incremental decisions " + (incremental ? "on" : "off") +
                         ", rotation priors " + std::to_string(place_rotation_sigma) + " rad (places), " +
                         std::to_string(control_rotation_sigma) + " rad (control points)" +
                         (bounded_prior_only ? " on the bounded side only" : ""));
  std::printf("solve  path_m  agents  control  places  settled  cpu_full_s  cpu_settled_s  ratio  "
              "control: mean    p99     max   places: mean    p99     max (m)  kept/closures  kept/carried  ate_full  "
              "ate_bounded\n");
  double total_full = 0.0, total_settled = 0.0, worst_control = 0.0, worst_place = 0.0;
  int decided_again = 0;
  for (std::size_t s = 0; s < paths.size(); ++s) {
    backend::DeformationProblemFile file;
    double path_m = 0.0;
    if (!read_problem(paths[s], &file, &path_m)) return 1;
    const backend::DeformationProblem& p = file.problem;
    if (bounded_only) {  // the bounded solve alone: where its time goes
      const Timed b = solve(&settled, p);
      std::printf("%5zu %7.1f %7zu %8zu %7zu %8zu %9.3f s: decide %d iterations (%d GNC outer), map %d iterations; "
                  "%zu of %zu kept, %zu carried%s\n",
                  s, path_m, p.result.agents, p.result.control_points, p.result.places, b.result.map_settled, b.cpu_s,
                  b.result.decide.iterations, b.result.decide.gnc_outer_iterations, b.result.solve.iterations,
                  b.result.loop_closures_kept, b.result.loop_closures, b.result.closures_carried,
                  b.result.decided_again ? ", decided again" : "");
      std::fflush(stdout);
      continue;
    }
    const Timed a = solve(&full, p), b = solve(&settled, p);
    if (!a.result.solve.poses_updated() || !b.result.solve.poses_updated()) {
      std::fprintf(stderr, "dg_sequence: solve %zu failed (%s / %s)\n", s, a.result.solve.message.c_str(),
                   b.result.solve.message.c_str());
      return 1;
    }
    // How far the bounded solve's map nodes are from the full solve's: the control points (what moves the mesh)
    // and the places apart.
    const std::size_t C = p.result.control_points;
    Spread control, places;
    for (std::size_t i = 0; i < full.num_map_nodes() && i < settled.num_map_nodes(); ++i)
      (i < C ? control : places).add((full.map_node_pose(i).t_m - settled.map_node_pose(i).t_m).norm());
    control.finish();
    places.finish();
    // The agents against the truth, as mapped (no alignment), when the file has it.
    const auto ate = [&](const backend::DeformationGraph& g) {
      double sum = 0.0;
      for (std::size_t k = 0; k < file.truth_m.size(); ++k)
        sum += (g.agent_pose(k).t_m - file.truth_m[k]).squaredNorm();
      return file.truth_m.empty() ? -1.0 : std::sqrt(sum / static_cast<double>(file.truth_m.size()));
    };
    const double ate_full = ate(full), ate_bounded = ate(settled);
    Spread truth_control[2], truth_places[2];
    map_truth_error(full, file, &truth_control[0], &truth_places[0]);
    map_truth_error(settled, file, &truth_control[1], &truth_places[1]);
    std::printf("%5zu %7.1f %7zu %8zu %7zu %8zu %11.3f %14.3f %6.2f  %7.4f %7.4f %7.4f  %7.4f %7.4f %7.4f  "
                "%4zu/%-4zu %4zu/%-4zu %6.3f %6.3f%s\n",
                s, path_m, p.result.agents, p.result.control_points, p.result.places, b.result.map_settled, a.cpu_s,
                b.cpu_s, b.cpu_s > 0.0 ? a.cpu_s / b.cpu_s : 0.0, control.mean, control.p99, control.max, places.mean,
                places.p99, places.max, a.result.loop_closures_kept, a.result.loop_closures,
                b.result.loop_closures_kept, b.result.closures_carried, ate_full, ate_bounded, b.result.decided_again ? " decided again" : "");
    std::fflush(stdout);
    char key[48];
    std::snprintf(key, sizeof key, "dg_sequence.s%03zu.", s);
    const std::string k = key;
    figures.add(k + "path", path_m, "m");
    figures.add(k + "map_nodes", static_cast<double>(control.values.size() + places.values.size()), "nodes");
    figures.add(k + "settled", static_cast<double>(b.result.map_settled), "nodes");
    figures.add(k + "cpu_full", a.cpu_s, "s");
    figures.add(k + "cpu_settled", b.cpu_s, "s");
    figures.add(k + "control_diff_mean", control.mean, "m");
    figures.add(k + "control_diff_p99", control.p99, "m");
    figures.add(k + "control_diff_max", control.max, "m");
    figures.add(k + "place_diff_mean", places.mean, "m");
    figures.add(k + "place_diff_p99", places.p99, "m");
    figures.add(k + "place_diff_max", places.max, "m");
    figures.add(k + "kept_full", static_cast<double>(a.result.loop_closures_kept), "closures");
    figures.add(k + "kept_bounded", static_cast<double>(b.result.loop_closures_kept), "closures");
    figures.add(k + "ate_full", ate_full, "m");
    figures.add(k + "ate_bounded", ate_bounded, "m");
    for (int side = 0; side < 2 && !truth_places[0].values.empty(); ++side) {
      const std::string n = k + (side == 0 ? "full" : "bounded");
      std::printf("      %s against the carried truth: control points mean %.4f p99 %.4f max %.4f, places mean %.4f "
                  "p99 %.4f max %.4f m\n", side == 0 ? "full   " : "bounded", truth_control[side].mean,
                  truth_control[side].p99, truth_control[side].max, truth_places[side].mean, truth_places[side].p99,
                  truth_places[side].max);
      figures.add(n + "_control_truth_mean", truth_control[side].mean, "m");
      figures.add(n + "_control_truth_p99", truth_control[side].p99, "m");
      figures.add(n + "_place_truth_mean", truth_places[side].mean, "m");
      figures.add(n + "_place_truth_p99", truth_places[side].p99, "m");
      figures.add(n + "_place_truth_max", truth_places[side].max, "m");
    }
    decided_again += b.result.decided_again ? 1 : 0;
    total_full += a.cpu_s;
    total_settled += b.cpu_s;
    worst_control = std::max(worst_control, control.max);
    worst_place = std::max(worst_place, places.max);
  }
  std::printf("dg_sequence: %zu solves, CPU %.2f s full, %.2f s settled (%.2fx); largest difference %.4f m (control "
              "points), %.4f m (places)\n",
              paths.size(), total_full, total_settled, total_settled > 0.0 ? total_full / total_settled : 0.0,
              worst_control, worst_place);
  figures.add("dg_sequence.cpu_full_total", total_full, "s");
  figures.add("dg_sequence.cpu_settled_total", total_settled, "s");
  figures.add("dg_sequence.control_diff_max", worst_control, "m");
  figures.add("dg_sequence.place_diff_max", worst_place, "m");
  figures.add("dg_sequence.decided_again", decided_again, "solves");
  if (!json.empty() && !figures.write(json)) return 1;
  return 0;
}
