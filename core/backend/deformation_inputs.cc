// Copying the deformation problem's inputs under the graph lock (deformation_inputs.h).
#include "core/backend/deformation_inputs.h"

#include "core/memory/prefault.h"

namespace qsg::backend {

void DeformationInputs::reserve(std::size_t chain_nodes, std::size_t control, std::size_t place_nodes,
                                std::size_t graph_edges) {
  chain.reserve(chain_nodes);
  control_points.reserve(control);
  control_times.reserve(control);
  places.reserve(place_nodes);
  edges.reserve(graph_edges);
  memory::prefault_capacity(&chain);
  memory::prefault_capacity(&control_points);
  memory::prefault_capacity(&control_times);
  memory::prefault_capacity(&places);
  memory::prefault_capacity(&edges);
}

void DeformationInputs::copy(const agents::ChainView& agents, const ControlPointView& control,
                             const scene_graph::SceneGraph& graph) {
  const std::size_t chain_capacity = chain.capacity(), place_capacity = places.capacity();
  const std::size_t edge_capacity = edges.capacity(), control_capacity = control_points.capacity();
  chain.clear();
  control_points.clear();
  control_times.clear();
  places.clear();
  edges.clear();
  for (std::size_t k = 0; k < agents.chain_size(); ++k) chain.push_back(agents.chain(k));
  for (std::size_t i = 0; i < control.size(); ++i) {
    control_points.push_back(control.point(i));
    control_times.push_back(control.time_ns(i));
  }
  graph.for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind != scene_graph::NodeKind::kPlace) return;
    const scene_graph::PlaceAttributes* a = graph.place_of(n);
    Place p;
    p.id = n.id;
    p.position_m = a->position_m;
    p.basis_m = a->mesh_connections.empty() ? a->position_m : a->mesh_connections[0].voxel_pos_m;
    p.time_ns = a->last_update_time_ns;
    places.push_back(p);
  });
  graph.for_each_edge([&](const scene_graph::EdgeRecord& e) {
    const scene_graph::NodeKind s = graph.node_at(e.source_node).kind, t = graph.node_at(e.target_node).kind;
    const bool place_s = s == scene_graph::NodeKind::kPlace, place_t = t == scene_graph::NodeKind::kPlace;
    const bool agent_s = s == scene_graph::NodeKind::kAgent, agent_t = t == scene_graph::NodeKind::kAgent;
    if ((place_s && place_t) || (agent_s && place_t) || (place_s && agent_t)) edges.emplace_back(e.source, e.target);
  });
  ++copies;
  if (chain.capacity() > chain_capacity || places.capacity() > place_capacity || edges.capacity() > edge_capacity ||
      control_points.capacity() > control_capacity)
    ++grown;
}

std::size_t DeformationInputs::capacity_bytes() const {
  return chain.capacity() * sizeof(agents::ChainNode) + places.capacity() * sizeof(Place) +
         control_points.capacity() * (sizeof(Eigen::Vector3d) + sizeof(std::uint64_t)) +
         edges.capacity() * sizeof(edges[0]);
}

}  // namespace qsg::backend
