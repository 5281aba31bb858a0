// The app's wiring of the persistent scene graph (the algorithms are core/backend/backend_stage.h): keyframes of
// agents captured by the loop thread into preallocated slots and handed to the backend thread, loop-closure
// detection and the deformation solve scheduled on the backend thread (the solve without the graph's lock), the
// correction of the outputs when the run finishes, and the closures scored against the truth where it is known.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "budgets/budget_table.h"
#include "core/backend/deformation_io.h"
#include "firmware_app/pipeline.h"
#include "firmware_app/runtime/clock.h"
#include "firmware_app/runtime/stage_marker.h"

namespace qsg::app {

bool Pipeline::init_loop_closure(std::string* error) {
  if (config_.loop_closure.enabled && odometry_.kind() == OdometrySourceKind::kGroundTruth) {
    std::printf("loop closure: off for this run (ground-truth poses need no correction)\n");
    config_.loop_closure.enabled = false;
  }
  if (!config_.loop_closure.enabled) return true;
  const auto slots = static_cast<std::uint32_t>(budgets::active::loop_closure::kAppearanceFrames);
  lc_frames_.resize(slots);
  for (AgentFrame& f : lc_frames_) {
    f.grey.assign(messages::kMaxFramePixels, 0);
    f.depth_m.assign(messages::kMaxFramePixels, 0.0f);
  }
  if (!lc_free_frames_.init(slots, budgets::DropPolicy::kDropNewest, nullptr, error) ||
      !lc_ready_frames_.init(slots, budgets::DropPolicy::kDropNewest, nullptr, error))
    return false;
  for (std::uint32_t i = 0; i < slots; ++i) lc_free_frames_.push(static_cast<int>(i));
  // --stage-markers: each agent's detection and verification is a marked run (no hook otherwise).
  if (runtime::stage_markers_on())
    backend_.set_detect_hook(
        [](void*, bool begin, std::uint64_t agent_time_ns) {
          if (begin) runtime::stage_begin(runtime::kLoopClosureDetectStage, agent_time_ns);
          else runtime::stage_end(runtime::kLoopClosureDetectStage, agent_time_ns);
        },
        nullptr);
  return true;
}

// Backend thread, after a solve: Ceres builds each problem on the heap and frees it; glibc keeps the freed pages of
// the thread's malloc arena resident, so a mission whose problems grow would grow its resident set with them. The
// pages go back to the system here, and the resident set holds what is live.
namespace {
void release_solver_heap() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}
}  // namespace

// Loop thread: the keyframe of a new agent node, when it is describe_every_m from the last captured one, goes to
// the backend for its appearance. Copies into a preallocated slot; none free, it is dropped and counted.
void Pipeline::capture_agent_frame(const messages::RgbdFrame& frame, scene_graph::NodeId agent, std::uint64_t time_ns) {
  if (!config_.loop_closure.enabled) return;
  const agents::AgentLayer& agents = frontend_.agents();
  if (agents.chain_size() == 0) return;
  // Spaced by the odometry's path: a change of the frontend's frame (map_in_corrected_frame) is not motion.
  const Eigen::Vector3d p = agents::odometric_pose(agents.chain(agents.chain_size() - 1)).translation();
  if (lc_have_captured_ && (p - lc_captured_m_).norm() < config_.loop_closure.describe_every_m) return;
  int slot = -1;
  if (!lc_free_frames_.try_pop(&slot)) {
    ++lc_frames_dropped_;
    return;
  }
  lc_captured_m_ = p;
  lc_have_captured_ = true;
  AgentFrame& f = lc_frames_[static_cast<std::size_t>(slot)];
  f.agent = agent;
  f.time_ns = time_ns;
  f.intrinsics = frame.intrinsics;
  const int n = frame.pixels();
  for (int i = 0; i < n; ++i) {
    const std::uint8_t* c = &frame.rgb[static_cast<std::size_t>(3 * i)];
    f.grey[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>((77 * c[0] + 150 * c[1] + 29 * c[2]) >> 8);
    f.depth_m[static_cast<std::size_t>(i)] = frame.depth_m[static_cast<std::size_t>(i)];
  }
  lc_ready_frames_.push(int{slot});
}

// Backend thread: the captured keyframes' appearance into the stage, their slots back to the loop.
void Pipeline::extract_captured_frames() {
  int slot = -1;
  while (lc_ready_frames_.try_pop(&slot)) {
    const AgentFrame& f = lc_frames_[static_cast<std::size_t>(slot)];
    loop_closure::GreyDepthView v;
    v.grey = f.grey.data();
    v.depth_m = f.depth_m.data();
    v.width = f.intrinsics.width;
    v.height = f.intrinsics.height;
    v.fx = f.intrinsics.fx;
    v.fy = f.intrinsics.fy;
    v.cx = f.intrinsics.cx;
    v.cy = f.intrinsics.cy;
    runtime::stage_begin(runtime::kLoopClosureAppearanceStage, f.time_ns);
    backend_.add_appearance(f.agent, f.time_ns, v);
    runtime::stage_end(runtime::kLoopClosureAppearanceStage, f.time_ns);
    lc_free_frames_.push(int{slot});
  }
}

// Loop closure's costs on the backend thread (pipeline.h).
runtime::TaskStats Pipeline::loop_closure_detect_cpu_stats() const {
  std::lock_guard<std::mutex> lock(backend_stats_mutex_);
  return lc_detect_cpu_;
}

runtime::TaskStats Pipeline::loop_closure_lock_cpu_stats() const {
  std::lock_guard<std::mutex> lock(backend_stats_mutex_);
  return lc_lock_cpu_;
}

runtime::TaskStats Pipeline::solve_cpu_stats() const {
  std::lock_guard<std::mutex> lock(backend_stats_mutex_);
  return solve_cpu_;
}

// Backend thread, graph_mutex_ held by *graph_lock: new loop closures, and the deformation graph re-solved when one
// waits and solve_interval_s has passed. Under the lock only what reads the loop thread's state: the agents left
// behind are described (their keyframes' appearance was extracted before the lock, run_backend_update) and, when a
// solve may follow, the chain, control points and places copied; the lookup,
// verification, build and solve run without it (the loop keeps mapping meanwhile). Detection is timed as part of
// the update; the solve as a run of its own (left out of the update's time).
void Pipeline::run_loop_closure(std::uint64_t time_ns, pipeline::Host::Held* graph_lock) {
  if (!backend_.loop_closure_enabled()) return;
  const runtime::ThreadCpuClock cpu_clock;
  const runtime::WallClock wall_clock;
  const std::int64_t describe0_ns = cpu_clock.now_ns();
  const std::size_t described = backend_.describe_agents(graph_, frontend_.agents(), time_ns);
  const std::int64_t describe_us = (cpu_clock.now_ns() - describe0_ns) / 1000;
  SolveRecord r;
  const bool may_solve = backend_.solve_may_follow(time_ns, described > 0);
  if (may_solve) {
    const std::int64_t copy0_ns = cpu_clock.now_ns(), copy0_wall_ns = wall_clock.now_ns();
    backend_.copy_deformation_inputs(frontend_.agents(), graph_);
    r.lock_cpu_us = (cpu_clock.now_ns() - copy0_ns) / 1000;
    r.lock_wall_us = (wall_clock.now_ns() - copy0_wall_ns) / 1000;
  }
  graph_lock->release();
  if (described > 0 || may_solve) {  // what the loop thread could have waited for
    std::lock_guard<std::mutex> lock(backend_stats_mutex_);
    lc_lock_cpu_.record(describe_us + r.lock_cpu_us, 0);
  }
  if (described > 0) {
    const std::int64_t detect0_ns = cpu_clock.now_ns();
    backend_.detect_described();
    std::lock_guard<std::mutex> lock(backend_stats_mutex_);
    lc_detect_cpu_.record(describe_us + (cpu_clock.now_ns() - detect0_ns) / 1000, 0);
  }
  if (!backend_.solve_due(time_ns)) return;
  runtime::stage_begin(runtime::kLoopClosureSolveStage, time_ns);  // the graph built and solved
  r.time_s = static_cast<double>(time_ns) * 1e-9;
  r.path_m = backend_.described_path_m();
  std::lock_guard<std::mutex> solving(deformation_mutex_);  // a snapshot reads the solution meanwhile: it waits
  std::int64_t cpu0_ns = cpu_clock.now_ns(), wall0_ns = wall_clock.now_ns();
  backend::DeformationProblem problem = build_deformation();
  r.build_cpu_us = (cpu_clock.now_ns() - cpu0_ns) / 1000;
  r.build_wall_us = (wall_clock.now_ns() - wall0_ns) / 1000;
  r.agents = static_cast<std::uint32_t>(problem.result.agents);
  r.control_points = static_cast<std::uint32_t>(problem.result.control_points);
  r.places = static_cast<std::uint32_t>(problem.result.places);
  r.closures = static_cast<std::uint32_t>(problem.result.loop_closures);
  cpu0_ns = cpu_clock.now_ns();
  wall0_ns = wall_clock.now_ns();
  std::string why;
  r.ok = backend_.solve_deformation(std::move(problem), &why);
  release_solver_heap();
  runtime::stage_end(runtime::kLoopClosureSolveStage, time_ns);
  if (runtime::stage_markers_on())  // the graph's size beside each marked solve (bench/arm/insn_counts.py)
    std::printf("loop_closure_solve %llu agents=%u control_points=%u places=%u loop_closures=%u\n",
                static_cast<unsigned long long>(time_ns), r.agents, r.control_points, r.places, r.closures);
  if (!r.ok) std::fprintf(stderr, "loop closure: optimization failed (kept the previous solution): %s\n", why.c_str());
  r.cpu_us = (cpu_clock.now_ns() - cpu0_ns) / 1000;
  r.wall_us = (wall_clock.now_ns() - wall0_ns) / 1000;
  r.closures_kept = static_cast<std::uint32_t>(backend_.counters().loop_closures_kept.load());
  if (r.ok) {
    const backend::DeformationResult& d = backend_.deformation_result();
    r.agents = static_cast<std::uint32_t>(d.agents_solved);
    r.map_settled = static_cast<std::uint32_t>(d.map_settled);
    r.closures_carried = static_cast<std::uint32_t>(d.closures_carried);
    r.decided_again = d.decided_again;
  }
  if (r.ok && config_.loop_closure.map_in_corrected_frame) {
    // The keyframes from now on are mapped where this solution puts the odometry frame.
    const Eigen::Isometry3d map_T_odom = backend_.map_T_odom();
    std::lock_guard<std::mutex> lock(frame_mutex_);
    map_T_odom_ = map_T_odom;
    ++frame_corrections_;
  }
  solve_cpu_in_update_us_ += r.cpu_us;
  solve_wall_in_update_us_ += r.wall_us;
  if (static_cast<std::uint64_t>(r.wall_us) > graph_optimization_max_us_.load())
    graph_optimization_max_us_.store(static_cast<std::uint64_t>(r.wall_us));
  std::printf("loop closure: solve at %.0f s, %.1f m of path: %u agents, %u control points, %u places, %u closures "
              "(%u kept): %.1f ms CPU (budget %.0f ms); %u control points held, %u decisions carried%s; inputs "
              "copied in %.2f ms CPU under the graph lock, built in %.1f ms CPU\n",
              r.time_s, r.path_m, r.agents, r.control_points, r.places, r.closures, r.closures_kept,
              static_cast<double>(r.cpu_us) / 1000.0, solve_budget_us_ / 1000.0, r.map_settled, r.closures_carried,
              r.decided_again ? " (all decided again)" : "", static_cast<double>(r.lock_cpu_us) / 1000.0,
              static_cast<double>(r.build_cpu_us) / 1000.0);
  std::lock_guard<std::mutex> lock(backend_stats_mutex_);
  solve_cpu_.record(r.cpu_us, solve_budget_us_);
  solve_records_[static_cast<std::size_t>(solves_recorded_ % solve_records_.size())] = r;
  ++solves_recorded_;
}

// The stage's deformation problem from its last copy of the chain and the places (copy_deformation_inputs, under
// graph_mutex_); QSG_DUMP_DEFORMATION=FILE also writes it (with each agent's true camera position where known) for
// bench/loop_closure/dg_solve to reproduce the solve offline.
backend::DeformationProblem Pipeline::build_deformation() {
  const agents::ChainView agents = backend_.deformation_inputs().chain_view();
  backend::DeformationProblem problem = backend_.build_deformation();
  if (const char* path = std::getenv("QSG_DUMP_DEFORMATION"); path != nullptr && *path != '\0') {
    std::vector<Eigen::Vector3d> truth;
    std::vector<Eigen::Quaterniond> truth_q;
    const Eigen::Isometry3d mount =
        sim_camera_ != nullptr ? sim_camera_->body_T_camera() : Eigen::Isometry3d::Identity();
    for (std::size_t k = 0; k < problem.result.agents && !ground_truth_.empty(); ++k) {
      replay::StampedPose g;
      if (!replay::interpolate_pose(ground_truth_, static_cast<std::int64_t>(agents.chain(k).time_ns), INT64_MAX, &g)) {
        truth.clear();
        truth_q.clear();
        break;
      }
      const Eigen::Isometry3d world_T_camera = g.world_T_body() * mount;
      truth.push_back(world_T_camera.translation());
      truth_q.push_back(Eigen::Quaterniond(world_T_camera.linear()));
    }
    // A path with "%d" keeps every solve's problem (numbered from 0); without, the last one.
    std::string file = path;
    if (const std::size_t at = file.find("%d"); at != std::string::npos)
      file.replace(at, 2, std::to_string(deformations_dumped_++));
    std::string error;
    if (!backend::write_deformation_problem(file, problem, truth, &error, truth_q))
      std::fprintf(stderr, "loop closure: QSG_DUMP_DEFORMATION: %s\n", error.c_str());
  }
  return problem;
}

// The mission's last solve, at the finish (not a backend-thread run: its CPU is printed, not in the solve budget).
bool Pipeline::optimize_graph() {
  const auto start = std::chrono::steady_clock::now();
  const runtime::ThreadCpuClock cpu_clock;
  const std::int64_t cpu0_ns = cpu_clock.now_ns();
  std::string why;
  backend_.copy_deformation_inputs(frontend_.agents(), graph_);
  const bool ok = backend_.solve_deformation(build_deformation(), &why);
  if (!ok) std::fprintf(stderr, "loop closure: optimization failed (kept the previous solution): %s\n", why.c_str());
  const auto us = static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - start).count());
  if (us > graph_optimization_max_us_.load()) graph_optimization_max_us_.store(us);
  if (ok) {
    const backend::DeformationResult& d = backend_.deformation_result();
    std::printf("loop closure: final solve: %zu agents, %zu control points, %zu places, %zu closures (%zu kept): "
                "%.1f ms CPU; %zu control points held, %zu decisions carried%s\n",
                d.agents_solved, d.control_points, d.places, d.loop_closures, d.loop_closures_kept,
                static_cast<double>(cpu_clock.now_ns() - cpu0_ns) / 1e6, d.map_settled, d.closures_carried,
                d.decided_again ? " (all decided again)" : "");
  }
  return ok;
}

void Pipeline::correct_outputs(reconstruction::Mesh* mesh, reconstruction::Mesh* odometric) {
  const backend::BackendStage::Counters& b = backend_.counters();
  counters_.agents_described = b.agents_described.load();
  if (backend_.loop_closure_enabled() && !backend_.loop_closures().empty() && !optimize_graph())
    std::fprintf(stderr, "loop closure: the final optimization failed; outputs keep the last solution\n");
  counters_.loop_closures = b.loop_closures.load();
  counters_.loop_closures_kept = b.loop_closures_kept.load();
  counters_.loop_closure_folds = b.loop_closure_folds.load();
  counters_.loop_closures_folded = b.loop_closures_folded.load();
  counters_.loop_closures_by_appearance = b.loop_closures_by_appearance.load();
  counters_.agent_frames_dropped = lc_frames_dropped_ + b.appearances_dropped.load();
  counters_.graph_optimizations = b.graph_optimizations.load();
  counters_.graph_optimization_failures = b.graph_optimization_failures.load();
  counters_.graph_optimization_max_us = graph_optimization_max_us_.load();
  if (!backend_.loop_closure_enabled()) return;
  backend_.detector().counters().print(stdout);
  std::printf("loop closure: %zu control points (%llu refused, %llu folded in %llu folds), %zu loop closures in the "
              "graph\n",
              backend_.control_points().size(),
              static_cast<unsigned long long>(backend_.control_points().stats().failed),
              static_cast<unsigned long long>(backend_.control_points().folded()),
              static_cast<unsigned long long>(backend_.control_points().folds()), backend_.loop_closures().size());
  if (config_.loop_closure.map_in_corrected_frame) {
    std::lock_guard<std::mutex> lock(frame_mutex_);
    std::printf(
        "loop closure: the frontend mapped in the corrected frame, %llu corrections followed (the last: "
        "%.3f m, %.2f degrees from the odometry)\n",
        static_cast<unsigned long long>(frame_corrections_), map_T_odom_.translation().norm(),
        Eigen::AngleAxisd(map_T_odom_.linear()).angle() * 180.0 / M_PI);
  }
  // A copy under the graph lock that found a buffer short allocated there: its reservation missed a store.
  const backend::DeformationInputs& in = backend_.deformation_inputs();
  std::printf("loop closure: %llu solve inputs copied under the graph lock, %llu of them grew a buffer%s\n",
              static_cast<unsigned long long>(in.copies), static_cast<unsigned long long>(in.grown),
              in.grown > 0 ? " (allocated under the lock)" : "");
  score_loop_closures();
  if (!backend_.solved()) return;
  backend_.deformation_result().print(stdout);
  // Agents and places to their optimized poses; objects, rooms and the building moved with the deformation around
  // them; the mesh too. The mesh as mapped is kept for the objects' vertex keys, which name positions there.
  backend_.correct_graph(frontend_.agents(), &graph_);
  *odometric = *mesh;
  backend_.correct_mesh(mesh);
  for (Eigen::Vector3d& p : trajectory_m_) p = backend_.deform(p);
}

// Where the truth is known (sim, replay with poses): each loop closure's relative pose against the true one.
void Pipeline::score_loop_closures() {
  const std::vector<loop_closure::LoopClosure>& closures = backend_.loop_closures();
  if (ground_truth_.empty() || closures.empty()) return;
  const std::vector<double>& weight = backend_.deformation_result().loop_closure_weight;
  const Eigen::Isometry3d mount = sim_camera_ != nullptr ? sim_camera_->body_T_camera() : Eigen::Isometry3d::Identity();
  std::size_t scored = 0, within = 0, kept_within = 0, wrong = 0, wrong_kept = 0;
  std::vector<double> errors_m;
  for (std::size_t i = 0; i < closures.size(); ++i) {
    const loop_closure::LoopClosure& lc = closures[i];
    replay::StampedPose a, b;
    if (!replay::interpolate_pose(ground_truth_, static_cast<std::int64_t>(lc.match_time_ns), INT64_MAX, &a) ||
        !replay::interpolate_pose(ground_truth_, static_cast<std::int64_t>(lc.query_time_ns), INT64_MAX, &b))
      continue;
    const Eigen::Isometry3d truth = (a.world_T_body() * mount).inverse() * (b.world_T_body() * mount);
    const Eigen::Isometry3d error = truth.inverse() * lc.match_T_query;
    const double e_m = error.translation().norm();
    const double e_rad = Eigen::AngleAxisd(error.linear()).angle();
    ++scored;
    errors_m.push_back(e_m);
    const bool good = e_m <= 0.10 && e_rad <= M_PI / 180.0;
    within += good ? 1 : 0;
    const bool kept = i < weight.size() && weight[i] > 0.5;
    kept_within += good && kept ? 1 : 0;
    const bool false_closure = e_m > 0.5 || e_rad > 5.0 * M_PI / 180.0;
    wrong += false_closure ? 1 : 0;
    wrong_kept += false_closure && kept ? 1 : 0;
    // The rotation error about the world's vertical (yaw) and about a horizontal axis (tilt).
    const Eigen::AngleAxisd e_aa(error.linear());
    const Eigen::Vector3d e_world = (a.world_T_body() * mount).linear() * (e_aa.axis() * e_aa.angle());
    if (std::getenv("QSG_DEBUG_LOOP_CLOSURES") != nullptr)
      std::printf(
          "  closure %zu (%s%s%s, icp overlap %.2f rmse %.3f m constraint %.2f): %.1f s -> %.1f s, error %.3f m "
          "%.2f deg (yaw %.2f, tilt %.2f), %u inliers, kept %d\n",
          i, loop_closure::to_string(lc.source), lc.refined ? "+icp" : "", lc.local_map ? " on local maps" : "",
          lc.icp.overlap, lc.icp.rmse_m, lc.icp.constraint_ratio, lc.match_time_ns * 1e-9, lc.query_time_ns * 1e-9, e_m,
          e_rad * 180.0 / M_PI, std::abs(e_world.z()) * 180.0 / M_PI, e_world.head<2>().norm() * 180.0 / M_PI,
          lc.source == loop_closure::ClosureSource::kAppearance ? lc.appearance.inliers : lc.registration.inliers,
          kept ? 1 : 0);
  }
  if (scored == 0) return;
  std::sort(errors_m.begin(), errors_m.end());
  std::printf("loop closure: %zu of %zu proposed within 10 cm / 1 deg of the truth (%zu of them kept); median "
              "translation error %.3f m; %zu false (over 0.5 m or 5 deg off), %zu of them kept\n",
              within, scored, kept_within, errors_m[errors_m.size() / 2], wrong, wrong_kept);
  counters_.loop_closures_true = within;
  counters_.loop_closures_false = wrong;
  counters_.loop_closures_false_kept = wrong_kept;
}

}  // namespace qsg::app
