// The backend's half of the objects the frontend kept apart by visit (objects::Config::archive_after_s): at the
// finish, in the graph as it then stands (corrected, when loop closure moved it), object nodes of one label merge
// when either's centre lies in the other's box (the paper's rule, Config::merge_overlapping). Not the frontend's
// fragment rules (intersecting boxes, the size prior): they join pieces of one visit, and between whole visits
// they also joined neighbours (bench/results/loop_closure.md, "Session of 2026-12-05 (4)"). Nor two objects the
// layer held at the same time (Config::finish_keeps_concurrent_apart): a survivor's grown box would join a visit's
// neighbour of its label ("Session of 2026-12-05 (6)").
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <unordered_map>

#include "core/objects/object_layer.h"
#include "core/scene_graph/spark_dsg_json.h"

namespace qsg::objects {

struct RevisitMerge {
  std::size_t objects = 0;             // object nodes looked at
  std::size_t merged = 0;              // absorbed by another
  std::size_t concurrent_refused = 0;  // pairs the rule made but the layer held at once (kept apart)
  std::size_t edges_refused = 0;       // edges the graph refused to move (its edge store full)
  void print(std::FILE* out) const;
};

// When the object layer held an object: from the update that created it to the last update that changed it.
struct Lifetime {
  std::uint64_t first_ns = 0;
  std::uint64_t last_ns = 0;
};
using Lifetimes = std::unordered_map<scene_graph::NodeId, Lifetime>;

// The lifetimes of the layer's objects (off the real-time path: it allocates).
Lifetimes lifetimes(const ObjectLayer& layer);

// Off the real-time path (it allocates). The object with fewer mesh vertices (indices; on a tie the smaller box, then
// the later node) merges into the other (SceneGraph::merge_into: edges moved, the node removed); the survivor's box becomes the
// union of both, its position that box's centre (the layer's convention), its time the later one, and its mesh
// vertices the union of both (indices may be null). Repeated until no pair is left (a grown box may pair again).
// With Config::finish_keeps_concurrent_apart and lifetimes (may be null: no such check), two groups of merged nodes
// are not joined when a lifetime of one overlaps a lifetime of the other: the layer held both at once and its own
// rules kept them apart, so they are two objects (a grown box would otherwise join a visit's neighbour).
RevisitMerge merge_revisits(const Config& config, scene_graph::SceneGraph* graph,
                            scene_graph::ObjectMeshIndices* indices, const Lifetimes* lifetimes = nullptr);

}  // namespace qsg::objects
