// Spark-DSG 1.1.x layout: what the writer puts where Spark-DSG 1.1.3 reads it, the graph Spark-DSG itself wrote,
// and what the reader keeps, drops and counts.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/scene_graph/spark_dsg_json.h"
#include "tests/scene_graph/test_graph.h"
#include "tests/support/test_data.h"

namespace qsg::scene_graph {
namespace {

using json = nlohmann::json;
constexpr const char* kWrittenBySparkDsg = "scene_graphs/spark_dsg_1.1.3/written_by_spark_dsg.json";

const NodeId kObject = make_node_id('O', 0);
const NodeId kPlace = make_node_id('p', 1);
const NodeId kRoom = make_node_id('R', 0);
const NodeId kAgent = make_node_id('a', 3);

void build(SceneGraph& g) {
  ObjectAttributes o;
  o.position_m = {1.25, -2.5, 0.75};
  o.semantic_label = 5;
  o.bounding_box = BoundingBox::aabb({1, -3, 0}, {1.5, -2, 1.5});
  ASSERT_EQ(g.add_object(kObject, o), Status::kOk);
  for (std::uint32_t v = 0; v < 5; ++v) g.append_mesh_connection(kObject, 1000 + v);
  ASSERT_EQ(g.add_place(kPlace, testing::place_at(1.0, -2.0, 0.8)), Status::kOk);
  RoomAttributes r;
  r.semantic_label = 10;
  r.class_probabilities.push_back({10, 0.625f});
  r.class_probabilities.push_back({1, 0.25f});
  r.class_probabilities.push_back({7, 0.125f});  // no name in the label space below: keyed "7"
  ASSERT_EQ(g.add_room(kRoom, r), Status::kOk);
  AgentAttributes a;
  a.timestamp_ns = 1234567890123;
  ASSERT_EQ(g.add_agent(kAgent, 'a', a), Status::kOk);
  ASSERT_EQ(g.add_edge(kObject, kPlace), Status::kOk);
  ASSERT_EQ(g.add_edge(kAgent, kPlace), Status::kOk);
  ASSERT_EQ(g.add_edge(kRoom, kPlace), Status::kOk);
}

LabelSpaces label_spaces() {
  LabelSpaces s;
  s.objects = {{3, "chair"}, {5, "table"}};
  s.rooms = {{0, "unknown"}, {1, "bedroom"}, {10, "kitchen"}};
  return s;
}

const json& node_with_id(const json& doc, NodeId id) {
  for (const json& n : doc.at("nodes"))
    if (n.at("id").get<NodeId>() == id) return n;
  static const json none;
  ADD_FAILURE() << "no node " << node_label(id);
  return none;
}

TEST(SparkDsgLayoutTest, WritesWhereSparkDsg113Reads) {
  auto g = testing::make_graph();
  build(*g);
  const LabelSpaces spaces = label_spaces();
  JsonExportOptions options;
  options.labelspaces = &spaces;
  const json doc = json::parse(write_spark_dsg_json(*g, options));
  EXPECT_EQ(doc.at("SPARK_DSG_header"), (json{{"project_name", "main"}, {"version", {{"major", 1}, {"minor", 1}, {"patch", 3}}}}));
  // Every partition a node uses is a layer key (Spark-DSG 1.1.2 on builds its layers from them).
  EXPECT_EQ(doc.at("layer_keys"), json::parse(R"([{"layer":2,"partition":0},{"layer":2,"partition":97},
      {"layer":3,"partition":0},{"layer":4,"partition":0},{"layer":5,"partition":0}])"));
  EXPECT_EQ(doc.at("layer_names").at("AGENTS"), (json{{"layer", 2}, {"partition", 0}}));
  // Label names as Spark-DSG's Labelspace::fromMetadata reads them: [[label, name], ...] per layer key.
  EXPECT_EQ(doc.at("metadata").at("labelspaces").at("_l2p0"), json::parse(R"([[3,"chair"],[5,"table"]])"));
  EXPECT_EQ(doc.at("metadata").at("labelspaces").at("_l4p0"), json::parse(R"([[0,"unknown"],[1,"bedroom"],[10,"kitchen"]])"));
  const json& agent = node_with_id(doc, kAgent);
  EXPECT_EQ(agent.at("partition"), 97);
  EXPECT_EQ(agent.at("attributes").at("timestamp"), 1234567890123u);
  EXPECT_FALSE(agent.contains("timestamp")) << "1.1 keeps the timestamp among the attributes";
  const json& room = node_with_id(doc, kRoom).at("attributes");
  EXPECT_EQ(room.at("semantic_class_probabilities"), (json{{"kitchen", 0.625}, {"bedroom", 0.25}, {"7", 0.125}}));
  const json& object = node_with_id(doc, kObject).at("attributes");
  EXPECT_EQ(object.at("color"), (json{{"r", 0}, {"g", 0}, {"b", 0}, {"a", 255}}));
  EXPECT_EQ(object.at("bounding_box").at("dimensions"), json::parse("[0.5, 1.0, 1.5]"));
  EXPECT_EQ(object.at("bounding_box").at("world_P_center"), json::parse("[1.25, -2.5, 0.75]"));
  EXPECT_EQ(object.at("mesh_connections"), json::parse("[1000, 1001, 1002, 1003, 1004]"));
  EXPECT_EQ(node_with_id(doc, kPlace).at("partition"), 0);

  // Read back: label spaces, names turned back into labels, the timestamp; and the text is a fixed point.
  auto back = testing::make_graph();
  const JsonImportResult r = read_spark_dsg_json(doc.dump(), *back);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.labelspaces.objects, spaces.objects);
  EXPECT_EQ(r.labelspaces.rooms, spaces.rooms);
  EXPECT_EQ(r.truncated.total(), 0u) << r.truncated.summary();
  EXPECT_EQ(back->agent(kAgent)->timestamp_ns, 1234567890123u);
  EXPECT_EQ(back->node(kAgent)->layer.partition, 'a');
  const RoomAttributes* rr = back->room(kRoom);
  ASSERT_EQ(rr->class_probabilities.size(), 3u);
  EXPECT_EQ(rr->class_probabilities[0], (LabelProbability{10, 0.625f}));
  EXPECT_EQ(rr->class_probabilities[1], (LabelProbability{1, 0.25f}));
  EXPECT_EQ(rr->class_probabilities[2], (LabelProbability{7, 0.125f}));
  JsonExportOptions again;
  again.labelspaces = &r.labelspaces;
  EXPECT_EQ(write_spark_dsg_json(*back, again), doc.dump());
}

TEST(SparkDsgLayoutTest, ObjectMeshConnectionsAreGivenIndicesOrOmitted) {
  auto g = testing::make_graph();
  build(*g);
  JsonExportOptions omit;
  omit.write_stored_mesh_connections = false;
  EXPECT_FALSE(node_with_id(json::parse(write_spark_dsg_json(*g, omit)), kObject).at("attributes").contains("mesh_connections"));
  const ObjectMeshIndices indices{{kObject, {4, 8, 15}}};
  JsonExportOptions given;
  given.object_mesh_indices = &indices;
  const json doc = json::parse(write_spark_dsg_json(*g, given));
  EXPECT_EQ(node_with_id(doc, kObject).at("attributes").at("mesh_connections"), json::parse("[4, 8, 15]"));
  const ObjectMeshIndices none;
  given.object_mesh_indices = &none;
  EXPECT_EQ(node_with_id(json::parse(write_spark_dsg_json(*g, given)), kObject).at("attributes").at("mesh_connections"),
            json::array());
}

// The mesh embedded as Spark-DSG's Mesh JSON lays it out; our reader counts its vertices and keeps the graph.
TEST(SparkDsgLayoutTest, EmbedsTheMeshAsSparkDsgDoes) {
  auto g = testing::make_graph();
  build(*g);
  EmbeddedMesh mesh;
  mesh.xyz = {0, 0, 0, 1, 0, 0, 0, 1, 0.5f};
  mesh.rgb = {10, 20, 30, 40, 50, 60, 70, 80, 90};
  mesh.labels = {2, 2, 5};
  mesh.faces = {0, 1, 2};
  JsonExportOptions options;
  options.mesh = &mesh;
  const json doc = json::parse(write_spark_dsg_json(*g, options));
  const json& m = doc.at("mesh");
  EXPECT_EQ(m.at("header").at("version"), (json{{"major", 1}, {"minor", 1}, {"patch", 3}}));
  EXPECT_EQ(m.at("has_colors"), true);
  EXPECT_EQ(m.at("has_labels"), true);
  EXPECT_EQ(m.at("has_timestamps"), false);
  EXPECT_EQ(m.at("points"), json::parse("[[0, 0, 0], [1, 0, 0], [0, 1, 0.5]]"));
  EXPECT_EQ(m.at("colors")[2], (json{{"r", 70}, {"g", 80}, {"b", 90}, {"a", 255}}));
  EXPECT_EQ(m.at("labels"), json::parse("[2, 2, 5]"));
  EXPECT_EQ(m.at("faces"), json::parse("[[0, 1, 2]]"));
  auto back = testing::make_graph();
  const JsonImportResult r = read_spark_dsg_json(doc.dump(), *back);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.ignored_mesh_vertices, 3u);
  EXPECT_EQ(back->num_nodes(), g->num_nodes());
}

// What a fixed-capacity attribute cannot hold is dropped and counted, not a refusal of the whole file.
TEST(SparkDsgLayoutTest, TruncationsAreCountedNotRefused) {
  auto g = testing::make_graph();
  build(*g);
  json doc = json::parse(write_spark_dsg_json(*g));
  json& place = const_cast<json&>(node_with_id(doc, kPlace)).at("attributes");
  for (int i = 0; i < 5; ++i)
    place["voxblox_mesh_connections"].push_back({{"block", {i, 0, 0}}, {"vertex", i}, {"voxel_pos", {0.1 * i, 0.0, 0.0}}});
  place["deformation_connections"] = json::array({1, 2, 3, 4, 5, 6});
  json& room = const_cast<json&>(node_with_id(doc, kRoom)).at("attributes");
  room["semantic_class_probabilities"] = json::object();
  for (int k = 0; k < 20; ++k) room["semantic_class_probabilities"][std::to_string(k)] = 0.01 * (k + 1);
  room["semantic_class_probabilities"]["teapot room"] = 0.5;
  auto back = testing::make_graph();
  const JsonImportResult r = read_spark_dsg_json(doc.dump(), *back);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.truncated.place_mesh_connections, 1u);
  EXPECT_EQ(r.truncated.place_other_connections, 2u);
  EXPECT_EQ(r.truncated.room_class_probabilities, 4u);
  EXPECT_EQ(r.truncated.unknown_class_names, 1u);
  EXPECT_NE(r.truncated.summary().find("1 place mesh connections past 4"), std::string::npos) << r.truncated.summary();
  const PlaceAttributes* p = back->place(kPlace);
  ASSERT_EQ(p->mesh_connections.size(), kMaxPlaceConnections);
  EXPECT_EQ(p->mesh_connections[3].vertex, 3u);  // the first four, in the file's order
  const RoomAttributes* rr = back->room(kRoom);
  ASSERT_EQ(rr->class_probabilities.size(), kMaxRoomClasses);
  EXPECT_EQ(rr->class_probabilities[0].label, 19u);  // the most likely kept, in order
  EXPECT_EQ(rr->class_probabilities[kMaxRoomClasses - 1].label, 4u);
}

// This project's files before 1.1: the probabilities as a list, the timestamp and prefix on the agent's node,
// boxes as min and max, colours as arrays.
TEST(SparkDsgLayoutTest, ReadsTheOlderLayout) {
  const json doc = json::parse(R"({"directed": false, "layer_ids": [2, 3, 4, 5], "nodes": [
    {"id": 5908722711110090752, "layer": 4, "attributes": {"type": "RoomNodeAttributes", "position": [0, 0, 0],
      "color": [1, 2, 3], "bounding_box": {"type": "AABB", "min": [0, 0, 0], "max": [2, 4, 6]},
      "semantic_class_probabilities": [{"label": 3, "probability": 0.25}, {"label": 1, "probability": 0.75}]}},
    {"id": 6989586621679009795, "layer": 2, "prefix": 97, "timestamp": 42, "attributes": {
      "type": "AgentNodeAttributes", "position": [1, 2, 3], "world_R_body": {"w": 1, "x": 0, "y": 0, "z": 0}}}],
    "edges": []})");
  auto g = testing::make_graph();
  const JsonImportResult r = read_spark_dsg_json(doc.dump(), *g);
  ASSERT_TRUE(r.ok) << r.error;
  const RoomAttributes* room = g->room(make_node_id('R', 0));
  ASSERT_NE(room, nullptr);
  EXPECT_EQ(room->color, (std::array<std::uint8_t, 3>{{1, 2, 3}}));
  EXPECT_EQ(room->bounding_box.world_P_center_m, Eigen::Vector3d(1, 2, 3));
  ASSERT_EQ(room->class_probabilities.size(), 2u);
  EXPECT_EQ(room->class_probabilities[0], (LabelProbability{1, 0.75f}));
  EXPECT_EQ(g->agent(make_node_id('a', 3))->timestamp_ns, 42u);
  EXPECT_EQ(g->node(make_node_id('a', 3))->layer.partition, 'a');
}

// Every value of a valid 1.1.3 document replaced, one at a time, by each of a set of wrong values (other types,
// negative, huge, empty, out of the double range): each import ends in a graph or in an error naming a field, and
// a failed one leaves the graph as it was.
TEST(SparkDsgLayoutTest, AnyReplacedValueGivesAGraphOrANamedError) {
  auto g = testing::make_graph();
  build(*g);
  const LabelSpaces spaces = label_spaces();
  JsonExportOptions options;
  options.labelspaces = &spaces;
  const std::string valid = write_spark_dsg_json(*g, options);
  const json doc = json::parse(valid);
  auto target = testing::make_graph();
  ASSERT_TRUE(read_spark_dsg_json(valid, *target).ok);
  const std::string before = write_spark_dsg_json(*target);
  const std::vector<std::string> wrong = {"null", "\"x\"", "-1", "1e400", "18446744073709551616", "[]", "{}",
                                          "[1, 2, 3, 4, 5]", "0.5", "true"};
  std::size_t imports = 0, refused = 0;
  const json flat = doc.flatten();
  for (auto it = flat.begin(); it != flat.end(); ++it) {
    for (const std::string& w : wrong) {
      json changed = flat;
      changed[it.key()] = "@@WRONG@@";
      std::string text = changed.unflatten().dump();
      text.replace(text.find("\"@@WRONG@@\""), 11, w);
      const JsonImportResult r = read_spark_dsg_json(text, *target);
      ++imports;
      if (r.ok) {
        ASSERT_TRUE(read_spark_dsg_json(valid, *target).ok);  // back to the reference for the next case
        continue;
      }
      ++refused;
      ASSERT_FALSE(r.error.empty());
      EXPECT_TRUE(r.error.find(':') != std::string::npos) << it.key() << " = " << w << ": " << r.error;
      ASSERT_EQ(write_spark_dsg_json(*target), before) << it.key() << " = " << w << ": a failed import changed the graph";
    }
  }
  EXPECT_GT(imports, 1000u);
  EXPECT_GT(refused, imports / 2);
}

// The graph Spark-DSG 1.1.3 saved itself: every node and edge, agents in their partition, boxes from centre and
// dimensions, probabilities keyed by label number; and our own output of it is a fixed point.
TEST(SparkDsgLayoutTest, ReadsTheGraphSparkDsgWrote) {
  QSG_REQUIRE_SHARED_DATA(path, kWrittenBySparkDsg);
  std::ifstream in(path);
  const json doc = json::parse(in);
  std::map<NodeKind, std::size_t> expected;
  std::size_t mesh_connections = 0;
  for (const json& n : doc.at("nodes")) {
    const std::string type = n.at("attributes").at("type");
    const NodeKind kind = type == "ObjectNodeAttributes" ? NodeKind::kObject
                          : type == "PlaceNodeAttributes" ? NodeKind::kPlace
                          : type == "RoomNodeAttributes"  ? NodeKind::kRoom
                          : type == "AgentNodeAttributes" ? NodeKind::kAgent
                                                          : NodeKind::kBuilding;
    ++expected[kind];
    if (kind == NodeKind::kObject) mesh_connections += n.at("attributes").at("mesh_connections").size();
  }
  auto g = testing::make_graph(capacities_from_budget());
  const JsonImportResult r = read_spark_dsg_json_file(path, *g);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.version[0], 1);
  EXPECT_EQ(r.version[1], 1);
  EXPECT_EQ(r.version[2], 3);
  EXPECT_EQ(r.truncated.total(), 0u) << r.truncated.summary();
  for (const auto& [kind, count] : expected) EXPECT_EQ(g->num_nodes(kind), count) << static_cast<int>(kind);
  EXPECT_EQ(g->num_edges(), doc.at("edges").size());
  std::size_t connections_read = 0;
  g->for_each_node([&](const NodeRecord& n) {
    if (n.kind == NodeKind::kObject) connections_read += g->num_mesh_connections(n.id);
    if (n.kind == NodeKind::kAgent) {
      EXPECT_EQ(n.layer.partition, 'a');
    }
  });
  EXPECT_EQ(connections_read, mesh_connections);
  // A room's probabilities and an object's box, against the file's values.
  for (const json& n : doc.at("nodes")) {
    const json& a = n.at("attributes");
    const NodeId id = n.at("id").get<NodeId>();
    if (a.at("type") == "RoomNodeAttributes") {
      const RoomAttributes* room = g->room(id);
      ASSERT_EQ(room->class_probabilities.size(), a.at("semantic_class_probabilities").size());
      for (const LabelProbability& lp : room->class_probabilities)
        EXPECT_FLOAT_EQ(lp.probability, a["semantic_class_probabilities"][std::to_string(lp.label)].get<double>());
    } else if (a.at("type") == "ObjectNodeAttributes") {
      const BoundingBox& b = g->object(id)->bounding_box;
      EXPECT_EQ(b.type, BoundingBox::Type::kAabb);
      for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(b.max_m[k] - b.min_m[k], a["bounding_box"]["dimensions"][k].get<double>(), 1e-12);
        EXPECT_DOUBLE_EQ(b.world_P_center_m[k], a["bounding_box"]["world_P_center"][k].get<double>());
      }
    }
  }
  const std::string ours = write_spark_dsg_json(*g);
  auto back = testing::make_graph(capacities_from_budget());
  const JsonImportResult r2 = read_spark_dsg_json(ours, *back);
  ASSERT_TRUE(r2.ok) << r2.error;
  EXPECT_EQ(write_spark_dsg_json(*back), ours);
}

}  // namespace
}  // namespace qsg::scene_graph
