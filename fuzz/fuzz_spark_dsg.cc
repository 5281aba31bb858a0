// Spark-DSG JSON reader (core/scene_graph/spark_dsg_json): any text either imports or is refused with an error;
// an import that succeeded exports and imports again to the same document.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "core/scene_graph/spark_dsg_json.h"

using namespace qsg;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static scene_graph::SceneGraph* graph = [] {
    auto* g = new scene_graph::SceneGraph();
    std::string error;
    // Small stores: an input larger than them must be refused by the reader, not overflow a store.
    scene_graph::Capacities c;
    c.object_nodes = c.agent_nodes = c.place_nodes = 64;
    c.room_nodes = c.building_nodes = 8;
    c.edges = 256;
    c.adjacency_chunks = 256;
    c.mesh_connections = 256;
    if (!g->init(c, scene_graph::SceneGraph::plan(c).total_bytes(), &error)) std::abort();
    return g;
  }();
  graph->clear();
  const std::string text(reinterpret_cast<const char*>(data), size);
  const scene_graph::JsonImportResult r = scene_graph::read_spark_dsg_json(text, *graph);
  if (!r.ok) {
    if (r.error.empty()) std::abort();  // a refusal must say why
    return 0;
  }
  const std::string exported = scene_graph::write_spark_dsg_json(*graph);
  graph->clear();
  if (!scene_graph::read_spark_dsg_json(exported, *graph).ok) std::abort();
  if (scene_graph::write_spark_dsg_json(*graph) != exported) std::abort();  // export is canonical
  return 0;
}
