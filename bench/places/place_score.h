// Places scored against the world's ground truth (places_eval's accuracy metric, shared with drift/drift_baseline):
// each place node's distance to the nearest voxel of the ground-truth GVD, in the world frame.
#pragma once

#include <vector>

#include "core/scene_graph/scene_graph.h"
#include "drivers/sim/ground_truth.h"

namespace qsg::bench {

// One distance per place node, in the graph's node order.
inline std::vector<double> place_distances_to_gvd(const scene_graph::SceneGraph& graph, const sim::GroundTruth& truth) {
  std::vector<double> distances;
  graph.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind == scene_graph::NodeKind::kPlace)
      distances.push_back(truth.distance_to_gvd(graph.place(n.id)->position_m));
  });
  return distances;
}

inline double mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (const double x : v) sum += x;
  return v.empty() ? 0.0 : sum / static_cast<double>(v.size());
}

}  // namespace qsg::bench
