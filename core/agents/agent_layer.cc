// Layer 2 agents: keyframe nodes and odometry edges in the scene graph.
#include "core/agents/agent_layer.h"

#include <cctype>
#include <cinttypes>
#include <cmath>
#include <cstring>

#include "core/scene_graph/scene_graph.h"

namespace qsg::agents {

std::string Config::check() const {
  if (!std::islower(static_cast<unsigned char>(prefix)))
    return "prefix must be a lower-case letter (the robot's partition; 'p' is taken by places)";
  if (prefix == scene_graph::kPlacePrefix) return "prefix 'p' is the places layer's";
  return {};
}

void Config::print(std::FILE* out) const { std::fprintf(out, "agents: prefix='%c'\n", prefix); }

Capacities capacities_from_budget() {
  Capacities c;
  c.keyframes = scene_graph::capacities_from_budget().agent_nodes;
  return c;
}

void Counters::print(std::FILE* out) const {
  std::fprintf(out, "agents: keyframes=%" PRIu64 " rejected time=%" PRIu64 " full=%" PRIu64 " pose=%" PRIu64 "\n",
               keyframes, rejected_time, rejected_full, rejected_pose);
}

const char* to_string(AddResult r) {
  switch (r) {
    case AddResult::kAdded: return "added";
    case AddResult::kTimeNotIncreasing: return "timestamp not after the previous keyframe";
    case AddResult::kFull: return "full";
    case AddResult::kBadPose: return "non-finite pose";
    case AddResult::kNotInitialized: return "not initialized";
  }
  return "?";
}

bool AgentLayer::init(const Config& config, const Capacities& capacities, std::string* error) {
  const std::string why = config.check();
  if (!why.empty()) {
    if (error != nullptr) *error = "agents config: " + why;
    return false;
  }
  if (capacities.keyframes == 0) {
    if (error != nullptr) *error = "agents capacities: keyframes must be positive";
    return false;
  }
  config_ = config;
  capacities_ = capacities;
  ready_ = true;
  return true;
}

void AgentLayer::log_rejection(const char* why, std::uint64_t count) const {
  if ((count & (count - 1)) == 0)
    std::fprintf(stderr, "qsg: warning: agents: keyframe rejected (%s); %" PRIu64 " so far\n", why, count);
}

namespace {
std::size_t free_of(const scene_graph::SceneGraph& graph, const char* name) {
  std::size_t free_units = 0;
  graph.for_each_resource([&](const memory::ResourceStats& s) {
    if (std::strcmp(s.name, name) == 0) free_units = s.capacity - s.in_use;
  });
  return free_units;
}
}  // namespace

AddResult AgentLayer::add_keyframe(scene_graph::SceneGraph* graph, std::uint64_t timestamp_ns,
                                   const Eigen::Isometry3d& world_T_body, std::uint64_t external_key) {
  if (!ready_ || graph == nullptr || !graph->initialized()) return AddResult::kNotInitialized;
  if (next_index_ > 0 && timestamp_ns <= last_time_ns_) {
    log_rejection(to_string(AddResult::kTimeNotIncreasing), ++counters_.rejected_time);
    return AddResult::kTimeNotIncreasing;
  }
  if (!world_T_body.matrix().allFinite()) {
    log_rejection(to_string(AddResult::kBadPose), ++counters_.rejected_pose);
    return AddResult::kBadPose;
  }
  // Check every store first, so a refusal never reaches the graph (whose debug policy is to abort).
  const scene_graph::Capacities& gc = graph->capacities();
  const bool need_edge = last_node_ != scene_graph::kNoNode && graph->has_node(last_node_);
  const bool fits = next_index_ < capacities_.keyframes &&
                    graph->num_nodes(scene_graph::NodeKind::kAgent) < gc.agent_nodes && graph->num_nodes() < gc.nodes() &&
                    (!need_edge || (graph->num_edges() < gc.edges && free_of(*graph, "scene_graph.adjacency_chunks") >= 2));
  if (!fits) {
    log_rejection(to_string(AddResult::kFull), ++counters_.rejected_full);
    return AddResult::kFull;
  }
  scene_graph::AgentAttributes a;
  a.position_m = world_T_body.translation();
  a.world_R_body = Eigen::Quaterniond(world_T_body.linear()).normalized();
  a.timestamp_ns = timestamp_ns;
  a.last_update_time_ns = timestamp_ns;
  a.is_active = true;
  a.external_key = external_key;
  const scene_graph::NodeId id = scene_graph::make_node_id(config_.prefix, next_index_);
  if (graph->add_agent(id, config_.prefix, a) != scene_graph::Status::kOk) {
    log_rejection("scene graph refused the node", ++counters_.rejected_full);
    return AddResult::kFull;
  }
  if (need_edge) {
    scene_graph::EdgeAttributes odometry;
    odometry.weight = 1.0;
    graph->add_edge(last_node_, id, odometry);  // fits: checked above
  }
  ++next_index_;
  ++counters_.keyframes;
  last_node_ = id;
  last_time_ns_ = timestamp_ns;
  return AddResult::kAdded;
}

}  // namespace qsg::agents
