// Hand-crafted scene-graph descriptors of an agent node (the paper's top-down detection, after Hughes et al. 2022):
// the sub-graph around the agent is the places reached from its nearest place through place edges within a radius,
// and the objects hanging from them. The places descriptor is the histogram of those places' clearances, the objects
// descriptor the histogram of their objects' semantic labels; both L1-normalised and compared by
// similarity = 1 - L1 / 2 (1: identical, 0: disjoint). The objects' centroids are kept for verification.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "core/loop_closure/object_registration.h"
#include "core/scene_graph/scene_graph.h"
#include "core/semantics/labels.h"

namespace qsg::loop_closure {

inline constexpr int kPlaceBins = 16;
inline constexpr int kObjectBins = semantics::kNumObjectLabels;
inline constexpr std::size_t kMaxDescriptorObjects = 32;  // object centroids kept per agent for registration

struct DescriptorConfig {
  double radius_m = 5.0;            // places within this distance of the agent, reached through place edges
  double max_clearance_m = 2.0;     // place histogram over [0, max_clearance_m), the last bin takes the rest
  std::uint32_t max_places = 1024;  // places visited per descriptor at most (bounds the search)

  std::string check() const;
  void print(std::FILE* out) const;
};

struct AgentDescriptor {
  std::array<float, kPlaceBins> places{};
  std::array<float, kObjectBins> objects{};
  std::uint32_t num_places = 0;
  std::uint32_t num_objects = 0;  // objects counted in the histogram (may exceed the points kept)
  std::uint32_t num_points = 0;
  std::array<LabelledPoint, kMaxDescriptorObjects> points;  // the nearest objects' centroids, odometric frame
};

// 1 - L1(a, b) / 2 for L1-normalised histograms; 0 when either is empty.
float histogram_similarity(const float* a, const float* b, int n);

class DescriptorBuilder {
 public:
  // Sizes the search's workspace; the only allocation.
  bool init(const DescriptorConfig& config, std::string* error);
  // Describes the sub-graph around an agent at `center_m` whose nearest place is `start_place`. False (and an
  // empty descriptor) when start_place is not a place of the graph.
  bool describe(const scene_graph::SceneGraph& graph, scene_graph::NodeId start_place, const Eigen::Vector3d& center_m,
                AgentDescriptor* out);
  const DescriptorConfig& config() const { return config_; }
  std::uint64_t truncated() const { return truncated_; }  // searches stopped at max_places

 private:
  DescriptorConfig config_;
  std::vector<scene_graph::NodeId> queue_;
  std::vector<scene_graph::NodeId> seen_;  // small: linear membership is faster than hashing at these sizes
  std::uint64_t truncated_ = 0;
};

}  // namespace qsg::loop_closure
