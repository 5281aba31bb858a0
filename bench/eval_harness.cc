// The evaluations' one pipeline: the app's stages driven in the app's order (eval_harness.h).
#include "bench/eval_harness.h"

#include <time.h>

#include <chrono>

namespace qsg::bench {
namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

}  // namespace

bool EvalPipeline::init(const PipelineConfig& config, scene_graph::SceneGraph* graph, std::string* error,
                        std::string* warning) {
  config_ = config;
  if (config_.frontend_every_n == 0) return *error = "frontend_every_n must be at least 1", false;
  graph_ = graph;
  std::size_t block_slots = 0;
  if (config_.frontend_stages) {
    tsdf_ = std::make_unique<reconstruction::SemanticTsdf>();
    if (!tsdf_->init(config_.reconstruction, config_.reconstruction_capacities, config_.reconstruction_arena_bytes,
                     error))
      return *error = "tsdf: " + *error, false;
    block_slots = tsdf_->block_slots();
    frontend_ = std::make_unique<frontend::Frontend>();
    if (!frontend_->init(config_.frontend, error)) return false;
  } else {
    config_.backend_stage.doors_online = false;  // nothing paints the wall map
  }
  if (!config_.backend) return true;
  config_.backend_stage.loop_closure.enabled = false;
  backend_ = std::make_unique<backend::BackendStage>();
  std::string unused;
  return backend_->init(config_.backend_stage, graph_->capacities(), block_slots, 0, error,
                        warning != nullptr ? warning : &unused);
}

void EvalPipeline::integrate(const messages::RgbdFrame& frame, const Eigen::Isometry3d& world_T_camera,
                             std::uint64_t time_ns) {
  const auto t0 = std::chrono::steady_clock::now();
  tsdf_->process(frame, world_T_camera);
  integrate_ms_.push_back(ms_since(t0));
  if (backend_ != nullptr) backend_->paint_walls(*tsdf_);
  const auto t1 = std::chrono::steady_clock::now();
  if (config_.observe) frontend_->observe(*tsdf_, world_T_camera);
  observe_ms_.push_back(ms_since(t1));
  frontend_->add_keyframe(graph_, time_ns, world_T_camera);
  ++keyframes_;
}

rooms::PassResult EvalPipeline::door_pass(const Eigen::Vector3d& robot_m, double* ms) {
  const auto t0 = std::chrono::steady_clock::now();
  backend_->begin_door_pass(robot_m);
  backend_->add_door_places(*graph_);
  backend_->rasterize_walls();
  const rooms::PassResult r = backend_->detect_doors();
  *ms = ms_since(t0);
  return r;
}

FrontendStep EvalPipeline::update(const Eigen::Vector3d& robot_m, std::uint64_t time_ns) {
  FrontendStep step;
  step.keyframe = keyframes_;
  step.time_ns = time_ns;
  const auto t0 = std::chrono::steady_clock::now();
  const double cpu0 = thread_cpu_ms();
  step.summary = frontend_->update(*tsdf_, robot_m, time_ns, graph_, frontend::Deadline{});
  step.update_cpu_ms = thread_cpu_ms() - cpu0;
  step.update_ms = ms_since(t0);
  if (backend_ != nullptr && backend_->door_pass_due()) {
    step.pass = door_pass(robot_m, &step.pass_ms);
    step.door_pass = step.pass.ran;
  }
  return step;
}

FrontendStep EvalPipeline::finish(const Eigen::Vector3d& robot_m, std::uint64_t time_ns) {
  for (int i = 0; i < config_.finish_updates; ++i)
    if (frontend_->update(*tsdf_, robot_m, time_ns, graph_, frontend::Deadline{}).places_complete) break;
  FrontendStep step;
  step.keyframe = keyframes_;
  step.time_ns = time_ns;
  if (backend_ != nullptr && backend_->online_doors_enabled()) {
    step.pass = door_pass(robot_m, &step.pass_ms);
    step.door_pass = step.pass.ran;
  }
  return step;
}

backend::BackendStage::FinalDoors EvalPipeline::close_doors(const reconstruction::Mesh& mesh,
                                                            std::vector<EdgeBefore>* changed) {
  std::vector<EdgeBefore> before;
  if (changed != nullptr)
    graph_->for_each_edge([&](const scene_graph::EdgeRecord& e) {
      if (graph_->place(e.source) != nullptr && graph_->place(e.target) != nullptr)
        before.push_back({{e.source, e.target}, e.info});
    });
  backend::BackendStage::FinalDoors d = backend_->close_doors(mesh, graph_);
  final_doors_ok_ = d.ok;
  if (changed != nullptr) {
    changed->clear();
    for (const auto& [ends, info] : before) {
      const scene_graph::EdgeAttributes* now = graph_->edge_info(ends.first, ends.second);
      if (now != nullptr && (now->weighted != info.weighted || now->weight != info.weight))
        changed->push_back({ends, info});
    }
  }
  return d;
}

rooms::UpdateResult EvalPipeline::update_rooms(std::uint64_t time_ns) {
  recorded_ran_ = false;
  return backend_->update_rooms(graph_, time_ns, /*final=*/true);
}

bool EvalPipeline::update_rooms_recorded(const std::vector<rooms::Door>& doors, const rooms::WallSight* sight,
                                         rooms::UpdateResult* result, std::string* error) {
  memory::Arena arena;
  rooms::DoorSet set;
  const std::size_t capacity = std::max<std::size_t>(1, doors.size());
  const memory::ArenaPlan plan = rooms::DoorSet::plan(capacity);
  if (!arena.create("recorded_doors", plan, plan.total_bytes(), error) ||
      !set.carve(arena, capacity, config_.backend_stage.doors))
    return false;
  for (const rooms::Door& d : doors) set.add(d);
  if (recorded_finder_ == nullptr) {
    recorded_finder_ = std::make_unique<rooms::RoomFinder>();
    if (!recorded_finder_->init(config_.backend_stage.rooms, rooms::Capacities::from_scene_graph(graph_->capacities()),
                                budgets::active::rooms::kArenaBytes, error))
      return false;
  }
  *result = recorded_finder_->update(graph_, 0, &set, sight);
  recorded_ran_ = true;
  return true;
}

const rooms::RoomFinder& EvalPipeline::room_finder() const {
  return recorded_ran_ ? *recorded_finder_ : backend_->room_finder();
}

bool EvalPipeline::has_sight() const {
  if (final_doors_ok_) return true;
  return backend_ != nullptr && backend_->online_doors_enabled() && backend_->online_doors().sight().slices() > 0;
}

}  // namespace qsg::bench
