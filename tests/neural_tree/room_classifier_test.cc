// Room classifier tests: PyTorch parity on the shipped weights (neural tree, LR head, blend), bad weight files,
// the LR head's features, allocation-free inference.
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

// A weights file init() must refuse: the error names the file and `expect`, and classify() then leaves every room
// "unknown".
void expect_weights_refused(const std::string& name, const std::string& text, const std::string& expect) {
  RoomClassifier::Config config;
  config.weights_path = write_temp(name, text);
  RoomClassifier classifier(config);
  std::string error;
  EXPECT_FALSE(classifier.init(&error)) << name;
  EXPECT_NE(error.find(config.weights_path + ": "), std::string::npos) << error;
  EXPECT_NE(error.find(expect), std::string::npos) << name << ": " << error;
  ObjectRoomGraph g;
  make_synthetic_building(2, 3, 1, classifier, &g);
  EXPECT_FALSE(classifier.classify(g, &error));
  EXPECT_EQ(classifier.predictions().size(), 2u) << name;
  for (const auto& p : classifier.predictions()) EXPECT_EQ(p.label, semantics::kRoomUnknown);
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
  // Through the label map (the default) a chest of drawers has no training class and is not read; read through
  // its own word vector (as before issue 38) it has a row.
  EXPECT_EQ(classifier.word_index(semantics::kChestOfDrawers), -1);
  EXPECT_GE(classifier.word_index("chest_of_drawers"), 0);
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
  config.read_through_label_map = false;  // the label map names the same classes and takes precedence
  RoomClassifier off(config);
  ASSERT_TRUE(off.init(&error)) << error;
  EXPECT_EQ(off.word_index(semantics::kSofa), off.word_index("sofa"));
  EXPECT_NE(off.word_index(semantics::kSofa), off.word_index("couch"));
  EXPECT_EQ(off.word_index(semantics::kTable), off.word_index("table"));
}

// C++ and PyTorch agree on the same weights: the neural tree's, the LR head's and the blended probabilities within
// 1e-4, the LR features exactly (to rounding), identical H-trees.
TEST(RoomClassifier, ParityWithPyTorch) {
  std::ifstream in(fixture_path());
  ASSERT_TRUE(in) << fixture_path();
  const nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
  ASSERT_FALSE(doc.is_discarded());
  ASSERT_EQ(doc["header"]["version"].get<int>(), NeuralTreeWeights::kFormatVersion)
      << "rerun bench/neural_tree/train_neural_tree.py train";
  RoomClassifier::Config config;
  config.weights_path = std::string(QSG_SOURCE_DIR) + "/" + doc["header"]["weights"].get<std::string>();
  RoomClassifier classifier(config);
  std::string error;
  ASSERT_TRUE(classifier.init(&error)) << error;
  EXPECT_DOUBLE_EQ(classifier.weights().lr.lr_weight, doc["header"]["blend"]["lr_weight"].get<double>());
  int cases = 0;
  double max_dp = 0.0, max_dp_nt = 0.0, max_dp_lr = 0.0;  // largest differences seen, printed for the record
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
    const auto nt_p = classifier.room_nt_probabilities();
    const auto lr_p = classifier.room_lr_probabilities();
    const auto lr_x = classifier.room_lr_features();
    for (std::size_t r = 0; r < rooms.size(); ++r) {
      EXPECT_EQ(classifier.predictions()[r].node, rooms[r].get<int>());
      const auto& expected = c["log_probabilities"][r];  // log of the blend
      const auto& expected_p = c["probabilities"][r];
      const auto row = static_cast<Eigen::Index>(r);
      EXPECT_NEAR(classifier.room_lr_coverage()[row], c["lr_coverage"][r].get<double>(), 1e-12) << "case " << cases;
      ASSERT_EQ(lr_x.cols(), static_cast<Eigen::Index>(c["lr_features"][r].size()));
      for (Eigen::Index f = 0; f < lr_x.cols(); ++f)
        EXPECT_NEAR(lr_x(row, f), c["lr_features"][r][f].get<double>(), 1e-9) << "case " << cases << " feature " << f;
      for (int k = 0; k < log_p.cols(); ++k) {
        max_dp = std::max(max_dp, std::fabs(std::exp(static_cast<double>(log_p(row, k))) - expected_p[k].get<double>()));
        max_dp_nt = std::max(max_dp_nt, std::fabs(nt_p(row, k) - c["nt_probabilities"][r][k].get<double>()));
        max_dp_lr = std::max(max_dp_lr, std::fabs(lr_p(row, k) - c["lr_probabilities"][r][k].get<double>()));
        EXPECT_NEAR(std::exp(log_p(row, k)), expected_p[k].get<float>(), 1e-4)
            << "case " << cases << " room " << r << " class " << k;
        EXPECT_NEAR(nt_p(row, k), c["nt_probabilities"][r][k].get<float>(), 1e-4)
            << "case " << cases << " room " << r << " class " << k;
        EXPECT_NEAR(lr_p(row, k), c["lr_probabilities"][r][k].get<double>(), 1e-4)
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
  std::printf("parity with PyTorch over %d cases: max |probability difference| blend %.3g, neural tree %.3g, "
              "LR head %.3g\n", cases, max_dp, max_dp_nt, max_dp_lr);
}

// The same inputs with each view head (weights version 4): the classifier told the labels a perception gives (the
// PASCAL VOC network's map; every mpcat40 label) uses the view head trained for them, whose features,
// probabilities and blend match PyTorch's.
std::vector<semantics::Label> perceived_labels_of(const std::string& view) {
  if (view == "segmentation_pascal_voc")
    return {semantics::kChair, semantics::kTable, semantics::kSofa, semantics::kPlant, semantics::kTvMonitor,
            semantics::kObjects, semantics::kUnlabeled};
  std::vector<semantics::Label> every;
  if (view == "mpcat40")
    for (semantics::Label l = 0; l < semantics::kNumObjectLabels; ++l) every.push_back(l);
  return every;
}

TEST(RoomClassifier, ParityWithPyTorchViewHeads) {
  std::ifstream in(fixture_path());
  ASSERT_TRUE(in) << fixture_path();
  const nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
  ASSERT_FALSE(doc.is_discarded());
  const std::size_t views = doc["cases"][0]["views"].size();
  ASSERT_EQ(views, 2u) << "the fixture's view heads: segmentation_pascal_voc and mpcat40";
  for (std::size_t vi = 0; vi < views; ++vi) {
    const std::string name = doc["cases"][0]["views"][vi]["name"].get<std::string>();
    RoomClassifier::Config config;
    config.weights_path = std::string(QSG_SOURCE_DIR) + "/" + doc["header"]["weights"].get<std::string>();
    config.perceived_labels = perceived_labels_of(name);
    ASSERT_FALSE(config.perceived_labels.empty()) << "no perceived labels for view " << name;
    RoomClassifier classifier(config);
    std::string error;
    ASSERT_TRUE(classifier.init(&error)) << error;
    EXPECT_EQ(classifier.view(), name);
    int cases = 0;
    double max_dp = 0.0;
    for (const auto& c : doc["cases"]) {
      const auto& v = c["views"][vi];
      ASSERT_EQ(v["name"].get<std::string>(), name);
      const ObjectRoomGraph g = graph_from_case(c, classifier);
      ASSERT_TRUE(classifier.classify(g, &error)) << error;
      const auto log_p = classifier.room_log_probabilities();
      const auto lr_p = classifier.room_lr_probabilities();
      const auto lr_x = classifier.room_lr_features();
      for (std::size_t r = 0; r < c["rooms"].size(); ++r) {
        const auto row = static_cast<Eigen::Index>(r);
        EXPECT_NEAR(classifier.room_lr_coverage()[row], v["lr_coverage"][r].get<double>(), 1e-12) << "case " << cases;
        ASSERT_EQ(lr_x.cols(), static_cast<Eigen::Index>(v["lr_features"][r].size()));
        for (Eigen::Index f = 0; f < lr_x.cols(); ++f)
          EXPECT_NEAR(lr_x(row, f), v["lr_features"][r][f].get<double>(), 1e-9)
              << name << " case " << cases << " feature " << f;
        for (int k = 0; k < log_p.cols(); ++k) {
          max_dp = std::max(max_dp, std::fabs(std::exp(static_cast<double>(log_p(row, k))) -
                                              v["probabilities"][r][k].get<double>()));
          EXPECT_NEAR(std::exp(log_p(row, k)), v["probabilities"][r][k].get<float>(), 1e-4)
              << name << " case " << cases << " room " << r << " class " << k;
          EXPECT_NEAR(lr_p(row, k), v["lr_probabilities"][r][k].get<double>(), 1e-4)
              << name << " case " << cases << " room " << r << " class " << k;
        }
      }
      ++cases;
    }
    EXPECT_EQ(cases, 5);
    std::printf("view head %s: parity with PyTorch over %d cases, max |probability difference| %.3g\n", name.c_str(),
                cases, max_dp);
  }
}

// Which LR head the classifier uses: the file's without perceived labels and with a label set no view head was
// trained for; the view head for exactly its label set (every mpcat40 label; the PASCAL VOC map's, in any order,
// with the structure labels a label map also produces; appliances count as the three appliance classes).
TEST(RoomClassifier, ViewHeadChosenByPerceivedLabels) {
  RoomClassifier full;
  std::string error;
  ASSERT_TRUE(full.init(&error)) << error;
  ASSERT_FALSE(full.weights().views.empty());
  EXPECT_EQ(full.view(), "");
  EXPECT_EQ(full.lr_head().vocabulary, full.weights().lr.vocabulary);
  const auto view_of = [&error](std::vector<semantics::Label> labels) {
    RoomClassifier::Config config;
    config.perceived_labels = std::move(labels);
    RoomClassifier c(config);
    EXPECT_TRUE(c.init(&error)) << error;
    return std::make_pair(c.view(), c.lr_head().vocabulary.size());
  };
  std::vector<semantics::Label> every;
  for (semantics::Label l = 0; l < semantics::kNumObjectLabels; ++l) every.push_back(l);
  EXPECT_EQ(view_of(every).first, "mpcat40");
  EXPECT_EQ(view_of(every).second, 12u);
  every.erase(std::find(every.begin(), every.end(), semantics::kAppliances));
  EXPECT_EQ(view_of(every).first, "") << "without appliances: not the label set the mpcat40 head was trained for";
  const auto pascal = view_of({semantics::kObjects, semantics::kTvMonitor, semantics::kSofa, semantics::kPlant,
                               semantics::kTable, semantics::kChair, semantics::kUnlabeled});
  EXPECT_EQ(pascal.first, "segmentation_pascal_voc");
  EXPECT_EQ(pascal.second, 5u);
  EXPECT_EQ(view_of({semantics::kChair, semantics::kTable, semantics::kSofa, semantics::kPlant}).first, "")
      << "no tv_monitor: not the label set the view head was trained for";
  EXPECT_EQ(view_of({semantics::kChair, semantics::kTable, semantics::kSofa, semantics::kPlant, semantics::kTvMonitor,
                     semantics::kAppliances})
                .first,
            "")
      << "appliances too: more than the view head can read";
  // The view changes the answer where it matters: a bathroom-sized room with nothing the network can see is not
  // labelled by the full LR head's reading of "no toilet, no sink".
  RoomClassifier::Config seg_config;
  seg_config.perceived_labels = {semantics::kChair, semantics::kTable, semantics::kSofa, semantics::kPlant,
                                 semantics::kTvMonitor};
  seg_config.min_probability = 0.0f;
  RoomClassifier seg(seg_config);
  ASSERT_TRUE(seg.init(&error)) << error;
  ObjectRoomGraph g;
  g.add_room(Eigen::Vector3d(0, 0, 1.2), Eigen::Vector3d(2.0, 1.8, 2.4));
  ASSERT_TRUE(seg.classify(g, &error)) << error;
  EXPECT_EQ(seg.predictions()[0].label, semantics::kBathroom)
      << semantics::room_label_name(seg.predictions()[0].label);
}

// The LR head counts an object under its word-table row's name: an mpcat40 sofa (aliased to COCO's couch) counts as
// a couch; a label outside the LR vocabulary, or no word, is not counted. The box features follow lr_features,
// then the footprint of the room's largest object of each footprint class (aliases included), 0 without one.
TEST(RoomClassifier, LrFeaturesCountAliasedLabelsTheBoxAndFootprints) {
  // Every object kept and mpcat40 labels read through their word vectors (the behaviour before issue 38), so that
  // unread objects stay in the room and the coverage arithmetic is exercised.
  RoomClassifier::Config keep_all;
  keep_all.read_through_label_map = false;
  keep_all.drop_unread_objects = false;
  RoomClassifier classifier(keep_all);
  std::string error;
  ASSERT_TRUE(classifier.init(&error)) << error;
  const NeuralTreeWeights::LrHead& lr = classifier.weights().lr;
  const auto column = [&](const std::string& name) {
    const auto it = std::find(lr.vocabulary.begin(), lr.vocabulary.end(), name);
    return static_cast<Eigen::Index>(it - lr.vocabulary.begin());
  };
  const Eigen::Index couch = column("couch"), chair = column("chair");
  ASSERT_LT(couch, static_cast<Eigen::Index>(lr.vocabulary.size()));
  ASSERT_LT(chair, static_cast<Eigen::Index>(lr.vocabulary.size()));
  ASSERT_EQ(column("cushion"), static_cast<Eigen::Index>(lr.vocabulary.size())) << "mpcat40 only, not counted";
  ObjectRoomGraph g;
  const int other = g.add_room({9, 0, 1.2}, {2.0, 5.0, 2.4});
  const int room = g.add_room({0, 0, 1.2}, {6.0, 0.005, 2.4});  // y below min_size_m
  g.add_object(room, classifier.word_index(semantics::kSofa), {0, 0, 0.4}, {2, 1.5, 0.8});
  g.add_object(room, classifier.word_index("couch"), {1, 0, 0.4}, {2, 1, 0.8});
  g.add_object(room, classifier.word_index(semantics::kChair), {1, 1, 0.4}, {0.5, 0.5, 0.9});
  g.add_object(room, classifier.word_index(semantics::kCushion), {1, 1, 0.6}, {0.3, 0.3, 0.1});
  g.add_object(room, -1, {2, 1, 0.6}, {0.3, 0.3, 0.1});
  g.add_object(-1, classifier.word_index(semantics::kChair), {2, 2, 0.6}, {0.3, 0.3, 0.1});  // no room
  g.add_object(other, classifier.word_index(semantics::kChair), {9, 0, 0.4}, {0.5, 0.5, 0.9});
  g.add_edge(other, room);
  ASSERT_TRUE(classifier.classify(g, &error)) << error;
  const auto x = classifier.room_lr_features();
  ASSERT_EQ(x.rows(), 2);
  const Eigen::Index v = static_cast<Eigen::Index>(lr.vocabulary.size());
  const Eigen::Index footprints = static_cast<Eigen::Index>(lr.footprint_classes.size());
  ASSERT_EQ(x.cols(), v + NeuralTreeWeights::kNumLrBoxFeatures + footprints);
  EXPECT_DOUBLE_EQ(x(1, couch), std::log1p(2.0));
  EXPECT_DOUBLE_EQ(x(1, chair), std::log1p(1.0));
  EXPECT_DOUBLE_EQ(x.row(1).head(v).sum(), std::log1p(2.0) + std::log1p(1.0));
  EXPECT_DOUBLE_EQ(x(0, chair), std::log1p(1.0));
  EXPECT_DOUBLE_EQ(x.row(0).head(v).sum(), std::log1p(1.0));
  const double min_size = lr.min_size_m;
  const double lx = std::log(6.0), ly = std::log(min_size), lz = std::log(2.4);
  EXPECT_DOUBLE_EQ(x(1, v), lx);
  EXPECT_DOUBLE_EQ(x(1, v + 1), ly);
  EXPECT_DOUBLE_EQ(x(1, v + 2), lz);
  EXPECT_DOUBLE_EQ(x(1, v + 3), lx);
  EXPECT_DOUBLE_EQ(x(1, v + 4), ly);
  EXPECT_DOUBLE_EQ(x(1, v + 5), lx + ly);
  EXPECT_DOUBLE_EQ(x(0, v + 3), std::log(5.0));  // x and y as stored; max and min sort them
  EXPECT_DOUBLE_EQ(x(0, v + 4), std::log(2.0));
  const auto footprint = [&](const std::string& name) {
    const auto it = std::find(lr.footprint_classes.begin(), lr.footprint_classes.end(), name);
    return v + NeuralTreeWeights::kNumLrBoxFeatures + static_cast<Eigen::Index>(it - lr.footprint_classes.begin());
  };
  const Eigen::Index couch_area = footprint("couch"), chair_area = footprint("chair");
  ASSERT_LT(couch_area, x.cols());
  ASSERT_LT(chair_area, x.cols());
  EXPECT_EQ(footprint("cup"), x.cols()) << "small portable things have no footprint feature";
  EXPECT_DOUBLE_EQ(x(1, couch_area), std::log1p(2.0 * 1.5));  // the larger of the sofa and the couch
  EXPECT_DOUBLE_EQ(x(1, chair_area), std::log1p(0.25));
  EXPECT_DOUBLE_EQ(x.row(1).tail(footprints).sum(), std::log1p(3.0) + std::log1p(0.25));
  EXPECT_DOUBLE_EQ(x(0, chair_area), std::log1p(0.25));
  EXPECT_DOUBLE_EQ(x.row(0).tail(footprints).sum(), std::log1p(0.25));
  // Coverage: room 1 holds 5 objects, 3 of them counted (two couches and the chair; not the cushion, nor the
  // object without a word); room 0 one counted chair.
  ASSERT_TRUE(lr.weight_by_coverage);
  EXPECT_DOUBLE_EQ(classifier.room_lr_coverage()[1], 3.0 / 5.0);
  EXPECT_DOUBLE_EQ(classifier.room_lr_coverage()[0], 1.0);
  // The reported probabilities are the blend of the two heads, the LR weighted by its coverage of the room.
  const int classes = classifier.weights().num_classes;
  for (int r = 0; r < 2; ++r) {
    const double a = lr.lr_weight * classifier.room_lr_coverage()[r];
    Eigen::VectorXd q(classes);
    for (int c = 0; c < classes; ++c) {
      const double nt = classifier.room_nt_probabilities()(r, c), p_lr = classifier.room_lr_probabilities()(r, c);
      q[c] = lr.log_pool ? std::pow(std::max(nt, 1e-30), 1.0 - a) * std::pow(std::max(p_lr, 1e-30), a)
                         : (1.0 - a) * nt + a * p_lr;
    }
    q /= q.sum();
    for (int c = 0; c < classes; ++c)
      EXPECT_NEAR(std::exp(classifier.room_log_probabilities()(r, c)), q[c], 1e-6) << "room " << r << " class " << c;
  }
}

TEST(RoomClassifier, MissingWeightsLeaveRoomsUnknown) {
  RoomClassifier::Config config;
  config.weights_path = "/nonexistent/room_classifier_v4.json";
  RoomClassifier classifier(config);
  std::string error;
  EXPECT_FALSE(classifier.init(&error));
  EXPECT_NE(error.find("/nonexistent/room_classifier_v4.json"), std::string::npos) << error;
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
  new_version["header"]["version"] = NeuralTreeWeights::kFormatVersion + 1;
  const std::string new_version_message =
      "header.version: " + std::to_string(NeuralTreeWeights::kFormatVersion + 1) + " unsupported";
  nlohmann::json v1 = doc;  // the neural tree alone (before the LR head): refused, naming the version
  v1["header"]["version"] = 1;
  v1.erase("lr_head");
  nlohmann::json v2 = doc;  // an LR head without furniture footprints: refused, naming the version
  v2["header"]["version"] = 2;
  v2["lr_head"]["features"].erase("largest_footprint");
  nlohmann::json v3 = doc;  // without view heads: refused, naming the version
  v3["header"]["version"] = 3;
  v3.erase("view_heads");
  nlohmann::json bad_label = doc;
  bad_label["class_room_labels"][3] = "dungeon";
  nlohmann::json nan_head = doc;
  std::vector<nlohmann::json> bias(15, 0.0);
  bias[0] = "nan";
  nan_head["members"][0]["head"]["b"] = bias;
  const Case cases[] = {
      {"truncated.json", good.substr(0, good.size() / 2), "not valid JSON"},
      {"short_layer.json", short_layer.dump(), short_message.c_str()},
      {"new_version.json", new_version.dump(), new_version_message.c_str()},
      {"v1.json", v1.dump(), "header.version: 1 unsupported (this build reads version 4"},
      {"v2.json", v2.dump(), "header.version: 2 unsupported (this build reads version 4"},
      {"v3.json", v3.dump(), "header.version: 3 unsupported (this build reads version 4"},
      {"bad_label.json", bad_label.dump(), "class_room_labels[3]: \"dungeon\" is not a room label"},
      {"nan_head.json", nan_head.dump(), "members[0].head.b (1 x 15)[0]: not a finite number"},
      {"short_b64.json", short_b64.dump(), short_b64_message.c_str()},
      {"bad_b64.json", bad_b64.dump(), "members[0].head.w (15 x " },
      {"bad_b64_reason.json", bad_b64.dump(), "not valid base64"},
      {"empty.json", "", "not valid JSON"},
  };
  for (const Case& c : cases) expect_weights_refused(c.name, c.text, c.expect);
}

// A file whose LR head or a view head is missing, corrupt or of the wrong shape is refused (the field named), and the
// classifier then leaves every room "unknown", as for any bad file.
TEST(RoomClassifier, CorruptLrHeadIsAnError) {
  const nlohmann::json doc = nlohmann::json::parse(read_text(RoomClassifier::Config().weights_path));
  ASSERT_TRUE(doc.contains("lr_head"));
  const int classes = doc["num_classes"].get<int>();
  const int features = doc["lr_head"]["num_features"].get<int>();
  const int vocabulary = static_cast<int>(doc["lr_head"]["features"]["object_counts"]["vocabulary"].size());
  const int footprints = static_cast<int>(doc["lr_head"]["features"]["largest_footprint"]["classes"].size());
  ASSERT_GT(footprints, 1);
  ASSERT_EQ(features, vocabulary + NeuralTreeWeights::kNumLrBoxFeatures + footprints);
  struct Case {
    std::string name;
    nlohmann::json doc;
    std::string expect;
  };
  std::vector<Case> cases;
  auto edit = [&](const std::string& name, const std::string& expect, auto&& change) {
    nlohmann::json d = doc;
    change(d["lr_head"], d);
    cases.push_back({name, std::move(d), expect});
  };
  const std::string fc = std::to_string(features), cc = std::to_string(classes);
  edit("lr_missing.json", "lr_head: missing", [](nlohmann::json&, nlohmann::json& d) { d.erase("lr_head"); });
  edit("lr_not_object.json", "lr_head: missing", [](nlohmann::json& h, nlohmann::json&) { h = "garbage"; });
  edit("lr_w_short.json",
       "lr_head.w (" + cc + " x " + fc + "): expected " + std::to_string(classes * features) + " numbers, got " +
           std::to_string(classes * features - 1),
       [&](nlohmann::json& h, nlohmann::json&) {
         h["w"] = std::vector<float>(static_cast<std::size_t>(classes * features - 1));
       });
  edit("lr_w_bad_b64.json", "lr_head.w (" + cc + " x " + fc + "): not valid base64",
       [](nlohmann::json& h, nlohmann::json&) { h["w"] = "@@@@"; });
  edit("lr_num_features.json", "lr_head.num_features: " + std::to_string(features + 1) + " outside",
       [&](nlohmann::json& h, nlohmann::json&) { h["num_features"] = features + 1; });
  edit("lr_classes.json", "lr_head.num_classes: " + std::to_string(classes - 1) + " outside",
       [&](nlohmann::json& h, nlohmann::json&) { h["num_classes"] = classes - 1; });
  edit("lr_mean_long.json",
       "lr_head.mean (1 x " + fc + "): expected " + fc + " numbers, got " + std::to_string(features + 1),
       [&](nlohmann::json& h, nlohmann::json&) {
         h["mean"] = std::vector<float>(static_cast<std::size_t>(features + 1));
       });
  edit("lr_b_missing.json", "lr_head.b (1 x " + cc + "): missing",
       [](nlohmann::json& h, nlohmann::json&) { h.erase("b"); });
  edit("lr_std_zero.json", "lr_head.std[2]: not positive", [&](nlohmann::json& h, nlohmann::json&) {
    std::vector<float> s(static_cast<std::size_t>(features), 1.0f);
    s[2] = 0.0f;
    h["std"] = s;
  });
  edit("lr_vocab_unknown.json", "vocabulary[1]: \"spaceship\" has no row in words",
       [](nlohmann::json& h, nlohmann::json&) { h["features"]["object_counts"]["vocabulary"][1] = "spaceship"; });
  const std::string first_name = doc["lr_head"]["features"]["object_counts"]["vocabulary"][0].get<std::string>();
  edit("lr_vocab_twice.json", "vocabulary[1]: \"" + first_name + "\" listed twice",
       [](nlohmann::json& h, nlohmann::json&) {
         h["features"]["object_counts"]["vocabulary"][1] = h["features"]["object_counts"]["vocabulary"][0];
       });
  edit("lr_vocab_shorter.json", "lr_head.num_features: " + fc + " outside", [](nlohmann::json& h, nlohmann::json&) {
    h["features"]["object_counts"]["vocabulary"].erase(h["features"]["object_counts"]["vocabulary"].size() - 1);
  });
  edit("lr_transform.json", "lr_head.features.object_counts: missing, or its transform",
       [](nlohmann::json& h, nlohmann::json&) { h["features"]["object_counts"]["transform"] = "identity"; });
  edit("lr_box.json", "lr_head.features.room_box: expected [log_size_x", [](nlohmann::json& h, nlohmann::json&) {
    std::swap(h["features"]["room_box"][0], h["features"]["room_box"][3]);
  });
  edit("lr_footprint_missing.json", "lr_head.features.largest_footprint: missing",
       [](nlohmann::json& h, nlohmann::json&) { h["features"].erase("largest_footprint"); });
  edit("lr_footprint_transform.json", "lr_head.features.largest_footprint: missing, or its transform",
       [](nlohmann::json& h, nlohmann::json&) { h["features"]["largest_footprint"]["transform"] = "log"; });
  edit("lr_footprint_classes.json", "lr_head.features.largest_footprint.classes: expected an array",
       [](nlohmann::json& h, nlohmann::json&) { h["features"]["largest_footprint"]["classes"] = "bed"; });
  edit("lr_footprint_unknown.json", "classes[1]: \"spaceship\" is not in object_counts.vocabulary",
       [](nlohmann::json& h, nlohmann::json&) { h["features"]["largest_footprint"]["classes"][1] = "spaceship"; });
  const std::string first_footprint =
      doc["lr_head"]["features"]["largest_footprint"]["classes"][0].get<std::string>();
  edit("lr_footprint_twice.json", "classes[1]: \"" + first_footprint + "\" listed twice",
       [](nlohmann::json& h, nlohmann::json&) {
         h["features"]["largest_footprint"]["classes"][1] = h["features"]["largest_footprint"]["classes"][0];
       });
  edit("lr_footprint_shorter.json", "lr_head.num_features: " + fc + " outside",
       [](nlohmann::json& h, nlohmann::json&) {
         h["features"]["largest_footprint"]["classes"].erase(h["features"]["largest_footprint"]["classes"].size() - 1);
       });
  edit("lr_blend_weight.json", "lr_head.blend.lr_weight: missing or not a number in [0, 1]",
       [](nlohmann::json& h, nlohmann::json&) { h["blend"]["lr_weight"] = 1.5; });
  edit("lr_blend_pool.json", "lr_head.blend.pool: expected", [](nlohmann::json& h, nlohmann::json&) {
    h["blend"]["pool"] = "max";
  });
  edit("lr_blend_coverage_missing.json", "lr_head.blend.weight_by_coverage: missing or not true/false",
       [](nlohmann::json& h, nlohmann::json&) { h["blend"].erase("weight_by_coverage"); });
  edit("lr_blend_coverage_number.json", "lr_head.blend.weight_by_coverage: missing or not true/false",
       [](nlohmann::json& h, nlohmann::json&) { h["blend"]["weight_by_coverage"] = 1; });
  // Version 4's view heads: the same checks, named by their place in view_heads.
  ASSERT_TRUE(doc.contains("view_heads") && !doc["view_heads"].empty());
  edit("views_missing.json", "view_heads: missing or not an array",
       [](nlohmann::json&, nlohmann::json& d) { d.erase("view_heads"); });
  edit("views_not_array.json", "view_heads: missing or not an array",
       [](nlohmann::json&, nlohmann::json& d) { d["view_heads"] = "pascal"; });
  edit("view_no_name.json", "view_heads[0].name: missing or empty",
       [](nlohmann::json&, nlohmann::json& d) { d["view_heads"][0].erase("name"); });
  edit("view_twice.json",
       "view_heads[" + std::to_string(doc["view_heads"].size()) + "].name: \"" +
           doc["view_heads"][0]["name"].get<std::string>() + "\" listed twice",
       [](nlohmann::json&, nlohmann::json& d) { d["view_heads"].push_back(d["view_heads"][0]); });
  edit("view_lr_missing.json", "view_heads[0].lr_head: missing",
       [](nlohmann::json&, nlohmann::json& d) { d["view_heads"][0].erase("lr_head"); });
  edit("view_vocab_unknown.json", "view_heads[0].lr_head.features.object_counts.vocabulary[0]: \"spaceship\" has no row",
       [](nlohmann::json&, nlohmann::json& d) {
         d["view_heads"][0]["lr_head"]["features"]["object_counts"]["vocabulary"][0] = "spaceship";
       });
  edit("view_w_bad_b64.json", "view_heads[0].lr_head.w (", [](nlohmann::json&, nlohmann::json& d) {
    d["view_heads"][0]["lr_head"]["w"] = "@@@@";
  });
  for (const Case& c : cases) expect_weights_refused(c.name, c.doc.dump(), c.expect);
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
  config.min_probability = 0.0f;
  RoomClassifier lenient(config);
  ASSERT_TRUE(lenient.init(&error)) << error;
  ASSERT_TRUE(lenient.classify(g, &error)) << error;
  for (const RoomPrediction& p : lenient.predictions()) EXPECT_NE(p.label, semantics::kRoomUnknown);
}

TEST(RoomClassifier, SyntheticBuildingIsLabelledWithoutAllocating) {
  RoomClassifier::Config config;
  config.min_probability = 0.0f;  // every room with a read object gets a label (the random rooms are ambiguous)
  RoomClassifier classifier(config);
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
  // The tree the classifier ran on is a valid H-tree over a valid Algorithm-1 decomposition. Checked with every
  // object kept: objects left out (unread labels) stay in the layered graph as isolated nodes, outside the H-tree.
  RoomClassifier::Config keep_all = config;
  keep_all.read_through_label_map = false;
  keep_all.drop_unread_objects = false;
  RoomClassifier full(keep_all);
  ASSERT_TRUE(full.init(&error)) << error;
  make_synthetic_building(30, 10, 3, full, &g);
  ASSERT_TRUE(full.classify(g, &error)) << error;
  const LayeredGraph& layered = full.layered_graph();
  EXPECT_EQ(check_h_tree(layered, full.h_tree()), "");
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
  EXPECT_EQ(td.width(), full.h_tree().width);
  std::printf("synthetic building 30 rooms / 300 objects: H-tree %d nodes, width %d\n", full.h_tree().num_nodes(),
              full.h_tree().width);
}

// End to end through the C++ path on all 482 Stanford rooms with the shipped model (neural tree blended with the LR
// head, both trained on all of them, so this is a training-set figure: it proves the pipeline, not
// generalisation; see bench/neural_tree for CV).
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
  std::printf("C++ neural tree + LR blend on Stanford3DSG (training set): %.2f %%\n", 100.0 * correct / total);
  EXPECT_GT(correct, total * 85 / 100);
}

}  // namespace
}  // namespace qsg::neural_tree
