// H-tree tests: Algorithm 1 and the split H-tree are trees and valid tree decompositions on every graph built.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/neural_tree/h_tree.h"
#include "tests/support/allocation_counter.h"
#include "tests/support/test_data.h"

namespace qsg::neural_tree {
namespace {

std::vector<std::int32_t> all_vertices(const LayeredGraph& g) {
  std::vector<std::int32_t> v(static_cast<std::size_t>(g.num_nodes()));
  for (int i = 0; i < g.num_nodes(); ++i) v[i] = i;
  return v;
}

void add(LayeredGraph* g, int a, int b) {
  g->edge_a.push_back(a);
  g->edge_b.push_back(b);
}

// Builds both decompositions and checks them; returns the top-level width.
int check_all(const LayeredGraph& g, HTreeBuilder* builder) {
  BagTree td;
  std::string error;
  const auto vertices = all_vertices(g);
  td.begin.reserve(4096);
  td.members.reserve(65536);
  td.edge_parent.reserve(4096);
  td.edge_child.reserve(4096);
  EXPECT_TRUE(builder->hierarchical_decomposition(g, vertices.data(), g.num_nodes(), &td, &error)) << error;
  EXPECT_EQ(check_tree_decomposition(g, vertices, td), "");
  HTree h;
  EXPECT_TRUE(builder->build(g, &h, &error)) << error;
  EXPECT_EQ(check_h_tree(g, h), "");
  EXPECT_EQ(h.width, td.width());
  // Every split bag's children form a decomposition of that bag: the leaves under it cover it.
  return h.width;
}

// The paper's Fig. "tree decomposition" example: building B1, rooms R1..R4, objects O1..O8.
LayeredGraph paper_example() {
  LayeredGraph g;
  g.layers = {NodeLayer::kBuilding, NodeLayer::kRoom, NodeLayer::kRoom, NodeLayer::kRoom, NodeLayer::kRoom};
  for (int i = 0; i < 8; ++i) g.layers.push_back(NodeLayer::kObject);
  for (int r = 1; r <= 4; ++r) add(&g, 0, r);
  add(&g, 1, 2);
  add(&g, 2, 3);
  add(&g, 3, 4);
  add(&g, 4, 1);  // a cycle of rooms: width 2 in the room layer
  for (int o = 0; o < 8; ++o) add(&g, 5 + o, 1 + o / 2);
  add(&g, 5, 6);
  add(&g, 9, 10);
  return g;
}

TEST(HTree, PaperExampleIsValidAndNarrow) {
  HTreeBuilder builder;
  const LayeredGraph g = paper_example();
  const int width = check_all(g, &builder);
  // Room cycle (tw 2) plus the building in every room bag: 3; object bags {o, o', room, ...} stay smaller.
  EXPECT_EQ(width, 3);
  HTree h;
  std::string error;
  ASSERT_TRUE(builder.build(g, &h, &error)) << error;
  int room_leaves = 0, object_leaves = 0;
  for (int k = 0; k < h.num_nodes(); ++k) {
    room_leaves += h.types[k] == kLeafRoom;
    object_leaves += h.types[k] == kLeafObject;
  }
  EXPECT_GE(room_leaves, 4);
  EXPECT_GE(object_leaves, 8);
}

TEST(HTree, NonCliqueBagsAreSplitFurther) {
  // One room with a 4-cycle of objects: the cycle is not a clique, so the room-object bags split again.
  LayeredGraph g;
  g.layers = {NodeLayer::kRoom, NodeLayer::kObject, NodeLayer::kObject, NodeLayer::kObject, NodeLayer::kObject};
  for (int o = 1; o <= 4; ++o) add(&g, 0, o);
  add(&g, 1, 2);
  add(&g, 2, 3);
  add(&g, 3, 4);
  add(&g, 4, 1);
  HTreeBuilder builder;
  EXPECT_EQ(check_all(g, &builder), 3);  // {room, o, o', o''}: the 4-cycle triangulated, plus the room
  HTree h;
  std::string error;
  ASSERT_TRUE(builder.build(g, &h, &error)) << error;
  for (int k = 0; k < h.num_nodes(); ++k) EXPECT_LE(h.tree.bag_size(k), 4);
}

TEST(HTree, EmptyAndSingleNodeGraphs) {
  HTreeBuilder builder;
  HTree h;
  std::string error;
  LayeredGraph g;
  EXPECT_TRUE(builder.build(g, &h, &error));
  EXPECT_EQ(h.num_nodes(), 0);
  g.layers = {NodeLayer::kRoom};
  EXPECT_TRUE(builder.build(g, &h, &error));
  EXPECT_EQ(h.num_nodes(), 1);
  EXPECT_EQ(check_h_tree(g, h), "");
}

// The check itself must be able to fail: merging identical separators makes a cycle; a vertex's bags split; an
// edge in no bag.
TEST(HTree, CheckRejectsInvalidDecompositions) {
  LayeredGraph g;
  g.layers = {NodeLayer::kObject, NodeLayer::kObject, NodeLayer::kObject, NodeLayer::kObject};
  add(&g, 0, 1);
  add(&g, 1, 2);
  add(&g, 2, 3);
  const std::vector<std::int32_t> v = {0, 1, 2, 3};
  BagTree t;
  auto bag = [&](std::initializer_list<int> m) {
    for (int x : m) t.members.push_back(x);
    t.begin.push_back(static_cast<std::int32_t>(t.members.size()));
  };
  bag({0, 1});
  bag({1, 2});
  bag({2, 3});
  t.edge_parent = {0, 1};
  t.edge_child = {1, 2};
  EXPECT_EQ(check_tree_decomposition(g, v, t), "");
  t.edge_parent = {0, 1, 2};
  t.edge_child = {1, 2, 0};
  EXPECT_NE(check_tree_decomposition(g, v, t).find("not a tree"), std::string::npos);
  t.edge_parent = {0, 1};
  t.edge_child = {2, 2};  // {0,1} - {2,3} - {1,2}: vertex 1's bags are not connected
  EXPECT_NE(check_tree_decomposition(g, v, t).find("not connected"), std::string::npos);
  add(&g, 0, 3);
  t.edge_parent = {0, 1};
  t.edge_child = {1, 2};
  EXPECT_NE(check_tree_decomposition(g, v, t).find("in no bag"), std::string::npos);
}

TEST(HTree, CapacityExceededIsAnErrorNotACrash) {
  HTreeBuilder::Config config;
  config.max_graph_nodes = 8;
  HTreeBuilder builder(config);
  const LayeredGraph g = paper_example();  // 13 nodes
  HTree h;
  std::string error;
  EXPECT_FALSE(builder.build(g, &h, &error));
  EXPECT_NE(error.find("max_graph_nodes"), std::string::npos) << error;
  EXPECT_EQ(h.num_nodes(), 0);
}

// Random hierarchical graphs: buildings of rooms with random room-room and object-object edges, some dense.
TEST(HTree, RandomHierarchicalGraphsAreValid) {
  std::uint32_t state = 7;
  auto next = [&state]() {
    state = state * 1664525u + 1013904223u;
    return state >> 8;
  };
  HTreeBuilder builder;
  int max_width = 0;
  for (int trial = 0; trial < 40; ++trial) {
    LayeredGraph g;
    const bool with_building = trial % 2 == 0;
    if (with_building) g.layers.push_back(NodeLayer::kBuilding);
    const int rooms = 1 + static_cast<int>(next() % 12);
    const int first_room = g.num_nodes();
    for (int r = 0; r < rooms; ++r) {
      g.layers.push_back(NodeLayer::kRoom);
      if (with_building) add(&g, 0, first_room + r);
    }
    const double room_density = (next() % 100) / 250.0;
    for (int a = 0; a < rooms; ++a)
      for (int b = a + 1; b < rooms; ++b)
        if ((next() % 1000) / 1000.0 < room_density || b == a + 1) add(&g, first_room + a, first_room + b);
    for (int r = 0; r < rooms; ++r) {
      const int objects = static_cast<int>(next() % 14);
      const int first = g.num_nodes();
      const double density = (next() % 100) / 100.0;
      for (int o = 0; o < objects; ++o) {
        g.layers.push_back(NodeLayer::kObject);
        add(&g, first + o, first_room + r);
      }
      for (int a = 0; a < objects; ++a)
        for (int b = a + 1; b < objects; ++b)
          if ((next() % 1000) / 1000.0 < density) add(&g, first + a, first + b);
    }
    max_width = std::max(max_width, check_all(g, &builder));
  }
  EXPECT_GE(max_width, 3);
}

// Every Stanford3DSG room graph (as the training tool sees it) gives valid decompositions; reports widths.
TEST(HTree, Stanford3DSGRoomsAreValid) {
  QSG_REQUIRE_SHARED_DATA(path, "scene_graphs/Stanford3DSG_rooms.json");
  std::ifstream in(path);
  const nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
  ASSERT_FALSE(doc.is_discarded());
  HTreeBuilder builder;
  int max_width = 0, graphs = 0, nodes = 0;
  double sum_width = 0.0;
  for (const auto& graph : doc["graphs"]) {
    LayeredGraph g;
    for (const auto& n : graph["nodes"])
      g.layers.push_back(n["type"] == "room" ? NodeLayer::kRoom : NodeLayer::kObject);
    for (const auto& e : graph["edges"]) add(&g, e[0].get<int>(), e[1].get<int>());
    const int w = check_all(g, &builder);
    HTree h;
    std::string error;
    ASSERT_TRUE(builder.build(g, &h, &error));
    nodes += h.num_nodes();
    max_width = std::max(max_width, w);
    sum_width += w;
    ++graphs;
  }
  EXPECT_EQ(graphs, 482);
  std::printf("Stanford3DSG: %d graphs, %d H-tree nodes, width max %d mean %.2f\n", graphs, nodes, max_width,
              sum_width / graphs);
  EXPECT_EQ(nodes, 6341);  // the same trees the training tool (bench/neural_tree/htree.py) builds
}

TEST(HTree, RebuildDoesNotAllocate) {
  HTreeBuilder builder;
  const LayeredGraph g = paper_example();
  HTree h;
  std::string error;
  ASSERT_TRUE(builder.build(g, &h, &error));
  bool ok = false;
  EXPECT_NO_ALLOCATIONS(ok = builder.build(g, &h, &error));
  EXPECT_TRUE(ok);
}

}  // namespace
}  // namespace qsg::neural_tree
