// Spark-DSG JSON import (validate everything, then commit) and export.
#include "core/scene_graph/spark_dsg_json.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/json/json_guard.h"

namespace qsg::scene_graph {
namespace {

using json = nlohmann::json;

// Thrown inside the reader only, caught at its boundary; never crosses the library's API.
struct FieldError {
  std::string message;
};

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw FieldError{path + ": " + what}; }

const json& member(const json& obj, const char* key, const std::string& path) {
  if (!obj.is_object()) fail(path, "expected an object");
  const auto it = obj.find(key);
  if (it == obj.end()) fail(path + "." + key, "missing");
  return *it;
}
const json* optional_member(const json& obj, const char* key) {
  const auto it = obj.find(key);
  return it == obj.end() || it->is_null() ? nullptr : &*it;
}

double as_double(const json& j, const std::string& path) {
  if (!j.is_number()) fail(path, "expected a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) fail(path, "not finite");
  return v;
}
std::uint64_t as_uint(const json& j, const std::string& path, std::uint64_t max = std::numeric_limits<std::uint64_t>::max()) {
  if (!j.is_number_unsigned() && !(j.is_number_integer() && j.get<std::int64_t>() >= 0))
    fail(path, "expected a non-negative integer");
  const std::uint64_t v = j.get<std::uint64_t>();
  if (v > max) fail(path, "value " + std::to_string(v) + " is out of range (max " + std::to_string(max) + ")");
  return v;
}
std::int64_t as_int(const json& j, const std::string& path) {
  if (!j.is_number_integer()) fail(path, "expected an integer");
  return j.get<std::int64_t>();
}
bool as_bool(const json& j, const std::string& path) {
  if (!j.is_boolean()) fail(path, "expected true or false");
  return j.get<bool>();
}
const std::string& as_string(const json& j, const std::string& path) {
  if (!j.is_string()) fail(path, "expected a string");
  return j.get_ref<const std::string&>();
}
const json& as_array(const json& j, const std::string& path) {
  if (!j.is_array()) fail(path, "expected an array");
  return j;
}
Eigen::Vector3d as_vec3(const json& j, const std::string& path) {
  if (!j.is_array() || j.size() != 3) fail(path, "expected an array of 3 numbers");
  return {as_double(j[0], path + "[0]"), as_double(j[1], path + "[1]"), as_double(j[2], path + "[2]")};
}
Eigen::Quaterniond as_quat(const json& j, const std::string& path) {
  const Eigen::Quaterniond q(as_double(member(j, "w", path), path + ".w"), as_double(member(j, "x", path), path + ".x"),
                             as_double(member(j, "y", path), path + ".y"), as_double(member(j, "z", path), path + ".z"));
  if (std::abs(q.norm() - 1.0) > 1e-3) fail(path, "quaternion is not unit length");
  return q;
}

template <typename Str>
void read_name(const json& attrs, const std::string& path, Str& out) {
  const json* name = optional_member(attrs, "name");
  if (name == nullptr) return;
  const std::string& s = as_string(*name, path + ".name");
  if (!out.assign(s.data(), s.size()))
    fail(path + ".name", "longer than " + std::to_string(Str::capacity()) + " characters");
}

std::array<std::uint8_t, 3> read_color(const json& j, const std::string& path) {
  if (j.is_array()) {  // Spark-DSG 1.0: [r, g, b]
    if (j.size() != 3) fail(path, "expected [r, g, b]");
    return {static_cast<std::uint8_t>(as_uint(j[0], path + "[0]", 255)),
            static_cast<std::uint8_t>(as_uint(j[1], path + "[1]", 255)),
            static_cast<std::uint8_t>(as_uint(j[2], path + "[2]", 255))};
  }
  if (j.is_object()) {  // later versions: {"r", "g", "b", "a"}
    return {static_cast<std::uint8_t>(as_uint(member(j, "r", path), path + ".r", 255)),
            static_cast<std::uint8_t>(as_uint(member(j, "g", path), path + ".g", 255)),
            static_cast<std::uint8_t>(as_uint(member(j, "b", path), path + ".b", 255))};
  }
  fail(path, "expected a colour");
}

BoundingBox read_bbox(const json& j, const std::string& path) {
  BoundingBox b;
  const std::string& type = as_string(member(j, "type", path), path + ".type");
  if (type == "INVALID") b.type = BoundingBox::Type::kInvalid;
  else if (type == "AABB") b.type = BoundingBox::Type::kAabb;
  else if (type == "OBB") b.type = BoundingBox::Type::kObb;
  else if (type == "RAABB") b.type = BoundingBox::Type::kRaabb;
  else fail(path + ".type", "unknown bounding-box type '" + type + "'");
  b.min_m = as_vec3(member(j, "min", path), path + ".min");
  b.max_m = as_vec3(member(j, "max", path), path + ".max");
  if (const json* c = optional_member(j, "world_P_center")) b.world_P_center_m = as_vec3(*c, path + ".world_P_center");
  if (const json* r = optional_member(j, "world_R_center")) b.world_R_center = as_quat(*r, path + ".world_R_center");
  return b;
}

void read_common(const json& attrs, const std::string& path, Eigen::Vector3d& position, std::uint64_t& update_ns,
                 bool& is_active) {
  position = as_vec3(member(attrs, "position", path), path + ".position");
  if (const json* t = optional_member(attrs, "last_update_time_ns")) update_ns = as_uint(*t, path + ".last_update_time_ns");
  if (const json* a = optional_member(attrs, "is_active")) is_active = as_bool(*a, path + ".is_active");
}

void read_semantic(const json& attrs, const std::string& path, SemanticAttributes& s) {
  read_common(attrs, path, s.position_m, s.last_update_time_ns, s.is_active);
  read_name(attrs, path, s.name);
  if (const json* c = optional_member(attrs, "color")) s.color = read_color(*c, path + ".color");
  if (const json* b = optional_member(attrs, "bounding_box")) s.bounding_box = read_bbox(*b, path + ".bounding_box");
  if (const json* l = optional_member(attrs, "semantic_label"))
    s.semantic_label = static_cast<std::uint32_t>(as_uint(*l, path + ".semantic_label", 0xFFFFFFFFu));
}

template <typename T, std::size_t N, typename ReadOne>
void read_bounded(const json* j, const std::string& path, memory::BoundedArray<T, N>& out, ReadOne&& read_one) {
  if (j == nullptr) return;
  as_array(*j, path);
  if (j->size() > N) fail(path, "has " + std::to_string(j->size()) + " entries; at most " + std::to_string(N) + " are kept");
  for (std::size_t i = 0; i < j->size(); ++i) out.push_back(read_one((*j)[i], path + "[" + std::to_string(i) + "]"));
}

struct PendingObject {
  NodeId id;
  ObjectAttributes attributes;
  std::vector<std::uint32_t> mesh_connections;
};
struct PendingAgent {
  NodeId id;
  char prefix;
  AgentAttributes attributes;
};
struct PendingEdge {
  NodeId source;
  NodeId target;
  EdgeAttributes info;
};

struct Document {
  std::vector<PendingObject> objects;
  std::vector<PendingAgent> agents;
  std::vector<std::pair<NodeId, PlaceAttributes>> places;
  std::vector<std::pair<NodeId, RoomAttributes>> rooms;
  std::vector<std::pair<NodeId, BuildingAttributes>> buildings;
  std::vector<PendingEdge> edges;
  std::unordered_map<NodeId, LayerKey> layers;
  std::size_t ignored_mesh_vertices = 0;
  std::size_t ignored_dbow_entries = 0;
};

void read_node(const json& n, const std::string& path, Document& doc) {
  const NodeId id = as_uint(member(n, "id", path), path + ".id");
  const auto layer = static_cast<std::uint8_t>(as_uint(member(n, "layer", path), path + ".layer", 255));
  const json& attrs = member(n, "attributes", path);
  const std::string apath = path + ".attributes";
  const std::string& type = as_string(member(attrs, "type", apath), apath + ".type");
  const auto expect_layer = [&](Layer l) {
    if (layer != static_cast<std::uint8_t>(l))
      fail(path + ".layer", type + " belongs on layer " + std::to_string(static_cast<int>(l)) + ", not " +
                                std::to_string(layer));
  };
  NodeKind kind;
  char prefix = 0;
  if (type == "ObjectNodeAttributes") {
    expect_layer(Layer::kObjects);
    kind = NodeKind::kObject;
    PendingObject o{id, {}, {}};
    read_semantic(attrs, apath, o.attributes);
    if (const json* r = optional_member(attrs, "registered")) o.attributes.registered = as_bool(*r, apath + ".registered");
    if (const json* q = optional_member(attrs, "world_R_object")) o.attributes.world_R_object = as_quat(*q, apath + ".world_R_object");
    if (const json* m = optional_member(attrs, "mesh_connections")) {
      as_array(*m, apath + ".mesh_connections");
      o.mesh_connections.reserve(m->size());
      for (std::size_t i = 0; i < m->size(); ++i)
        o.mesh_connections.push_back(static_cast<std::uint32_t>(
            as_uint((*m)[i], apath + ".mesh_connections[" + std::to_string(i) + "]", 0xFFFFFFFFu)));
    }
    doc.objects.push_back(std::move(o));
  } else if (type == "PlaceNodeAttributes") {
    expect_layer(Layer::kPlaces);
    kind = NodeKind::kPlace;
    PlaceAttributes p;
    read_semantic(attrs, apath, p);
    p.distance_m = as_double(member(attrs, "distance", apath), apath + ".distance");
    if (const json* b = optional_member(attrs, "num_basis_points"))
      p.num_basis_points = static_cast<std::uint32_t>(as_uint(*b, apath + ".num_basis_points", 0xFFFFFFFFu));
    read_bounded(optional_member(attrs, "voxblox_mesh_connections"), apath + ".voxblox_mesh_connections",
                 p.mesh_connections, [](const json& c, const std::string& cp) {
                   PlaceMeshConnection pc;
                   const json& block = member(c, "block", cp);
                   if (!block.is_array() || block.size() != 3) fail(cp + ".block", "expected 3 integers");
                   pc.block = {static_cast<std::int32_t>(as_int(block[0], cp + ".block[0]")),
                               static_cast<std::int32_t>(as_int(block[1], cp + ".block[1]")),
                               static_cast<std::int32_t>(as_int(block[2], cp + ".block[2]"))};
                   pc.vertex = static_cast<std::uint32_t>(as_uint(member(c, "vertex", cp), cp + ".vertex", 0xFFFFFFFFu));
                   pc.voxel_pos_m = as_vec3(member(c, "voxel_pos", cp), cp + ".voxel_pos");
                   return pc;
                 });
    const auto read_u64 = [](const json& v, const std::string& vp) { return as_uint(v, vp); };
    const auto read_u32 = [](const json& v, const std::string& vp) {
      return static_cast<std::uint32_t>(as_uint(v, vp, 0xFFFFFFFFu));
    };
    read_bounded(optional_member(attrs, "deformation_connections"), apath + ".deformation_connections",
                 p.deformation_connections, read_u64);
    read_bounded(optional_member(attrs, "mesh_vertex_labels"), apath + ".mesh_vertex_labels", p.mesh_vertex_labels,
                 read_u32);
    read_bounded(optional_member(attrs, "pcl_mesh_connections"), apath + ".pcl_mesh_connections",
                 p.pcl_mesh_connections, read_u64);
    doc.places.emplace_back(id, p);
  } else if (type == "RoomNodeAttributes") {
    expect_layer(Layer::kRooms);
    kind = NodeKind::kRoom;
    RoomAttributes r;
    read_semantic(attrs, apath, r);
    read_bounded(optional_member(attrs, "semantic_class_probabilities"), apath + ".semantic_class_probabilities",
                 r.class_probabilities, [](const json& c, const std::string& cp) {
                   LabelProbability lp;
                   lp.label = static_cast<std::uint32_t>(as_uint(member(c, "label", cp), cp + ".label", 0xFFFFFFFFu));
                   lp.probability = static_cast<float>(as_double(member(c, "probability", cp), cp + ".probability"));
                   return lp;
                 });
    doc.rooms.emplace_back(id, r);
  } else if (type == "SemanticNodeAttributes" && layer == static_cast<std::uint8_t>(Layer::kBuildings)) {
    kind = NodeKind::kBuilding;
    BuildingAttributes b;
    read_semantic(attrs, apath, b);
    doc.buildings.emplace_back(id, b);
  } else if (type == "AgentNodeAttributes") {
    expect_layer(Layer::kAgents);
    kind = NodeKind::kAgent;
    PendingAgent a{id, node_prefix(id), {}};
    if (const json* p = optional_member(n, "prefix")) a.prefix = static_cast<char>(as_uint(*p, path + ".prefix", 255));
    if (a.prefix == 0) fail(path + ".prefix", "an agent needs a non-zero partition prefix");
    a.attributes.timestamp_ns = as_uint(member(n, "timestamp", path), path + ".timestamp");
    read_common(attrs, apath, a.attributes.position_m, a.attributes.last_update_time_ns, a.attributes.is_active);
    a.attributes.world_R_body = as_quat(member(attrs, "world_R_body", apath), apath + ".world_R_body");
    if (const json* k = optional_member(attrs, "external_key")) a.attributes.external_key = as_uint(*k, apath + ".external_key");
    if (const json* d = optional_member(attrs, "dbow_ids")) doc.ignored_dbow_entries += as_array(*d, apath + ".dbow_ids").size();
    prefix = a.prefix;
    doc.agents.push_back(a);
  } else {
    fail(apath + ".type", "unsupported node type '" + type + "' on layer " + std::to_string(layer));
  }
  if (!doc.layers.emplace(id, layer_of(kind, prefix)).second)
    fail(path + ".id", "duplicate node id " + std::to_string(id) + " (" + node_label(id) + ")");
}

void read_document(const json& root, Document& doc) {
  if (!root.is_object()) fail("(document)", "expected a JSON object");
  if (const json* header = optional_member(root, "SPARK_DSG_header")) {
    const json& version = member(*header, "version", "SPARK_DSG_header");
    const auto major = as_uint(member(version, "major", "SPARK_DSG_header.version"), "SPARK_DSG_header.version.major");
    if (major != 1) fail("SPARK_DSG_header.version.major", "unsupported Spark-DSG major version " + std::to_string(major));
  }
  if (const json* directed = optional_member(root, "directed"); directed != nullptr && as_bool(*directed, "directed"))
    fail("directed", "directed scene graphs are not supported");
  const json& nodes = as_array(member(root, "nodes", "(document)"), "nodes");
  for (std::size_t i = 0; i < nodes.size(); ++i) read_node(nodes[i], "nodes[" + std::to_string(i) + "]", doc);

  const json& edges = as_array(member(root, "edges", "(document)"), "edges");
  std::unordered_map<NodeId, NodeId> parent_of;
  std::unordered_map<NodeId, std::vector<NodeId>> neighbours;
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const std::string path = "edges[" + std::to_string(i) + "]";
    const json& e = edges[i];
    PendingEdge pe;
    pe.source = as_uint(member(e, "source", path), path + ".source");
    pe.target = as_uint(member(e, "target", path), path + ".target");
    if (const json* info = optional_member(e, "info")) {
      if (const json* w = optional_member(*info, "weight")) pe.info.weight = as_double(*w, path + ".info.weight");
      if (const json* w = optional_member(*info, "weighted")) pe.info.weighted = as_bool(*w, path + ".info.weighted");
    }
    const auto ls = doc.layers.find(pe.source);
    const auto lt = doc.layers.find(pe.target);
    if (ls == doc.layers.end()) fail(path + ".source", "no node " + node_label(pe.source));
    if (lt == doc.layers.end()) fail(path + ".target", "no node " + node_label(pe.target));
    if (pe.source == pe.target) fail(path, "self loop on " + node_label(pe.source));
    const Status rule = SceneGraph::check_layers(ls->second, lt->second);
    if (rule != Status::kOk)
      fail(path, std::string(to_string(rule)) + ": " + node_label(pe.source) + " and " + node_label(pe.target));
    const NodeId lo = std::min(pe.source, pe.target);
    const NodeId hi = std::max(pe.source, pe.target);
    auto& nl = neighbours[lo];
    if (std::find(nl.begin(), nl.end(), hi) != nl.end())
      fail(path, "duplicate edge " + node_label(pe.source) + " - " + node_label(pe.target));
    nl.push_back(hi);
    if (ls->second.layer != lt->second.layer) {
      const bool source_is_child = ls->second.layer < lt->second.layer;
      const NodeId child = source_is_child ? pe.source : pe.target;
      const NodeId parent = source_is_child ? pe.target : pe.source;
      if (!parent_of.emplace(child, parent).second)
        fail(path, "single-parent rule: " + node_label(child) + " already has parent " + node_label(parent_of[child]));
    }
    doc.edges.push_back(pe);
  }
  if (const json* mesh = optional_member(root, "mesh")) {
    if (const json* v = optional_member(*mesh, "vertices"); v != nullptr && v->is_array()) doc.ignored_mesh_vertices = v->size();
  }
}

void check_capacities(const Document& doc, const SceneGraph& graph) {
  const Capacities& c = graph.capacities();
  const auto check = [](std::size_t need, std::size_t have, const char* what) {
    if (need > have)
      fail(what, "the document has " + std::to_string(need) + " but the budget allows " + std::to_string(have) +
                     " (budgets/, scene_graph arena)");
  };
  check(doc.objects.size(), c.object_nodes, "nodes (objects)");
  check(doc.agents.size(), c.agent_nodes, "nodes (agents)");
  check(doc.places.size(), c.place_nodes, "nodes (places)");
  check(doc.rooms.size(), c.room_nodes, "nodes (rooms)");
  check(doc.buildings.size(), c.building_nodes, "nodes (buildings)");
  check(doc.edges.size(), c.edges, "edges");
  std::unordered_map<NodeId, std::size_t> degree;
  for (const PendingEdge& e : doc.edges) {
    ++degree[e.source];
    ++degree[e.target];
  }
  std::size_t chunks = 0;
  for (const auto& [id, d] : degree) chunks += (d + kAdjacencyChunkEdges - 1) / kAdjacencyChunkEdges;
  check(chunks, c.adjacency_chunks, "edges (adjacency chunks)");
  std::size_t mesh_chunks = 0;
  for (const PendingObject& o : doc.objects) mesh_chunks += (o.mesh_connections.size() + kMeshChunkValues - 1) / kMeshChunkValues;
  check(mesh_chunks * kMeshChunkValues, (c.mesh_connections + kMeshChunkValues - 1) / kMeshChunkValues * kMeshChunkValues,
        "nodes (object mesh_connections)");
}

}  // namespace

JsonImportResult read_spark_dsg_json(const std::string& text, SceneGraph& graph) {
  JsonImportResult result;
  if (!graph.initialized()) {
    result.error = "scene graph is not initialized (call init() with the budget's capacities first)";
    return result;
  }
  json root;
  json_guard::Limits limits;
  limits.reject_duplicate_keys = false;  // another tool's format: keep the last, as Spark-DSG's own reader does
  if (json_guard::ParseFailure f; !json_guard::parse(text, limits, &root, &f)) {
    using Kind = json_guard::ParseFailure::Kind;
    if (f.kind == Kind::kSyntax && f.byte != std::string::npos)
      result.error = "(document): not valid JSON at byte " + std::to_string(f.byte) + " (truncated or malformed): " + f.message;
    else if (f.kind == Kind::kTooDeep)
      result.error = f.message;  // names the path
    else
      result.error = "(document): " + f.message;
    return result;
  }
  Document doc;
  try {
    read_document(root, doc);
    check_capacities(doc, graph);
  } catch (const FieldError& e) {
    result.error = e.message;
    return result;
  } catch (const json::exception& e) {  // a type the checks above did not anticipate
    result.error = std::string("(document): ") + e.what();
    return result;
  }

  // Everything was validated against the rules and the capacities: from here on nothing can fail.
  graph.clear();
  const auto must = [&](Status s, const char* what) {
    if (s != Status::kOk && result.error.empty()) result.error = std::string("internal: ") + what + ": " + to_string(s);
  };
  for (const PendingObject& o : doc.objects) {
    must(graph.add_object(o.id, o.attributes), "object");
    for (std::uint32_t v : o.mesh_connections) graph.append_mesh_connection(o.id, v);
  }
  for (const auto& [id, a] : doc.places) must(graph.add_place(id, a), "place");
  for (const auto& [id, a] : doc.rooms) must(graph.add_room(id, a), "room");
  for (const auto& [id, a] : doc.buildings) must(graph.add_building(id, a), "building");
  for (const PendingAgent& a : doc.agents) must(graph.add_agent(a.id, a.prefix, a.attributes), "agent");
  for (const PendingEdge& e : doc.edges) must(graph.add_edge(e.source, e.target, e.info), "edge");
  if (!result.error.empty()) {
    graph.clear();  // never leave a half-built graph
    return result;
  }
  result.ok = true;
  result.nodes = graph.num_nodes();
  result.edges = graph.num_edges();
  result.ignored_mesh_vertices = doc.ignored_mesh_vertices;
  result.ignored_dbow_entries = doc.ignored_dbow_entries;
  return result;
}

JsonImportResult read_spark_dsg_json_file(const std::string& path, SceneGraph& graph) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    JsonImportResult r;
    r.error = "cannot open '" + path + "'";
    return r;
  }
  std::stringstream buffer;
  buffer << in.rdbuf();
  JsonImportResult r = read_spark_dsg_json(buffer.str(), graph);
  if (!r.ok) r.error = path + ": " + r.error;
  return r;
}

namespace {

json vec3(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }
json quat(const Eigen::Quaterniond& q) { return json{{"w", q.w()}, {"x", q.x()}, {"y", q.y()}, {"z", q.z()}}; }

json bbox(const BoundingBox& b) {
  static const char* const kTypes[] = {"INVALID", "AABB", "OBB", "RAABB"};
  return json{{"type", kTypes[static_cast<int>(b.type)]},
              {"min", vec3(b.min_m)},
              {"max", vec3(b.max_m)},
              {"world_P_center", vec3(b.world_P_center_m)},
              {"world_R_center", quat(b.world_R_center)}};
}

void write_semantic(const SemanticAttributes& s, json& a) {
  a["position"] = vec3(s.position_m);
  a["last_update_time_ns"] = s.last_update_time_ns;
  a["is_active"] = s.is_active;
  a["name"] = std::string(s.name.c_str(), s.name.size());
  a["color"] = json::array({s.color[0], s.color[1], s.color[2]});
  a["bounding_box"] = bbox(s.bounding_box);
  a["semantic_label"] = s.semantic_label;
}

template <typename T, std::size_t N>
json array_of(const memory::BoundedArray<T, N>& values) {
  json out = json::array();
  for (const T& v : values) out.push_back(v);
  return out;
}

}  // namespace

std::string write_spark_dsg_json(const SceneGraph& graph, const JsonExportOptions& options) {
  json root;
  root["SPARK_DSG_header"] = {{"project_name", "main"}, {"version", {{"major", 1}, {"minor", 0}, {"patch", 0}}}};
  root["directed"] = false;
  root["multigraph"] = false;
  root["layer_ids"] = json::array({2, 3, 4, 5});
  root["mesh_layer_id"] = 1;
  root["mesh_edges"] = json::array();
  // Canonical order (nodes by layer then id, edges by endpoints), so equal graphs give equal files.
  std::vector<const NodeRecord*> records;
  records.reserve(graph.num_nodes());
  graph.for_each_node([&](const NodeRecord& n) { records.push_back(&n); });
  std::sort(records.begin(), records.end(), [](const NodeRecord* a, const NodeRecord* b) {
    return a->layer.layer != b->layer.layer ? a->layer.layer < b->layer.layer : a->id < b->id;
  });
  json& nodes = root["nodes"] = json::array();
  for (const NodeRecord* record : records) {
    const NodeRecord& n = *record;
    json node{{"id", n.id}, {"layer", n.layer.layer}};
    json a;
    switch (n.kind) {
      case NodeKind::kObject: {
        const ObjectAttributes& o = *graph.object(n.id);
        write_semantic(o, a);
        a["type"] = "ObjectNodeAttributes";
        a["registered"] = o.registered;
        a["world_R_object"] = quat(o.world_R_object);
        json mesh = json::array();
        graph.for_each_mesh_connection(n.id, [&](std::uint32_t v) { mesh.push_back(v); });
        a["mesh_connections"] = std::move(mesh);
        break;
      }
      case NodeKind::kPlace: {
        const PlaceAttributes& p = *graph.place(n.id);
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
        break;
      }
      case NodeKind::kRoom: {
        const RoomAttributes& r = *graph.room(n.id);
        write_semantic(r, a);
        a["type"] = "RoomNodeAttributes";
        if (!r.class_probabilities.empty()) {
          json probs = json::array();
          for (const LabelProbability& lp : r.class_probabilities)
            probs.push_back({{"label", lp.label}, {"probability", lp.probability}});
          a["semantic_class_probabilities"] = std::move(probs);
        }
        break;
      }
      case NodeKind::kBuilding:
        write_semantic(*graph.building(n.id), a);
        a["type"] = "SemanticNodeAttributes";
        break;
      case NodeKind::kAgent: {
        const AgentAttributes& g = *graph.agent(n.id);
        node["prefix"] = static_cast<unsigned char>(n.layer.partition);
        node["timestamp"] = g.timestamp_ns;
        a["type"] = "AgentNodeAttributes";
        a["position"] = vec3(g.position_m);
        a["last_update_time_ns"] = g.last_update_time_ns;
        a["is_active"] = g.is_active;
        a["world_R_body"] = quat(g.world_R_body);
        a["external_key"] = g.external_key;
        a["dbow_ids"] = nullptr;
        a["dbow_values"] = nullptr;
        break;
      }
    }
    node["attributes"] = std::move(a);
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
