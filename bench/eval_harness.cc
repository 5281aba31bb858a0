// The evaluations' one pipeline: the app's stages driven in the app's order (eval_harness.h).
#include "bench/eval_harness.h"

#include <time.h>

#include <chrono>

namespace qsg::bench {
namespace {

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

}  // namespace

void EvalPipeline::Timer::begin(pipeline::Step step) {
  const auto i = static_cast<std::size_t>(step);
  if (step == pipeline::Step::kFrontendUpdate) cpu0_[i] = thread_cpu_ms();
  t0_[i] = std::chrono::steady_clock::now();
}

void EvalPipeline::Timer::end(pipeline::Step step, bool) {
  const auto i = static_cast<std::size_t>(step);
  ms_[i] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0_[i]).count();
  if (step == pipeline::Step::kFrontendUpdate) cpu_ms_[i] = thread_cpu_ms() - cpu0_[i];
}

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
  const pipeline::KeyframeResult r = pipeline::integrate_keyframe(
      stages(), host_, frame, world_T_camera, time_ns, Eigen::Matrix<double, 6, 1>::Zero(), config_.observe);
  integrate_ms_.push_back(host_.ms(pipeline::Step::kIntegrate));
  observe_ms_.push_back(r.integrated ? host_.ms(pipeline::Step::kObserve) : 0.0);
  ++keyframes_;
}

FrontendStep EvalPipeline::update(const Eigen::Vector3d& robot_m, std::uint64_t time_ns) {
  FrontendStep step;
  step.keyframe = keyframes_;
  step.time_ns = time_ns;
  step.summary = pipeline::frontend_update(stages(), host_, robot_m, time_ns, frontend::Deadline{});
  step.update_cpu_ms = host_.cpu_ms(pipeline::Step::kFrontendUpdate);
  step.update_ms = host_.ms(pipeline::Step::kFrontendUpdate);
  if (backend_ != nullptr && pipeline::backend_update_due(step.summary)) {
    const pipeline::BackendResult b = pipeline::backend_update(stages(), host_, robot_m, time_ns, /*rooms=*/false);
    step.pass = b.pass;
    step.door_pass = b.door_pass;
    if (b.door_pass) step.pass_ms = host_.ms(pipeline::Step::kDoorPass);
  }
  return step;
}

FrontendStep EvalPipeline::finish(const Eigen::Vector3d& robot_m, std::uint64_t time_ns) {
  for (int i = 0; i < config_.finish_updates; ++i)
    if (pipeline::frontend_update(stages(), host_, robot_m, time_ns, frontend::Deadline{}).places_complete) break;
  FrontendStep step;
  step.keyframe = keyframes_;
  step.time_ns = time_ns;
  if (backend_ != nullptr && backend_->online_doors_enabled()) {
    step.pass = pipeline::door_pass(stages(), host_, robot_m);
    step.door_pass = step.pass.ran;
    step.pass_ms = host_.ms(pipeline::Step::kDoorPass);
  }
  merge_object_visits();
  return step;
}

objects::RevisitMerge EvalPipeline::merge_object_visits() {
  const objects::Lifetimes lives = objects::lifetimes(frontend_->objects());
  return objects::merge_revisits(frontend_->objects().config(), graph_, nullptr, &lives);
}

backend::BackendStage::FinalDoors EvalPipeline::close_doors(const reconstruction::Mesh& mesh,
                                                            std::vector<EdgeBefore>* changed) {
  std::vector<EdgeBefore> before;
  if (changed != nullptr)
    graph_->for_each_edge([&](const scene_graph::EdgeRecord& e) {
      if (graph_->place(e.source) != nullptr && graph_->place(e.target) != nullptr)
        before.push_back({{e.source, e.target}, e.info});
    });
  backend::BackendStage::FinalDoors d = pipeline::final_doors(stages(), host_, mesh);
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
  return pipeline::final_rooms(stages(), host_, time_ns);
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
