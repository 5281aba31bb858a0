// Reading and writing scene graphs in Spark-DSG's JSON schema (the format the paper's system saves).
//
// Export writes Spark-DSG 1.1.3's layout (the version the CI's interoperability stage loads with the real
// library): a 1.1.3 header, layer keys and names, the graph's label spaces in its metadata, node partitions,
// agents' timestamps among their attributes, boxes as centre and dimensions, colours as {r, g, b, a}, room class
// probabilities as an object keyed by class name.
//
// Import reads that layout and the older ones (1.0.x: boxes as min/max, colours as arrays, agents' timestamp and
// prefix on the node, room probabilities as a list), including real Hydra output. What a fixed-capacity
// attribute cannot hold (a place's fifth mesh connection, a room's seventeenth class) is dropped and counted in
// the result, not refused. Import validates the whole document (every field, id uniqueness, the hierarchy rules
// and the graph's capacities) before it touches the graph, so a malformed or truncated file leaves the graph as
// it was and the error names the offending field, e.g. "nodes[12].attributes.position: expected an array of 3
// numbers". Import and export run off the real-time path (start-up, snapshots) and may use the heap.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/scene_graph/scene_graph.h"

namespace qsg::scene_graph {

// Label names, as Spark-DSG keeps them in the graph's metadata: "labelspaces": {"_l2p0": [[label, "name"], ...],
// "_l4p0": [...]} (layer 2 partition 0: objects; layer 4: rooms).
struct LabelSpaces {
  std::map<std::uint32_t, std::string> objects;
  std::map<std::uint32_t, std::string> rooms;
  bool empty() const { return objects.empty() && rooms.empty(); }
};

// What import kept short of the file (each an entry count), so a caller can say what a graph lost.
struct ImportTruncations {
  std::size_t place_mesh_connections = 0;     // voxblox_mesh_connections past kMaxPlaceConnections
  std::size_t place_other_connections = 0;    // deformation / pcl connections and vertex labels past the same
  std::size_t room_class_probabilities = 0;   // classes past kMaxRoomClasses (the least likely are dropped)
  std::size_t unknown_class_names = 0;        // probabilities keyed by a name no label space of the file has
  std::size_t total() const {
    return place_mesh_connections + place_other_connections + room_class_probabilities + unknown_class_names;
  }
  std::string summary() const;  // "3 place mesh connections past 4, ..." or "" when nothing was dropped
};

struct JsonImportResult {
  bool ok = false;
  std::string error;              // set when !ok; names the field
  std::size_t nodes = 0;
  std::size_t edges = 0;
  int version[3] = {1, 0, 0};     // the file's SPARK_DSG_header version (1.0.0 when it has none)
  LabelSpaces labelspaces;        // the file's label names (empty when it has none)
  ImportTruncations truncated;
  std::size_t ignored_mesh_vertices = 0;  // the file's "mesh" vertices (Layer 1 is not kept in the graph)
  std::size_t ignored_dbow_entries = 0;   // agents' bag-of-words descriptors (not used by this system)
};

// Replaces the graph's content with the document's. On failure the graph is unchanged.
JsonImportResult read_spark_dsg_json(const std::string& text, SceneGraph& graph);
JsonImportResult read_spark_dsg_json_file(const std::string& path, SceneGraph& graph);

// Object mesh connections in the written file: Spark-DSG reads them as indices into the graph's mesh.
using ObjectMeshIndices = std::unordered_map<NodeId, std::vector<std::uint32_t>>;

// A mesh embedded in the file as Spark-DSG does ("mesh": points, colours, labels, faces): Spark-DSG loads it as
// the graph's mesh, which the objects' mesh_connections then index.
struct EmbeddedMesh {
  std::vector<float> xyz;             // 3 per vertex
  std::vector<std::uint8_t> rgb;      // 3 per vertex, or empty
  std::vector<std::uint32_t> labels;  // 1 per vertex, or empty
  std::vector<std::uint32_t> faces;   // 3 per triangle
};

struct JsonExportOptions {
  int indent = -1;  // -1: compact; >= 0: pretty-printed with this many spaces
  // Written into the metadata, and the names that key the rooms' class probabilities (a label without a name is
  // keyed by its number).
  const LabelSpaces* labelspaces = nullptr;
  // Object mesh connections: the given indices (an object missing from the map gets none) when set; else the
  // graph's stored values when write_stored_mesh_connections (a graph read from a file keeps the file's); else
  // the field is omitted (the app's graph stores internal handles, meaningless outside the process).
  const ObjectMeshIndices* object_mesh_indices = nullptr;
  bool write_stored_mesh_connections = true;
  const EmbeddedMesh* mesh = nullptr;  // written as the file's "mesh" when set
  // When set, each node is written at correct_position(id, kind, position, last_update_time_ns) instead of its
  // stored position, its box moved with it: a snapshot of a graph mapped in the odometry frame, written as the
  // latest loop-closure correction puts it (the graph itself is not changed).
  std::function<Eigen::Vector3d(NodeId, NodeKind, const Eigen::Vector3d&, std::uint64_t)> correct_position = nullptr;
};

// Spark-DSG 1.1.3 layout (see the top of this file).
std::string write_spark_dsg_json(const SceneGraph& graph, const JsonExportOptions& options = {});
bool write_spark_dsg_json_file(const SceneGraph& graph, const std::string& path, std::string* error,
                               const JsonExportOptions& options = {});

}  // namespace qsg::scene_graph
