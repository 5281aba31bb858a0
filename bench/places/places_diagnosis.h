// places_eval's ground-truth regions and its diagnosis: the connected free-space regions the tour mapped (through the
// generator's doors, or on the ground-truth grid for floor plans), the places graph's components, and with
// --diagnose the history of every place node and the explanation of every extra component.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <map>
#include <set>
#include <vector>

#include "core/places/places.h"
#include "core/scene_graph/scene_graph.h"
#include "drivers/sim/ground_truth.h"
#include "drivers/world/world.h"

namespace qsg::bench {

double polygon_area(const world::Polygon2& p);
// Connected components of the visited rooms through their doors: the connected free-space regions mapped.
std::size_t free_space_regions(const world::World& w, const std::set<std::int32_t>& visited);
// The ground-truth voxel holding p (may lie outside the grid), and its index when it lies inside.
Eigen::Vector3i gt_cell(const sim::GroundTruth& truth, const Eigen::Vector3d& p);
bool gt_index(const sim::GroundTruth& truth, const Eigen::Vector3d& p, std::size_t* out);
// Connected free-space regions from the ground-truth grid (floor plans): 6-connected components of voxels with at
// least min_clearance_m, counted when the tour passed through them.
std::size_t free_space_regions_gt(const sim::GroundTruth& truth, const std::vector<Eigen::Vector3d>& path_m,
                                  double min_clearance_m);
// Components of the places graph; *sizes gets their node counts.
std::size_t place_components(const scene_graph::SceneGraph& g, std::vector<std::size_t>* sizes);

// Diagnosis (--diagnose): what happened to each place node over the run, to explain extra components.
struct NodeHistory {
  int added_kf = -1;
  int deactivated_kf = -1;
  int reactivations = 0;
  std::size_t degree_at_deactivation = 0;
  std::size_t max_degree = 0;
  std::vector<scene_graph::NodeId> neighbours_at_deactivation;
};
void track_history(const scene_graph::SceneGraph& g, int kf, std::map<scene_graph::NodeId, NodeHistory>* h);
void diagnose_components(const scene_graph::SceneGraph& g, const places::Places& places, const sim::GroundTruth& truth,
                         const std::map<scene_graph::NodeId, NodeHistory>& history);

}  // namespace qsg::bench
