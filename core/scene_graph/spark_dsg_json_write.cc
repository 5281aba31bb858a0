// Spark-DSG JSON export in the 1.1.3 layout (see spark_dsg_json.h), canonical: equal graphs give equal files.
#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "core/scene_graph/spark_dsg_json.h"

namespace qsg::scene_graph {
namespace {

using json = nlohmann::json;

// The Spark-DSG version whose layout this file writes (and the CI's interoperability stage loads).
constexpr int kVersion[3] = {1, 1, 3};

json vec3(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }
json quat(const Eigen::Quaterniond& q) { return json{{"w", q.w()}, {"x", q.x()}, {"y", q.y()}, {"z", q.z()}}; }
json layer_key(int layer, int partition) { return json{{"layer", layer}, {"partition", partition}}; }

// Spark-DSG reads the centre and the dimensions. min and max are written as well (Spark-DSG 1.0.3 on ignores
// them): read back here they give the box exactly, where centre +- dimensions / 2 can differ in the last bit.
json bbox(const BoundingBox& b) {
  static const char* const kTypes[] = {"INVALID", "AABB", "OBB", "RAABB"};
  json out{{"type", kTypes[static_cast<int>(b.type)]},
           {"dimensions", vec3(b.max_m - b.min_m)},
           {"world_P_center", vec3(b.world_P_center_m)},
           {"world_R_center", quat(b.world_R_center)}};
  if (b.type != BoundingBox::Type::kInvalid) {
    out["min"] = vec3(b.min_m);
    out["max"] = vec3(b.max_m);
  }
  return out;
}

void write_node_common(const Eigen::Vector3d& position_m, std::uint64_t update_ns, bool is_active, json& a) {
  a["position"] = vec3(position_m);
  a["last_update_time_ns"] = update_ns;
  a["is_active"] = is_active;
  a["is_predicted"] = false;
}

void write_semantic(const SemanticAttributes& s, json& a) {
  write_node_common(s.position_m, s.last_update_time_ns, s.is_active, a);
  a["name"] = std::string(s.name.c_str(), s.name.size());
  a["color"] = json{{"r", s.color[0]}, {"g", s.color[1]}, {"b", s.color[2]}, {"a", 255}};
  a["bounding_box"] = bbox(s.bounding_box);
  a["semantic_label"] = s.semantic_label;
}

template <typename T, std::size_t N>
json array_of(const memory::BoundedArray<T, N>& values) {
  json out = json::array();
  for (const T& v : values) out.push_back(v);
  return out;
}

// Spark-DSG keeps label names as a std::map<label, name>, which its JSON library writes as [[label, name], ...].
json labelspace(const std::map<std::uint32_t, std::string>& names) {
  json out = json::array();
  for (const auto& [label, name] : names) out.push_back(json::array({label, name}));
  return out;
}

json metadata(const LabelSpaces* spaces) {
  json out = json::object();
  if (spaces == nullptr || spaces->empty()) return out;
  out["labelspaces"] = json::object();
  if (!spaces->objects.empty()) out["labelspaces"]["_l2p0"] = labelspace(spaces->objects);
  if (!spaces->rooms.empty()) out["labelspaces"]["_l4p0"] = labelspace(spaces->rooms);
  return out;
}

json object_attributes(const SceneGraph& graph, NodeId id, const JsonExportOptions& options) {
  const ObjectAttributes& o = *graph.object(id);
  json a;
  write_semantic(o, a);
  a["type"] = "ObjectNodeAttributes";
  a["registered"] = o.registered;
  a["world_R_object"] = quat(o.world_R_object);
  if (options.object_mesh_indices != nullptr) {
    const auto it = options.object_mesh_indices->find(id);
    a["mesh_connections"] = it == options.object_mesh_indices->end() ? json::array() : json(it->second);
  } else if (options.write_stored_mesh_connections) {
    json mesh = json::array();
    graph.for_each_mesh_connection(id, [&](std::uint32_t v) { mesh.push_back(v); });
    a["mesh_connections"] = std::move(mesh);
  }
  return a;
}

json place_attributes(const PlaceAttributes& p) {
  json a;
  write_semantic(p, a);
  a["type"] = "PlaceNodeAttributes";
  a["distance"] = p.distance_m;
  a["num_basis_points"] = p.num_basis_points;
  json conns = json::array();
  for (const PlaceMeshConnection& c : p.mesh_connections)
    conns.push_back({{"block", {c.block.x, c.block.y, c.block.z}}, {"vertex", c.vertex}, {"voxel_pos", vec3(c.voxel_pos_m)}});
  a["voxblox_mesh_connections"] = std::move(conns);
  a["deformation_connections"] = array_of(p.deformation_connections);
  a["mesh_vertex_labels"] = array_of(p.mesh_vertex_labels);
  a["pcl_mesh_connections"] = array_of(p.pcl_mesh_connections);
  return a;
}

json room_attributes(const RoomAttributes& r, const LabelSpaces* spaces) {
  json a;
  write_semantic(r, a);
  a["type"] = "RoomNodeAttributes";
  json probs = json::object();  // keyed by class name (Spark-DSG's std::map<std::string, double>)
  for (const LabelProbability& lp : r.class_probabilities) {
    std::string key = std::to_string(lp.label);
    if (spaces != nullptr)
      if (const auto it = spaces->rooms.find(lp.label); it != spaces->rooms.end()) key = it->second;
    probs[key] = lp.probability;
  }
  a["semantic_class_probabilities"] = std::move(probs);
  return a;
}

json header() {
  return {{"project_name", "main"}, {"version", {{"major", kVersion[0]}, {"minor", kVersion[1]}, {"patch", kVersion[2]}}}};
}

// Spark-DSG's Mesh as its JSON writer lays it out (points as [x, y, z], colours as {r, g, b, a}, faces as [a, b, c]).
json mesh_json(const EmbeddedMesh& m) {
  const std::size_t n = m.xyz.size() / 3;
  json out{{"header", header()},
           {"has_colors", !m.rgb.empty()},
           {"has_timestamps", false},
           {"has_labels", !m.labels.empty()},
           {"has_first_seen_stamps", false}};
  json& points = out["points"] = json::array();
  for (std::size_t i = 0; i < n; ++i) points.push_back({m.xyz[3 * i], m.xyz[3 * i + 1], m.xyz[3 * i + 2]});
  if (!m.rgb.empty()) {
    json& colors = out["colors"] = json::array();
    for (std::size_t i = 0; i < n; ++i)
      colors.push_back({{"r", m.rgb[3 * i]}, {"g", m.rgb[3 * i + 1]}, {"b", m.rgb[3 * i + 2]}, {"a", 255}});
  }
  if (!m.labels.empty()) out["labels"] = m.labels;
  json& faces = out["faces"] = json::array();
  for (std::size_t i = 0; i + 2 < m.faces.size(); i += 3) faces.push_back({m.faces[i], m.faces[i + 1], m.faces[i + 2]});
  return out;
}

json agent_attributes(const AgentAttributes& g) {
  json a;
  write_node_common(g.position_m, g.last_update_time_ns, g.is_active, a);
  a["type"] = "AgentNodeAttributes";
  a["timestamp"] = g.timestamp_ns;
  a["world_R_body"] = quat(g.world_R_body);
  a["external_key"] = g.external_key;
  a["dbow_ids"] = nullptr;  // Spark-DSG's own encoding of empty descriptors
  a["dbow_values"] = nullptr;
  return a;
}

}  // namespace

std::string write_spark_dsg_json(const SceneGraph& graph, const JsonExportOptions& options) {
  json root;
  root["SPARK_DSG_header"] = header();
  root["directed"] = false;
  root["multigraph"] = false;
  root["metadata"] = metadata(options.labelspaces);
  // Canonical order (nodes by layer then id, edges by endpoints), so equal graphs give equal files.
  std::vector<const NodeRecord*> records;
  records.reserve(graph.num_nodes());
  std::set<int> agent_partitions;
  graph.for_each_node([&](const NodeRecord& n) {
    records.push_back(&n);
    if (n.kind == NodeKind::kAgent) agent_partitions.insert(static_cast<unsigned char>(n.layer.partition));
  });
  json keys = json::array({layer_key(2, 0)});
  for (int p : agent_partitions) keys.push_back(layer_key(2, p));
  for (int layer : {3, 4, 5}) keys.push_back(layer_key(layer, 0));
  root["layer_keys"] = std::move(keys);
  root["layer_names"] = {{"OBJECTS", layer_key(2, 0)}, {"AGENTS", layer_key(2, 0)}, {"PLACES", layer_key(3, 0)},
                         {"ROOMS", layer_key(4, 0)},   {"BUILDINGS", layer_key(5, 0)}};
  std::sort(records.begin(), records.end(), [](const NodeRecord* a, const NodeRecord* b) {
    return a->layer.layer != b->layer.layer ? a->layer.layer < b->layer.layer : a->id < b->id;
  });
  json& nodes = root["nodes"] = json::array();
  for (const NodeRecord* record : records) {
    const NodeRecord& n = *record;
    json node{{"id", n.id}, {"layer", n.layer.layer}, {"partition", static_cast<unsigned char>(n.layer.partition)}};
    switch (n.kind) {
      case NodeKind::kObject: node["attributes"] = object_attributes(graph, n.id, options); break;
      case NodeKind::kPlace: node["attributes"] = place_attributes(*graph.place(n.id)); break;
      case NodeKind::kRoom: node["attributes"] = room_attributes(*graph.room(n.id), options.labelspaces); break;
      case NodeKind::kBuilding: {
        json a;
        write_semantic(*graph.building(n.id), a);
        a["type"] = "SemanticNodeAttributes";
        node["attributes"] = std::move(a);
        break;
      }
      case NodeKind::kAgent: node["attributes"] = agent_attributes(*graph.agent(n.id)); break;
    }
    if (options.correct_position) {
      json& a = node["attributes"];
      const json& at = a["position"];
      const Eigen::Vector3d p(at[0].get<double>(), at[1].get<double>(), at[2].get<double>());
      const Eigen::Vector3d q = options.correct_position(n.id, n.kind, p, a["last_update_time_ns"].get<std::uint64_t>());
      a["position"] = vec3(q);
      if (a.contains("bounding_box")) {
        json& b = a["bounding_box"];
        const Eigen::Vector3d shift = q - p;
        for (const char* key : {"world_P_center", "min", "max"}) {
          if (!b.contains(key)) continue;
          const json& v = b[key];
          b[key] = vec3(Eigen::Vector3d(v[0].get<double>(), v[1].get<double>(), v[2].get<double>()) + shift);
        }
      }
    }
    nodes.push_back(std::move(node));
  }
  std::vector<const EdgeRecord*> edge_records;
  edge_records.reserve(graph.num_edges());
  graph.for_each_edge([&](const EdgeRecord& e) { edge_records.push_back(&e); });
  std::sort(edge_records.begin(), edge_records.end(), [](const EdgeRecord* a, const EdgeRecord* b) {
    return a->source != b->source ? a->source < b->source : a->target < b->target;
  });
  json& edges = root["edges"] = json::array();
  for (const EdgeRecord* e : edge_records) {
    edges.push_back({{"source", e->source},
                     {"target", e->target},
                     {"info", {{"type", "EdgeAttributes"}, {"weight", e->info.weight}, {"weighted", e->info.weighted}}}});
  }
  if (options.mesh != nullptr) root["mesh"] = mesh_json(*options.mesh);
  return root.dump(options.indent);
}

bool write_spark_dsg_json_file(const SceneGraph& graph, const std::string& path, std::string* error,
                               const JsonExportOptions& options) {
  const std::string text = write_spark_dsg_json(graph, options);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (out) out << text;
  if (!out) {
    if (error != nullptr) *error = "cannot write '" + path + "'";
    return false;
  }
  return true;
}

}  // namespace qsg::scene_graph
