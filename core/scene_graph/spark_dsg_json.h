// Reading and writing scene graphs in Spark-DSG's JSON schema (the format the paper's system saves).
//
// Import validates the whole document (every field, id uniqueness, the hierarchy rules and the graph's
// capacities) before it touches the graph, so a malformed or truncated file leaves the graph as it was and
// the error names the offending field, e.g. "nodes[12].attributes.position: expected an array of 3 numbers".
// Import and export run off the real-time path (start-up, snapshots) and may use the heap.
#pragma once

#include <cstddef>
#include <string>

#include "core/scene_graph/scene_graph.h"

namespace qsg::scene_graph {

struct JsonImportResult {
  bool ok = false;
  std::string error;              // set when !ok; names the field
  std::size_t nodes = 0;
  std::size_t edges = 0;
  std::size_t ignored_mesh_vertices = 0;  // the file's "mesh" (Layer 1 is not stored in the graph yet)
  std::size_t ignored_dbow_entries = 0;   // agents' bag-of-words descriptors (not used by this system)
};

// Replaces the graph's content with the document's. On failure the graph is unchanged.
JsonImportResult read_spark_dsg_json(const std::string& text, SceneGraph& graph);
JsonImportResult read_spark_dsg_json_file(const std::string& path, SceneGraph& graph);

struct JsonExportOptions {
  int indent = -1;  // -1: compact; >= 0: pretty-printed with this many spaces
};

// Spark-DSG 1.0 layout, with a SPARK_DSG_header naming that version.
std::string write_spark_dsg_json(const SceneGraph& graph, const JsonExportOptions& options = {});
bool write_spark_dsg_json_file(const SceneGraph& graph, const std::string& path, std::string* error,
                               const JsonExportOptions& options = {});

}  // namespace qsg::scene_graph
