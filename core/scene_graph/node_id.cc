// Printable node labels.
#include "core/scene_graph/node_id.h"

namespace qsg::scene_graph {

std::string node_label(NodeId id) {
  const char prefix = node_prefix(id);
  if (prefix >= 33 && prefix <= 126) return std::string(1, prefix) + "(" + std::to_string(node_index(id)) + ")";
  return std::to_string(id);
}

}  // namespace qsg::scene_graph
