// Spark-DSG JSON: the reference library's own file round-trips; malformed input fails cleanly and changes nothing.
#include "core/scene_graph/spark_dsg_json.h"

#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/json/json_guard.h"
#include "tests/scene_graph/test_graph.h"
#include "tests/support/test_data.h"

namespace qsg::scene_graph {
namespace {

using json = nlohmann::json;
constexpr const char* kApartment = "scene_graphs/apartment_dsg.json";

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A small graph built through the API, covering every node kind and attribute.
void build_sample(SceneGraph& g) {
  ObjectAttributes o;
  o.position_m = {1.25, -2.5, 0.75};
  o.name.assign("O(0)", 4);
  o.color = {{10, 20, 30}};
  o.semantic_label = 5;
  o.registered = true;
  o.bounding_box = BoundingBox::aabb({1, -3, 0}, {1.5, -2, 1.5});
  ASSERT_EQ(g.add_object(make_node_id('O', 0), o), Status::kOk);
  for (std::uint32_t v = 0; v < 40; ++v) g.append_mesh_connection(make_node_id('O', 0), 7 * v);
  PlaceAttributes p = testing::place_at(1.0, -2.0, 0.8);
  p.num_basis_points = 2;
  p.mesh_connections.push_back({{-9, -2, 0}, 463, {-13.15, -2.45, 0.98}});
  p.deformation_connections.push_back(3);
  ASSERT_EQ(g.add_place(make_node_id('p', 1), p), Status::kOk);
  ASSERT_EQ(g.add_place(make_node_id('p', 2), testing::place_at(2.0, -2.0, 1.1)), Status::kOk);
  RoomAttributes r;
  r.name.assign("R(0)", 4);
  r.semantic_label = 3;
  r.class_probabilities.push_back({3, 0.75f});
  r.class_probabilities.push_back({1, 0.25f});
  ASSERT_EQ(g.add_room(make_node_id('R', 0), r), Status::kOk);
  ASSERT_EQ(g.add_building(make_node_id('B', 0), BuildingAttributes{}), Status::kOk);
  AgentAttributes a;
  a.timestamp_ns = 123456789;
  a.world_R_body = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  ASSERT_EQ(g.add_agent(make_node_id('a', 0), 'a', a), Status::kOk);
  ASSERT_EQ(g.add_edge(make_node_id('p', 1), make_node_id('p', 2), {0.7, true}), Status::kOk);
  ASSERT_EQ(g.add_edge(make_node_id('O', 0), make_node_id('p', 1)), Status::kOk);
  ASSERT_EQ(g.add_edge(make_node_id('a', 0), make_node_id('p', 2)), Status::kOk);
  ASSERT_EQ(g.add_edge(make_node_id('R', 0), make_node_id('p', 1)), Status::kOk);
  ASSERT_EQ(g.add_edge(make_node_id('R', 0), make_node_id('p', 2)), Status::kOk);
  ASSERT_EQ(g.add_edge(make_node_id('B', 0), make_node_id('R', 0)), Status::kOk);
}

// Node id -> node JSON, and the set of undirected edges with their info, for order-free comparison.
std::map<std::uint64_t, json> nodes_by_id(const json& doc) {
  std::map<std::uint64_t, json> out;
  for (const json& n : doc.at("nodes")) out[n.at("id").get<std::uint64_t>()] = n;
  return out;
}
std::map<std::pair<std::uint64_t, std::uint64_t>, json> edges_by_key(const json& doc) {
  std::map<std::pair<std::uint64_t, std::uint64_t>, json> out;
  for (const json& e : doc.at("edges")) {
    auto a = e.at("source").get<std::uint64_t>();
    auto b = e.at("target").get<std::uint64_t>();
    out[{std::min(a, b), std::max(a, b)}] = e.at("info");
  }
  return out;
}

TEST(SparkDsgJsonTest, ReadsTheReferenceApartmentGraph) {
  QSG_REQUIRE_SHARED_DATA(path, kApartment);
  auto g = testing::make_graph(capacities_from_budget());
  const JsonImportResult r = read_spark_dsg_json_file(path, *g);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(g->num_nodes(NodeKind::kRoom), 1u);
  EXPECT_EQ(g->num_nodes(NodeKind::kObject), 7u);
  EXPECT_EQ(g->num_nodes(NodeKind::kPlace), 185u);
  EXPECT_EQ(g->num_nodes(NodeKind::kAgent), 102u);
  EXPECT_EQ(g->num_nodes(NodeKind::kBuilding), 1u);
  EXPECT_EQ(g->num_edges(), 742u);
  // Spot checks against values in the file.
  const PlaceAttributes* p = g->place(8070450532247928838ULL);
  ASSERT_NE(p, nullptr);
  EXPECT_DOUBLE_EQ(p->distance_m, 0.800000011920929);
  EXPECT_EQ(p->num_basis_points, 4u);
  EXPECT_EQ(p->mesh_connections.size(), 4u);
  EXPECT_EQ(g->num_mesh_connections(5692549928996306944ULL), 33754u);
  const AgentAttributes* a = g->agent(6989586621679009792ULL);
  ASSERT_NE(a, nullptr);
  EXPECT_EQ(a->timestamp_ns, 3647910000u);
  EXPECT_EQ(g->node(6989586621679009792ULL)->layer.partition, 'a');
  EXPECT_EQ(g->parent(8070450532247928838ULL), make_node_id('R', 0));
}

// The real Hydra file (1.0 layout) comes out in the 1.1.3 layout with every value it had, and that output is a
// fixed point: read and written again it gives the same text.
TEST(SparkDsgJsonTest, ApartmentConvertsToTheCurrentLayoutLosslessly) {
  QSG_REQUIRE_SHARED_DATA(path, kApartment);
  auto first = testing::make_graph(capacities_from_budget());
  const JsonImportResult in = read_spark_dsg_json_file(path, *first);
  ASSERT_TRUE(in.ok) << in.error;
  EXPECT_EQ(in.version[0], 1);
  EXPECT_EQ(in.version[1], 0);  // no header: the legacy layout
  EXPECT_EQ(in.truncated.total(), 0u) << in.truncated.summary();
  const std::string written = write_spark_dsg_json(*first);

  const json original = json::parse(read_text(path));
  const json ours = json::parse(written);
  EXPECT_EQ(ours.at("SPARK_DSG_header").at("version"), (json{{"major", 1}, {"minor", 1}, {"patch", 3}}));
  const auto on = nodes_by_id(original);
  const auto wn = nodes_by_id(ours);
  ASSERT_EQ(on.size(), wn.size());
  for (const auto& [id, node] : on) {
    ASSERT_EQ(wn.count(id), 1u) << node_label(id);
    const json& a = node.at("attributes");
    const json& b = wn.at(id).at("attributes");
    SCOPED_TRACE(node_label(id));
    EXPECT_EQ(b.at("type"), a.at("type"));
    EXPECT_EQ(wn.at(id).at("layer"), node.at("layer"));
    EXPECT_EQ(b.at("position"), a.at("position"));
    EXPECT_EQ(b.at("last_update_time_ns"), a.at("last_update_time_ns"));
    if (a.at("type") == "AgentNodeAttributes") {
      EXPECT_EQ(b.at("timestamp"), node.at("timestamp"));  // moved from the node into the attributes
      EXPECT_EQ(wn.at(id).at("partition"), node.at("prefix"));
      EXPECT_EQ(b.at("world_R_body"), a.at("world_R_body"));
      EXPECT_EQ(b.at("external_key"), a.at("external_key"));
      continue;
    }
    EXPECT_EQ(wn.at(id).at("partition"), 0);
    EXPECT_EQ(b.at("color"), (json{{"r", a["color"][0]}, {"g", a["color"][1]}, {"b", a["color"][2]}, {"a", 255}}));
    EXPECT_EQ(b.at("semantic_label"), a.at("semantic_label"));
    EXPECT_EQ(b.at("name"), a.at("name"));
    EXPECT_EQ(b.at("bounding_box").at("type"), a.at("bounding_box").at("type"));
    if (a.at("bounding_box").at("type") != "INVALID") {
      for (const char* key : {"min", "max", "world_P_center", "world_R_center"})
        EXPECT_EQ(b.at("bounding_box").at(key), a.at("bounding_box").at(key)) << key;
      for (int k = 0; k < 3; ++k)
        EXPECT_DOUBLE_EQ(b["bounding_box"]["dimensions"][k].get<double>(),
                         a["bounding_box"]["max"][k].get<double>() - a["bounding_box"]["min"][k].get<double>());
    }
    for (const char* key : {"mesh_connections", "registered", "world_R_object", "distance", "num_basis_points",
                            "voxblox_mesh_connections", "deformation_connections", "mesh_vertex_labels",
                            "pcl_mesh_connections"})
      if (a.contains(key)) {
        EXPECT_EQ(b.at(key), a.at(key)) << key;
      }
  }
  EXPECT_EQ(edges_by_key(original), edges_by_key(ours));
  for (const char* key : {"directed", "multigraph"}) EXPECT_EQ(ours.at(key), original.at(key)) << key;

  // Reading our output gives the same graph again (and the same text).
  auto second = testing::make_graph(capacities_from_budget());
  const JsonImportResult r = read_spark_dsg_json(written, *second);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.version[1], 1);
  EXPECT_EQ(write_spark_dsg_json(*second), written);
}

TEST(SparkDsgJsonTest, BuiltGraphRoundTrips) {
  auto g = testing::make_graph();
  build_sample(*g);
  const std::string text = write_spark_dsg_json(*g, {2});
  auto back = testing::make_graph();
  const JsonImportResult r = read_spark_dsg_json(text, *back);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(write_spark_dsg_json(*back, {2}), text);
  EXPECT_EQ(back->num_mesh_connections(make_node_id('O', 0)), 40u);
  EXPECT_EQ(back->room(make_node_id('R', 0))->class_probabilities.size(), 2u);
  EXPECT_EQ(back->parent(make_node_id('R', 0)), make_node_id('B', 0));
}

// A snapshot written as a loop-closure correction puts the graph: positions through the callback, boxes moved with
// their node, the graph itself unchanged.
TEST(SparkDsgJsonTest, CorrectedPositionsMoveNodesAndTheirBoxes) {
  auto g = testing::make_graph();
  build_sample(*g);
  const std::string plain = write_spark_dsg_json(*g);
  JsonExportOptions options;
  std::size_t calls = 0;
  options.correct_position = [&](NodeId, NodeKind kind, const Eigen::Vector3d& p, std::uint64_t) {
    ++calls;
    return kind == NodeKind::kAgent ? p : Eigen::Vector3d(p + Eigen::Vector3d(1.0, -2.0, 0.5));
  };
  const nlohmann::json before = nlohmann::json::parse(plain), after = nlohmann::json::parse(write_spark_dsg_json(*g, options));
  EXPECT_EQ(calls, g->num_nodes());
  ASSERT_EQ(before["nodes"].size(), after["nodes"].size());
  std::size_t boxes = 0;
  for (std::size_t i = 0; i < before["nodes"].size(); ++i) {
    const nlohmann::json& a = before["nodes"][i]["attributes"];
    const nlohmann::json& b = after["nodes"][i]["attributes"];
    const bool agent = a.value("type", "") == "AgentNodeAttributes";
    const double dx = agent ? 0.0 : 1.0;
    EXPECT_NEAR(b["position"][0].get<double>() - a["position"][0].get<double>(), dx, 1e-9);
    EXPECT_NEAR(b["position"][1].get<double>() - a["position"][1].get<double>(), agent ? 0.0 : -2.0, 1e-9);
    if (!a.contains("bounding_box") || !a["bounding_box"].contains("min")) continue;
    ++boxes;
    EXPECT_NEAR(b["bounding_box"]["min"][0].get<double>() - a["bounding_box"]["min"][0].get<double>(), dx, 1e-9);
    EXPECT_NEAR(b["bounding_box"]["max"][2].get<double>() - a["bounding_box"]["max"][2].get<double>(), 0.5, 1e-9);
    EXPECT_NEAR(b["bounding_box"]["world_P_center"][1].get<double>() -
                    a["bounding_box"]["world_P_center"][1].get<double>(), -2.0, 1e-9);
  }
  EXPECT_GT(boxes, 0u) << "the sample graph has boxed nodes";
  EXPECT_EQ(write_spark_dsg_json(*g), plain) << "the graph itself is unchanged";
}

class MalformedJsonTest : public ::testing::Test {
 protected:
  void SetUp() override {
    graph_ = testing::make_graph();
    build_sample(*graph_);
    valid_ = json::parse(write_spark_dsg_json(*graph_));
    before_ = write_spark_dsg_json(*graph_);
  }
  // Import must fail with an error naming `field`, and leave the graph exactly as it was.
  void expect_rejected(const std::string& text, const std::string& field) {
    const JsonImportResult r = read_spark_dsg_json(text, *graph_);
    EXPECT_FALSE(r.ok);
    EXPECT_NE(r.error.find(field), std::string::npos) << "error '" << r.error << "' does not name '" << field << "'";
    EXPECT_EQ(write_spark_dsg_json(*graph_), before_) << "a failed import changed the graph";
  }
  json node_of_type(const char* type) {
    for (const json& n : valid_["nodes"])
      if (n["attributes"]["type"] == type) return n;
    return {};
  }
  std::size_t index_of_type(const char* type) {
    for (std::size_t i = 0; i < valid_["nodes"].size(); ++i)
      if (valid_["nodes"][i]["attributes"]["type"] == type) return i;
    return 0;
  }
  std::unique_ptr<SceneGraph> graph_;
  json valid_;
  std::string before_;
};

TEST_F(MalformedJsonTest, TruncatedAtEveryTenthByteFailsCleanly) {
  const std::string text = valid_.dump();
  for (std::size_t cut = 0; cut < text.size(); cut += text.size() / 97 + 1) {
    SCOPED_TRACE(cut);
    expect_rejected(text.substr(0, cut), "(document)");
  }
}

TEST_F(MalformedJsonTest, WrongTypesNameTheField) {
  const std::size_t place = index_of_type("PlaceNodeAttributes");
  const std::string prefix = "nodes[" + std::to_string(place) + "].attributes.";
  json doc = valid_;
  doc["nodes"][place]["attributes"]["position"] = json::array({1, 2});
  expect_rejected(doc.dump(), prefix + "position");
  doc = valid_;
  doc["nodes"][place]["attributes"]["distance"] = "far";
  expect_rejected(doc.dump(), prefix + "distance");
  doc = valid_;
  doc["nodes"][place]["attributes"].erase("distance");
  expect_rejected(doc.dump(), prefix + "distance");
  doc = valid_;
  doc["nodes"][place]["attributes"]["color"] = json::array({1, 2, 300});
  expect_rejected(doc.dump(), prefix + "color[2]");
  doc = valid_;
  doc["nodes"][place]["attributes"]["bounding_box"]["type"] = "SPHERE";
  expect_rejected(doc.dump(), prefix + "bounding_box.type");
  doc = valid_;
  doc["nodes"][place]["attributes"]["type"] = "TeapotNodeAttributes";
  expect_rejected(doc.dump(), prefix + "type");
  doc = valid_;
  doc["nodes"][place]["layer"] = 4;
  expect_rejected(doc.dump(), "nodes[" + std::to_string(place) + "].layer");
  doc = valid_;
  doc["nodes"][place]["attributes"]["name"] = std::string(100, 'x');
  expect_rejected(doc.dump(), prefix + "name");
  const std::size_t agent = index_of_type("AgentNodeAttributes");
  doc = valid_;
  doc["nodes"][agent]["attributes"]["world_R_body"]["w"] = 3.0;
  expect_rejected(doc.dump(), "nodes[" + std::to_string(agent) + "].attributes.world_R_body");
  doc = valid_;
  doc["nodes"][agent]["attributes"].erase("timestamp");
  expect_rejected(doc.dump(), "nodes[" + std::to_string(agent) + "].attributes.timestamp");
  doc = valid_;
  doc["nodes"][agent]["attributes"]["timestamp"] = -5;
  expect_rejected(doc.dump(), "nodes[" + std::to_string(agent) + "].attributes.timestamp");
  doc = valid_;
  doc["nodes"][place]["attributes"]["bounding_box"].erase("min");
  doc["nodes"][place]["attributes"]["bounding_box"].erase("max");
  doc["nodes"][place]["attributes"]["bounding_box"]["type"] = "AABB";
  doc["nodes"][place]["attributes"]["bounding_box"]["dimensions"] = json::array({1.0, -1.0, 1.0});
  expect_rejected(doc.dump(), prefix + "bounding_box.dimensions");
  doc["nodes"][place]["attributes"]["bounding_box"].erase("dimensions");
  expect_rejected(doc.dump(), prefix + "bounding_box.dimensions");
  const std::size_t room = index_of_type("RoomNodeAttributes");
  doc = valid_;
  doc["nodes"][room]["attributes"]["semantic_class_probabilities"]["kitchen"] = "likely";
  expect_rejected(doc.dump(), "nodes[" + std::to_string(room) + "].attributes.semantic_class_probabilities.kitchen");
  doc = valid_;
  doc["nodes"][place]["partition"] = 3;
  expect_rejected(doc.dump(), "nodes[" + std::to_string(place) + "].partition");
  doc = valid_;
  doc["metadata"] = {{"labelspaces", {{"_l4p0", json::array({json::array({1, 2})})}}}};
  expect_rejected(doc.dump(), "metadata.labelspaces._l4p0[0][1]");
  doc = valid_;
  doc["SPARK_DSG_header"]["version"]["minor"] = "one";
  expect_rejected(doc.dump(), "SPARK_DSG_header.version.minor");
  doc = valid_;
  doc.erase("nodes");
  expect_rejected(doc.dump(), "nodes");
  expect_rejected("[1, 2, 3]", "(document)");
}

// Regression (issue 36): a number outside the double range escaped the reader as an exception and aborted
// `qsg_app --convert`.
TEST_F(MalformedJsonTest, NumberOutsideTheDoubleRangeIsANamedError) {
  std::string text = valid_.dump();
  const std::string key = "\"distance\":";
  std::size_t at = text.find(key);
  ASSERT_NE(at, std::string::npos);
  at += key.size();
  const std::size_t end = text.find_first_of(",}", at);
  text.replace(at, end - at, "1e400");
  expect_rejected(text, "(document): a number outside the double range");
  expect_rejected(text, "1e400");
  expect_rejected("{\"nodes\": [], \"edges\": [], \"x\": -1e400}", "number overflow");
}

// Deep nesting is refused while parsing, by a named limit, instead of recursing through it.
TEST_F(MalformedJsonTest, NestingDeeperThanTheLimitIsANamedError) {
  const int depth = 100000;
  const std::string text =
      "{\"nodes\": [], \"edges\": [], \"mesh\": " + std::string(depth, '[') + std::string(depth, ']') + "}";
  expect_rejected(text, "mesh");
  expect_rejected(text, "nested deeper than " + std::to_string(json_guard::kDefaultMaxDepth) + " levels");
}

TEST_F(MalformedJsonTest, GraphRuleViolationsAreRejectedBeforeAnyChange) {
  json doc = valid_;
  doc["nodes"].push_back(doc["nodes"][0]);  // duplicate id
  expect_rejected(doc.dump(), "duplicate node id");
  doc = valid_;
  doc["edges"].push_back(doc["edges"][0]);
  expect_rejected(doc.dump(), "duplicate edge");
  doc = valid_;
  doc["edges"].push_back({{"source", make_node_id('p', 1)}, {"target", make_node_id('p', 77)}});
  expect_rejected(doc.dump(), "edges[" + std::to_string(valid_["edges"].size()) + "].target");
  // A second room would give p(1) a second parent.
  doc = valid_;
  json room = node_of_type("RoomNodeAttributes");
  room["id"] = make_node_id('R', 5);
  doc["nodes"].push_back(room);
  doc["edges"].push_back({{"source", make_node_id('R', 5)}, {"target", make_node_id('p', 1)}});
  expect_rejected(doc.dump(), "single-parent rule");
  // Locality: an object joined straight to a room.
  doc = valid_;
  doc["edges"].push_back({{"source", make_node_id('O', 0)}, {"target", make_node_id('R', 0)}});
  expect_rejected(doc.dump(), "layers not adjacent");
}

TEST_F(MalformedJsonTest, DocumentOverCapacityIsRejectedWhole) {
  json doc = valid_;
  const json place = node_of_type("PlaceNodeAttributes");
  for (int i = 0; i < 600; ++i) {  // small_capacities() holds 512 places
    json p = place;
    p["id"] = make_node_id('p', 1000 + i);
    doc["nodes"].push_back(p);
  }
  expect_rejected(doc.dump(), "nodes (places)");
}

TEST(SparkDsgJsonFileTest, MissingFileIsAClearError) {
  auto g = testing::make_graph();
  const JsonImportResult r = read_spark_dsg_json_file("/nonexistent/graph.json", *g);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("cannot open"), std::string::npos);
}

}  // namespace
}  // namespace qsg::scene_graph
