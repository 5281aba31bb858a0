// Layer 2 agents: the robot's keyframes as agent nodes (pose, timestamp) joined by odometry edges in the scene
// graph's agent partition, with bounded capacity and rejected (counted) out-of-order timestamps. The layer keeps
// each node's odometric pose and covariance (the pose chain a pose graph optimizes) and sparsifies the chain so
// that a mission of any length fits the store: see Config.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "core/memory/resource_stats.h"

#include "core/scene_graph/node_id.h"

namespace qsg::scene_graph {
class SceneGraph;
}

namespace qsg::agents {

// Sparsification policy. A keyframe becomes an agent node when the body moved min_translation_m or turned
// min_rotation_rad since the last node, or max_interval_s passed (a robot standing still); the others are folded
// into the odometry edge between their neighbours. When the chain holds fold_at_fraction of its capacity, every
// second node of its older half is folded the same way (its odometry edges composed into one, its other edges
// dropped): the oldest part of the trajectory gets sparser, the store never fills, memory stays flat.
struct Config {
  char prefix = scene_graph::kDefaultAgentPrefix;  // the robot's partition of layer 2 ('a', 'b', ...)
  double min_translation_m = 0.25;
  double min_rotation_rad = 0.2618;  // 15 degrees
  double max_interval_s = 10.0;
  double fold_at_fraction = 0.9;
  std::string check() const;                        // empty when usable, else the bad field and why
  void print(std::FILE* out) const;
};

struct Capacities {
  std::size_t keyframes = 0;  // agent nodes this layer may add
};
// The scene graph's agent-node capacity of the board this build targets.
Capacities capacities_from_budget();

struct Counters {
  std::uint64_t keyframes = 0;       // agent nodes added
  std::uint64_t sparsified = 0;      // keyframes too close to the last node: folded into the next node's edge
  std::uint64_t folded = 0;          // nodes folded out of the older half of the chain when it filled
  std::uint64_t fold_passes = 0;
  std::uint64_t rejected_time = 0;   // timestamp not after the previous keyframe's
  std::uint64_t rejected_full = 0;   // capacity reached, or the graph's stores are full
  std::uint64_t rejected_pose = 0;   // non-finite pose
  void print(std::FILE* out) const;
};

enum class AddResult : std::uint8_t { kAdded, kSparsified, kTimeNotIncreasing, kFull, kBadPose, kNotInitialized };

// One node of the pose chain: the odometric pose it was added with (never moved by optimization) and the diagonal
// of the odometry's covariance there ([t (m^2); r (rad^2)], growing with distance).
struct ChainNode {
  scene_graph::NodeId id = scene_graph::kNoNode;
  std::uint64_t time_ns = 0;
  Eigen::Vector3d t_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  Eigen::Matrix<double, 6, 1> variance = Eigen::Matrix<double, 6, 1>::Zero();
  // Odometric path length from the first keyframe to this node, over every keyframe offered (sparsified ones too):
  // what a per-distance odometry noise model integrates between two nodes.
  double path_m = 0.0;
  // The odometry stepped (a relocalization or a reset, AgentLayer::mark_odometry_step) between the previous node and
  // this one: the edge into this node does not measure the robot's motion.
  bool after_odometry_step = false;
  // The correction the frontend mapped this node in (map_T_odom; LoopClosureConfig::map_in_corrected_frame): the
  // pose above is this correction times the odometric pose. Identity when the frontend maps in the odometry frame.
  Eigen::Vector3d frame_t_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond frame_q = Eigen::Quaterniond::Identity();
  bool frame_is_identity() const {
    return frame_t_m.isZero(0.0) && frame_q.coeffs() == Eigen::Quaterniond::Identity().coeffs();
  }
};
// A node's pose as mapped (frame correction included) and as the odometry gave it (the odometry edges' measurement).
inline Eigen::Isometry3d mapped_pose(const ChainNode& n) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.linear() = n.q.toRotationMatrix();
  p.translation() = n.t_m;
  return p;
}
inline Eigen::Isometry3d odometric_pose(const ChainNode& n) {
  if (n.frame_is_identity()) return mapped_pose(n);
  Eigen::Isometry3d c = Eigen::Isometry3d::Identity();
  c.linear() = n.frame_q.toRotationMatrix();
  c.translation() = n.frame_t_m;
  return c.inverse() * mapped_pose(n);
}
const char* to_string(AddResult r);

class AgentLayer {
 public:
  bool init(const Config& config, const Capacities& capacities, std::string* error);

  // Adds keyframe node make_node_id(prefix, k) for the k-th accepted keyframe with its pose and time, and an
  // odometry edge from the previous node; or sparsifies it (kSparsified, see Config). `variance` is the odometry's
  // covariance diagonal at the keyframe (zero when unknown). Never allocates; rejections are counted (and logged
  // sparsely).
  AddResult add_keyframe(scene_graph::SceneGraph* graph, std::uint64_t timestamp_ns, const Eigen::Isometry3d& world_T_body,
                         std::uint64_t external_key = 0,
                         const Eigen::Matrix<double, 6, 1>& variance = Eigen::Matrix<double, 6, 1>::Zero());
  // The odometry source stepped (its pose buffer accepted a jump it kept): the next node added is marked
  // ChainNode::after_odometry_step. A node folded away passes its mark to the next one.
  void mark_odometry_step() { step_pending_ = true; }
  // The correction (map_T_odom) the poses offered from now on already include: stamped on each node added, so that
  // odometry edges measure the odometry alone (LoopClosureConfig::map_in_corrected_frame).
  void set_frame_correction(const Eigen::Isometry3d& map_T_odom) { frame_ = map_T_odom; }

  scene_graph::NodeId last_node() const { return last_node_; }
  std::uint64_t last_timestamp_ns() const { return last_time_ns_; }
  std::size_t num_keyframes() const { return static_cast<std::size_t>(next_index_); }
  // The id the k-th added node had (it may have been folded since: check the graph).
  scene_graph::NodeId node_of(std::size_t k) const { return scene_graph::make_node_id(config_.prefix, k); }
  // The live pose chain, oldest first.
  std::size_t chain_size() const { return chain_size_; }
  const ChainNode& chain(std::size_t i) const { return chain_[i]; }
  memory::ResourceStats chain_stats() const;
  const Config& config() const { return config_; }
  const Counters& counters() const { return counters_; }

 private:
  void log_rejection(const char* why, std::uint64_t count) const;
  void fold_older_half(scene_graph::SceneGraph* graph);

  Config config_;
  Capacities capacities_;
  Counters counters_;
  scene_graph::NodeId last_node_ = scene_graph::kNoNode;
  std::uint64_t last_time_ns_ = 0;
  std::uint64_t next_index_ = 0;
  double path_m_ = 0.0;                                  // odometric path over every keyframe offered
  Eigen::Vector3d last_offered_m_ = Eigen::Vector3d::Zero();
  bool have_offered_ = false;
  bool step_pending_ = false;  // mark_odometry_step() since the last node added
  Eigen::Isometry3d frame_ = Eigen::Isometry3d::Identity();  // set_frame_correction()
  bool ready_ = false;
  std::unique_ptr<ChainNode[]> chain_;
  std::size_t chain_size_ = 0;
  std::size_t chain_high_water_ = 0;
};

// A read-only view of a pose chain, oldest first: the live one (an AgentLayer converts to it) or a copy of it taken
// under a lock (backend::DeformationInputs), so what reads the chain does not care which.
class ChainView {
 public:
  ChainView(const ChainNode* nodes, std::size_t size) : nodes_(nodes), size_(size) {}
  ChainView(const AgentLayer& agents)  // NOLINT(google-explicit-constructor): the live chain is a chain
      : nodes_(agents.chain_size() > 0 ? &agents.chain(0) : nullptr), size_(agents.chain_size()) {}
  std::size_t chain_size() const { return size_; }
  const ChainNode& chain(std::size_t i) const { return nodes_[i]; }

 private:
  const ChainNode* nodes_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace qsg::agents
