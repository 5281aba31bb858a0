// The pipeline's order in one place (pipeline_steps.h).
#include "core/pipeline/pipeline_steps.h"

namespace qsg::pipeline {

KeyframeResult integrate_keyframe(const Stages& s, Host& host, const messages::RgbdFrame& frame,
                                  const Eigen::Isometry3d& world_T_camera, std::uint64_t time_ns,
                                  const Eigen::Matrix<double, 6, 1>& variance, bool observe) {
  KeyframeResult r;
  host.begin(Step::kIntegrate);
  r.integrated = s.tsdf->process(frame, world_T_camera);
  host.end(Step::kIntegrate, r.integrated);
  if (!r.integrated) return r;
  host.integrated(frame, world_T_camera);
  // The blocks marching cubes re-ran on go into the wall map; while a door pass reads it, the next keyframe does.
  if (s.backend != nullptr && s.backend->online_doors_enabled()) {
    if (host.try_lock(Shared::kWallMap)) {
      r.blocks_painted = s.backend->paint_walls(*s.tsdf);
      host.unlock(Shared::kWallMap);
    } else {
      r.walls_deferred = true;
    }
  }
  host.begin(Step::kObserve);
  if (observe) s.frontend->observe(*s.tsdf, world_T_camera);
  host.end(Step::kObserve, observe);
  Host::Held graph(host, Shared::kGraph);
  r.added = s.frontend->add_keyframe(s.graph, time_ns, world_T_camera, variance);
  return r;
}

frontend::UpdateSummary frontend_update(const Stages& s, Host& host, const Eigen::Vector3d& robot_m,
                                        std::uint64_t time_ns, const frontend::Deadline& deadline) {
  Host::Held graph(host, Shared::kGraph);
  host.begin(Step::kFrontendUpdate);
  const frontend::UpdateSummary summary = s.frontend->update(*s.tsdf, robot_m, time_ns, s.graph, deadline);
  host.end(Step::kFrontendUpdate, summary.places_complete);
  if (s.backend != nullptr) s.backend->offer_control_points(*s.tsdf, time_ns);
  return summary;
}

rooms::PassResult door_pass(const Stages& s, Host& host, const Eigen::Vector3d& robot_m) {
  host.begin(Step::kDoorPass);
  s.backend->begin_door_pass(robot_m);
  {
    Host::Held graph(host, Shared::kGraph);
    s.backend->add_door_places(*s.graph);
  }
  {
    Host::Held walls(host, Shared::kWallMap);
    s.backend->rasterize_walls();
  }
  const rooms::PassResult r = s.backend->detect_doors();
  host.end(Step::kDoorPass, r.ran);
  return r;
}

BackendResult backend_update(const Stages& s, Host& host, const Eigen::Vector3d& robot_m, std::uint64_t time_ns,
                             bool rooms) {
  BackendResult r;
  if (s.backend == nullptr) return r;
  if (s.backend->door_pass_due()) {
    r.pass = door_pass(s, host, robot_m);
    r.door_pass = r.pass.ran;
  }
  if (!rooms) return r;
  Host::Held graph(host, Shared::kGraph);
  r.rooms = s.backend->update_rooms(s.graph, time_ns);
  host.after_rooms(time_ns, &graph);
  return r;
}

backend::BackendStage::FinalDoors final_doors(const Stages& s, Host& host, const reconstruction::Mesh& mesh) {
  Host::Held graph(host, Shared::kGraph);
  return s.backend->close_doors(mesh, s.graph);
}

rooms::UpdateResult final_rooms(const Stages& s, Host& host, std::uint64_t time_ns) {
  Host::Held graph(host, Shared::kGraph);
  return s.backend->update_rooms(s.graph, time_ns, /*final=*/true);
}

FinalResult final_stage(const Stages& s, Host& host, const reconstruction::Mesh* mesh, std::uint64_t time_ns) {
  FinalResult r;
  host.begin(Step::kFinalStage);
  if (mesh != nullptr) r.doors = final_doors(s, host, *mesh);
  r.rooms = final_rooms(s, host, time_ns);
  host.end(Step::kFinalStage, true);
  return r;
}

}  // namespace qsg::pipeline
