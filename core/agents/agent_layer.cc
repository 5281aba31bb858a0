// Layer 2 agents: keyframe nodes and odometry edges in the scene graph.
#include "core/agents/agent_layer.h"

#include <cctype>
#include <cinttypes>
#include <cmath>
#include <cstring>

#include "core/agents/agents_params.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::agents {

std::string Config::check() const {
  if (!std::islower(static_cast<unsigned char>(prefix)))
    return "prefix must be a lower-case letter (the robot's partition; 'p' is taken by places)";
  if (prefix == scene_graph::kPlacePrefix) return "prefix 'p' is the places layer's";
  return params::check(params_table(), *this);  // the policy's fields (agents_params.cc; the prefix is no setting)
}

void Config::print(std::FILE* out) const {
  params::print(params::sections_of("agents", params_table()), this, out);  // every field, from the table
}

Capacities capacities_from_budget() {
  Capacities c;
  c.keyframes = scene_graph::capacities_from_budget().agent_nodes;
  return c;
}

void Counters::print(std::FILE* out) const {
  std::fprintf(out,
               "agents: nodes added=%" PRIu64 " keyframes sparsified=%" PRIu64 " nodes folded=%" PRIu64
               " (in %" PRIu64 " passes) rejected time=%" PRIu64 " full=%" PRIu64 " pose=%" PRIu64 "\n",
               keyframes, sparsified, folded, fold_passes, rejected_time, rejected_full, rejected_pose);
}

const char* to_string(AddResult r) {
  switch (r) {
    case AddResult::kAdded: return "added";
    case AddResult::kSparsified: return "sparsified (too close to the last node)";
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
  chain_ = std::make_unique<ChainNode[]>(capacities.keyframes);
  chain_size_ = chain_high_water_ = 0;
  path_m_ = 0.0;
  step_pending_ = false;
  have_offered_ = false;
  ready_ = true;
  return true;
}

memory::ResourceStats AgentLayer::chain_stats() const {
  memory::ResourceStats s;
  s.name = "agents.chain";
  s.unit = "nodes";
  s.capacity = capacities_.keyframes;
  s.in_use = chain_size_;
  s.high_water = chain_high_water_;
  s.failed = counters_.rejected_full;
  return s;
}

// Folds every second node of the chain's older half (never the first, which anchors the map) into the odometry
// edge between its neighbours. O(chain) and allocation-free; a pass frees about a quarter of the chain, so passes
// come once per that many added nodes and the cost per keyframe stays bounded.
void AgentLayer::fold_older_half(scene_graph::SceneGraph* graph) {
  const std::size_t half = chain_size_ / 2;
  std::size_t kept = 1;
  for (std::size_t i = 1; i < chain_size_; ++i) {
    const bool fold = i < half && i % 2 == 1;
    if (!fold) {
      chain_[kept++] = chain_[i];
      continue;
    }
    if (chain_[i].after_odometry_step) chain_[i + 1].after_odometry_step = true;  // the step is now before i + 1
    // Its neighbours: the last kept node and the next one (i + 1 is kept: odd indices fold, i + 1 is even).
    const scene_graph::NodeId prev = chain_[kept - 1].id, next = chain_[i + 1].id;
    graph->remove_node(chain_[i].id);  // its odometry edges and its place edge go with it
    if (graph->has_node(prev) && graph->has_node(next)) {
      scene_graph::EdgeAttributes odometry;
      odometry.weight = 1.0;
      graph->add_edge(prev, next, odometry);  // fits: the removal freed two edges
    }
    ++counters_.folded;
  }
  chain_size_ = kept;
  ++counters_.fold_passes;
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
                                   const Eigen::Isometry3d& world_T_body, std::uint64_t external_key,
                                   const Eigen::Matrix<double, 6, 1>& variance) {
  if (!ready_ || graph == nullptr || !graph->initialized()) return AddResult::kNotInitialized;
  if (next_index_ > 0 && timestamp_ns <= last_time_ns_) {
    log_rejection(to_string(AddResult::kTimeNotIncreasing), ++counters_.rejected_time);
    return AddResult::kTimeNotIncreasing;
  }
  if (!world_T_body.matrix().allFinite() || !variance.allFinite()) {
    log_rejection(to_string(AddResult::kBadPose), ++counters_.rejected_pose);
    return AddResult::kBadPose;
  }
  const Eigen::Quaterniond q(world_T_body.linear());
  // The path in the odometry's own frame: a change of the frame correction is not motion.
  const Eigen::Vector3d odometric_m = frame_.inverse() * world_T_body.translation();
  if (have_offered_) path_m_ += (odometric_m - last_offered_m_).norm();
  last_offered_m_ = odometric_m;
  have_offered_ = true;
  if (chain_size_ > 0) {
    const ChainNode& last = chain_[chain_size_ - 1];
    const bool moved = (world_T_body.translation() - last.t_m).norm() >= config_.min_translation_m;
    const bool turned = last.q.angularDistance(q) >= config_.min_rotation_rad;
    const bool waited = 1e-9 * static_cast<double>(timestamp_ns - last.time_ns) >= config_.max_interval_s;
    if (!moved && !turned && !waited) {
      ++counters_.sparsified;
      return AddResult::kSparsified;
    }
  }
  if (static_cast<double>(chain_size_) >= config_.fold_at_fraction * static_cast<double>(capacities_.keyframes))
    fold_older_half(graph);
  // Check every store first, so a refusal never reaches the graph (whose debug policy is to abort).
  const scene_graph::Capacities& gc = graph->capacities();
  const bool need_edge = last_node_ != scene_graph::kNoNode && graph->has_node(last_node_);
  const bool fits = chain_size_ < capacities_.keyframes &&
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
  ChainNode& c = chain_[chain_size_++];
  c.id = id;
  c.time_ns = timestamp_ns;
  c.t_m = world_T_body.translation();
  c.q = q.normalized();
  c.variance = variance;
  c.path_m = path_m_;
  c.after_odometry_step = step_pending_;
  step_pending_ = false;
  c.frame_t_m = frame_.translation();
  c.frame_q = Eigen::Quaterniond(frame_.linear()).normalized();
  if (chain_size_ > chain_high_water_) chain_high_water_ = chain_size_;
  ++next_index_;
  ++counters_.keyframes;
  last_node_ = id;
  last_time_ns_ = timestamp_ns;
  return AddResult::kAdded;
}

}  // namespace qsg::agents
