// Neural-tree room classification: H-tree features, message passing, pooling, and the logistic-regression head
// blended with it (the weights are read and checked in weights_reader.cc).
#include "core/neural_tree/room_classifier.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/neural_tree/label_map.h"

namespace qsg::neural_tree {
Eigen::Vector3d offset_feature(const Eigen::Vector3d& d) {
  const double h = std::hypot(d.x(), d.y());
  return {h, d.z(), std::sqrt(h * h + d.z() * d.z())};
}


void ObjectRoomGraph::reserve(int nodes_capacity, int edges_capacity) {
  nodes.reserve(static_cast<std::size_t>(nodes_capacity));
  edge_a.reserve(static_cast<std::size_t>(edges_capacity));
  edge_b.reserve(static_cast<std::size_t>(edges_capacity));
}

void ObjectRoomGraph::clear() {
  nodes.clear();
  edge_a.clear();
  edge_b.clear();
}

int ObjectRoomGraph::add_room(const Eigen::Vector3d& centroid_m, const Eigen::Vector3d& size_m) {
  Node n;
  n.layer = NodeLayer::kRoom;
  n.centroid_m = centroid_m;
  n.size_m = size_m;
  nodes.push_back(n);
  return static_cast<int>(nodes.size()) - 1;
}

int ObjectRoomGraph::add_building(const Eigen::Vector3d& centroid_m) {
  Node n;
  n.layer = NodeLayer::kBuilding;
  n.centroid_m = centroid_m;
  nodes.push_back(n);
  return static_cast<int>(nodes.size()) - 1;
}

int ObjectRoomGraph::add_object(int room, int word, const Eigen::Vector3d& centroid_m, const Eigen::Vector3d& size_m) {
  Node n;
  n.layer = NodeLayer::kObject;
  n.room = room;
  n.word = word;
  n.centroid_m = centroid_m;
  n.size_m = size_m;
  nodes.push_back(n);
  return static_cast<int>(nodes.size()) - 1;
}

void ObjectRoomGraph::add_edge(int a, int b) {
  edge_a.push_back(a);
  edge_b.push_back(b);
}

void RoomClassifier::Config::print(std::FILE* out) const {
  std::fprintf(out,
               "RoomClassifier::Config: weights_path=%s max_rooms=%d min_probability=%.3f min_objects=%d "
               "mpcat40_aliases=%s read_through_label_map=%s drop_unread_objects=%s empty_rooms_from_box=%s "
               "lr_weight=%.3f perceived_labels=%zu\n",
               weights_path.c_str(), max_rooms, static_cast<double>(min_probability), min_objects,
               alias_mpcat40_to_training_classes ? "on" : "off", read_through_label_map ? "on" : "off",
               drop_unread_objects ? "on" : "off", empty_rooms_from_box ? "on" : "off", lr_weight,
               perceived_labels.size());
  h_tree.print(out);
}

void RoomClassifier::Stats::print(std::FILE* out) const {
  std::fprintf(out,
               "RoomClassifier: runs=%llu failures=%llu dropped_edges=%llu last graph/H-tree nodes=%d/%d "
               "width last/max=%d/%d max H-tree nodes=%d\n",
               static_cast<unsigned long long>(runs), static_cast<unsigned long long>(failures),
               static_cast<unsigned long long>(dropped_edges), last_graph_nodes, last_htree_nodes, last_width,
               max_width, max_htree_nodes);
}

RoomClassifier::RoomClassifier() : RoomClassifier(Config()) {}

RoomClassifier::RoomClassifier(const Config& config) : config_(config), builder_(config.h_tree) {
  predictions_.reserve(static_cast<std::size_t>(config_.max_rooms));
}

bool RoomClassifier::init(std::string* error) {
  ready_ = false;
  std::string reason;
  if (!load_weights(config_.weights_path, &weights_, &reason)) {
    if (error) *error = reason;
    return false;
  }
  const NeuralTreeWeights& w = weights_;
  const int hidden = w.hidden;
  // Word features enter layer 0 linearly: project the table once instead of every object every run.
  word_self_.resize(w.members.size());
  word_neigh_.resize(w.members.size());
  for (std::size_t m = 0; m < w.members.size(); ++m) {
    const auto& l0 = w.members[m].layers[0];
    word_self_[m].noalias() = w.words * l0.w_self.middleCols(w.offsets.word, w.word_dim).transpose();
    word_neigh_[m].noalias() = w.words * l0.w_neigh.middleCols(w.offsets.word, w.word_dim).transpose();
  }
  mpcat40_word_.assign(semantics::kNumObjectLabels, -1);
  for (semantics::Label l = 0; l < semantics::kNumObjectLabels; ++l)
    mpcat40_word_[l] = word_index(semantics::object_label(l).name);
  refrigerator_word_ = word_index("refrigerator");
  oven_word_ = word_index("oven");
  microwave_word_ = word_index("microwave");
  if (config_.read_through_label_map) {
    for (semantics::Label l = 0; l < semantics::kNumObjectLabels; ++l) {
      const char* reads = label_reading(l).reads_as;
      mpcat40_word_[l] = std::strcmp(reads, "appliances") == 0 ? -1 : word_index(std::string(reads));
    }
  } else if (config_.alias_mpcat40_to_training_classes) {
    // mpcat40 name -> the COCO class (Stanford3DSG spelling) for the same object.
    static constexpr std::pair<semantics::Label, const char*> kAliases[] = {
        {semantics::kSofa, "couch"}, {semantics::kTvMonitor, "tv"}, {semantics::kTable, "dining_table"}};
    for (const auto& [label, coco] : kAliases)
      if (const int row = word_index(coco); row >= 0) mpcat40_word_[label] = row;
  }
  // The LR head: the file's, or the view head trained for exactly the training classes the perceived labels are
  // read as (Config::perceived_labels).
  view_index_ = -1;
  if (!config_.perceived_labels.empty() && config_.read_through_label_map) {
    std::vector<std::string> visible;
    const auto add = [&visible](const std::string& name) {
      if (!name.empty() && std::find(visible.begin(), visible.end(), name) == visible.end()) visible.push_back(name);
    };
    for (const semantics::Label l : config_.perceived_labels) {
      const char* reads = label_reading(l).reads_as;
      if (std::strcmp(reads, "appliances") == 0) {
        for (const char* a : {"refrigerator", "oven", "microwave"}) add(a);
      } else {
        add(reads);
      }
    }
    for (std::size_t i = 0; i < w.views.size(); ++i) {
      const std::vector<std::string>& reads = w.views[i].lr.vocabulary;
      const bool same = reads.size() == visible.size() &&
                        std::all_of(reads.begin(), reads.end(), [&visible](const std::string& n) {
                          return std::find(visible.begin(), visible.end(), n) != visible.end();
                        });
      if (same) view_index_ = static_cast<int>(i);
    }
  }
  const auto nodes = static_cast<Eigen::Index>(config_.h_tree.max_htree_nodes);
  const auto graph_nodes = static_cast<std::size_t>(config_.h_tree.max_graph_nodes);
  layered_.layers.reserve(graph_nodes);
  filtered_.reserve(static_cast<int>(graph_nodes), static_cast<int>(graph_nodes * 8));
  layered_.edge_a.reserve(graph_nodes * 8);
  layered_.edge_b.reserve(graph_nodes * 8);
  adj_begin_.reserve(static_cast<std::size_t>(nodes) + 1);
  adj_fill_.reserve(static_cast<std::size_t>(nodes));
  adj_.reserve(2 * static_cast<std::size_t>(nodes));
  room_slot_.reserve(graph_nodes);
  object_count_.reserve(graph_nodes);
  label_count_.reserve(graph_nodes);
  graph_word_.reserve(graph_nodes);
  leaf_begin_.reserve(static_cast<std::size_t>(config_.max_rooms) + 1);
  leaves_.reserve(static_cast<std::size_t>(nodes));
  positions_.resize(nodes, 3);
  relative_.resize(nodes, 3);
  log_size_.resize(nodes, 3);
  offset_.resize(nodes, 4);  // offset from the room (3) and log(1 + objects in the room)
  for (RowMatrixXf* m : {&h_, &h_next_, &aggregate_, &self_, &neigh_}) m->resize(nodes, hidden);
  pooled_.resize(config_.max_rooms, hidden);
  logits_.resize(config_.max_rooms, w.num_classes);
  probabilities_.resize(config_.max_rooms, w.num_classes);
  log_probabilities_.resize(config_.max_rooms, w.num_classes);
  nt_probabilities_.resize(config_.max_rooms, w.num_classes);
  // LR head: each word-table row counts under its name's feature (so mpcat40 aliases count as their COCO class).
  const NeuralTreeWeights::LrHead& lr = lr_head();
  lr_column_of_word_.assign(w.word_names.size(), -1);
  for (std::size_t v = 0; v < lr.vocabulary.size(); ++v)
    lr_column_of_word_[static_cast<std::size_t>(word_index(lr.vocabulary[v]))] = static_cast<int>(v);
  lr_footprint_of_word_.assign(w.word_names.size(), -1);
  for (std::size_t v = 0; v < lr.footprint_classes.size(); ++v)
    lr_footprint_of_word_[static_cast<std::size_t>(word_index(lr.footprint_classes[v]))] = static_cast<int>(v);
  lr_w_ = lr.w.transpose().cast<double>();
  lr_b_ = lr.b.transpose().cast<double>();
  lr_features_.resize(config_.max_rooms, lr.num_features());
  lr_probabilities_.resize(config_.max_rooms, w.num_classes);
  lr_coverage_.resize(config_.max_rooms);
  // Size the H-tree storage now rather than on the first classify().
  LayeredGraph empty;
  builder_.build(empty, &h_tree_, nullptr);
  ready_ = true;
  return true;
}

int RoomClassifier::word_index(const std::string& name) const {
  for (std::size_t i = 0; i < weights_.word_names.size(); ++i)
    if (weights_.word_names[i] == name) return static_cast<int>(i);
  return -1;
}

int RoomClassifier::word_index(semantics::Label mpcat40_label) const {
  return mpcat40_label < mpcat40_word_.size() ? mpcat40_word_[mpcat40_label] : -1;
}

int RoomClassifier::word_index(semantics::Label mpcat40_label, const Eigen::Vector3d& size_m) const {
  if (config_.read_through_label_map && mpcat40_label == semantics::kAppliances) {
    const char* c = appliance_class(size_m);
    return std::strcmp(c, "refrigerator") == 0 ? refrigerator_word_
           : std::strcmp(c, "oven") == 0       ? oven_word_
                                               : microwave_word_;
  }
  return word_index(mpcat40_label);
}

bool RoomClassifier::fail(std::string* error, const std::string& message) {
  ++stats_.failures;
  for (RoomPrediction& p : predictions_) {
    p.label = semantics::kRoomUnknown;
    p.probability = 0.0f;
    p.label_probabilities.fill(0.0f);
  }
  if (error) *error = message;
  return false;
}

bool RoomClassifier::build_graph(const ObjectRoomGraph& graph, std::string* error) {
  const int n = static_cast<int>(graph.nodes.size());
  layered_.clear();
  int building = -1;
  for (int v = 0; v < n; ++v) {
    const auto& node = graph.nodes[v];
    layered_.layers.push_back(node.layer);
    if (node.layer == NodeLayer::kBuilding) {
      if (building >= 0) {
        if (error) *error = "neural_tree: more than one building node (" + std::to_string(building) + ", " +
                            std::to_string(v) + ")";
        return false;
      }
      building = v;
    }
  }
  // Parent edges (object-room, room-building) come from the nodes; explicit edges only within a layer, and
  // object-object edges only inside one room, so the graph stays hierarchical.
  for (int v = 0; v < n; ++v) {
    const auto& node = graph.nodes[v];
    if (node.layer == NodeLayer::kObject && node.room >= 0) {
      if (node.room >= n || graph.nodes[node.room].layer != NodeLayer::kRoom) {
        if (error) *error = "neural_tree: object " + std::to_string(v) + " names room " + std::to_string(node.room) +
                            ", which is not a room node";
        return false;
      }
      layered_.edge_a.push_back(v);
      layered_.edge_b.push_back(node.room);
    } else if (node.layer == NodeLayer::kRoom && building >= 0) {
      layered_.edge_a.push_back(v);
      layered_.edge_b.push_back(building);
    }
  }
  for (std::size_t e = 0; e < graph.edge_a.size() && e < graph.edge_b.size(); ++e) {
    const int a = graph.edge_a[e], b = graph.edge_b[e];
    if (a < 0 || b < 0 || a >= n || b >= n) {
      if (error) *error = "neural_tree: edge " + std::to_string(e) + " (" + std::to_string(a) + "," +
                          std::to_string(b) + ") names a node outside 0.." + std::to_string(n - 1);
      return false;
    }
    const auto& na = graph.nodes[a];
    const auto& nb = graph.nodes[b];
    bool keep = false;
    if (na.layer == NodeLayer::kObject && nb.layer == NodeLayer::kObject)
      keep = na.room >= 0 && na.room == nb.room;
    else if (na.layer == NodeLayer::kRoom && nb.layer == NodeLayer::kRoom)
      keep = true;
    else if (na.layer == NodeLayer::kObject && nb.layer == NodeLayer::kRoom)
      keep = na.room == b;  // the parent edge, already present
    else if (na.layer == NodeLayer::kRoom && nb.layer == NodeLayer::kObject)
      keep = nb.room == a;
    else
      keep = (na.layer == NodeLayer::kBuilding) != (nb.layer == NodeLayer::kBuilding) &&
             (na.layer == NodeLayer::kRoom || nb.layer == NodeLayer::kRoom);
    if (!keep) {
      ++stats_.dropped_edges;
      continue;
    }
    layered_.edge_a.push_back(a);
    layered_.edge_b.push_back(b);
  }
  return true;
}

void RoomClassifier::compute_features(const ObjectRoomGraph& graph) {
  const NeuralTreeWeights& w = weights_;
  const int n = h_tree_.num_nodes();
  const BagTree& t = h_tree_.tree;
  object_count_.assign(graph.nodes.size(), 0);
  for (const auto& node : graph.nodes)
    if (node.layer == NodeLayer::kObject && node.room >= 0) ++object_count_[node.room];
  label_count_.assign(graph.nodes.size(), 0.0f);
  if (w.offsets.object_label_count >= 0) {
    for (std::size_t v = 0; v < graph.nodes.size(); ++v) {
      const auto& a = graph.nodes[v];
      if (a.layer != NodeLayer::kObject || a.room < 0) continue;
      int same = 0;
      for (const auto& b : graph.nodes)
        same += b.layer == NodeLayer::kObject && b.room == a.room && graph_word_[&b - graph.nodes.data()] == graph_word_[v];
      label_count_[v] = static_cast<float>(std::log1p(static_cast<double>(same)));
    }
  }
  const double min_size = w.min_size_m;
  // Box size without the room's orientation: log of the larger and smaller horizontal side, log height.
  auto log_size = [&](int row, const Eigen::Vector3d& s) {
    const double sx = std::max(s.x(), min_size), sy = std::max(s.y(), min_size), sz = std::max(s.z(), min_size);
    log_size_(row, 0) = static_cast<float>(std::log(std::max(sx, sy)));
    log_size_(row, 1) = static_cast<float>(std::log(std::min(sx, sy)));
    log_size_(row, 2) = static_cast<float>(std::log(sz));
  };
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (int k = 0; k < t.bag_size(i); ++k) p += graph.nodes[t.bag(i)[k]].centroid_m;
    p /= t.bag_size(i);
    positions_.row(i) = p.transpose();
    log_size_.row(i).setZero();
    offset_.row(i).setZero();
    if (t.bag_size(i) != 1) continue;
    const auto& node = graph.nodes[t.bag(i)[0]];
    if (node.layer == NodeLayer::kObject) {
      log_size(i, node.size_m);
      if (node.room >= 0)
        offset_.row(i).head<3>() =
            (offset_feature(node.centroid_m - graph.nodes[node.room].centroid_m) * w.position_scale)
                .transpose()
                .cast<float>();
    } else if (node.layer == NodeLayer::kRoom) {
      log_size(i, node.size_m);
      offset_(i, 3) = static_cast<float>(std::log1p(static_cast<double>(object_count_[t.bag(i)[0]])));
    }
  }
  // H-tree adjacency (CSR) and the edge feature: mean relative position of each node's neighbours.
  adj_begin_.assign(static_cast<std::size_t>(n) + 1, 0);
  for (std::size_t e = 0; e < t.edge_parent.size(); ++e) {
    ++adj_begin_[t.edge_parent[e] + 1];
    ++adj_begin_[t.edge_child[e] + 1];
  }
  for (int i = 0; i < n; ++i) adj_begin_[i + 1] += adj_begin_[i];
  adj_.resize(static_cast<std::size_t>(adj_begin_[n]));
  adj_fill_.assign(adj_begin_.begin(), adj_begin_.end() - 1);
  for (std::size_t e = 0; e < t.edge_parent.size(); ++e) {
    adj_[adj_fill_[t.edge_parent[e]]++] = t.edge_child[e];
    adj_[adj_fill_[t.edge_child[e]]++] = t.edge_parent[e];
  }
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d r = Eigen::Vector3d::Zero();
    const int deg = adj_begin_[i + 1] - adj_begin_[i];
    for (int p = adj_begin_[i]; p < adj_begin_[i + 1]; ++p)
      r += offset_feature((positions_.row(adj_[p]) - positions_.row(i)).transpose());
    relative_.row(i) = ((deg > 0 ? r / deg : r) * w.position_scale).transpose().cast<float>();
  }
}

void RoomClassifier::run_member(std::size_t m) {
  const NeuralTreeWeights& w = weights_;
  const auto& member = w.members[m];
  const auto& l0 = member.layers[0];
  const auto& o = w.offsets;
  const int n = h_tree_.num_nodes();
  const BagTree& t = h_tree_.tree;
  // Layer 0 applied to each node's sparse input: its type column plus the features its kind carries.
  for (int i = 0; i < n; ++i) {
    const int type = h_tree_.types[i];
    auto self = self_.row(i);
    auto neigh = neigh_.row(i);
    self = l0.w_self.col(o.type + type).transpose();
    neigh = l0.w_neigh.col(o.type + type).transpose();
    if (t.bag_size(i) != 1) continue;
    const auto& s = log_size_.row(i).transpose();
    if (type == kLeafObject) {
      const int word = graph_word_[t.bag(i)[0]];
      if (word >= 0) {
        self += word_self_[m].row(word);
        neigh += word_neigh_[m].row(word);
      }
      const auto r = offset_.row(i).head<3>().transpose();
      self.noalias() += (l0.w_self.middleCols<3>(o.object_size) * s).transpose();
      neigh.noalias() += (l0.w_neigh.middleCols<3>(o.object_size) * s).transpose();
      self.noalias() += (l0.w_self.middleCols<3>(o.object_relative_position) * r).transpose();
      neigh.noalias() += (l0.w_neigh.middleCols<3>(o.object_relative_position) * r).transpose();
      if (o.object_label_count >= 0) {
        const float c = label_count_[t.bag(i)[0]];
        self += c * l0.w_self.col(o.object_label_count).transpose();
        neigh += c * l0.w_neigh.col(o.object_label_count).transpose();
      }
    } else if (type == kLeafRoom) {
      const float count = offset_(i, 3);
      self.noalias() += (l0.w_self.middleCols<3>(o.room_size) * s).transpose();
      neigh.noalias() += (l0.w_neigh.middleCols<3>(o.room_size) * s).transpose();
      self += count * l0.w_self.col(o.room_object_count).transpose();
      neigh += count * l0.w_neigh.col(o.room_object_count).transpose();
    }
  }
  for (std::size_t l = 0; l < member.layers.size(); ++l) {
    const auto& layer = member.layers[l];
    if (l > 0) {
      self_.topRows(n).noalias() = h_.topRows(n) * layer.w_self.transpose();
      neigh_.topRows(n).noalias() = h_.topRows(n) * layer.w_neigh.transpose();
    }
    for (int i = 0; i < n; ++i) {
      const int deg = adj_begin_[i + 1] - adj_begin_[i];
      auto agg = aggregate_.row(i);
      agg.setZero();
      for (int p = adj_begin_[i]; p < adj_begin_[i + 1]; ++p) agg += neigh_.row(adj_[p]);
      if (deg > 0 && !w.sum_aggregation) agg /= static_cast<float>(deg);
    }
    h_next_.topRows(n).noalias() = relative_.topRows(n) * layer.w_edge.transpose();
    h_next_.topRows(n) += self_.topRows(n) + aggregate_.topRows(n);
    h_next_.topRows(n).rowwise() += layer.b_self.transpose();
    h_.topRows(n) = h_next_.topRows(n).cwiseMax(0.0f);
  }
  for (int r = 0; r < num_rooms_; ++r) {
    auto pooled = pooled_.row(r);
    pooled.setZero();
    const int count = leaf_begin_[r + 1] - leaf_begin_[r];
    for (int p = leaf_begin_[r]; p < leaf_begin_[r + 1]; ++p) pooled += h_.row(leaves_[p]);
    if (count > 0) pooled /= static_cast<float>(count);
  }
  logits_.topRows(num_rooms_).noalias() = pooled_.topRows(num_rooms_) * member.head_w.transpose();
  logits_.topRows(num_rooms_).rowwise() += member.head_b.transpose();
  for (int r = 0; r < num_rooms_; ++r) {
    const float top = logits_.row(r).maxCoeff();
    float sum = 0.0f;
    for (int c = 0; c < w.num_classes; ++c) sum += std::exp(logits_(r, c) - top);
    for (int c = 0; c < w.num_classes; ++c) probabilities_(r, c) += std::exp(logits_(r, c) - top) / sum;
  }
}

void RoomClassifier::run_lr(const ObjectRoomGraph& graph) {
  const NeuralTreeWeights::LrHead& lr = lr_head();
  const int vocabulary = static_cast<int>(lr.vocabulary.size());
  auto x = lr_features_.topRows(num_rooms_);
  x.setZero();
  auto counted = lr_coverage_.head(num_rooms_);
  counted.setZero();
  const int footprints = vocabulary + NeuralTreeWeights::kNumLrBoxFeatures;  // first footprint column
  const double min_size = lr.min_size_m;
  for (std::size_t v = 0; v < graph.nodes.size(); ++v) {
    const auto& node = graph.nodes[v];
    if (node.layer != NodeLayer::kObject || node.room < 0 || graph_word_[v] < 0) continue;
    const int column = lr_column_of_word_[static_cast<std::size_t>(graph_word_[v])];
    if (column < 0) continue;
    const int r = room_slot_[node.room];
    x(r, column) += 1.0;
    counted[r] += 1.0;
    const int fp = lr_footprint_of_word_[static_cast<std::size_t>(graph_word_[v])];
    if (fp >= 0) {
      // The largest footprint of the class so far, kept as its log1p (monotonic, so the max carries over).
      const double area = std::max(node.size_m.x(), min_size) * std::max(node.size_m.y(), min_size);
      x(r, footprints + fp) = std::max(x(r, footprints + fp), std::log1p(area));
    }
  }
  // Coverage: the counted share of the room's objects (object_count_, from compute_features); 1 without objects.
  for (int r = 0; r < num_rooms_; ++r) {
    const int objects = object_count_[predictions_[r].node];
    counted[r] = objects > 0 ? counted[r] / objects : 1.0;
  }
  for (int r = 0; r < num_rooms_; ++r) {
    for (int c = 0; c < vocabulary; ++c) x(r, c) = std::log1p(x(r, c));
    // The box as the trainer's lr_room_features: x and y as stored (not sorted), then max, min and sum.
    const Eigen::Vector3d& size = graph.nodes[predictions_[r].node].size_m;
    const double sx = std::log(std::max(size.x(), min_size)), sy = std::log(std::max(size.y(), min_size)),
                 sz = std::log(std::max(size.z(), min_size));
    x(r, vocabulary) = sx;
    x(r, vocabulary + 1) = sy;
    x(r, vocabulary + 2) = sz;
    x(r, vocabulary + 3) = std::max(sx, sy);
    x(r, vocabulary + 4) = std::min(sx, sy);
    x(r, vocabulary + 5) = sx + sy;
  }
  auto p = lr_probabilities_.topRows(num_rooms_);
  for (int r = 0; r < num_rooms_; ++r) {
    // Logits ((x - mean) / std) w + b; lr_features_ keeps the raw features (parity tests read them).
    p.row(r) = lr_b_;
    for (int f = 0; f < lr.num_features(); ++f) p.row(r) += ((x(r, f) - lr.mean[f]) / lr.std[f]) * lr_w_.row(f);
    const double top = p.row(r).maxCoeff();
    p.row(r) = (p.row(r).array() - top).exp();
    p.row(r) /= p.row(r).sum();
  }
}

bool RoomClassifier::classify(const ObjectRoomGraph& input, std::string* error) {
  ++stats_.runs;
  predictions_.clear();
  num_rooms_ = 0;
  const int n = static_cast<int>(input.nodes.size());
  for (int v = 0; v < n; ++v) {
    if (input.nodes[v].layer != NodeLayer::kRoom) continue;
    if (static_cast<int>(predictions_.size()) == config_.max_rooms)
      return fail(error, "neural_tree: more than max_rooms = " + std::to_string(config_.max_rooms) + " rooms");
    RoomPrediction p;
    p.node = v;
    predictions_.push_back(p);
  }
  if (!ready_) return fail(error, "neural_tree: no weights loaded (" + config_.weights_path + "); rooms stay unknown");
  if (config_.drop_unread_objects) {
    // Unread objects (no word) lose their room: left out, as an object without a room always was.
    filtered_.nodes.assign(input.nodes.begin(), input.nodes.end());
    filtered_.edge_a.assign(input.edge_a.begin(), input.edge_a.end());
    filtered_.edge_b.assign(input.edge_b.begin(), input.edge_b.end());
    for (ObjectRoomGraph::Node& node : filtered_.nodes)
      if (node.layer == NodeLayer::kObject && (node.word < 0 || node.word >= weights_.words.rows())) node.room = -1;
  }
  const ObjectRoomGraph& graph = config_.drop_unread_objects ? filtered_ : input;
  if (!build_graph(graph, error)) return fail(error, error ? *error : std::string());
  std::string reason;
  if (!builder_.build(layered_, &h_tree_, error ? error : &reason)) return fail(error, error ? *error : reason);
  num_rooms_ = static_cast<int>(predictions_.size());
  stats_.last_graph_nodes = n;
  stats_.last_htree_nodes = h_tree_.num_nodes();
  stats_.last_width = h_tree_.width;
  stats_.max_width = std::max(stats_.max_width, h_tree_.width);
  stats_.max_htree_nodes = std::max(stats_.max_htree_nodes, h_tree_.num_nodes());
  // Each room's leaves, grouped by the room's slot in predictions_.
  room_slot_.assign(static_cast<std::size_t>(n), -1);
  for (int r = 0; r < num_rooms_; ++r) room_slot_[predictions_[r].node] = r;
  leaf_begin_.assign(static_cast<std::size_t>(num_rooms_) + 1, 0);
  const BagTree& t = h_tree_.tree;
  for (int i = 0; i < t.num_bags(); ++i)
    if (t.bag_size(i) == 1 && room_slot_[t.bag(i)[0]] >= 0) ++leaf_begin_[room_slot_[t.bag(i)[0]] + 1];
  for (int r = 0; r < num_rooms_; ++r) leaf_begin_[r + 1] += leaf_begin_[r];
  leaves_.resize(static_cast<std::size_t>(leaf_begin_[num_rooms_]));
  adj_fill_.assign(leaf_begin_.begin(), leaf_begin_.end() - 1);
  for (int i = 0; i < t.num_bags(); ++i)
    if (t.bag_size(i) == 1 && room_slot_[t.bag(i)[0]] >= 0) leaves_[adj_fill_[room_slot_[t.bag(i)[0]]]++] = i;
  graph_word_.clear();
  for (const auto& node : graph.nodes)
    graph_word_.push_back(node.word >= 0 && node.word < weights_.words.rows() ? node.word : -1);
  compute_features(graph);
  probabilities_.topRows(num_rooms_).setZero();
  for (std::size_t m = 0; m < weights_.members.size(); ++m) run_member(m);
  nt_probabilities_.topRows(num_rooms_) =
      probabilities_.topRows(num_rooms_) * (1.0f / static_cast<float>(weights_.members.size()));
  run_lr(graph);
  for (int r = 0; r < num_rooms_; ++r) {
    RoomPrediction& p = predictions_[r];
    const bool from_box = config_.empty_rooms_from_box && object_count_[p.node] == 0;
    const double a = from_box ? 1.0 : lr_weight() * (lr_head().weight_by_coverage ? lr_coverage_[r] : 1.0);
    // The blend: (1 - a) p_nt + a p_lr, or with log pooling p_nt^(1 - a) p_lr^a normalised.
    double sum = 0.0;
    for (int c = 0; c < weights_.num_classes; ++c) {
      const double nt = nt_probabilities_(r, c), lr = lr_probabilities_(r, c);
      const double q = lr_head().log_pool
                           ? std::exp((1.0 - a) * std::log(std::max(nt, 1e-30)) + a * std::log(std::max(lr, 1e-30)))
                           : (1.0 - a) * nt + a * lr;
      probabilities_(r, c) = static_cast<float>(q);
      sum += q;
    }
    p.label_probabilities.fill(0.0f);
    for (int c = 0; c < weights_.num_classes; ++c) {
      const float q = static_cast<float>(probabilities_(r, c) / sum);
      log_probabilities_(r, c) = std::log(std::max(q, 1e-30f));
      p.label_probabilities[weights_.class_room_labels[c]] += q;
    }
    p.label = semantics::kRoomUnknown;
    p.probability = 0.0f;
    for (semantics::RoomLabel l = 1; l < semantics::kNumRoomLabels; ++l)
      if (p.label_probabilities[l] > p.probability) {
        p.probability = p.label_probabilities[l];
        p.label = l;
      }
    if (p.probability < config_.min_probability || (!from_box && object_count_[p.node] < config_.min_objects))
      p.label = semantics::kRoomUnknown;
  }
  return true;
}

}  // namespace qsg::neural_tree
