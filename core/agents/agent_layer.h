// Layer 2 agents: the robot's keyframes as agent nodes (pose, timestamp) joined by odometry edges in the scene
// graph's agent partition, with bounded capacity and rejected (counted) out-of-order timestamps.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <cstdio>
#include <string>

#include "core/scene_graph/node_id.h"

namespace qsg::scene_graph {
class SceneGraph;
}

namespace qsg::agents {

struct Config {
  char prefix = scene_graph::kDefaultAgentPrefix;  // the robot's partition of layer 2 ('a', 'b', ...)
  std::string check() const;                        // empty when usable, else the bad field and why
  void print(std::FILE* out) const;
};

struct Capacities {
  std::size_t keyframes = 0;  // agent nodes this layer may add
};
// The scene graph's agent-node capacity of the board this build targets.
Capacities capacities_from_budget();

struct Counters {
  std::uint64_t keyframes = 0;
  std::uint64_t rejected_time = 0;   // timestamp not after the previous keyframe's
  std::uint64_t rejected_full = 0;   // capacity reached, or the graph's stores are full
  std::uint64_t rejected_pose = 0;   // non-finite pose
  void print(std::FILE* out) const;
};

enum class AddResult : std::uint8_t { kAdded, kTimeNotIncreasing, kFull, kBadPose, kNotInitialized };
const char* to_string(AddResult r);

class AgentLayer {
 public:
  bool init(const Config& config, const Capacities& capacities, std::string* error);

  // Adds keyframe node make_node_id(prefix, k) for the k-th accepted keyframe with its pose and time, and an
  // odometry edge from the previous keyframe. Never allocates; rejections are counted (and logged sparsely).
  AddResult add_keyframe(scene_graph::SceneGraph* graph, std::uint64_t timestamp_ns, const Eigen::Isometry3d& world_T_body,
                         std::uint64_t external_key = 0);

  scene_graph::NodeId last_node() const { return last_node_; }
  std::uint64_t last_timestamp_ns() const { return last_time_ns_; }
  std::size_t num_keyframes() const { return static_cast<std::size_t>(next_index_); }
  scene_graph::NodeId node_of(std::size_t k) const { return scene_graph::make_node_id(config_.prefix, k); }
  const Config& config() const { return config_; }
  const Counters& counters() const { return counters_; }

 private:
  void log_rejection(const char* why, std::uint64_t count) const;

  Config config_;
  Capacities capacities_;
  Counters counters_;
  scene_graph::NodeId last_node_ = scene_graph::kNoNode;
  std::uint64_t last_time_ns_ = 0;
  std::uint64_t next_index_ = 0;
  bool ready_ = false;
};

}  // namespace qsg::agents
