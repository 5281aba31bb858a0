// The room classifier's label mapping (core/neural_tree/label_map.h): every mpcat40 label and every
// segmentation-network class has a documented reading, clutter and structure are never read, the Stanford3DSG
// classes round-trip through the app's labels where the app can name them, and the appliance split recovers the
// real appliances' classes from their boxes. Also the clutter generator of labels_eval and the classifier's
// behaviour under clutter.
#include "core/neural_tree/label_map.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "bench/neural_tree/room_clutter.h"
#include "core/neural_tree/room_classifier.h"
#include "tests/support/test_data.h"

namespace qsg::neural_tree {
namespace {

using namespace semantics;

TEST(RoomLabelMap, EveryMpcat40LabelHasAReasonedReadingTheModelKnows) {
  RoomClassifier classifier;
  std::string error;
  ASSERT_TRUE(classifier.init(&error)) << error;
  int read = 0;
  for (Label l = 0; l < kNumObjectLabels; ++l) {
    const LabelReading& r = label_reading(l);
    EXPECT_EQ(r.label, l) << "table out of order at " << object_label(l).name;
    EXPECT_GT(std::strlen(r.why), 0u) << object_label(l).name;
    const std::string reads = r.reads_as;
    if (reads.empty()) continue;
    ++read;
    EXPECT_FALSE(is_structure(l)) << object_label(l).name << ": structure is never read";
    if (reads == "appliances") continue;
    bool training_class = false;
    for (int i = 0; i < kNumStanfordClasses; ++i) training_class |= reads == stanford_class(i);
    EXPECT_TRUE(training_class) << object_label(l).name << " reads as " << reads << ", not a training class";
    EXPECT_GE(classifier.word_index(reads), 0) << reads;
    EXPECT_EQ(classifier.word_index(l), classifier.word_index(reads)) << object_label(l).name;
  }
  EXPECT_EQ(read, 11);  // chair table sofa bed plant sink toilet stool tv_monitor seating appliances
  for (Label clutter : {kLighting, kCushion, kTowel, kCurtain, kPicture, kMirror, kMisc, kObjects, kFurniture,
                        kClothes, kBlinds, kCabinet, kShelving}) {
    EXPECT_STREQ(classifier_class(clutter, Eigen::Vector3d(0.5, 0.5, 1.0)), "") << object_label(clutter).name;
    EXPECT_EQ(classifier.word_index(clutter), -1) << object_label(clutter).name;
  }
  EXPECT_EQ(label_reading(kInvalidLabel).label, kUnlabeled);
}

TEST(RoomLabelMap, StanfordClassesRoundTripWhereTheAppCanNameThem) {
  std::map<std::string, std::string> back;
  for (int i = 0; i < kNumStanfordClasses; ++i) {
    const std::string coco = stanford_class(i);
    const Label l = mpcat40_from_stanford(coco);
    ASSERT_NE(l, kInvalidLabel) << coco;
    EXPECT_FALSE(is_structure(l)) << coco;
    back[coco] = classifier_class(l, Eigen::Vector3d(0.6, 0.6, 0.9));
  }
  for (const char* same : {"chair", "couch", "dining_table", "bed", "toilet", "sink", "plant", "tv", "bench"})
    EXPECT_EQ(back[same], same);
  for (const char* small : {"bottle", "book", "vase", "cup", "laptop", "clock"}) {
    EXPECT_EQ(mpcat40_from_stanford(small), kObjects) << small;
    EXPECT_EQ(back[small], "") << small << ": 'objects' is a catch-all, not read";
  }
  for (const char* appliance : {"oven", "microwave", "refrigerator", "toaster"})
    EXPECT_EQ(mpcat40_from_stanford(appliance), kAppliances) << appliance;
  EXPECT_EQ(mpcat40_from_stanford("no such class"), kInvalidLabel);
  EXPECT_STREQ(stanford_class(kNumStanfordClasses), "");
}

TEST(RoomLabelMap, SegmentationNetworkClassesReachOnlyTrainingClasses) {
  const std::string path = std::string(QSG_SOURCE_DIR) + "/firmware_app/config/segmentation_pascal_voc.json";
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  const nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
  ASSERT_FALSE(doc.is_discarded());
  std::set<std::string> read;
  for (const auto& c : doc["classes"]) {
    const Label l = object_label_from_name(c["label"].get<std::string>().c_str());
    ASSERT_NE(l, kInvalidLabel) << c.dump();
    const std::string reads = classifier_class(l, Eigen::Vector3d(0.5, 0.5, 0.8));
    if (!reads.empty()) read.insert(c["name"].get<std::string>() + "->" + reads);
  }
  EXPECT_EQ(read, (std::set<std::string>{"chair->chair", "diningtable->dining_table", "pottedplant->plant",
                                         "sofa->couch", "tvmonitor->tv"}));
}

// The shipped weights carry a view head trained for exactly what the network's label map lets the classifier read,
// and a classifier given the map's labels (as qsg_app does when it runs that network) uses it.
TEST(RoomLabelMap, SegmentationNetworkHasItsViewHead) {
  const std::string path = std::string(QSG_SOURCE_DIR) + "/firmware_app/config/segmentation_pascal_voc.json";
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  const nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
  ASSERT_FALSE(doc.is_discarded());
  RoomClassifier::Config config;
  std::set<std::string> read;
  for (const auto& c : doc["classes"]) {
    const Label l = object_label_from_name(c["label"].get<std::string>().c_str());
    ASSERT_NE(l, kInvalidLabel) << c.dump();
    config.perceived_labels.push_back(l);
    if (const std::string reads = label_reading(l).reads_as; !reads.empty()) read.insert(reads);
  }
  RoomClassifier classifier(config);
  std::string error;
  ASSERT_TRUE(classifier.init(&error)) << error;
  EXPECT_EQ(classifier.view(), doc["network"].get<std::string>() == "espnetv2_s2_pascal384" ? "segmentation_pascal_voc"
                                                                                              : "?");
  const std::vector<std::string>& vocabulary = classifier.lr_head().vocabulary;
  EXPECT_EQ(std::set<std::string>(vocabulary.begin(), vocabulary.end()), read);
  EXPECT_EQ(classifier.lr_weight(), classifier.weights().views[0].lr.lr_weight);
}

TEST(RoomLabelMap, ApplianceSplitRecoversStanfordAppliancesFromTheirBoxes) {
  EXPECT_STREQ(appliance_class({0.7, 0.7, 1.8}), "refrigerator");
  EXPECT_STREQ(appliance_class({0.6, 0.6, 0.9}), "oven");
  EXPECT_STREQ(appliance_class({0.5, 0.35, 0.3}), "microwave");
  QSG_REQUIRE_SHARED_DATA(path, "scene_graphs/Stanford3DSG_rooms.json");
  std::ifstream in(path);
  const nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
  ASSERT_FALSE(doc.is_discarded());
  std::map<std::string, std::pair<int, int>> recovered;  // class -> (right, all)
  for (const auto& g : doc["graphs"])
    for (const auto& n : g["nodes"]) {
      const std::string label = n["label"].get<std::string>();
      if (n["type"] != "object" || mpcat40_from_stanford(label) != kAppliances || label == "toaster") continue;
      const Eigen::Vector3d size(n["x"][3].get<double>(), n["x"][4].get<double>(), n["x"][5].get<double>());
      auto& r = recovered[label];
      r.first += label == classifier_class(kAppliances, size);
      ++r.second;
    }
  ASSERT_EQ(recovered.size(), 3u);
  int right = 0, all = 0;
  for (const auto& [label, r] : recovered) {
    std::printf("%s: %d of %d recovered from the box\n", label.c_str(), r.first, r.second);
    EXPECT_GE(r.first, r.second * 85 / 100) << label;
    right += r.first;
    all += r.second;
  }
  EXPECT_GE(right, all * 90 / 100);
}

TEST(RoomClutter, TopsRoomsUpToTenToFifteenObjectsInsideTheRoom) {
  const Eigen::Vector3d c(2.0, -1.0, 1.25), s(4.0, 3.0, 2.5);
  std::set<Label> kinds;
  for (std::uint64_t seed = 1; seed <= 200; ++seed) {
    const int existing = static_cast<int>(seed % 8);
    const auto items = bench::make_clutter(c, s, existing, seed);
    const int total = existing + static_cast<int>(items.size());
    EXPECT_GE(total, 10) << seed;
    EXPECT_LE(total, 15) << seed;
    for (const auto& it : items) {
      kinds.insert(it.label);
      EXPECT_FALSE(is_structure(it.label));
      EXPECT_STREQ(classifier_class(it.label, it.size_m), "") << "clutter must be labels the model was not trained on";
      EXPECT_LE((it.centroid_m - c).cwiseAbs().x(), 0.5 * s.x() + 1e-9);
      EXPECT_LE((it.centroid_m - c).cwiseAbs().y(), 0.5 * s.y() + 1e-9);
      EXPECT_GE(it.centroid_m.z() - 0.5 * it.size_m.z(), c.z() - 0.5 * s.z() - 1e-9);  // not below the floor
    }
    const auto again = bench::make_clutter(c, s, existing, seed);
    ASSERT_EQ(again.size(), items.size());
    for (std::size_t i = 0; i < items.size(); ++i) EXPECT_EQ(again[i].centroid_m, items[i].centroid_m);
  }
  EXPECT_EQ(kinds.size(), sizeof(bench::kClutter) / sizeof(bench::kClutter[0]));
  EXPECT_TRUE(bench::make_clutter(c, s, 20, 3).empty()) << "a room fuller than 15 gets none";
}

// A bathroom and a bedroom; then the same rooms with 12 clutter objects each. Through the label map the clutter is
// left out, so the probabilities do not move; read through word vectors (as before issue 38) they do.
TEST(RoomClassifierUnderClutter, UnreadLabelsCannotOutvoteReadOnes) {
  const auto build = [](const RoomClassifier& m, bool clutter, ObjectRoomGraph* g) {
    g->clear();
    const int bath = g->add_room({0, 0, 1.25}, {2.0, 2.5, 2.5});
    const int bed = g->add_room({4, 0, 1.25}, {3.5, 4.0, 2.5});
    g->add_edge(bath, bed);
    g->add_object(bath, m.word_index(kToilet), {0.5, 0.8, 0.4}, {0.4, 0.7, 0.75});
    g->add_object(bath, m.word_index(kSink), {-0.6, 0.8, 0.8}, {0.6, 0.45, 0.2});
    g->add_object(bed, m.word_index(kBed), {4, 0.5, 0.4}, {1.6, 2.0, 0.9});
    g->add_object(bed, m.word_index(kBed), {4.8, -0.5, 0.4}, {1.0, 2.0, 0.9});
    if (!clutter) return;
    for (int room : {bath, bed})
      for (const auto& it : bench::make_clutter(g->nodes[room].centroid_m, g->nodes[room].size_m, 2, 7 + room))
        g->add_object(room, m.word_index(it.label, it.size_m), it.centroid_m, it.size_m);
  };
  RoomClassifier model;
  std::string error;
  ASSERT_TRUE(model.init(&error)) << error;
  ObjectRoomGraph g;
  build(model, false, &g);
  ASSERT_TRUE(model.classify(g, &error)) << error;
  const auto clean = model.predictions();
  EXPECT_EQ(clean[0].label, kBathroom);
  EXPECT_EQ(clean[1].label, kBedroom);
  build(model, true, &g);
  ASSERT_TRUE(model.classify(g, &error)) << error;
  for (std::size_t r = 0; r < 2; ++r) {
    EXPECT_EQ(model.predictions()[r].label, clean[r].label);
    for (RoomLabel l = 0; l < kNumRoomLabels; ++l)
      EXPECT_FLOAT_EQ(model.predictions()[r].label_probabilities[l], clean[r].label_probabilities[l]);
  }
  // The old reading: the same clutter through word vectors moves the probabilities.
  RoomClassifier::Config old;
  old.read_through_label_map = false;
  old.drop_unread_objects = false;
  old.min_probability = 0.0f;
  RoomClassifier before(old);
  ASSERT_TRUE(before.init(&error)) << error;
  build(before, false, &g);
  ASSERT_TRUE(before.classify(g, &error)) << error;
  const float clean_bath = before.predictions()[0].label_probabilities[kBathroom];
  build(before, true, &g);
  ASSERT_TRUE(before.classify(g, &error)) << error;
  EXPECT_GT(std::abs(before.predictions()[0].label_probabilities[kBathroom] - clean_bath), 0.01f);
}

TEST(RoomClassifierUnderClutter, AppliancesSplitByBoxAndWeakEvidenceStaysUnknown) {
  RoomClassifier model;
  std::string error;
  ASSERT_TRUE(model.init(&error)) << error;
  EXPECT_EQ(model.word_index(kAppliances, {0.7, 0.7, 1.8}), model.word_index("refrigerator"));
  EXPECT_EQ(model.word_index(kAppliances, {0.6, 0.6, 0.9}), model.word_index("oven"));
  EXPECT_EQ(model.word_index(kAppliances, {0.5, 0.35, 0.3}), model.word_index("microwave"));
  EXPECT_EQ(model.word_index(kAppliances), -1) << "without its box an appliance is not read";
  ObjectRoomGraph g;
  const int kitchen = g.add_room({0, 0, 1.25}, {3.5, 3.0, 2.5});
  const int clutter_only = g.add_room({4, 0, 1.25}, {3.0, 3.0, 2.5});
  const Eigen::Vector3d fridge(0.75, 0.7, 1.8), stove(0.6, 0.6, 0.9);
  g.add_object(kitchen, model.word_index(kAppliances, fridge), {1.2, 1.0, 0.9}, fridge);
  g.add_object(kitchen, model.word_index(kAppliances, stove), {0.0, 1.0, 0.45}, stove);
  g.add_object(kitchen, model.word_index(kSink), {-1.0, 1.0, 0.8}, {0.7, 0.5, 0.2});
  for (Label l : {kLighting, kPicture, kMisc, kObjects, kCushion})
    g.add_object(clutter_only, model.word_index(l, Eigen::Vector3d(0.4, 0.4, 0.4)), {4, 0, 0.5}, {0.4, 0.4, 0.4});
  ASSERT_TRUE(model.classify(g, &error)) << error;
  EXPECT_EQ(model.predictions()[0].label, kKitchen);
  EXPECT_GE(model.predictions()[0].probability, model.config().min_probability);
  // Nothing the classifier reads: "unknown", its probabilities still reported.
  EXPECT_EQ(model.predictions()[1].label, kRoomUnknown);
  float sum = 0.0f;
  for (float q : model.predictions()[1].label_probabilities) sum += q;
  EXPECT_NEAR(sum, 1.0f, 1e-4f);
}

// A room with nothing the classifier reads: with empty_rooms_from_box (the default) its probabilities are the LR
// head's alone (the room box) and it is labelled when they clear min_probability; off, it stays "unknown".
TEST(RoomClassifierUnderClutter, EmptyRoomsAreReadFromTheirBoxByTheLrHeadAlone) {
  for (const bool from_box : {true, false}) {
    RoomClassifier::Config config;
    config.empty_rooms_from_box = from_box;
    config.min_probability = 0.0f;
    RoomClassifier model(config);
    std::string error;
    ASSERT_TRUE(model.init(&error)) << error;
    ObjectRoomGraph g;
    const int corridor = g.add_room({0, 0, 1.25}, {1.6, 9.0, 2.5});
    const int bath = g.add_room({3, 0, 1.25}, {2.0, 2.5, 2.5});
    g.add_edge(corridor, bath);
    g.add_object(corridor, model.word_index(kMisc), {0, 1, 0.5}, {0.3, 0.3, 0.3});  // not read
    g.add_object(bath, model.word_index(kToilet), {3.5, 0.8, 0.4}, {0.4, 0.7, 0.75});
    ASSERT_TRUE(model.classify(g, &error)) << error;
    const auto blend = model.room_log_probabilities();
    const auto lr = model.room_lr_probabilities();
    const auto nt = model.room_nt_probabilities();
    double lr_gap = 0.0, nt_gap = 0.0;
    for (Eigen::Index c = 0; c < blend.cols(); ++c) {
      lr_gap = std::max(lr_gap, std::abs(std::exp(static_cast<double>(blend(0, c))) - lr(0, c)));
      nt_gap = std::max(nt_gap, std::abs(std::exp(static_cast<double>(blend(0, c))) - nt(0, c)));
    }
    if (from_box) {
      EXPECT_LT(lr_gap, 1e-5) << "the empty room's probabilities are the LR head's";
      EXPECT_NE(model.predictions()[0].label, kRoomUnknown);
    } else {
      EXPECT_GT(lr_gap, 1e-3) << "blended with the neural tree";
      EXPECT_EQ(model.predictions()[0].label, kRoomUnknown) << "min_objects 1";
    }
    EXPECT_GT(nt_gap, 1e-3);
    EXPECT_EQ(model.predictions()[1].label, kBathroom);
  }
}

// The failure, end to end on the 482 Stanford3DSG rooms as the app would label them (mpcat40 through the
// label map, clutter to 10-15 objects): the shipped classifier must not drift to one type ("kitchen" for two rooms
// in three before), and must stay close to its clean figure. Training-set rooms (the model saw their clean form):
// this guards the reading of labels, not generalisation (bench/neural_tree/labels_eval and
// bench/results/room_labels.md for that).
TEST(RoomClassifierUnderClutter, StanfordRoomsAsTheAppSeesThem) {
  QSG_REQUIRE_SHARED_DATA(path, "scene_graphs/Stanford3DSG_rooms.json");
  std::ifstream in(path);
  const nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
  ASSERT_FALSE(doc.is_discarded());
  RoomClassifier::Config config;
  config.min_probability = 0.0f;  // every room with a read object answers: the ranking is what is checked
  RoomClassifier model(config);
  std::string error;
  ASSERT_TRUE(model.init(&error)) << error;
  int rooms = 0, right = 0;
  std::map<RoomLabel, int> answered;
  std::uint64_t seed = 0;
  for (const auto& g : doc["graphs"]) {
    ObjectRoomGraph graph;
    RoomLabel truth = kRoomUnknown;
    int room = -1, objects = 0;
    for (const auto& n : g["nodes"]) {
      const auto& x = n["x"];
      const Eigen::Vector3d c(x[0].get<double>(), x[1].get<double>(), x[2].get<double>());
      const Eigen::Vector3d s(x[3].get<double>(), x[4].get<double>(), x[5].get<double>());
      if (n["type"] == "room") {
        const auto& classes = model.weights().classes;
        const auto it = std::find(classes.begin(), classes.end(), n["label"].get<std::string>());
        ASSERT_NE(it, classes.end());
        truth = model.weights().class_room_labels[static_cast<std::size_t>(it - classes.begin())];
        room = graph.add_room(c, s);
      }
    }
    ASSERT_GE(room, 0);
    for (const auto& n : g["nodes"]) {
      if (n["type"] == "room") continue;
      const auto& x = n["x"];
      const Eigen::Vector3d s(x[3].get<double>(), x[4].get<double>(), x[5].get<double>());
      const Label l = mpcat40_from_stanford(n["label"].get<std::string>());
      graph.add_object(room, model.word_index(l, s), {x[0].get<double>(), x[1].get<double>(), x[2].get<double>()}, s);
      ++objects;
    }
    for (const auto& it : bench::make_clutter(graph.nodes[room].centroid_m, graph.nodes[room].size_m, objects, ++seed))
      graph.add_object(room, model.word_index(it.label, it.size_m), it.centroid_m, it.size_m);
    ASSERT_TRUE(model.classify(graph, &error)) << error;
    ++rooms;
    right += model.predictions()[0].label == truth;
    ++answered[model.predictions()[0].label];
  }
  ASSERT_EQ(rooms, 482);
  std::printf("Stanford rooms as the app sees them (training rooms): %.1f %% right\n", 100.0 * right / rooms);
  EXPECT_GE(right, rooms * 78 / 100);
  for (const auto& [label, n] : answered) EXPECT_LT(n, rooms * 30 / 100) << room_label_name(label);
}

}  // namespace
}  // namespace qsg::neural_tree
