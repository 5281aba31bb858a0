// Interoperability check against the real Spark-DSG (1.1.3, built from its source in the CI's Spark-DSG stage;
// test-only, never linked into the product):
//   1. Spark-DSG's loader reads the app's scene_graph.json, and every node, edge and typed attribute it reads
//      (timestamps and label names included) equals this project's own reading of the file;
//   2. what Spark-DSG saves of it (JSON and its binary format) reads back the same in both libraries;
//   3. the graph Spark-DSG 1.1.3 wrote itself (the shared fixture) reads the same in both, and this project's
//      rewrite of it loads in Spark-DSG with the same content;
//   4. with the app's mesh given: the graph written with the mesh embedded loads in Spark-DSG with that mesh, vertex
//      for vertex and face for face, and the objects' mesh connections index it.
//
//   spark_dsg_check APP_GRAPH.json FIXTURE_DIR OUT_DIR [APP_MESH.ply]
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>

#include <spark_dsg/dynamic_scene_graph.h>
#include <spark_dsg/edge_attributes.h>
#include <spark_dsg/labelspace.h>
#include <spark_dsg/node_attributes.h>

#include "core/reconstruction/ply_writer.h"
#include "core/scene_graph/spark_dsg_json.h"
#include "tests/interop/graph_fields.h"

namespace {

using namespace qsg;
using interop::Fields;
using interop::FlatGraph;

std::string join(const std::vector<std::uint64_t>& values) {
  std::string out;
  for (std::uint64_t v : values) out += (out.empty() ? "" : ",") + std::to_string(v);
  return out;
}
void put_vec3(Fields& f, const std::string& name, const double* v, bool as_float) {
  for (int k = 0; k < 3; ++k) {
    const std::string n = name + "[" + std::to_string(k) + "]";
    if (as_float) interop::put_float(f, n, v[k]);
    else interop::put_double(f, n, v[k]);
  }
}
void put_quat(Fields& f, const std::string& name, double w, double x, double y, double z) {
  interop::put_double(f, name + ".w", w);
  interop::put_double(f, name + ".x", x);
  interop::put_double(f, name + ".y", y);
  interop::put_double(f, name + ".z", z);
}
const char* kBoxTypes[] = {"INVALID", "AABB", "OBB", "RAABB"};
std::string name_of(const std::map<std::uint32_t, std::string>& space, std::uint32_t label) {
  const auto it = space.find(label);
  return it == space.end() ? "(no name)" : it->second;
}

// ---- this project's reading ------------------------------------------------------------------------------------

void put_semantic(Fields& f, const scene_graph::SemanticAttributes& s, const std::map<std::uint32_t, std::string>* space) {
  put_vec3(f, "position", s.position_m.data(), false);
  interop::put_int(f, "last_update_time_ns", s.last_update_time_ns);
  interop::put_bool(f, "is_active", s.is_active);
  interop::put_text(f, "name", std::string(s.name.c_str(), s.name.size()));
  for (int k = 0; k < 3; ++k) interop::put_int(f, "color[" + std::to_string(k) + "]", s.color[k]);
  interop::put_int(f, "semantic_label", s.semantic_label);
  if (space != nullptr) interop::put_text(f, "label_name", name_of(*space, s.semantic_label));
  const scene_graph::BoundingBox& b = s.bounding_box;
  interop::put_text(f, "bounding_box.type", kBoxTypes[static_cast<int>(b.type)]);
  if (b.type == scene_graph::BoundingBox::Type::kInvalid) return;
  const Eigen::Vector3d dims = b.max_m - b.min_m;
  put_vec3(f, "bounding_box.dimensions", dims.data(), true);
  put_vec3(f, "bounding_box.world_P_center", b.world_P_center_m.data(), true);
}

FlatGraph flatten(const scene_graph::SceneGraph& g, const scene_graph::LabelSpaces& spaces) {
  using namespace scene_graph;
  FlatGraph out;
  g.for_each_node([&](const NodeRecord& n) {
    Fields& f = out.nodes[n.id];
    interop::put_int(f, "layer", n.layer.layer);
    interop::put_int(f, "partition", static_cast<unsigned char>(n.layer.partition));
    switch (n.kind) {
      case NodeKind::kObject: {
        const ObjectAttributes& o = *g.object(n.id);
        interop::put_text(f, "type", "object");
        put_semantic(f, o, &spaces.objects);
        interop::put_bool(f, "registered", o.registered);
        put_quat(f, "world_R_object", o.world_R_object.w(), o.world_R_object.x(), o.world_R_object.y(), o.world_R_object.z());
        std::vector<std::uint64_t> mesh;
        g.for_each_mesh_connection(n.id, [&](std::uint32_t v) { mesh.push_back(v); });
        interop::put_text(f, "mesh_connections", join(mesh));
        break;
      }
      case NodeKind::kPlace: {
        const PlaceAttributes& p = *g.place(n.id);
        interop::put_text(f, "type", "place");
        put_semantic(f, p, nullptr);
        interop::put_double(f, "distance", p.distance_m);
        interop::put_int(f, "num_basis_points", p.num_basis_points);
        for (std::size_t i = 0; i < p.mesh_connections.size(); ++i) {
          const std::string c = "voxblox_mesh_connections[" + std::to_string(i) + "]";
          const PlaceMeshConnection& m = p.mesh_connections[i];
          interop::put_text(f, c + ".block", std::to_string(m.block.x) + "," + std::to_string(m.block.y) + "," +
                                                 std::to_string(m.block.z));
          interop::put_int(f, c + ".vertex", m.vertex);
          put_vec3(f, c + ".voxel_pos", m.voxel_pos_m.data(), false);
        }
        interop::put_text(f, "deformation_connections", join({p.deformation_connections.begin(), p.deformation_connections.end()}));
        interop::put_text(f, "pcl_mesh_connections", join({p.pcl_mesh_connections.begin(), p.pcl_mesh_connections.end()}));
        interop::put_text(f, "mesh_vertex_labels", join({p.mesh_vertex_labels.begin(), p.mesh_vertex_labels.end()}));
        break;
      }
      case NodeKind::kRoom: {
        const RoomAttributes& r = *g.room(n.id);
        interop::put_text(f, "type", "room");
        put_semantic(f, r, &spaces.rooms);
        for (const LabelProbability& lp : r.class_probabilities) {
          const auto it = spaces.rooms.find(lp.label);
          interop::put_double(f, "p[" + (it == spaces.rooms.end() ? std::to_string(lp.label) : it->second) + "]",
                              lp.probability);
        }
        break;
      }
      case NodeKind::kBuilding:
        interop::put_text(f, "type", "building");
        put_semantic(f, *g.building(n.id), nullptr);
        break;
      case NodeKind::kAgent: {
        const AgentAttributes& a = *g.agent(n.id);
        interop::put_text(f, "type", "agent");
        put_vec3(f, "position", a.position_m.data(), false);
        interop::put_int(f, "last_update_time_ns", a.last_update_time_ns);
        interop::put_bool(f, "is_active", a.is_active);
        interop::put_int(f, "timestamp_ns", a.timestamp_ns);
        put_quat(f, "world_R_body", a.world_R_body.w(), a.world_R_body.x(), a.world_R_body.y(), a.world_R_body.z());
        interop::put_int(f, "external_key", a.external_key);
        break;
      }
    }
  });
  g.for_each_edge([&](const EdgeRecord& e) {
    Fields& f = out.edges[{std::min(e.source, e.target), std::max(e.source, e.target)}];
    interop::put_double(f, "weight", e.info.weight);
    interop::put_bool(f, "weighted", e.info.weighted);
  });
  return out;
}

// ---- Spark-DSG's reading ---------------------------------------------------------------------------------------

void put_semantic(Fields& f, const spark_dsg::SemanticNodeAttributes& s, const spark_dsg::Labelspace* space) {
  put_vec3(f, "position", s.position.data(), false);
  interop::put_int(f, "last_update_time_ns", s.last_update_time_ns);
  interop::put_bool(f, "is_active", s.is_active);
  interop::put_text(f, "name", s.name);
  interop::put_int(f, "color[0]", s.color.r);
  interop::put_int(f, "color[1]", s.color.g);
  interop::put_int(f, "color[2]", s.color.b);
  interop::put_int(f, "semantic_label", s.semantic_label);
  if (space != nullptr) interop::put_text(f, "label_name", space->getCategory(s.semantic_label).value_or("(no name)"));
  const spark_dsg::BoundingBox& b = s.bounding_box;
  interop::put_text(f, "bounding_box.type", kBoxTypes[static_cast<int>(b.type)]);
  if (b.type == spark_dsg::BoundingBox::Type::INVALID) return;
  const Eigen::Vector3d dims = b.dimensions.cast<double>(), centre = b.world_P_center.cast<double>();
  put_vec3(f, "bounding_box.dimensions", dims.data(), true);
  put_vec3(f, "bounding_box.world_P_center", centre.data(), true);
}

void put_edge(FlatGraph& out, const spark_dsg::SceneGraphEdge& e) {
  Fields& f = out.edges[{std::min(e.source, e.target), std::max(e.source, e.target)}];
  interop::put_double(f, "weight", e.info->weight);
  interop::put_bool(f, "weighted", e.info->weighted);
}

void flatten_node(const spark_dsg::SceneGraphNode& node, const spark_dsg::Labelspace& objects,
                  const spark_dsg::Labelspace& rooms, Fields& f) {
  using namespace spark_dsg;
  interop::put_int(f, "layer", node.layer.layer);
  interop::put_int(f, "partition", node.layer.partition);
  const NodeAttributes* attrs = &node.attributes();
  if (const auto* o = dynamic_cast<const ObjectNodeAttributes*>(attrs)) {
    interop::put_text(f, "type", "object");
    put_semantic(f, *o, &objects);
    interop::put_bool(f, "registered", o->registered);
    put_quat(f, "world_R_object", o->world_R_object.w(), o->world_R_object.x(), o->world_R_object.y(), o->world_R_object.z());
    interop::put_text(f, "mesh_connections", join({o->mesh_connections.begin(), o->mesh_connections.end()}));
  } else if (const auto* p = dynamic_cast<const PlaceNodeAttributes*>(attrs)) {
    interop::put_text(f, "type", "place");
    put_semantic(f, *p, nullptr);
    interop::put_double(f, "distance", p->distance);
    interop::put_int(f, "num_basis_points", p->num_basis_points);
    for (std::size_t i = 0; i < p->voxblox_mesh_connections.size(); ++i) {
      const std::string c = "voxblox_mesh_connections[" + std::to_string(i) + "]";
      const NearestVertexInfo& m = p->voxblox_mesh_connections[i];
      interop::put_text(f, c + ".block", std::to_string(m.block[0]) + "," + std::to_string(m.block[1]) + "," +
                                             std::to_string(m.block[2]));
      interop::put_int(f, c + ".vertex", m.vertex);
      put_vec3(f, c + ".voxel_pos", m.voxel_pos, false);
    }
    interop::put_text(f, "deformation_connections", join({p->deformation_connections.begin(), p->deformation_connections.end()}));
    interop::put_text(f, "pcl_mesh_connections", join({p->pcl_mesh_connections.begin(), p->pcl_mesh_connections.end()}));
    interop::put_text(f, "mesh_vertex_labels", join({p->mesh_vertex_labels.begin(), p->mesh_vertex_labels.end()}));
  } else if (const auto* r = dynamic_cast<const RoomNodeAttributes*>(attrs)) {
    interop::put_text(f, "type", "room");
    put_semantic(f, *r, &rooms);
    for (const auto& [name, probability] : r->semantic_class_probabilities) interop::put_double(f, "p[" + name + "]", probability);
  } else if (const auto* a = dynamic_cast<const AgentNodeAttributes*>(attrs)) {
    interop::put_text(f, "type", "agent");
    put_vec3(f, "position", a->position.data(), false);
    interop::put_int(f, "last_update_time_ns", a->last_update_time_ns);
    interop::put_bool(f, "is_active", a->is_active);
    interop::put_int(f, "timestamp_ns", static_cast<std::uint64_t>(a->timestamp.count()));
    put_quat(f, "world_R_body", a->world_R_body.w(), a->world_R_body.x(), a->world_R_body.y(), a->world_R_body.z());
    interop::put_int(f, "external_key", a->external_key);
  } else if (const auto* s = dynamic_cast<const SemanticNodeAttributes*>(attrs)) {
    interop::put_text(f, "type", node.layer.layer == 5 ? "building" : "semantic node off the building layer");
    put_semantic(f, *s, nullptr);
  } else {
    interop::put_text(f, "type", "unexpected attributes");
  }
}

FlatGraph flatten(const spark_dsg::DynamicSceneGraph& g) {
  FlatGraph out;
  const auto objects = spark_dsg::Labelspace::fromMetadata(g, 2, 0);
  const auto rooms = spark_dsg::Labelspace::fromMetadata(g, 4, 0);
  for (const auto& [id, key] : g.node_lookup()) flatten_node(g.getNode(id), objects, rooms, out.nodes[id]);
  for (const auto& [layer_id, layer] : g.layers())
    for (const auto& [key, edge] : layer->edges()) put_edge(out, edge);
  for (const auto& [layer_id, partitions] : g.layer_partitions())
    for (const auto& [partition_id, partition] : partitions)
      for (const auto& [key, edge] : partition->edges()) put_edge(out, edge);
  for (const auto& [key, edge] : g.interlayer_edges()) put_edge(out, edge);
  return out;
}

// ---- the checks ------------------------------------------------------------------------------------------------

struct Ours {
  scene_graph::SceneGraph graph;
  scene_graph::JsonImportResult result;
};

bool read_ours(const std::string& path, Ours* ours) {
  std::string error;
  if (!ours->graph.init(scene_graph::capacities_from_budget(), scene_graph::arena_bytes_from_budget(), &error)) {
    std::fprintf(stderr, "spark_dsg_check: %s\n", error.c_str());
    return false;
  }
  ours->result = scene_graph::read_spark_dsg_json_file(path, ours->graph);
  if (!ours->result.ok) std::fprintf(stderr, "spark_dsg_check: our reader: %s\n", ours->result.error.c_str());
  return ours->result.ok;
}

spark_dsg::DynamicSceneGraph::Ptr load_spark(const std::string& path) {
  try {
    auto g = spark_dsg::DynamicSceneGraph::load(path);
    if (!g) std::fprintf(stderr, "spark_dsg_check: Spark-DSG loaded nothing from %s\n", path.c_str());
    return g;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "spark_dsg_check: Spark-DSG cannot load %s: %s\n", path.c_str(), e.what());
    return nullptr;
  }
}

// One comparison, printed; false when the readings differ anywhere.
bool agree(const std::string& what, const FlatGraph& a, const FlatGraph& b, const std::string& a_name,
           const std::string& b_name) {
  const interop::Comparison c = interop::compare(a, b, a_name, b_name);
  std::printf("%-4s %s: %zu nodes, %zu edges, %zu fields compared, %zu differences\n", c.differences == 0 ? "ok" : "FAIL",
              what.c_str(), c.nodes, c.edges, c.fields, c.differences);
  if (c.differences != 0) std::printf("%s", c.first_differences.c_str());
  return c.differences == 0 && c.nodes > 0;
}

bool check_file(const std::string& label, const std::string& path, const std::string& out_dir, const std::string& binary) {
  Ours ours;
  if (!read_ours(path, &ours)) return false;
  const FlatGraph mine = flatten(ours.graph, ours.result.labelspaces);
  bool ok = true;
  if (auto spark = load_spark(path)) {
    ok &= agree(label + ": Spark-DSG's load vs ours", flatten(*spark), mine, "spark_dsg", "ours");
    // What Spark-DSG saves of it, in its JSON and its binary format.
    const std::string saved_json = out_dir + "/" + label + ".saved_by_spark_dsg.json";
    const std::string saved_binary = out_dir + "/" + label + ".saved_by_spark_dsg.sparkdsg";
    spark->save(saved_json, false);
    spark->save(saved_binary, false);
    Ours back;
    ok &= read_ours(saved_json, &back) &&
          agree(label + ": our reading of Spark-DSG's save vs ours", flatten(back.graph, back.result.labelspaces), mine,
                "ours(saved)", "ours");
    if (auto binary_back = load_spark(saved_binary))
      ok &= agree(label + ": Spark-DSG's binary save reloaded vs ours", flatten(*binary_back), mine, "spark_dsg(bin)", "ours");
    else ok = false;
  } else {
    ok = false;
  }
  if (!binary.empty()) {
    if (auto b = load_spark(binary)) ok &= agree(label + ": Spark-DSG's binary file vs our reading of its JSON", flatten(*b), mine, "spark_dsg(bin)", "ours");
    else ok = false;
  }
  // Our rewrite of the file (the current layout, its label names through) in Spark-DSG.
  const std::string rewritten = out_dir + "/" + label + ".rewritten_by_us.json";
  scene_graph::JsonExportOptions options;
  options.labelspaces = &ours.result.labelspaces;
  std::string error;
  if (!scene_graph::write_spark_dsg_json_file(ours.graph, rewritten, &error, options)) {
    std::fprintf(stderr, "spark_dsg_check: %s\n", error.c_str());
    return false;
  }
  if (auto again = load_spark(rewritten)) ok &= agree(label + ": Spark-DSG's load of our rewrite vs ours", flatten(*again), mine, "spark_dsg", "ours");
  else ok = false;
  std::printf("     %s: Spark-DSG %d.%d.%d file, %zu nodes, %zu edges, %zu object and %zu room label names%s%s\n",
              label.c_str(), ours.result.version[0], ours.result.version[1], ours.result.version[2], ours.result.nodes,
              ours.result.edges, ours.result.labelspaces.objects.size(), ours.result.labelspaces.rooms.size(),
              ours.result.truncated.total() ? "; kept short: " : "", ours.result.truncated.summary().c_str());
  return ok;
}

// The app's graph written with its mesh embedded: Spark-DSG's mesh equals the PLY's, and every object's mesh
// connection is a vertex of it.
bool check_embedded_mesh(const std::string& graph_path, const std::string& mesh_path, const std::string& out_dir) {
  Ours ours;
  reconstruction::Mesh mesh;
  std::string error;
  if (!read_ours(graph_path, &ours)) return false;
  if (!reconstruction::read_ply(mesh_path, &mesh, &error)) {
    std::fprintf(stderr, "spark_dsg_check: %s\n", error.c_str());
    return false;
  }
  scene_graph::EmbeddedMesh embedded;
  for (const reconstruction::MeshVertex& v : mesh.vertices) {
    embedded.xyz.insert(embedded.xyz.end(), {v.x, v.y, v.z});
    embedded.rgb.insert(embedded.rgb.end(), {v.r, v.g, v.b});
    embedded.labels.push_back(v.label);
  }
  for (const reconstruction::MeshTriangle& t : mesh.triangles) embedded.faces.insert(embedded.faces.end(), t.v, t.v + 3);
  scene_graph::JsonExportOptions options;
  options.labelspaces = &ours.result.labelspaces;
  options.mesh = &embedded;
  const std::string path = out_dir + "/app_output.with_mesh.json";
  if (!scene_graph::write_spark_dsg_json_file(ours.graph, path, &error, options)) {
    std::fprintf(stderr, "spark_dsg_check: %s\n", error.c_str());
    return false;
  }
  const auto spark = load_spark(path);
  const auto m = spark ? spark->mesh() : nullptr;
  if (!m) {
    std::printf("FAIL app_output with its mesh embedded: Spark-DSG has no mesh\n");
    return false;
  }
  std::size_t differences = 0;
  if (m->numVertices() != mesh.vertices.size() || m->numFaces() != mesh.triangles.size()) ++differences;
  for (std::size_t i = 0; differences == 0 && i < mesh.vertices.size(); ++i) {
    const reconstruction::MeshVertex& v = mesh.vertices[i];
    const auto& p = m->pos(i);
    const auto& c = m->color(i);
    if (p.x() != v.x || p.y() != v.y || p.z() != v.z || c.r != v.r || c.g != v.g || c.b != v.b || m->label(i) != v.label)
      ++differences;
  }
  for (std::size_t i = 0; differences == 0 && i < mesh.triangles.size(); ++i)
    for (int k = 0; k < 3; ++k) differences += m->face(i)[k] != mesh.triangles[i].v[k] ? 1 : 0;
  std::size_t connections = 0;
  for (const auto& [id, key] : spark->node_lookup())
    if (const auto* o = dynamic_cast<const spark_dsg::ObjectNodeAttributes*>(&spark->getNode(id).attributes()))
      for (std::size_t v : o->mesh_connections) {
        ++connections;
        differences += v < m->numVertices() ? 0 : 1;
      }
  std::printf("%-4s app_output with its mesh embedded: Spark-DSG's mesh %zu vertices, %zu faces (the PLY's: %zu, %zu), "
              "%zu object mesh connections into it, %zu differences\n", differences == 0 ? "ok" : "FAIL",
              m->numVertices(), m->numFaces(), mesh.vertices.size(), mesh.triangles.size(), connections, differences);
  return differences == 0 && connections > 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4 && argc != 5) {
    std::fprintf(stderr, "usage: spark_dsg_check APP_GRAPH.json FIXTURE_DIR OUT_DIR [APP_MESH.ply]\n");
    return 2;
  }
  const std::string app_graph = argv[1], fixture_dir = argv[2], out_dir = argv[3];
  std::filesystem::create_directories(out_dir);
  bool ok = check_file("app_output", app_graph, out_dir, "");
  if (argc == 5) ok &= check_embedded_mesh(app_graph, argv[4], out_dir);
  const std::string fixture = fixture_dir + "/written_by_spark_dsg.json";
  if (std::filesystem::exists(fixture)) {
    ok &= check_file("fixture", fixture, out_dir, fixture_dir + "/written_by_spark_dsg.sparkdsg");
  } else {
    std::printf("skip fixture: %s not found\n", fixture.c_str());
  }
  std::printf("spark_dsg_check: %s\n", ok ? "every reading agrees" : "FAILED");
  return ok ? 0 : 1;
}
