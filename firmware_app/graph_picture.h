// The top-down picture of a scene graph: rooms (filled by label, when the graph has them, and named), place nodes
// and edges, objects (their boxes) and the agent's keyframe trajectory; over the simulated world's plan when there
// is one, else on a plain canvas framed around the graph.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/scene_graph/scene_graph.h"
#include "drivers/world/world.h"

namespace qsg::app {

struct GraphPictureConfig {
  // Neither side of the picture exceeds this: the scale drops instead, so one pose 20 km off (a bad ground-truth
  // line) gives a small-scale picture, not a 30 GB one. Range 256 .. 16384.
  int max_side_px = 6000;
  bool draw_room_names = true;  // each room's label name (or its node name until it is labelled) at its node
};

// world may be empty (replay, hardware): the picture is then framed around the graph. Writes a PNG, atomically
// (a temporary file beside it, fsync'd, renamed). Never throws: a failure is false with *error.
bool write_graph_picture(const scene_graph::SceneGraph& graph, const world::World& world,
                         const std::vector<Eigen::Vector3d>& trajectory_m, const std::string& path, std::string* error,
                         const GraphPictureConfig& config = GraphPictureConfig{});

}  // namespace qsg::app
