// Room classifier tests: PyTorch parity on the shipped weights, bad weight files, allocation-free inference.
#include "core/neural_tree/room_classifier.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/neural_tree/synthetic_building.h"
#include "tests/support/allocation_counter.h"
#include "tests/support/test_data.h"

namespace qsg::neural_tree {
namespace {

std::string fixture_path() { return std::string(QSG_SOURCE_DIR) + "/tests/neural_tree/parity_fixture.json"; }

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string write_temp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

// The fixture's scenes as the C++ API takes them (object rooms from their object-room edges).
ObjectRoomGraph graph_from_case(const nlohmann::json& c, const RoomClassifier& classifier) {
  ObjectRoomGraph g;
  const auto& layers = c["layers"];
  const std::size_t n = layers.size();
  std::vector<int> room(n, -1);
  for (const auto& e : c["edges"]) {
    const int a = e[0].get<int>(), b = e[1].get<int>();
    if (layers[a] == 1 && layers[b] == 2) room[a] = b;
    if (layers[b] == 1 && layers[a] == 2) room[b] = a;
  }
  for (std::size_t v = 0; v < n; ++v) {
    ObjectRoomGraph::Node node;
    node.layer = static_cast<NodeLayer>(layers[v].get<int>());
    for (int k = 0; k < 3; ++k) {
      node.centroid_m[k] = c["centroids"][3 * v + k].get<double>();
      node.size_m[k] = c["sizes"][3 * v + k].get<double>();
    }
    node.room = room[v];
    const std::string label = c["labels"][v].get<std::string>();
    node.word = label.empty() ? -1 : classifier.word_index(label);
    g.nodes.push_back(node);
  }
  for (const auto& e : c["edges"]) g.add_edge(e[0].get<int>(), e[1].get<int>());
  return g;
}

TEST(RoomClassifier, ShippedWeightsLoad) {
  RoomClassifier classifier;
  std::string error;
  ASSERT_TRUE(classifier.init(&error)) << error;
  const NeuralTreeWeights& w = classifier.weights();
  EXPECT_EQ(w.num_classes, 15);
  ASSERT_GE(w.members.size(), 1u);
  EXPECT_EQ(w.members[0].layers.size(), 3u);
  EXPECT_GE(classifier.word_index(semantics::kChair), 0);
  EXPECT_GE(classifier.word_index(semantics::kChestOfDrawers), 0);
  EXPECT_GE(classifier.word_index("refrigerator"), 0);
  EXPECT_EQ(classifier.word_index("no such label"), -1);
  classifier.config().print(stdout);
}

// mpcat40 labels that name a COCO training class use that class's row (one-hot included); off, their own word.
TEST(RoomClassifier, Mpcat40AliasesUseTheTrainingClassRow) {
  RoomClassifier on;
  std::string error;
  ASSERT_TRUE(on.init(&error)) << error;
  EXPECT_EQ(on.word_index(semantics::kSofa), on.word_index("couch"));
  EXPECT_EQ(on.word_index(semantics::kTvMonitor), on.word_index("tv"));
  EXPECT_EQ(on.word_index(semantics::kTable), on.word_index("dining_table"));
  EXPECT_EQ(on.word_index(semantics::kChair), on.word_index("chair"));  // same name in both sets
  RoomClassifier::Config config;
  config.alias_mpcat40_to_training_classes = false;
  RoomClassifier off(config);
  ASSERT_TRUE(off.init(&error)) << error;
  EXPECT_EQ(off.word_index(semantics::kSofa), off.word_index("sofa"));
  EXPECT_NE(off.word_index(semantics::kSofa), off.word_index("couch"));
  EXPECT_EQ(off.word_index(semantics::kTable), off.word_index("table"));
}

// C++ and PyTorch agree on the same weights: logits and probabilities within 1e-4, identical H-trees.
TEST(RoomClassifier, ParityWithPyTorch) {
  std::ifstream in(fixture_path());
  ASSERT_TRUE(in) << fixture_path();
  const nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
  ASSERT_FALSE(doc.is_discarded());
  RoomClassifier::Config config;
  config.weights_path = std::string(QSG_SOURCE_DIR) + "/" + doc["header"]["weights"].get<std::string>();
  RoomClassifier classifier(config);
  std::string error;
  ASSERT_TRUE(classifier.init(&error)) << error;
  int cases = 0;
  double max_dp = 0.0;  // largest probability difference seen, printed for the record
  for (const auto& c : doc["cases"]) {
    const ObjectRoomGraph g = graph_from_case(c, classifier);
    ASSERT_TRUE(classifier.classify(g, &error)) << error;
    const HTree& h = classifier.h_tree();
    EXPECT_EQ(h.num_nodes(), c["htree_nodes"].get<int>()) << "case " << cases;
    EXPECT_EQ(h.width, c["htree_width"].get<int>()) << "case " << cases;
    for (int k = 0; k < h.num_nodes() && k < static_cast<int>(c["htree_types"].size()); ++k)
      EXPECT_EQ(h.types[k], c["htree_types"][k].get<int>()) << "case " << cases << " node " << k;
    const auto& rooms = c["rooms"];
    ASSERT_EQ(classifier.predictions().size(), rooms.size());
    const auto log_p = classifier.room_log_probabilities();
    for (std::size_t r = 0; r < rooms.size(); ++r) {
      EXPECT_EQ(classifier.predictions()[r].node, rooms[r].get<int>());
      const auto& expected = c["logits"][r];  // the ensemble's log-probabilities
      const auto& expected_p = c["probabilities"][r];
      const auto row = static_cast<Eigen::Index>(r);
      for (int k = 0; k < log_p.cols(); ++k) {
        max_dp = std::max(max_dp, std::fabs(std::exp(static_cast<double>(log_p(row, k))) - expected_p[k].get<double>()));
        EXPECT_NEAR(std::exp(log_p(row, k)), expected_p[k].get<float>(), 1e-4)
            << "case " << cases << " room " << r << " class " << k;
        // Log-probabilities too, where float32 still resolves them (p > 1e-20).
        if (expected[k].get<float>() > -46.0f) {
          EXPECT_NEAR(log_p(row, k), expected[k].get<float>(), 1e-4 * std::max(1.0f, std::fabs(expected[k].get<float>())))
              << "case " << cases << " room " << r << " class " << k;
        }
      }
    }
    ++cases;
  }
  EXPECT_EQ(cases, 5);
  std::printf("parity with PyTorch: max |probability difference| %.3g over %d cases\n", max_dp, cases);
}

TEST(RoomClassifier, MissingWeightsLeaveRoomsUnknown) {
  RoomClassifier::Config config;
  config.weights_path = "/nonexistent/room_classifier_v1.json";
  RoomClassifier classifier(config);
  std::string error;
  EXPECT_FALSE(classifier.init(&error));
  EXPECT_NE(error.find("/nonexistent/room_classifier_v1.json"), std::string::npos) << error;
  ObjectRoomGraph g;
  make_synthetic_building(3, 4, 1, classifier, &g);
  EXPECT_FALSE(classifier.classify(g, &error));
  EXPECT_NE(error.find("no weights"), std::string::npos) << error;
  ASSERT_EQ(classifier.predictions().size(), 3u);
  for (const auto& p : classifier.predictions()) EXPECT_EQ(p.label, semantics::kRoomUnknown);
  EXPECT_EQ(classifier.stats().failures, 1u);
}

TEST(RoomClassifier, CorruptWeightsNameFileAndField) {
  const std::string good = read_text(RoomClassifier::Config().weights_path);
  ASSERT_FALSE(good.empty());
  struct Case {
    const char* name;
    std::string text;
    const char* expect;
  };
  nlohmann::json doc = nlohmann::json::parse(good);
  const int hidden = doc["hidden"].get<int>();
  const std::string short_message = "members[0].layers[1].w_neigh (" + std::to_string(hidden) + " x " +
                                    std::to_string(hidden) + "): expected " + std::to_string(hidden * hidden) +
                                    " numbers, got " + std::to_string(hidden * hidden - 1);
  nlohmann::json short_layer = doc;
  short_layer["members"][0]["layers"][1]["w_neigh"] = std::vector<float>(static_cast<std::size_t>(hidden * hidden - 1));
  nlohmann::json short_b64 = doc;  // the compact form: base64 float32, one value short
  std::string text = short_b64["members"][0]["head"]["w"].get<std::string>();
  short_b64["members"][0]["head"]["w"] = text.substr(0, text.size() - 8);
  const std::string short_b64_message = "members[0].head.w (15 x " + std::to_string(hidden) + "): expected " +
                                        std::to_string(15 * hidden) + " numbers, got " +
                                        std::to_string(15 * hidden - 2) + " and a partial one";
  nlohmann::json bad_b64 = doc;
  bad_b64["members"][0]["head"]["w"] = "!!!!";
  nlohmann::json new_version = doc;
  new_version["header"]["version"] = 2;
  nlohmann::json bad_label = doc;
  bad_label["class_room_labels"][3] = "dungeon";
  nlohmann::json nan_head = doc;
  std::vector<nlohmann::json> bias(15, 0.0);
  bias[0] = "nan";
  nan_head["members"][0]["head"]["b"] = bias;
  const Case cases[] = {
      {"truncated.json", good.substr(0, good.size() / 2), "not valid JSON"},
      {"short_layer.json", short_layer.dump(), short_message.c_str()},
      {"new_version.json", new_version.dump(), "header.version: 2 unsupported"},
      {"bad_label.json", bad_label.dump(), "class_room_labels[3]: \"dungeon\" is not a room label"},
      {"nan_head.json", nan_head.dump(), "members[0].head.b (1 x 15)[0]: not a finite number"},
      {"short_b64.json", short_b64.dump(), short_b64_message.c_str()},
      {"bad_b64.json", bad_b64.dump(), "members[0].head.w (15 x " },
      {"bad_b64_reason.json", bad_b64.dump(), "not valid base64"},
      {"empty.json", "", "not valid JSON"},
  };
  for (const Case& c : cases) {
    RoomClassifier::Config config;
    config.weights_path = write_temp(c.name, c.text);
    RoomClassifier classifier(config);
    std::string error;
    EXPECT_FALSE(classifier.init(&error)) << c.name;
    EXPECT_NE(error.find(config.weights_path + ": "), std::string::npos) << error;
    EXPECT_NE(error.find(c.expect), std::string::npos) << c.name << ": " << error;
    ObjectRoomGraph g;
    make_synthetic_building(2, 3, 1, classifier, &g);
    EXPECT_FALSE(classifier.classify(g, &error));
    for (const auto& p : classifier.predictions()) EXPECT_EQ(p.label, semantics::kRoomUnknown);
  }
}

TEST(RoomClassifier, BadGraphIsAnErrorAndRoomsStayUnknown) {
  RoomClassifier classifier;
  std::string error;
  ASSERT_TRUE(classifier.init(&error)) << error;
  ObjectRoomGraph g;
  const int room = g.add_room({0, 0, 1}, {3, 3, 2.5});
  g.add_object(room, 0, {0.5, 0, 0.5}, {0.5, 0.5, 0.5});
  g.add_edge(0, 7);
  EXPECT_FALSE(classifier.classify(g, &error));
  EXPECT_NE(error.find("edge 0 (0,7)"), std::string::npos) << error;
  ASSERT_EQ(classifier.predictions().size(), 1u);
  EXPECT_EQ(classifier.predictions()[0].label, semantics::kRoomUnknown);
  // An object naming a non-room parent.
  g.clear();
  g.add_room({0, 0, 1}, {3, 3, 2.5});
  g.add_object(5, 0, {0, 0, 0}, {1, 1, 1});
  EXPECT_FALSE(classifier.classify(g, &error));
  EXPECT_NE(error.find("object 1 names room 5"), std::string::npos) << error;
  // Edges across rooms are dropped (counted), not fatal.
  g.clear();
  const int r0 = g.add_room({0, 0, 1}, {3, 3, 2.5});
  const int r1 = g.add_room({4, 0, 1}, {3, 3, 2.5});
  const int o0 = g.add_object(r0, classifier.word_index(semantics::kBed), {0, 0, 0.4}, {2, 1.6, 0.6});
  const int o1 = g.add_object(r1, classifier.word_index(semantics::kToilet), {4, 0, 0.4}, {0.5, 0.7, 0.8});
  g.add_edge(o0, o1);
  g.add_edge(r0, r1);
  EXPECT_TRUE(classifier.classify(g, &error)) << error;
  EXPECT_EQ(classifier.stats().dropped_edges, 1u);
}

// A room without objects (a hallway, a stairwell) stays "unknown": the training rooms all hold objects. Its
// probabilities are still reported; with min_objects 0 it takes the best label.
TEST(RoomClassifier, RoomsWithoutObjectsStayUnknown) {
  ObjectRoomGraph g;
  const int empty = g.add_room({0, 0, 1.25}, {1.8, 8, 2.5});
  const int bedroom = g.add_room({4, 0, 1.25}, {4, 4, 2.5});
  g.add_object(bedroom, -1, {4, 0, 0.4}, {2, 1.6, 0.6});
  g.add_edge(empty, bedroom);
  std::string error;
  RoomClassifier strict;
  ASSERT_TRUE(strict.init(&error)) << error;
  const int bed = strict.word_index(semantics::kBed);
  g.nodes[2].word = bed;
  ASSERT_TRUE(strict.classify(g, &error)) << error;
  ASSERT_EQ(strict.predictions().size(), 2u);
  for (const RoomPrediction& p : strict.predictions()) {
    float sum = 0.0f;
    for (float q : p.label_probabilities) sum += q;
    EXPECT_NEAR(sum, 1.0f, 1e-4f);
    if (p.node == empty) EXPECT_EQ(p.label, semantics::kRoomUnknown);
    else EXPECT_NE(p.label, semantics::kRoomUnknown);
  }
  RoomClassifier::Config config;
  config.min_objects = 0;
  RoomClassifier lenient(config);
  ASSERT_TRUE(lenient.init(&error)) << error;
  ASSERT_TRUE(lenient.classify(g, &error)) << error;
  for (const RoomPrediction& p : lenient.predictions()) EXPECT_NE(p.label, semantics::kRoomUnknown);
}

TEST(RoomClassifier, SyntheticBuildingIsLabelledWithoutAllocating) {
  RoomClassifier classifier;
  std::string error;
  ASSERT_TRUE(classifier.init(&error)) << error;
  ObjectRoomGraph g;
  g.reserve(512, 4096);
  make_synthetic_building(30, 10, 3, classifier, &g);
  // Everything was sized by init(): even the first run does not allocate (error stays empty on success).
  bool ok = false;
  EXPECT_NO_ALLOCATIONS(ok = classifier.classify(g, &error));
  EXPECT_TRUE(ok) << error;
  EXPECT_NO_ALLOCATIONS(ok = classifier.classify(g, &error));
  EXPECT_TRUE(ok);
  ASSERT_EQ(classifier.predictions().size(), 30u);
  for (const auto& p : classifier.predictions()) {
    EXPECT_NE(p.label, semantics::kRoomUnknown);
    float sum = 0.0f;
    for (float q : p.label_probabilities) sum += q;
    EXPECT_NEAR(sum, 1.0f, 1e-4f);
    EXPECT_GT(p.probability, 0.0f);
  }
  classifier.stats().print(stdout);
  // The tree the classifier ran on is a valid H-tree over a valid Algorithm-1 decomposition.
  const LayeredGraph& layered = classifier.layered_graph();
  EXPECT_EQ(check_h_tree(layered, classifier.h_tree()), "");
  std::vector<std::int32_t> vertices(layered.layers.size());
  for (std::size_t v = 0; v < vertices.size(); ++v) vertices[v] = static_cast<std::int32_t>(v);
  BagTree td;
  td.begin.reserve(4096);
  td.members.reserve(32768);
  td.edge_parent.reserve(4096);
  td.edge_child.reserve(4096);
  HTreeBuilder builder;
  ASSERT_TRUE(builder.hierarchical_decomposition(layered, vertices.data(), static_cast<int>(vertices.size()), &td,
                                                 &error))
      << error;
  EXPECT_EQ(check_tree_decomposition(layered, vertices, td), "");
  EXPECT_EQ(td.width(), classifier.h_tree().width);
  std::printf("synthetic building 30 rooms / 300 objects: H-tree %d nodes, width %d\n", classifier.h_tree().num_nodes(),
              classifier.h_tree().width);
}

// End to end through the C++ path on all 482 Stanford rooms with the shipped model (trained on all of them, so
// this is a training-set figure: it proves the pipeline, not generalisation; see bench/neural_tree for CV).
TEST(RoomClassifier, Stanford3DSGTrainingSetAccuracy) {
  QSG_REQUIRE_SHARED_DATA(path, "scene_graphs/Stanford3DSG_rooms.json");
  std::ifstream in(path);
  const nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
  ASSERT_FALSE(doc.is_discarded());
  RoomClassifier classifier;
  std::string error;
  ASSERT_TRUE(classifier.init(&error)) << error;
  int correct = 0, total = 0;
  for (const auto& graph : doc["graphs"]) {
    nlohmann::json c;
    c["layers"] = nlohmann::json::array();
    c["labels"] = nlohmann::json::array();
    c["centroids"] = nlohmann::json::array();
    c["sizes"] = nlohmann::json::array();
    std::string room_class;
    for (const auto& n : graph["nodes"]) {
      const bool is_room = n["type"] == "room";
      c["layers"].push_back(is_room ? 2 : 1);
      c["labels"].push_back(is_room ? std::string() : n["label"].get<std::string>());
      if (is_room) room_class = n["label"].get<std::string>();
      for (int k = 0; k < 3; ++k) c["centroids"].push_back(n["x"][k]);
      for (int k = 3; k < 6; ++k) c["sizes"].push_back(n["x"][k]);
    }
    c["edges"] = graph["edges"];
    const ObjectRoomGraph g = graph_from_case(c, classifier);
    ASSERT_TRUE(classifier.classify(g, &error)) << error;
    const auto logits = classifier.room_log_probabilities();
    Eigen::Index best = 0;
    logits.row(0).maxCoeff(&best);
    correct += classifier.weights().classes[static_cast<std::size_t>(best)] == room_class;
    ++total;
  }
  EXPECT_EQ(total, 482);
  std::printf("C++ neural tree on Stanford3DSG (training set): %.2f %%\n", 100.0 * correct / total);
  EXPECT_GT(correct, total * 85 / 100);
}

}  // namespace
}  // namespace qsg::neural_tree
