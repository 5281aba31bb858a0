// What building the deformation problem reads of the loop thread's state: the pose chain, the mesh control points
// (which the loop thread offers), the places (position, time, mesh basis point) and the scene graph's place-place
// and agent-place edges. The backend copies them under
// the graph lock and builds the problem from the copy without it, so the loop thread, which takes that lock to add
// each keyframe, waits for a copy of fixed size, not for a build that grows with the path.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <utility>
#include <vector>

#include "core/agents/agent_layer.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::backend {

// Control points as a build reads them: positions and the times they were seen, oldest first.
class ControlPointView {
 public:
  ControlPointView(const Eigen::Vector3d* points, const std::uint64_t* times, std::size_t size)
      : points_(points), times_(times), size_(size) {}
  std::size_t size() const { return size_; }
  const Eigen::Vector3d& point(std::size_t i) const { return points_[i]; }
  std::uint64_t time_ns(std::size_t i) const { return times_[i]; }

 private:
  const Eigen::Vector3d* points_;
  const std::uint64_t* times_;
  std::size_t size_;
};

struct DeformationInputs {
  struct Place {
    scene_graph::NodeId id = scene_graph::kNoNode;
    Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
    Eigen::Vector3d basis_m = Eigen::Vector3d::Zero();  // its first mesh connection (the position when it has none)
    std::uint64_t time_ns = 0;                          // last updated
  };
  std::vector<agents::ChainNode> chain;
  std::vector<Eigen::Vector3d> control_points;
  std::vector<std::uint64_t> control_times;
  std::vector<Place> places;  // in the graph's node order
  // The graph's edges between two places or an agent and a place, in the graph's edge order.
  std::vector<std::pair<scene_graph::NodeId, scene_graph::NodeId>> edges;
  std::uint64_t copies = 0;
  std::uint64_t grown = 0;  // copies that found a buffer short and allocated (none once reserve() covers the stores)

  // Reserves each buffer for the stores it copies, once at start-up, so that copy() does not allocate.
  void reserve(std::size_t chain_nodes, std::size_t control_points, std::size_t place_nodes, std::size_t graph_edges);
  // Replaces the contents with the chain, the control points and the graph as they are now (call with the graph's
  // lock held).
  void copy(const agents::ChainView& agents, const ControlPointView& control, const scene_graph::SceneGraph& graph);
  agents::ChainView chain_view() const { return {chain.data(), chain.size()}; }
  ControlPointView control_view() const { return {control_points.data(), control_times.data(), control_points.size()}; }
  // Bytes reserved (the buffers' capacities).
  std::size_t capacity_bytes() const;
};

}  // namespace qsg::backend
