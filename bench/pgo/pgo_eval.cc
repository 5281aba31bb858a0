// Pose-graph optimizer on the public g2o benchmarks (../shared/data/pose_graphs): the cost reached and the time from
// the file's odometry guess; then, with wrong loop closures injected (10 %, 30 %, 50 % of all closures by default:
// random pairs, random relative poses, each with the information matrix of a real closure, so they look as sure),
// the trajectory error against the outlier-free solution, for GNC-TLS (the backend's outlier rejection) and for
// the Cauchy loss beside it. One thread; every figure also as JSON.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bench/figures.h"
#include "core/backend/chordal_init.h"
#include "core/backend/g2o_file.h"
#include "core/backend/pose_graph.h"

namespace {

using namespace qsg;
using backend::Pose3;
using backend::RelativePoseEdge;

struct Options {
  std::string data_dir = std::string(QSG_SHARED_DATA_DIR) + "/pose_graphs";
  std::vector<std::string> graphs{"smallGrid3D", "parking-garage", "sphere2500", "torus3D", "cubicle"};
  std::vector<double> outliers{0.1, 0.3, 0.5};
  unsigned seed = 1;
  std::string json_path;
  backend::PoseGraphConfig robust;  // --threshold-sigma, --gnc-inner, --gnc-mu-factor, --gnc-max-outer, --pcm-*
  // gnc_tls (the paper's), pcm_gnc_tls (pairwise-consistency prefilter, then GNC-TLS), cauchy (Huber warm start).
  std::vector<std::string> solvers{"gnc_tls", "pcm_gnc_tls", "cauchy"};
  bool diagnose = false;  // --diagnose 1
  bool chordal_timing = false;  // --chordal-timing 1
  // Every solve's stopping rule and iteration cap (--function-tolerance, --max-iterations). Tight by default: on a
  // graph whose stated noise is loose (parking-garage) the cost is flat over metres, and Ceres' default 1e-6 stops
  // the reference itself metres from its minimum.
  double function_tolerance = 1e-12;
  int max_iterations = 500;
  // --noise-bound Q: the robust threshold in the graph's real noise, not its stated one: the Q-quantile (1: the
  // largest) of the right closures' whitened residuals at the outlier-free solution, GNC's noise bound (every inlier
  // within it), as a user calibrates a front end's noise model on clean data. 0: --threshold-sigma in the stated
  // sigmas. The public files state noise up to hundreds of times their residuals.
  double noise_bound_quantile = 0.0;
  double noise_margin = 1.0;  // with noise_bound_quantile: the threshold is this many times the quantile
  backend::G2oReadOptions read;  // --drop-indefinite-coupling 1 (cubicle)
};

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

bool parse(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) return false;
    const std::string v = argv[++i];
    if (a == "--data-dir") {
      o->data_dir = v;
    } else if (a == "--graphs") {
      o->graphs = split(v);
    } else if (a == "--outliers") {
      o->outliers.clear();
      for (const std::string& f : split(v)) {
        char* end = nullptr;
        const double x = std::strtod(f.c_str(), &end);
        if (end == f.c_str() || *end != '\0' || !(x >= 0.0 && x < 1.0)) return false;
        o->outliers.push_back(x);
      }
    } else if (a == "--threshold-sigma") {
      o->robust.loop_closure_loss_scale_sigma = std::strtod(v.c_str(), nullptr);
    } else if (a == "--gnc-inner") {
      o->robust.gnc_inner_iterations = std::atoi(v.c_str());
    } else if (a == "--gnc-mu-factor") {
      o->robust.gnc_mu_factor = std::strtod(v.c_str(), nullptr);
    } else if (a == "--pcm-threshold-sigma") {
      o->robust.pairwise_consistency.threshold_sigma = std::strtod(v.c_str(), nullptr);
    } else if (a == "--pcm-max-clique-nodes") {
      o->robust.pairwise_consistency.max_clique_nodes = static_cast<std::uint32_t>(std::strtoul(v.c_str(), nullptr, 10));
    } else if (a == "--function-tolerance") {
      o->function_tolerance = std::strtod(v.c_str(), nullptr);
    } else if (a == "--max-iterations") {
      o->max_iterations = std::atoi(v.c_str());
    } else if (a == "--noise-bound") {
      o->noise_bound_quantile = std::strtod(v.c_str(), nullptr);
      if (!(o->noise_bound_quantile >= 0.0 && o->noise_bound_quantile <= 1.0)) return false;
    } else if (a == "--drop-indefinite-coupling") {
      o->read.drop_indefinite_coupling = v == "1";
    } else if (a == "--gnc-chordal") {
      o->robust.gnc_chordal_solves = v == "1";
    } else if (a == "--chordal-weighting") {
      if (v != "isotropic" && v != "anisotropic") return false;
      o->robust.chordal_weighting =
          v == "isotropic" ? backend::ChordalWeighting::kIsotropic : backend::ChordalWeighting::kAnisotropic;
    } else if (a == "--noise-margin") {
      o->noise_margin = std::strtod(v.c_str(), nullptr);
      if (!(o->noise_margin > 0.0)) return false;
    } else if (a == "--chordal-solver") {
      if (v != "direct" && v != "iterative") return false;
      o->robust.chordal_solver =
          v == "iterative" ? backend::ChordalSolver::kIterative : backend::ChordalSolver::kDirect;
    } else if (a == "--chordal-timing") {
      o->chordal_timing = v == "1";
    } else if (a == "--diagnose") {
      o->diagnose = v == "1";
    } else if (a == "--solvers") {
      o->solvers = split(v);
    } else if (a == "--gnc-refine") {
      o->robust.gnc_tls_refine_rounds = std::atoi(v.c_str());
    } else if (a == "--gnc-cluster-trials") {
      o->robust.gnc_cluster_trials = std::atoi(v.c_str());
    } else if (a == "--gnc-cluster-gap") {
      o->robust.gnc_cluster_gap_poses = static_cast<std::uint32_t>(std::atoi(v.c_str()));
    } else if (a == "--gnc-lone-trials") {
      o->robust.gnc_cluster_lone_trials = static_cast<std::uint32_t>(std::atoi(v.c_str()));
    } else if (a == "--gnc-trial-iterations") {
      o->robust.gnc_cluster_trial_iterations = std::atoi(v.c_str());
    } else if (a == "--gnc-cluster-screen") {
      o->robust.gnc_cluster_screen = v == "1";
    } else if (a == "--gnc-cluster-min") {
      o->robust.gnc_cluster_min_closures = static_cast<std::uint32_t>(std::atoi(v.c_str()));
    } else if (a == "--gnc-max-outer") {
      o->robust.gnc_max_outer_iterations = std::atoi(v.c_str());
    } else if (a == "--seed") {
      o->seed = static_cast<unsigned>(std::strtoul(v.c_str(), nullptr, 10));
    } else if (a == "--json") {
      o->json_path = v;
    } else {
      return false;
    }
  }
  for (const std::string& solver : o->solvers)
    if (solver != "gnc_tls" && solver != "pcm_gnc_tls" && solver != "cauchy" && solver != "none") return false;
  return !o->graphs.empty() && !o->solvers.empty();
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// RMSE of positions against the reference (pose 0 is held at the file's guess in both: no alignment needed), and
// the reference's RMS distance to its centroid (the scale the error is judged against).
double rmse_m(const std::vector<Pose3>& a, const std::vector<Pose3>& b) {
  double s = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) s += (a[i].t_m - b[i].t_m).squaredNorm();
  return std::sqrt(s / static_cast<double>(a.size()));
}
double rms_radius_m(const std::vector<Pose3>& p) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const Pose3& x : p) c += x.t_m;
  c /= static_cast<double>(p.size());
  double s = 0.0;
  for (const Pose3& x : p) s += (x.t_m - c).squaredNorm();
  return std::sqrt(s / static_cast<double>(p.size()));
}

// Wrong closures: `count` random pairs at least 2 ids apart, random rotation, translation uniform in the
// trajectory's bounding box size, with the information matrix of a random real closure.
std::vector<RelativePoseEdge> wrong_closures(const backend::G2oPoseGraph& g, std::size_t count, std::mt19937* rng) {
  std::vector<const RelativePoseEdge*> real;
  for (const RelativePoseEdge& e : g.edges)
    if (e.is_loop_closure) real.push_back(&e);
  Eigen::Vector3d lo = g.poses[0].t_m, hi = lo;
  for (const Pose3& p : g.poses) {
    lo = lo.cwiseMin(p.t_m);
    hi = hi.cwiseMax(p.t_m);
  }
  const Eigen::Vector3d span = (hi - lo).cwiseMax(Eigen::Vector3d::Constant(1.0));
  std::uniform_int_distribution<std::uint32_t> pick(0, static_cast<std::uint32_t>(g.poses.size() - 1));
  std::uniform_real_distribution<double> unit(-0.5, 0.5);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<RelativePoseEdge> out;
  while (out.size() < count) {
    std::uint32_t a = pick(*rng), b = pick(*rng);
    if (a > b) std::swap(a, b);
    if (b - a < 2) continue;
    RelativePoseEdge e = real.empty() ? RelativePoseEdge{} : *real[pick(*rng) % real.size()];
    e.from = a;
    e.to = b;
    e.is_loop_closure = true;
    for (int k = 0; k < 3; ++k) e.measured_from_T_to.t_m[k] = unit(*rng) * span[k];
    Eigen::Quaterniond q;
    q.coeffs() << gauss(*rng), gauss(*rng), gauss(*rng), gauss(*rng);
    e.measured_from_T_to.q = q.normalized();
    out.push_back(e);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parse(argc, argv, &opt)) {
    std::fprintf(
        stderr,
        "usage: %s [--data-dir DIR] [--graphs a,b,...] [--outliers 0.1,0.3,0.5] [--seed N] [--json OUT]\n"
        "          [--threshold-sigma C] [--gnc-inner N] [--gnc-mu-factor F] [--gnc-max-outer N] [--gnc-refine N]\n"
        "          [--solvers gnc_tls,pcm_gnc_tls,cauchy] [--pcm-threshold-sigma G] [--pcm-max-clique-nodes N]\n"
        "          [--diagnose 1] [--function-tolerance T] [--max-iterations N] [--noise-bound Q]\n"
        "          [--noise-margin M] [--gnc-chordal 1] [--chordal-weighting isotropic|anisotropic]\n"
        "          [--drop-indefinite-coupling 1] [--gnc-cluster-trials N] [--gnc-cluster-gap P]\n"
        "          [--gnc-cluster-min K] [--gnc-lone-trials L] [--gnc-trial-iterations I]\n"
        "          [--gnc-cluster-screen 0|1] [--chordal-timing 1] [--chordal-solver direct|iterative]\n"
        "  DIR holds NAME.g2o (default ../shared/data/pose_graphs); an outlier fraction f injects\n"
        "  f / (1 - f) x (the file's loop closures) wrong ones, so they are f of all closures.\n"
        "  The backend's pose-graph optimizer on the public g2o benchmarks: least-squares cost, iterations\n"
        "  and time from the file's guess (one thread), then with wrong loop closures injected: RMSE to the\n"
        "  outlier-free solution for GNC-TLS, pairwise consistency (PCM) then GNC-TLS, and Cauchy; wrong closures\n"
        "  kept and right ones dropped. --diagnose 1: the dropped closures' residuals, the TLS cost there and at the\n"
        "  outlier-free solution, the clean graph re-solved from there. --drop-indefinite-coupling 1: an edge\n"
        "  whose information is indefinite only through its translation-rotation coupling is read with the\n"
        "  coupling zeroed, and counted (cubicle), instead of refusing the file. --chordal-weighting: the\n"
        "  chordal estimates (the reference's second solve, GNC's with --gnc-chordal 1) by each edge's axes\n"
        "  (anisotropic, the default) or its mean precision. --gnc-cluster-trials N: after GNC, up to N trials\n"
        "  switching a run of dropped closures (ends within P poses, at least K dropped) back on, and up to L\n"
        "  lone kept closures a sweep off, each kept only if it lowers the TLS cost (pose_graph.h); each trial's\n"
        "  two solves up to I iterations (0: --max-iterations); with --gnc-cluster-screen 1 (the default) a run\n"
        "  is tried only when K of its dropped closures pass the pairwise test with each other (the gate of\n"
        "  --pcm-threshold-sigma). --chordal-timing 1: per outlier level, the time of one chordal estimate\n"
        "  with every closure weighted (GNC's first weighted solve); --solvers none skips the solvers.\n"
        "  --chordal-solver direct|iterative: GNC's chordal estimates by sparse LDLT or by conjugate gradients\n"
        "  (PoseGraphConfig's default; the outlier-free reference stays direct).\n"
        "  JSON: pgo_eval.<graph>.*; results in bench/results/pose_graph.md.\n",
        argv[0]);
    return 2;
  }
  char settings[256];
  if (opt.noise_bound_quantile > 0.0)
    std::snprintf(settings, sizeof settings,
                  "; function tolerance %g, up to %d iterations a solve; robust threshold %g x the %g-quantile of the "
                  "right closures' residuals at the outlier-free solution",
                  opt.function_tolerance, opt.max_iterations, opt.noise_margin, opt.noise_bound_quantile);
  else
    std::snprintf(settings, sizeof settings,
                  "; function tolerance %g, up to %d iterations a solve; robust threshold %g sigma of the stated noise",
                  opt.function_tolerance, opt.max_iterations, opt.robust.loop_closure_loss_scale_sigma);
  const char* const weighting =
      opt.robust.chordal_weighting == backend::ChordalWeighting::kIsotropic ? "isotropic" : "anisotropic";
  const std::string refine =
      "; GNC-TLS refine rounds " + std::to_string(opt.robust.gnc_tls_refine_rounds) +
      (opt.robust.gnc_cluster_trials > 0
           ? "; cluster trials up to " + std::to_string(opt.robust.gnc_cluster_trials) + " (gap " +
                 std::to_string(opt.robust.gnc_cluster_gap_poses) + " poses, at least " +
                 std::to_string(opt.robust.gnc_cluster_min_closures) + " dropped in a run, up to " +
                 std::to_string(opt.robust.gnc_cluster_lone_trials) + " lone closures a sweep, " +
                 (opt.robust.gnc_cluster_trial_iterations > 0 ? std::to_string(opt.robust.gnc_cluster_trial_iterations)
                                                              : std::to_string(opt.max_iterations)) +
                 " iterations a trial solve" +
                 (opt.robust.gnc_cluster_screen ? ", runs screened by pairwise consistency" : "") + ")"
           : "") +
      "; chordal estimates with " + weighting + " weights" +
      (opt.robust.gnc_chordal_solves ? "; GNC's weighted solves from the chordal estimate" : "") +
      (opt.robust.chordal_solver == backend::ChordalSolver::kIterative ? " (conjugate gradients)" : "") +
      "; GNC inner iterations " + std::to_string(opt.robust.gnc_inner_iterations) +
      (opt.robust.gnc_inner_iterations == 0 ? " (the chordal estimate alone)" : "");
  bench::Figures figures(
      "pgo_eval: g2o pose graphs from the file's initial guess, Ceres sparse normal Cholesky, 1 "
      "thread; wrong closures seed " +
      std::to_string(opt.seed) + settings + refine);
  int failures = 0;
  for (const std::string& name : opt.graphs) {
    backend::G2oPoseGraph g;
    std::string error;
    if (!backend::read_g2o_pose_graph(opt.data_dir + "/" + name + ".g2o", &g, &error, opt.read)) {
      std::fprintf(stderr, "%s\n", error.c_str());
      ++failures;
      continue;
    }
    if (g.couplings_dropped > 0) {
      std::printf("%-15s %zu edges read with their indefinite translation-rotation coupling zeroed\n", name.c_str(),
                  g.couplings_dropped);
      figures.add("pgo_eval." + name + ".couplings_dropped", static_cast<double>(g.couplings_dropped), "edges");
    }
    backend::PoseGraphConfig plain;
    plain.loop_closure_loss = backend::RobustLoss::kNone;
    plain.max_iterations = opt.max_iterations;
    plain.function_tolerance = opt.function_tolerance;
    std::vector<Pose3> reference = g.poses;
    auto t0 = std::chrono::steady_clock::now();
    const backend::PoseGraphResult from_guess = backend::optimize_pose_graph(plain, reference, g.edges);
    const double ref_s = seconds_since(t0);
    if (!from_guess.poses_updated()) {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), from_guess.message.c_str());
      ++failures;
      continue;
    }
    // The outlier-free solution is the lowest-cost one found: least squares from the file's guess (the odometry) can
    // settle in a local minimum (torus3D does), so the graph is solved from its chordal estimate too.
    std::vector<Pose3> from_chordal = g.poses;
    std::vector<bool> anchored(g.poses.size(), false);
    anchored[0] = true;
    t0 = std::chrono::steady_clock::now();
    backend::PoseGraphResult chordal_ref;
    if (backend::chordal_initialize(g.edges, std::vector<double>(g.edges.size(), 1.0), anchored, &from_chordal,
                                    opt.robust.chordal_weighting))
      chordal_ref = backend::optimize_pose_graph(plain, from_chordal, g.edges);
    else
      chordal_ref.message = "the chordal estimate failed";
    const double chordal_s = seconds_since(t0);
    const bool chordal_lower = chordal_ref.poses_updated() && chordal_ref.final_cost < from_guess.final_cost;
    const backend::PoseGraphResult& ref = chordal_lower ? chordal_ref : from_guess;
    if (chordal_lower) reference = from_chordal;
    const double radius = rms_radius_m(reference);
    const double dof = 6.0 * static_cast<double>(g.edges.size()) - 6.0 * static_cast<double>(g.poses.size() - 1);
    const double noise_scale = std::sqrt(2.0 * ref.final_cost / std::max(dof, 1.0));
    std::vector<double> right;  // the right closures' whitened residuals at the outlier-free solution, ascending
    for (std::size_t k = 0; k < g.edges.size(); ++k)
      if (g.edges[k].is_loop_closure) right.push_back(ref.edge_residual_sigma[k]);
    std::sort(right.begin(), right.end());
    const auto quantile = [&right](double q) {
      return right.empty() ? 0.0
                           : right[static_cast<std::size_t>(std::lround(q * static_cast<double>(right.size() - 1)))];
    };
    const double threshold = opt.noise_bound_quantile > 0.0 ? opt.noise_margin * quantile(opt.noise_bound_quantile)
                                                            : opt.robust.loop_closure_loss_scale_sigma;
    std::printf(
        "%-15s %5zu poses %6zu edges (%zu loop closures): least squares cost %.6g -> %.6g (chi2 %.6g) in %d "
        "iterations, %.2f s; trajectory RMS radius %.2f m\n",
        name.c_str(), g.poses.size(), g.edges.size(), g.num_loop_closures, from_guess.initial_cost,
        from_guess.final_cost, 2.0 * from_guess.final_cost, from_guess.iterations, ref_s, radius);
    std::printf("%-15s from the chordal estimate: %s; %.2f s with the estimate; the outlier-free solution is the %s\n",
                name.c_str(), chordal_ref.message.c_str(), chordal_s,
                chordal_lower ? "chordal one" : "one from the file's guess");
    std::printf(
        "%-15s real noise / stated: sqrt(chi2 / dof) %.4g (%.0f dof); right closures' residuals (stated sigma) "
        "median %.3g, 90 %% %.3g, 99 %% %.3g, largest %.3g; robust threshold %.4g\n",
        name.c_str(), noise_scale, dof, quantile(0.5), quantile(0.9), quantile(0.99), quantile(1.0), threshold);
    const std::string p = "pgo_eval." + name + ".";
    figures.add(p + "poses", static_cast<double>(g.poses.size()), "poses");
    figures.add(p + "loop_closures", static_cast<double>(g.num_loop_closures), "edges");
    figures.add(p + "initial_cost", from_guess.initial_cost, "half chi2");
    figures.add(p + "final_cost", from_guess.final_cost, "half chi2");
    figures.add(p + "iterations", from_guess.iterations, "iterations");
    figures.add(p + "solve_time", ref_s, "s");
    if (chordal_ref.poses_updated()) {
      figures.add(p + "chordal_init.final_cost", chordal_ref.final_cost, "half chi2");
      figures.add(p + "chordal_init.iterations", chordal_ref.iterations, "iterations");
      figures.add(p + "chordal_init.solve_time", chordal_s, "s (the chordal estimate and the solve)");
    }
    figures.add(p + "outlier_free_cost", ref.final_cost, "half chi2 (the lower of the two solves)");
    figures.add(p + "noise_scale", noise_scale, "sqrt(chi2 / dof) of the outlier-free solution, stated sigma");
    figures.add(p + "right_residual_p99", quantile(0.99), "stated sigma");
    figures.add(p + "right_residual_max", quantile(1.0), "stated sigma");
    figures.add(p + "robust_threshold", threshold, "stated sigma");
    for (const double f : opt.outliers) {
      const auto count = static_cast<std::size_t>(std::lround(f / (1.0 - f) * static_cast<double>(g.num_loop_closures)));
      std::mt19937 rng(opt.seed);
      std::vector<RelativePoseEdge> edges = g.edges;
      const std::vector<RelativePoseEdge> wrong = wrong_closures(g, count, &rng);
      edges.insert(edges.end(), wrong.begin(), wrong.end());
      if (opt.chordal_timing) {
        // GNC's first weighted solve with --gnc-chordal 1: the chordal estimate with every closure weighted.
        std::vector<Pose3> estimate = g.poses;
        t0 = std::chrono::steady_clock::now();
        backend::ChordalStats stats;
        const bool ok = backend::chordal_initialize(edges, std::vector<double>(edges.size(), 1.0), anchored, &estimate,
                                                    opt.robust.chordal_weighting, opt.robust.chordal_solver, &stats);
        const double chordal_all_s = seconds_since(t0);
        std::printf(
            "  %2.0f %% wrong (%zu): the chordal estimate with every closure weighted %s in %.2f s (%d linear "
            "systems, %d by conjugate gradients in %lld iterations, %d direct after they did not converge)\n",
            100.0 * f, count, ok ? "solved" : "failed", chordal_all_s, stats.systems, stats.iterative, stats.iterations,
            stats.direct_fallbacks);
        figures.add(p + "outliers_" + std::to_string(static_cast<int>(std::lround(100.0 * f))) +
                        ".chordal_all_weighted_time" +
                        (opt.robust.chordal_solver == backend::ChordalSolver::kIterative ? "_cg" : ""),
                    chordal_all_s, "s (one chordal estimate, every closure at weight 1)");
      }
      for (const std::string& solver : opt.solvers) {
        if (solver == "none") continue;
        backend::PoseGraphConfig config = opt.robust;
        config.loop_closure_loss = solver == "cauchy" ? backend::RobustLoss::kCauchy : backend::RobustLoss::kGncTls;
        config.prefilter_pairwise_consistency = solver == "pcm_gnc_tls";
        config.max_iterations = opt.max_iterations;
        config.function_tolerance = opt.function_tolerance;
        if (opt.noise_bound_quantile > 0.0) {
          config.pairwise_consistency.threshold_sigma *= threshold / config.loop_closure_loss_scale_sigma;
          config.loop_closure_loss_scale_sigma = threshold;
        }
        std::vector<Pose3> poses = g.poses;
        t0 = std::chrono::steady_clock::now();
        const backend::PoseGraphResult r = backend::optimize_pose_graph(config, poses, edges);
        const double s = seconds_since(t0);
        if (!r.poses_updated()) {
          std::printf("  %2.0f %% wrong, %-11s: %s\n", 100.0 * f, solver.c_str(), r.message.c_str());
          ++failures;
          continue;
        }
        const double e = rmse_m(poses, reference);
        if (opt.diagnose) {
          // Are the decisions or the basin to blame? The right closures dropped and the wrong ones nearest to
          // being kept (whitened residuals at the solution), then the outlier-free graph re-solved from here.
          std::printf("    residuals (sigma) right dropped:");
          for (std::size_t k = 0; k < g.edges.size(); ++k)
            if (g.edges[k].is_loop_closure && !r.edge_weight.empty() && r.edge_weight[k] == 0.0) std::printf(" %.1f", r.edge_residual_sigma[k]);
          std::vector<double> w;
          for (std::size_t k = g.edges.size(); k < edges.size(); ++k) w.push_back(r.edge_residual_sigma[k]);
          std::sort(w.begin(), w.end());
          std::printf("\n    wrong, 10 smallest:");
          for (std::size_t k = 0; k < w.size() && k < 10; ++k) std::printf(" %.1f", w[k]);
          std::printf("\n");
        }
        if (opt.diagnose) {
          // Is the truncated least-squares optimum itself off, or did GNC miss it? The TLS cost (half the sum of
          // squared whitened residuals, a closure's capped at the threshold) at this solution and at the
          // outlier-free solution, over every edge, wrong closures included.
          const double c2 = config.loop_closure_loss_scale_sigma * config.loop_closure_loss_scale_sigma;
          const auto tls_cost = [&](const std::vector<double>& residual) {
            double cost = 0.0;
            for (std::size_t k = 0; k < edges.size(); ++k)
              cost += 0.5 *
                      (edges[k].is_loop_closure ? std::min(residual[k] * residual[k], c2) : residual[k] * residual[k]);
            return cost;
          };
          backend::PoseGraphConfig hold = plain;
          hold.hold_first_poses = reference.size();  // every pose constant: residuals at the reference, no solve
          std::vector<Pose3> at_reference = reference;
          const backend::PoseGraphResult h = backend::optimize_pose_graph(hold, at_reference, edges);
          if (h.poses_updated())
            std::printf("    TLS cost (threshold %.3g): this solution %.6g, the outlier-free solution %.6g\n",
                        config.loop_closure_loss_scale_sigma, tls_cost(r.edge_residual_sigma),
                        tls_cost(h.edge_residual_sigma));
          else
            std::printf("    TLS cost at the outlier-free solution: %s\n", h.message.c_str());
        }
        if (opt.diagnose) {
          std::vector<Pose3> again = poses;
          const backend::PoseGraphResult c = backend::optimize_pose_graph(plain, again, g.edges);
          std::printf("    clean graph re-solved from this solution: cost %.6g (reference %.6g), %.4f m from the reference\n",
                      c.final_cost, ref.final_cost, rmse_m(again, reference));
        }
        std::size_t wrong_kept = 0, right_dropped = 0;
        for (std::size_t k = 0; k < edges.size(); ++k) {
          if (!edges[k].is_loop_closure) continue;
          const bool rejected = !r.pairwise.rejected.empty() && r.pairwise.rejected[k];
          const bool off = rejected || (r.edge_weight.empty()
                                            ? r.edge_residual_sigma[k] > config.loop_closure_loss_scale_sigma
                                            : r.edge_weight[k] == 0.0);
          if (k >= g.edges.size() && !off) ++wrong_kept;
          if (k < g.edges.size() && off) ++right_dropped;
        }
        std::printf(
            "  %2.0f %% wrong (%zu), %-11s: %.4f m from the outlier-free solution (%.3f %% of its radius); "
            "%zu wrong kept, %zu right dropped; %d iterations%s, %.2f s [%s]\n",
            100.0 * f, count, solver.c_str(), e, 100.0 * e / radius, wrong_kept, right_dropped, r.iterations,
            r.gnc_outer_iterations > 0
                ? (" (" + std::to_string(r.gnc_outer_iterations) + " GNC, " + std::to_string(r.gnc_refine_rounds) +
                   " TLS rounds, " + std::to_string(r.gnc_clusters_readmitted) + " runs on and " +
                   std::to_string(r.gnc_lone_dropped) + " lone off in " + std::to_string(r.gnc_cluster_trials) +
                   " trials, " + std::to_string(r.gnc_clusters_screened_out) + " screened out)" +
                   (r.chordal.systems > 0
                        ? "; chordal: " + std::to_string(r.chordal.systems) + " systems, " +
                              std::to_string(r.chordal.iterative) + " by CG, " + std::to_string(r.chordal.truncated) +
                              " truncated, " + std::to_string(r.chordal.direct_fallbacks) + " direct fallbacks, " +
                              std::to_string(r.chordal.iterations) + " CG iterations"
                        : ""))
                      .c_str()
                : "",
            s, r.message.c_str());
        const std::string q =
            p + "outliers_" + std::to_string(static_cast<int>(std::lround(100.0 * f))) + "." + solver +
            (opt.noise_bound_quantile > 0.0 ? "_noise_bound" : "") +
            (opt.noise_bound_quantile > 0.0 && opt.noise_margin != 1.0
                 ? "_" + std::to_string(std::lround(100.0 * opt.noise_margin)) + "pct"
                 : "") +
            (opt.robust.chordal_solver == backend::ChordalSolver::kIterative ? "_cg" : "") +
            (opt.robust.gnc_chordal_solves ? (opt.robust.gnc_inner_iterations == 0 ? "_chordal_only" : "_chordal")
                                           : "") +
            (opt.robust.gnc_chordal_solves && opt.robust.chordal_weighting == backend::ChordalWeighting::kIsotropic
                 ? "_isotropic"
                 : "") +
            (opt.robust.gnc_cluster_trials > 0 ? (opt.robust.gnc_cluster_screen ? "_clusters_screened" : "_clusters")
                                               : "") +
            (opt.robust.gnc_tls_refine_rounds > 0 ? "_tls_refined." : ".");
        figures.add(q + "rmse_to_outlier_free", e, "m");
        figures.add(q + "rmse_to_outlier_free_share", e / radius, "fraction of the RMS radius");
        figures.add(q + "wrong_kept", static_cast<double>(wrong_kept), "edges");
        figures.add(q + "right_dropped", static_cast<double>(right_dropped), "edges");
        figures.add(q + "solve_time", s, "s");
        if (config.gnc_cluster_trials > 0) {
          figures.add(q + "cluster_trials", r.gnc_cluster_trials, "trials");
          figures.add(q + "clusters_readmitted", r.gnc_clusters_readmitted, "runs switched on");
          figures.add(q + "lone_dropped", r.gnc_lone_dropped, "lone closures switched off");
          figures.add(q + "clusters_screened_out", r.gnc_clusters_screened_out, "trials skipped");
        }
        if (r.chordal.systems > 0) {
          figures.add(q + "chordal_systems", r.chordal.systems, "linear systems");
          figures.add(q + "chordal_cg_converged", r.chordal.iterative, "systems");
          figures.add(q + "chordal_cg_truncated", r.chordal.truncated, "Gauss-Newton steps");
          figures.add(q + "chordal_direct_fallbacks", r.chordal.direct_fallbacks, "systems");
          figures.add(q + "chordal_cg_iterations", static_cast<double>(r.chordal.iterations), "iterations");
        }
        if (config.prefilter_pairwise_consistency) {
          std::printf("    ");
          r.pairwise.print(stdout);
          figures.add(q + "pcm_kept", r.pairwise.kept, "edges");
          figures.add(q + "pcm_clique_truncated", r.pairwise.clique_truncated ? 1.0 : 0.0, "flag");
        }
        // Written after every solve: a run of the large graphs takes hours, and one stopped keeps what it measured.
        if (!opt.json_path.empty() && !figures.write(opt.json_path)) return 1;
      }
    }
  }
  if (!opt.json_path.empty() && !figures.write(opt.json_path)) return 1;
  return failures == 0 ? 0 : 1;
}
