// Room labels from a neural tree (GraphSAGE message passing on the H-tree of the object-room(-building) graph)
// averaged with a logistic-regression head on the room's object counts and box; Eigen only, weights from a
// versioned file; a room keeps "unknown" whenever the classifier cannot run.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "budgets/budget_table.h"

#include "core/neural_tree/h_tree.h"
#include "core/semantics/labels.h"

namespace qsg::neural_tree {

using RowMatrixXf = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// A trained classifier as stored in core/neural_tree/weights/room_classifier_v<version>.json: the neural tree and
// (from version 2) the logistic-regression head whose class probabilities are blended with it (version 3: the head
// also reads furniture footprints; version 4: view heads for perceptions that see only some labels).
struct NeuralTreeWeights {
  static constexpr int kFormatVersion = 4;
  // The LR head's box features after the count features, in this order (the trainer's LR_BOX_FEATURES): log of
  // each box side (x, y as the room stores them, z), max and min of the two horizontal ones, their sum.
  static constexpr int kNumLrBoxFeatures = 6;
  struct Offsets {
    int type = 0, word = 0, object_size = 0, object_relative_position = 0, room_size = 0, room_object_count = 0;
    int object_label_count = -1;  // log(1 + objects of the same label in the room); -1 = not used
  };
  struct Layer {
    RowMatrixXf w_self;   // out x in
    Eigen::VectorXf b_self;
    RowMatrixXf w_neigh;  // out x in
    RowMatrixXf w_edge;   // out x 3 (mean relative position of the H-tree neighbours)
  };
  int input_dim = 0, hidden = 0, num_classes = 0, word_dim = 0;
  float min_size_m = 0.01f;
  double position_scale = 1.0;  // distances (m) are multiplied by this before entering the network
  bool sum_aggregation = false;  // neighbour messages summed (GIN-like) instead of averaged (GraphSAGE-mean)
  Offsets offsets;
  std::vector<std::string> classes;                         // the training set's room classes
  std::vector<semantics::RoomLabel> class_room_labels;      // each class on our room labels (many-to-one allowed)
  std::vector<std::string> word_names;                      // object label names with a word vector
  RowMatrixXf words;                                        // num_words x word_dim
  // One trained network; the file holds an ensemble whose class probabilities are averaged.
  struct Member {
    std::vector<Layer> layers;
    RowMatrixXf head_w;  // num_classes x hidden
    Eigen::VectorXf head_b;
  };
  std::vector<Member> members;
  // Multinomial logistic regression on one room: log(1 + objects per vocabulary name), then the box features, then
  // per footprint class log(1 + the footprint max(sx, min) x max(sy, min) of the room's largest object of that
  // name), 0 without one; standardised by mean and std. Objects count under their word-table row's name (mpcat40
  // aliases included), for the footprints too.
  struct LrHead {
    std::vector<std::string> vocabulary;  // count features, in feature order
    std::vector<std::string> footprint_classes;  // footprint features, in feature order; each in the vocabulary
    float min_size_m = 0.01f;             // floor under the box sides before the log
    Eigen::VectorXd mean, std;            // num_features
    RowMatrixXf w;                        // num_classes x num_features
    Eigen::VectorXf b;
    double lr_weight = 0.0;  // the LR's weight in the blend; the neural tree's is 1 - lr_weight
    bool log_pool = false;   // false: convex average of probabilities; true: normalised weighted geometric mean
    // The LR's weight in a room is lr_weight x the share of the room's objects it counts (1 without objects): it is
    // blind to labels outside its vocabulary (mpcat40 appliances, cabinet, shelving, ...), which the neural tree
    // reads through their word vectors. Every training room has share 1.
    bool weight_by_coverage = false;
    int num_features() const {
      return static_cast<int>(vocabulary.size()) + kNumLrBoxFeatures + static_cast<int>(footprint_classes.size());
    }
  };
  LrHead lr;
  // Version 4: LR heads trained on the training rooms as one perception shows them (only the objects of its label
  // set; train_neural_tree.py VIEWS): its vocabulary is the training classes that perception's labels are read as.
  // RoomClassifier uses one in place of `lr` (with its own blend weight) when Config::perceived_labels is read as
  // exactly its vocabulary.
  struct ViewHead {
    std::string name;  // e.g. "segmentation_pascal_voc"
    LrHead lr;
  };
  std::vector<ViewHead> views;
};

// A relative position without the room's orientation (the scene's z is up): horizontal distance, height
// difference, distance. Used for an object's offset from its room and for the H-tree edge feature.
Eigen::Vector3d offset_feature(const Eigen::Vector3d& d);

// Loads and shape-checks a weights file. On failure returns false and `error` names the file and the field.
bool load_weights(const std::string& path, NeuralTreeWeights* out, std::string* error);

// The classifier's input: objects (with their room), rooms, at most one building; indices are node numbers.
struct ObjectRoomGraph {
  struct Node {
    NodeLayer layer = NodeLayer::kObject;
    int word = -1;   // objects: row of the model's word table (RoomClassifier::word_index), -1 = no word
    int room = -1;   // objects: node index of their room, -1 = none (the object is then left out)
    Eigen::Vector3d centroid_m = Eigen::Vector3d::Zero();
    Eigen::Vector3d size_m = Eigen::Vector3d::Zero();
  };
  std::vector<Node> nodes;
  std::vector<std::int32_t> edge_a, edge_b;  // object-object (same room) and room-room edges; parents implicit

  void reserve(int nodes_capacity, int edges_capacity);
  void clear();
  int add_room(const Eigen::Vector3d& centroid_m, const Eigen::Vector3d& size_m);
  int add_building(const Eigen::Vector3d& centroid_m);
  int add_object(int room, int word, const Eigen::Vector3d& centroid_m, const Eigen::Vector3d& size_m);
  void add_edge(int a, int b);
};

struct RoomPrediction {
  int node = -1;
  semantics::RoomLabel label = semantics::kRoomUnknown;
  float probability = 0.0f;  // of `label`
  std::array<float, semantics::kNumRoomLabels> label_probabilities{};  // over our room labels
};

class RoomClassifier {
 public:
  struct Config {
    std::string weights_path = QSG_NEURAL_TREE_DEFAULT_WEIGHTS;
    HTreeBuilder::Config h_tree;
    int max_rooms = static_cast<int>(budgets::active::scene_graph::kRoomNodes);  // every room node the graph holds
    // A room whose best label is less likely stays "unknown" (its probabilities are still reported): weak
    // evidence says so. 0.45 maximises right minus wrong answers ("unknown" scoring 0) on held-out generated
    // buildings with clutter, as the app and as the segmentation network see them (labels_eval --calibrate,
    // bench/results/room_labels.md).
    float min_probability = 0.45f;
    // A room with fewer objects stays "unknown": every training room holds at least one, so the network has never
    // seen an empty room and labels one at random (generated buildings' hallways and stairwells,
    // bench/results/room_labels.md). The probabilities are still reported. 0 labels every room.
    int min_objects = 1;
    // Our segmenter's mpcat40 labels that name the same thing as a COCO class the classifier was trained on (sofa
    // = couch, tv_monitor = tv, table = dining_table, COCO's only table) take that class's row of the word table,
    // one-hot included; off, they keep only their own word vector, which the training data never showed.
    bool alias_mpcat40_to_training_classes = true;
    // Read the app's mpcat40 labels through the label map (label_map.h): each becomes the training class that
    // names the same thing, appliances split by their box, and every other label (clutter, catch-alls, furniture
    // without a training class, structure) is not read (word -1). Off: a label is read through its own word
    // vector (or the aliases above), as before issue 38. Takes precedence over the aliases when on.
    bool read_through_label_map = true;
    // Objects that are not read (word -1) are left out of the classifier's input altogether: they neither enter
    // the neural tree (as a zero word vector) nor count towards the room's objects, min_objects or the LR head's
    // coverage, so unfamiliar labels cannot outvote the familiar ones. Off: they enter with a zero word vector.
    bool drop_unread_objects = true;
    // The weight in the blend of the LR head in use (the file's or the view head perceived_labels chose); negative:
    // that head's own from the weights file (its blend.lr_weight).
    double lr_weight = -1.0;
    // A room with no object the classifier reads is labelled by the LR head alone (its box; the neural tree has
    // never seen an empty room), min_objects not applied, min_probability still. Off: such a room stays
    // "unknown" (min_objects 1). On earned its keep on held-out data (labels_eval, bench/results/room_labels.md).
    bool empty_rooms_from_box = true;
    // The mpcat40 labels the app's perception can give an object (e.g. its segmentation network's label map);
    // empty: every label (ground-truth labels). When they are read (through the label map) as exactly the
    // vocabulary of one of the weights file's view heads, that head replaces the LR head, with its own blend
    // weight: it was trained on the training rooms with every other object removed, so a toilet or bed the
    // perception cannot see is not taken for a toilet or bed that is not there. Otherwise the file's LR head.
    std::vector<semantics::Label> perceived_labels;
    void print(std::FILE* out) const;
  };
  struct Stats {
    std::uint64_t runs = 0, failures = 0, dropped_edges = 0;
    int last_graph_nodes = 0, last_htree_nodes = 0, last_width = -1, max_width = -1, max_htree_nodes = 0;
    void print(std::FILE* out) const;
  };

  RoomClassifier();
  explicit RoomClassifier(const Config& config);

  // Loads the weights and sizes every buffer. On failure the classifier stays usable: classify() then reports the
  // error and leaves every room "unknown".
  bool init(std::string* error);
  bool ready() const { return ready_; }

  // Row of the word table for an object label name (Stanford3DSG or mpcat40 spelling), or -1.
  int word_index(const std::string& name) const;
  // Without a box: with read_through_label_map an appliance is not read (-1), as its class depends on its box.
  int word_index(semantics::Label mpcat40_label) const;
  // With the object's box (x, y horizontal, z up, m): appliances split by label_map.h's appliance_class().
  int word_index(semantics::Label mpcat40_label, const Eigen::Vector3d& size_m) const;
  // The LR head's weight in the blend in use (Config::lr_weight or the file's).
  double lr_weight() const {
    return config_.lr_weight >= 0.0 ? config_.lr_weight : lr_head().lr_weight;
  }
  // The LR head in use (after init): the file's, or the view head Config::perceived_labels chose; its name ("" =
  // the file's LR head).
  const NeuralTreeWeights::LrHead& lr_head() const {
    return view_index_ >= 0 ? weights_.views[static_cast<std::size_t>(view_index_)].lr : weights_.lr;
  }
  std::string view() const {
    return view_index_ >= 0 ? weights_.views[static_cast<std::size_t>(view_index_)].name : std::string();
  }

  // Labels every room of `graph`. Returns false with a reason (no weights, bad graph, capacity) and then every
  // prediction is "unknown". Does not allocate once init() has run, while the graph stays within Config.
  bool classify(const ObjectRoomGraph& graph, std::string* error);

  const std::vector<RoomPrediction>& predictions() const { return predictions_; }
  // Log of the blended class probabilities per room (rows follow predictions()), in the model's class order,
  // floored at 1e-30; the neural tree's and the LR head's own probabilities and the LR's raw features (before
  // standardisation): for parity tests.
  Eigen::Block<const RowMatrixXf, Eigen::Dynamic, Eigen::Dynamic, true> room_log_probabilities() const {
    return log_probabilities_.topRows(num_rooms_);
  }
  Eigen::Block<const RowMatrixXf, Eigen::Dynamic, Eigen::Dynamic, true> room_nt_probabilities() const {
    return nt_probabilities_.topRows(num_rooms_);
  }
  Eigen::Block<const RowMatrixXd, Eigen::Dynamic, Eigen::Dynamic, true> room_lr_probabilities() const {
    return lr_probabilities_.topRows(num_rooms_);
  }
  Eigen::Block<const RowMatrixXd, Eigen::Dynamic, Eigen::Dynamic, true> room_lr_features() const {
    return lr_features_.topRows(num_rooms_);
  }
  // Per room: the share of its objects the LR head counted (1 for a room without objects).
  Eigen::VectorBlock<const Eigen::VectorXd> room_lr_coverage() const { return lr_coverage_.head(num_rooms_); }
  const HTree& h_tree() const { return h_tree_; }
  const LayeredGraph& layered_graph() const { return layered_; }  // the hierarchical graph the H-tree was built on
  const NeuralTreeWeights& weights() const { return weights_; }
  const Stats& stats() const { return stats_; }
  const Config& config() const { return config_; }

 private:
  bool fail(std::string* error, const std::string& message);
  bool build_graph(const ObjectRoomGraph& graph, std::string* error);
  void compute_features(const ObjectRoomGraph& graph);  // graph-side inputs shared by every member
  void run_member(std::size_t m);                       // adds the member's probabilities to probabilities_
  void run_lr(const ObjectRoomGraph& graph);            // lr_features_ and lr_probabilities_ of every room

  Config config_;
  bool ready_ = false;
  NeuralTreeWeights weights_;
  int view_index_ = -1;  // the view head in use (weights_.views), -1: the file's LR head
  std::vector<int> mpcat40_word_;
  int refrigerator_word_ = -1, oven_word_ = -1, microwave_word_ = -1;  // appliance_class() rows
  ObjectRoomGraph filtered_;  // the input with unread objects left out (drop_unread_objects)
  std::vector<RowMatrixXf> word_self_, word_neigh_;  // per member: word table through layer 0 (words x hidden)
  HTreeBuilder builder_;
  LayeredGraph layered_;
  HTree h_tree_;
  std::vector<RoomPrediction> predictions_;
  int num_rooms_ = 0;
  // Per H-tree node buffers, sized at init for Config::h_tree.max_htree_nodes rows.
  std::vector<float> label_count_;  // per graph node: log(1 + same-label objects in its room)
  std::vector<std::int32_t> graph_word_, adj_begin_, adj_, adj_fill_, room_slot_, object_count_, leaf_begin_, leaves_;
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> positions_;  // mean member centroid per node
  RowMatrixXf relative_, log_size_, offset_, h_, h_next_, aggregate_, self_, neigh_, pooled_, logits_;
  RowMatrixXf probabilities_, log_probabilities_, nt_probabilities_;
  std::vector<int> lr_column_of_word_;  // per word-table row: its LR count feature, -1 = not counted
  std::vector<int> lr_footprint_of_word_;  // per word-table row: its footprint class, -1 = none
  RowMatrixXd lr_w_;                    // num_features x num_classes (the head's w, transposed, in double)
  Eigen::RowVectorXd lr_b_;
  RowMatrixXd lr_features_, lr_probabilities_;  // per room, sized at init for Config::max_rooms rows
  Eigen::VectorXd lr_coverage_;                  // per room: the share of its objects the LR counted
  Stats stats_;
};

}  // namespace qsg::neural_tree
