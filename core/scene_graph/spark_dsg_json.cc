// Spark-DSG JSON import: validate everything, then commit (export: spark_dsg_json_write.cc).
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
  if (j.is_array()) {  // Spark-DSG up to 1.0.2: [r, g, b] or [r, g, b, a] (alpha is not kept)
    if (j.size() != 3 && j.size() != 4) fail(path, "expected [r, g, b] or [r, g, b, a]");
    return {static_cast<std::uint8_t>(as_uint(j[0], path + "[0]", 255)),
            static_cast<std::uint8_t>(as_uint(j[1], path + "[1]", 255)),
            static_cast<std::uint8_t>(as_uint(j[2], path + "[2]", 255))};
  }
  if (j.is_object()) {  // later versions: {"r", "g", "b", "a"} (alpha is not kept)
    return {static_cast<std::uint8_t>(as_uint(member(j, "r", path), path + ".r", 255)),
            static_cast<std::uint8_t>(as_uint(member(j, "g", path), path + ".g", 255)),
            static_cast<std::uint8_t>(as_uint(member(j, "b", path), path + ".b", 255))};
  }
  fail(path, "expected a colour");
}

// Spark-DSG up to 1.0.2 writes min and max (and the centre); 1.0.3 on writes the centre and the dimensions, and
// this project writes both (min and max give its boxes back exactly). An invalid box carries nothing else that
// Spark-DSG reads, so nothing else is read here either.
BoundingBox read_bbox(const json& j, const std::string& path) {
  BoundingBox b;
  const json& type_field = member(j, "type", path);
  if (type_field.is_null()) return b;
  const std::string& type = as_string(type_field, path + ".type");
  if (type == "INVALID") return b;
  if (type == "AABB") b.type = BoundingBox::Type::kAabb;
  else if (type == "OBB") b.type = BoundingBox::Type::kObb;
  else if (type == "RAABB") b.type = BoundingBox::Type::kRaabb;
  else fail(path + ".type", "unknown bounding-box type '" + type + "'");
  if (const json* r = optional_member(j, "world_R_center")) b.world_R_center = as_quat(*r, path + ".world_R_center");
  if (optional_member(j, "min") != nullptr || optional_member(j, "max") != nullptr) {
    b.min_m = as_vec3(member(j, "min", path), path + ".min");
    b.max_m = as_vec3(member(j, "max", path), path + ".max");
    if (const json* c = optional_member(j, "world_P_center")) b.world_P_center_m = as_vec3(*c, path + ".world_P_center");
    else b.world_P_center_m = 0.5 * (b.min_m + b.max_m);
    return b;
  }
  const json* d = optional_member(j, "dimensions");
  if (d == nullptr) fail(path + ".dimensions", "missing (and no legacy min and max)");
  const Eigen::Vector3d dims = as_vec3(*d, path + ".dimensions");
  if ((dims.array() < 0.0).any()) fail(path + ".dimensions", "negative");
  b.world_P_center_m = as_vec3(member(j, "world_P_center", path), path + ".world_P_center");
  b.min_m = b.world_P_center_m - 0.5 * dims;
  b.max_m = b.world_P_center_m + 0.5 * dims;
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

// Reads (and validates) every entry, keeps the first N and adds the rest to *dropped.
template <typename T, std::size_t N, typename ReadOne>
void read_bounded(const json* j, const std::string& path, memory::BoundedArray<T, N>& out, std::size_t* dropped,
                  ReadOne&& read_one) {
  if (j == nullptr) return;
  as_array(*j, path);
  for (std::size_t i = 0; i < j->size(); ++i) {
    const T value = read_one((*j)[i], path + "[" + std::to_string(i) + "]");
    if (out.size() < N) out.push_back(value);
    else ++*dropped;
  }
}

// A label space: [[label, "name"], ...] as Spark-DSG writes a std::map with integer keys, or {"label": "name"}.
std::map<std::uint32_t, std::string> read_labelspace(const json& j, const std::string& path) {
  std::map<std::uint32_t, std::string> out;
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      const std::string& key = it.key();
      if (key.empty() || key.size() > 10 || key.find_first_not_of("0123456789") != std::string::npos ||
          std::stoull(key) > 0xFFFFFFFFull)
        fail(path + "." + key, "expected a label number as the key");
      out[static_cast<std::uint32_t>(std::stoull(key))] = as_string(it.value(), path + "." + key);
    }
    return out;
  }
  as_array(j, path);
  for (std::size_t i = 0; i < j.size(); ++i) {
    const std::string p = path + "[" + std::to_string(i) + "]";
    if (!j[i].is_array() || j[i].size() != 2) fail(p, "expected [label, \"name\"]");
    out[static_cast<std::uint32_t>(as_uint(j[i][0], p + "[0]", 0xFFFFFFFFu))] = as_string(j[i][1], p + "[1]");
  }
  return out;
}

void read_labelspaces(const json& metadata, LabelSpaces& out) {
  if (!metadata.is_object()) fail("metadata", "expected an object");
  const json* spaces = optional_member(metadata, "labelspaces");
  if (spaces == nullptr) return;
  if (!spaces->is_object()) fail("metadata.labelspaces", "expected an object");
  if (const json* o = optional_member(*spaces, "_l2p0")) out.objects = read_labelspace(*o, "metadata.labelspaces._l2p0");
  if (const json* r = optional_member(*spaces, "_l4p0")) out.rooms = read_labelspace(*r, "metadata.labelspaces._l4p0");
}

// A room's class probabilities: an object keyed by class name (Spark-DSG 1.0.2 on; a name the file's room label
// space does not have, unless it is a label number, is dropped and counted) or the list of {label, probability}
// this project wrote before. The most likely kMaxRoomClasses are kept, the rest counted.
void read_class_probabilities(const json& j, const std::string& path, const LabelSpaces& spaces,
                              ImportTruncations& truncated, RoomAttributes& room) {
  std::vector<LabelProbability> all;
  if (j.is_object()) {
    std::map<std::string, std::uint32_t> by_name;
    for (const auto& [label, name] : spaces.rooms) by_name.emplace(name, label);
    for (auto it = j.begin(); it != j.end(); ++it) {
      const std::string& key = it.key();
      const std::string p = path + "." + key;
      const float probability = static_cast<float>(as_double(it.value(), p));
      if (const auto named = by_name.find(key); named != by_name.end()) {
        all.push_back({named->second, probability});
      } else if (!key.empty() && key.size() <= 10 && key.find_first_not_of("0123456789") == std::string::npos &&
                 std::stoull(key) <= 0xFFFFFFFFull) {
        all.push_back({static_cast<std::uint32_t>(std::stoull(key)), probability});
      } else {
        ++truncated.unknown_class_names;
      }
    }
  } else {
    as_array(j, path);
    for (std::size_t i = 0; i < j.size(); ++i) {
      const std::string cp = path + "[" + std::to_string(i) + "]";
      const std::uint32_t label = static_cast<std::uint32_t>(as_uint(member(j[i], "label", cp), cp + ".label", 0xFFFFFFFFu));
      all.push_back({label, static_cast<float>(as_double(member(j[i], "probability", cp), cp + ".probability"))});
    }
  }
  std::stable_sort(all.begin(), all.end(),
                   [](const LabelProbability& a, const LabelProbability& b) { return a.probability > b.probability; });
  for (const LabelProbability& lp : all) {
    if (room.class_probabilities.size() < kMaxRoomClasses) room.class_probabilities.push_back(lp);
    else ++truncated.room_class_probabilities;
  }
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
  LabelSpaces labelspaces;
  ImportTruncations truncated;
  int version[3] = {1, 0, 0};
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
  if (const json* part = optional_member(n, "partition");
      part != nullptr && type != "AgentNodeAttributes" && as_uint(*part, path + ".partition", 255) != 0)
    fail(path + ".partition", "only agents are kept in a partition here (layer " + std::to_string(layer) + ")");
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
                 p.mesh_connections, &doc.truncated.place_mesh_connections, [](const json& c, const std::string& cp) {
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
    std::size_t* other = &doc.truncated.place_other_connections;
    read_bounded(optional_member(attrs, "deformation_connections"), apath + ".deformation_connections",
                 p.deformation_connections, other, read_u64);
    read_bounded(optional_member(attrs, "mesh_vertex_labels"), apath + ".mesh_vertex_labels", p.mesh_vertex_labels,
                 other, read_u32);
    read_bounded(optional_member(attrs, "pcl_mesh_connections"), apath + ".pcl_mesh_connections",
                 p.pcl_mesh_connections, other, read_u64);
    doc.places.emplace_back(id, p);
  } else if (type == "RoomNodeAttributes") {
    expect_layer(Layer::kRooms);
    kind = NodeKind::kRoom;
    RoomAttributes r;
    read_semantic(attrs, apath, r);
    if (const json* probs = optional_member(attrs, "semantic_class_probabilities"))
      read_class_probabilities(*probs, apath + ".semantic_class_probabilities", doc.labelspaces, doc.truncated, r);
    doc.rooms.emplace_back(id, r);
  } else if (type == "SemanticNodeAttributes" && layer == static_cast<std::uint8_t>(Layer::kBuildings)) {
    kind = NodeKind::kBuilding;
    BuildingAttributes b;
    read_semantic(attrs, apath, b);
    doc.buildings.emplace_back(id, b);
  } else if (type == "AgentNodeAttributes") {
    expect_layer(Layer::kAgents);
    kind = NodeKind::kAgent;
    // The partition: "partition" (1.1.0 on), "prefix" (this project's 1.0 files), else the id's character.
    PendingAgent a{id, node_prefix(id), {}};
    if (const json* p = optional_member(n, "partition")) a.prefix = static_cast<char>(as_uint(*p, path + ".partition", 255));
    else if (const json* q = optional_member(n, "prefix")) a.prefix = static_cast<char>(as_uint(*q, path + ".prefix", 255));
    if (a.prefix == 0) fail(path + ".partition", "an agent needs a non-zero partition");
    // The timestamp: among the attributes from 1.1.0 on, on the node before.
    if (const json* t = optional_member(attrs, "timestamp")) a.attributes.timestamp_ns = as_uint(*t, apath + ".timestamp");
    else if (const json* u = optional_member(n, "timestamp")) a.attributes.timestamp_ns = as_uint(*u, path + ".timestamp");
    else fail(apath + ".timestamp", "missing (an agent's timestamp, nor on the node as before 1.1.0)");
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
    const std::string vpath = "SPARK_DSG_header.version";
    const auto major = as_uint(member(version, "major", vpath), vpath + ".major", 255);
    if (major != 1) fail(vpath + ".major", "unsupported Spark-DSG major version " + std::to_string(major));
    doc.version[0] = 1;
    doc.version[1] = static_cast<int>(as_uint(member(version, "minor", vpath), vpath + ".minor", 255));
    doc.version[2] = static_cast<int>(as_uint(member(version, "patch", vpath), vpath + ".patch", 255));
  }
  // Label names before the nodes: room probabilities are keyed by them.
  if (const json* metadata = optional_member(root, "metadata")) read_labelspaces(*metadata, doc.labelspaces);
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
    // "points" (Spark-DSG 1.0.2 on) or "vertices" (before).
    if (const json* v = optional_member(*mesh, "points"); v != nullptr && v->is_array()) doc.ignored_mesh_vertices = v->size();
    else if (const json* w = optional_member(*mesh, "vertices"); w != nullptr && w->is_array()) doc.ignored_mesh_vertices = w->size();
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

std::string ImportTruncations::summary() const {
  std::string out;
  const auto add = [&](std::size_t n, const char* what) {
    if (n != 0) out += (out.empty() ? "" : ", ") + std::to_string(n) + " " + what;
  };
  const std::string places = std::to_string(kMaxPlaceConnections), rooms = std::to_string(kMaxRoomClasses);
  add(place_mesh_connections, ("place mesh connections past " + places).c_str());
  add(place_other_connections, ("place deformation/pcl connections or vertex labels past " + places).c_str());
  add(room_class_probabilities, ("room class probabilities past " + rooms + " (the least likely)").c_str());
  add(unknown_class_names, "room class probabilities keyed by an unknown class name");
  return out;
}

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
  std::copy(doc.version, doc.version + 3, result.version);
  result.labelspaces = std::move(doc.labelspaces);
  result.truncated = doc.truncated;
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

}  // namespace qsg::scene_graph
