// The pipeline's finish (Pipeline::finish): the last loop closures and the final correction, the objects' visits
// merged, the backend's final stage, and the outputs written (graph, mesh, trajectories, picture).
#include "firmware_app/pipeline.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <unistd.h>

#include <cmath>
#include <algorithm>
#include <cstring>

#include "core/backend/agent_pose_graph.h"
#include "core/metrics/trajectory_error.h"
#include "core/objects/revisit_merge.h"
#include "core/reconstruction/mesh_cleanup.h"
#include "core/reconstruction/ply_writer.h"
#include "core/scene_graph/spark_dsg_json.h"
#include "firmware_app/graph_outputs.h"
#include "firmware_app/graph_picture.h"

namespace qsg::app {

// What the doors on the final surface did (AppConfig::doors_at_finish): they close the place edges through them. A
// failure is logged and counted; the rooms then stay as the run found them.
void Pipeline::report_final_doors(const backend::BackendStage::FinalDoors& d) {
  if (!d.ok) {
    ++counters_.door_failures;
    std::fprintf(stderr, "doors: %s; the rooms stay as the run found them\n", d.error.c_str());
    return;
  }
  counters_.doors = d.doors;
  counters_.doors_bypassed = d.bypassed;
  counters_.door_edges_closed = d.edges_closed;
  counters_.edges_through_walls = d.edges_through_walls;
  std::printf("doors: %zu in %zu storey slice(s) of the final surface (%zu more dropped: the places go round them; "
              "%zu kept unchecked), %llu place edges closed, %llu more through walls\n",
              d.doors, d.slices, d.bypassed, d.bypass_unchecked, static_cast<unsigned long long>(d.edges_closed),
              static_cast<unsigned long long>(d.edges_through_walls));
}

// The backend stage's totals into the run's counters (loop thread; the stage's counters are atomics).
void Pipeline::copy_backend_counters() {
  const backend::BackendStage::Counters& b = backend_.counters();
  counters_.backend_updates = b.updates.load();
  counters_.rooms = b.rooms.load();
  counters_.rooms_labelled = b.rooms_labelled.load();
  counters_.rooms_merged_visible = b.rooms_merged_visible.load();
  counters_.door_passes = b.door_passes.load();
  counters_.door_passes_climbing = b.door_passes_climbing.load();
  counters_.online_doors = b.online_doors.load();
  counters_.online_doors_kept_missed = b.online_doors_kept_missed.load();
  counters_.online_doors_dropped = b.online_doors_dropped.load();
  counters_.online_doors_bypassed = b.online_doors_bypassed.load();
  counters_.online_bypass_refused = b.online_bypass_refused.load();
  counters_.door_pass_max_us = b.door_pass_max_us.load();
}

bool Pipeline::finish(std::string* error) {
  // The backend finishes its last update first (a final one covers what the last keyframes changed).
  backend_stop_.store(true);
  backend_queue_.close();
  if (backend_thread_.joinable()) backend_thread_.join();
  // The frame segmentation was working on is finished and its votes cast, like every labelled frame's.
  segmentation_.stop();
  segmentation_.run_pending();
  if (segmentation_.initialized()) {
    cast_label_votes();
    tsdf_.update_mesh();
    const SegmentationWorkerCounters sc = segmentation_.counters();
    counters_.keyframes_unlabelled = sc.offered - std::min(sc.offered, counters_.keyframes_segmented);
  }
  telemetry_.stop();  // every queued line is out before the final report
  reconstruction::Mesh mesh;
  tsdf_.extract_full_mesh(&mesh);
  reconstruction::clean_mesh(&mesh).print(stdout);
  // The persistent scene graph: the last loop closures, then the final solve and every layer corrected. With
  // loop_closure.reconcile the layers are corrected and reconciled first, and the final doors, rooms and labels are
  // found on the corrected map (with loop_closure.rooms_after_correction alone, corrected but not reconciled);
  // without either (the default: bench/results/loop_closure.md) they are found on the map as mapped and moved with
  // it.
  reconstruction::Mesh odometric;  // the mesh as mapped, when a correction moves the written one
  scene_graph::ObjectMeshIndices indices;
  const bool reconcile = backend_.loop_closure_enabled() && config_.loop_closure.reconcile;
  // The final stage runs on the corrected map (reconcile, or loop_closure.rooms_after_correction alone).
  const bool correct_first = backend_.loop_closure_enabled() &&
                             (config_.loop_closure.reconcile || config_.loop_closure.rooms_after_correction);
  // The visits the object layer kept apart (objects.archive_after_s), joined in the map as corrected (as mapped,
  // without loop closure). Until then the live graph holds a revisited object once per visit.
  const auto merge_revisited_objects = [&](scene_graph::ObjectMeshIndices* object_indices) {
    const objects::Lifetimes lives = objects::lifetimes(frontend_.objects());
    const objects::RevisitMerge m = objects::merge_revisits(config_.frontend.objects, &graph_, object_indices, &lives);
    counters_.objects_merged_at_finish = m.merged;
    counters_.objects_held_at_once_kept_apart = m.concurrent_refused;
    m.print(stdout);
  };
  const auto match_object_keys = [&] {
    std::size_t unmatched = 0;
    indices = object_mesh_indices(frontend_.objects(), tsdf_, odometric.vertices.empty() ? mesh : odometric, &unmatched);
    if (unmatched != 0) std::printf("objects: %zu kept mesh-vertex keys have no vertex in the written mesh\n", unmatched);
  };
  {
    std::unique_lock<std::mutex> lock(graph_mutex_);
    if (backend_.loop_closure_enabled()) {
      extract_captured_frames();
      backend_.detect_at_finish(graph_, frontend_.agents(), latest_keyframe_ns_);  // the last horizon_s too
    }
    if (correct_first) {
      correct_outputs(&mesh, &odometric);
      match_object_keys();
      if (reconcile && backend_.solved()) {
        const backend::BackendStage::Reconciliation r = backend_.reconcile(mesh, indices, &graph_);
        counters_.places_merged_after_correction = r.places_merged;
        std::printf(
            "reconciliation: %zu objects re-boxed from the corrected mesh; %zu places merged (%zu edges "
            "refused)\n",
            r.objects_from_mesh, r.places_merged, r.edges_refused);
      }
      merge_revisited_objects(&indices);
    }
  }
  // The backend's final stage (doors on the whole surface, rooms and labels once more), timed against its budget.
  const pipeline::FinalResult final_stage =
      pipeline::final_stage(stages(), host_, config_.doors_at_finish ? &mesh : nullptr, latest_keyframe_ns_);
  if (config_.doors_at_finish) report_final_doors(final_stage.doors);
  {
    std::lock_guard<std::mutex> lock(graph_mutex_);
    if (!correct_first) {
      correct_outputs(&mesh, &odometric);
      match_object_keys();
      merge_revisited_objects(&indices);
    }
  }
  copy_backend_counters();
  std::lock_guard<std::mutex> lock(graph_mutex_);
  const std::string dir = config_.output_dir;
  // Every output is attempted whatever became of the others (the picture last: it is the least of them); each
  // replaces its file atomically, so a failure or a kill leaves the previous file or none, never half of one.
  std::string failures;
  const auto attempt = [&](bool ok, const std::string& why) {
    if (!ok) failures += (failures.empty() ? "" : "; ") + why;
  };
  std::string why;
  bool viewer = false;  // scene_graph.json and, where three.js is installed, scene_graph.html
  write_final_graph(graph_, indices, mesh, dir, &failures, &viewer);
  const std::string mesh_path = dir + "/mesh.ply", mesh_tmp = temporary_path_for(mesh_path);
  why.clear();
  const bool mesh_ok = reconstruction::write_ply(mesh_tmp, mesh, &why) && commit_file_atomically(mesh_tmp, mesh_path, &why);
  if (!mesh_ok) ::unlink(mesh_tmp.c_str());
  attempt(mesh_ok, why);
  why.clear();
  attempt(finish_trajectory(&why), why);
  why.clear();
  attempt(write_graph_picture(graph_, world_, trajectory_m_, dir + "/top_down.png", &why), why);
  if (!failures.empty()) {
    *error = failures;
    return false;
  }
  std::printf("outputs: %s/scene_graph.json (%zu nodes), %s/mesh.ply (%zu vertices, %zu triangles), %s/top_down.png, "
              "%s%s/trajectory_estimate.txt%s\n",
              dir.c_str(), graph_.num_nodes(), dir.c_str(), mesh.vertices.size(), mesh.triangles.size(), dir.c_str(),
              viewer ? (dir + "/scene_graph.html, ").c_str() : "", dir.c_str(),
              ground_truth_.empty() ? "" : " and trajectory_ground_truth.txt");
  return true;
}

// The agents' pose chain: its pose graph solved (no loop closures yet: a consistency check of the odometry edges),
// written as a TUM trajectory, and, where the truth is known (sim, replay with poses), scored against it.
bool Pipeline::finish_trajectory(std::string* error) {
  const agents::AgentLayer& agents = frontend_.agents();
  std::vector<backend::Pose3> optimized;
  pose_graph_ = backend::optimize_agent_chain(agents, {}, backend::AgentGraphConfig{}, &optimized);
  pose_graph_.print(stdout);
  replay::Trajectory estimate, odometric, truth;
  std::vector<metrics::TimedPose> est, odo, ref;
  const Eigen::Isometry3d mount = sim_camera_ != nullptr ? sim_camera_->body_T_camera() : Eigen::Isometry3d::Identity();
  for (std::size_t k = 0; k < agents.chain_size(); ++k) {
    const agents::ChainNode& n = agents.chain(k);
    const auto t_ns = static_cast<std::int64_t>(n.time_ns);
    const Eigen::Isometry3d corrected = backend_.corrected_pose(agents, k);  // odometric without loop closures
    estimate.push_back(replay::StampedPose::from_isometry(t_ns, corrected));
    // As the odometry gave it (loop_closure.map_in_corrected_frame maps it moved by a correction).
    const Eigen::Isometry3d odom = agents::odometric_pose(n);
    const Eigen::Quaterniond odom_q = n.frame_is_identity() ? n.q : Eigen::Quaterniond(odom.linear());
    replay::StampedPose p;
    p.time_ns = t_ns;
    p.world_t_body_m = odom.translation();
    p.world_R_body = odom_q;
    odometric.push_back(p);
    replay::StampedPose g;
    if (ground_truth_.empty() || !replay::interpolate_pose(ground_truth_, t_ns, INT64_MAX, &g)) continue;
    const Eigen::Isometry3d world_T_camera = g.world_T_body() * mount;
    truth.push_back(replay::StampedPose::from_isometry(t_ns, world_T_camera));
    est.push_back({t_ns, corrected.translation(), Eigen::Quaterniond(corrected.linear())});
    odo.push_back({t_ns, odom.translation(), odom_q});
    ref.push_back({t_ns, world_T_camera.translation(), Eigen::Quaterniond(world_T_camera.linear())});
  }
  const std::string dir = config_.output_dir;
  const auto write_atomically = [&](const std::string& path, const replay::Trajectory& t) {
    const std::string tmp = temporary_path_for(path);
    if (replay::write_tum_trajectory(tmp, t, error) && commit_file_atomically(tmp, path, error)) return true;
    ::unlink(tmp.c_str());
    return false;
  };
  if (!write_atomically(dir + "/trajectory_estimate.txt", estimate)) return false;
  if (backend_.solved() && !write_atomically(dir + "/trajectory_odometry.txt", odometric)) return false;
  if (truth.empty()) return true;
  if (!write_atomically(dir + "/trajectory_ground_truth.txt", truth)) return false;
  // The map is built in the odometry frame from the true start: the error without alignment is what the map shows.
  metrics::TrajectoryErrorConfig tc;
  tc.max_time_difference_ns = 0;
  tc.alignment = metrics::Alignment::kNone;
  ate_unaligned_ = metrics::evaluate_trajectory(ref, est, tc);
  ate_odometry_ = metrics::evaluate_trajectory(ref, odo, tc);
  if (backend_.solved() && ate_odometry_.ok && ate_unaligned_.ok)
    std::printf("loop closure: %llu proposed, %llu kept; ATE RMSE %.3f m with odometry alone, %.3f m optimized "
                "(%.1f %%)\n",
                static_cast<unsigned long long>(counters_.loop_closures),
                static_cast<unsigned long long>(counters_.loop_closures_kept), ate_odometry_.ate_rmse_m,
                ate_unaligned_.ate_rmse_m, 100.0 * ate_unaligned_.ate_rmse_m / std::max(1e-9, ate_odometry_.ate_rmse_m));
  tc.alignment = metrics::Alignment::kSE3;
  const metrics::TrajectoryError aligned = metrics::evaluate_trajectory(ref, est, tc);
  if (ate_unaligned_.ok && aligned.ok)
    std::printf("trajectory: %zu agent poses against the truth over %.1f m: ATE RMSE %.3f m as mapped (max %.3f m), "
                "%.3f m after SE(3) alignment; drift %.2f %% of distance (RPE over 1 m)\n",
                ate_unaligned_.associated, ate_unaligned_.path_length_m, ate_unaligned_.ate_rmse_m,
                ate_unaligned_.ate_max_m, aligned.ate_rmse_m, 100.0 * ate_unaligned_.rpe_translation_rmse_m_per_m);
  else
    std::printf("trajectory: not scored (%s)\n", ate_unaligned_.error.c_str());
  return true;
}

}  // namespace qsg::app
