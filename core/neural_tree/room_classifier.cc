// Neural-tree room classification: weight loading with shape checks, H-tree features, message passing, pooling,
// and the logistic-regression head blended with it.
#include "core/neural_tree/room_classifier.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/neural_tree/label_map.h"

namespace qsg::neural_tree {
namespace {

using nlohmann::json;

// Decodes standard base64 (with '=' padding); false on a character outside the alphabet.
bool decode_base64(const std::string& text, std::vector<unsigned char>* out) {
  out->clear();
  unsigned value = 0;
  int bits = 0;
  for (const char ch : text) {
    int d;
    if (ch >= 'A' && ch <= 'Z') d = ch - 'A';
    else if (ch >= 'a' && ch <= 'z') d = ch - 'a' + 26;
    else if (ch >= '0' && ch <= '9') d = ch - '0' + 52;
    else if (ch == '+') d = 62;
    else if (ch == '/') d = 63;
    else if (ch == '=') break;
    else return false;
    value = (value << 6) | static_cast<unsigned>(d);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out->push_back(static_cast<unsigned char>((value >> bits) & 0xFFu));
    }
  }
  return true;
}

// Reads `count` finite numbers from doc[key] into `out`: a JSON array of numbers, or a string holding base64 of
// little-endian float32 (the training tool's compact form). On failure sets `error` naming the field.
bool read_floats(const json& doc, const char* key, const std::string& field, std::size_t count, float* out,
                 std::string* error) {
  const auto it = doc.find(key);
  if (it != doc.end() && it->is_string()) {
    std::vector<unsigned char> bytes;
    if (!decode_base64(it->get<std::string>(), &bytes)) {
      *error = field + ": not valid base64";
      return false;
    }
    if (bytes.size() != 4 * count) {
      *error = field + ": expected " + std::to_string(count) + " numbers, got " + std::to_string(bytes.size() / 4) +
               (bytes.size() % 4 ? " and a partial one" : "");
      return false;
    }
    for (std::size_t i = 0; i < count; ++i) {
      const std::uint32_t u = static_cast<std::uint32_t>(bytes[4 * i]) |
                              static_cast<std::uint32_t>(bytes[4 * i + 1]) << 8 |
                              static_cast<std::uint32_t>(bytes[4 * i + 2]) << 16 |
                              static_cast<std::uint32_t>(bytes[4 * i + 3]) << 24;
      std::memcpy(&out[i], &u, sizeof(float));
      if (!std::isfinite(out[i])) {
        *error = field + "[" + std::to_string(i) + "]: not a finite number";
        return false;
      }
    }
    return true;
  }
  if (it == doc.end() || !it->is_array()) {
    *error = field + ": missing, or neither an array nor base64 float32";
    return false;
  }
  if (it->size() != count) {
    *error = field + ": expected " + std::to_string(count) + " numbers, got " + std::to_string(it->size());
    return false;
  }
  for (std::size_t i = 0; i < count; ++i) {
    const json& v = (*it)[i];
    if (!v.is_number() || !std::isfinite(v.get<double>())) {
      *error = field + "[" + std::to_string(i) + "]: not a finite number";
      return false;
    }
    out[i] = v.get<float>();
  }
  return true;
}

bool read_int(const json& doc, const char* key, const std::string& field, int lo, int hi, int* out,
              std::string* error) {
  const auto it = doc.find(key);
  if (it == doc.end() || !it->is_number_integer()) {
    *error = field + ": missing or not an integer";
    return false;
  }
  const auto v = it->get<long long>();
  if (v < lo || v > hi) {
    *error = field + ": " + std::to_string(v) + " outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    return false;
  }
  *out = static_cast<int>(v);
  return true;
}

bool read_matrix(const json& doc, const char* key, const std::string& field, int rows, int cols, RowMatrixXf* out,
                 std::string* error) {
  out->resize(rows, cols);
  return read_floats(doc, key, field + "." + key + " (" + std::to_string(rows) + " x " + std::to_string(cols) + ")",
                     static_cast<std::size_t>(rows) * cols, out->data(), error);
}

// A list of distinct names, each one of `allowed` (else "<field>[i]: \"name\" <not_allowed>"), appended to `out`.
bool read_names(const json& list, const std::string& field, const std::vector<std::string>& allowed,
                const char* not_allowed, std::vector<std::string>* out, std::string* error) {
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string item = field + "[" + std::to_string(i) + "]";
    if (!list[i].is_string()) {
      *error = item + ": not a string";
      return false;
    }
    const std::string name = list[i].get<std::string>();
    if (std::find(allowed.begin(), allowed.end(), name) == allowed.end()) {
      *error = item + ": \"" + name + "\" " + not_allowed;
      return false;
    }
    if (std::find(out->begin(), out->end(), name) != out->end()) {
      *error = item + ": \"" + name + "\" listed twice";
      return false;
    }
    out->push_back(name);
  }
  return true;
}

// An LR head (the file's lr_head, or a view head's): its feature definition must be exactly the one this build
// computes. `prefix` names it in errors.
bool parse_lr_head(const json& doc, const std::string& key, const std::string& prefix, const NeuralTreeWeights& weights,
                   NeuralTreeWeights::LrHead* out, std::string* error) {
  const NeuralTreeWeights* w = &weights;
  static constexpr const char* kBoxFeatures[NeuralTreeWeights::kNumLrBoxFeatures] = {
      "log_size_x", "log_size_y", "log_size_z", "log_size_max_xy", "log_size_min_xy", "log_area_xy"};
  const auto head = doc.find(key);
  if (head == doc.end() || !head->is_object()) {
    *error = prefix + ": missing or not an object (a version 4 file carries the logistic-regression heads)";
    return false;
  }
  NeuralTreeWeights::LrHead& lr = *out;
  const auto features = head->find("features");
  if (features == head->end() || !features->is_object()) {
    *error = prefix + ".features: missing";
    return false;
  }
  const auto counts = features->find("object_counts");
  if (counts == features->end() || !counts->is_object() || counts->value("transform", std::string()) != "log1p") {
    *error = prefix + ".features.object_counts: missing, or its transform is not \"log1p\"";
    return false;
  }
  const auto vocabulary = counts->find("vocabulary");
  if (vocabulary == counts->end() || !vocabulary->is_array() || vocabulary->empty() || vocabulary->size() > 4096) {
    *error = prefix + ".features.object_counts.vocabulary: expected an array of 1 to 4096 object names";
    return false;
  }
  if (!read_names(*vocabulary, prefix + ".features.object_counts.vocabulary", w->word_names, "has no row in words",
                  &lr.vocabulary, error))
    return false;
  const auto box = features->find("room_box");
  bool box_ok = box != features->end() && box->is_array() && box->size() == NeuralTreeWeights::kNumLrBoxFeatures;
  for (int i = 0; box_ok && i < NeuralTreeWeights::kNumLrBoxFeatures; ++i)
    box_ok = (*box)[i].is_string() && (*box)[i].get<std::string>() == kBoxFeatures[i];
  if (!box_ok) {
    *error = prefix + ".features.room_box: expected [log_size_x, log_size_y, log_size_z, log_size_max_xy, "
             "log_size_min_xy, log_area_xy]";
    return false;
  }
  const auto ms = features->find("min_size_m");
  if (ms == features->end() || !ms->is_number() || !(ms->get<double>() > 0.0)) {
    *error = prefix + ".features.min_size_m: missing or not a positive number";
    return false;
  }
  lr.min_size_m = ms->get<float>();
  // Version 3: per class, log(1 + the footprint of the room's largest object of that name); may list none.
  const auto footprint = features->find("largest_footprint");
  if (footprint == features->end() || !footprint->is_object() ||
      footprint->value("transform", std::string()) != "log1p") {
    *error = prefix + ".features.largest_footprint: missing, or its transform is not \"log1p\"";
    return false;
  }
  const auto footprint_classes = footprint->find("classes");
  if (footprint_classes == footprint->end() || !footprint_classes->is_array() || footprint_classes->size() > 256) {
    *error = prefix + ".features.largest_footprint.classes: expected an array of at most 256 object names";
    return false;
  }
  if (!read_names(*footprint_classes, prefix + ".features.largest_footprint.classes", lr.vocabulary,
                  "is not in object_counts.vocabulary", &lr.footprint_classes, error))
    return false;
  const int f = lr.num_features();
  int num_features = 0, num_classes = 0;
  if (!read_int(*head, "num_features", prefix + ".num_features", f, f, &num_features, error) ||
      !read_int(*head, "num_classes", prefix + ".num_classes", w->num_classes, w->num_classes, &num_classes, error))
    return false;
  RowMatrixXf mean, std, bias;
  if (!read_matrix(*head, "mean", prefix, 1, f, &mean, error) ||
      !read_matrix(*head, "std", prefix, 1, f, &std, error) ||
      !read_matrix(*head, "w", prefix, num_classes, f, &lr.w, error) ||
      !read_matrix(*head, "b", prefix, 1, num_classes, &bias, error))
    return false;
  for (int i = 0; i < f; ++i) {
    if (!(std(0, i) > 0.0f)) {
      *error = prefix + ".std[" + std::to_string(i) + "]: not positive";
      return false;
    }
  }
  lr.mean = mean.row(0).transpose().cast<double>();
  lr.std = std.row(0).transpose().cast<double>();
  lr.b = bias.row(0).transpose();
  const auto blend = head->find("blend");
  if (blend == head->end() || !blend->is_object()) {
    *error = prefix + ".blend: missing";
    return false;
  }
  const json weight = blend->value("lr_weight", json());
  if (!weight.is_number() || !(weight.get<double>() >= 0.0) || !(weight.get<double>() <= 1.0)) {
    *error = prefix + ".blend.lr_weight: missing or not a number in [0, 1]";
    return false;
  }
  lr.lr_weight = weight.get<double>();
  const std::string pool = blend->value("pool", std::string());
  if (pool != "linear" && pool != "log") {
    *error = prefix + ".blend.pool: expected \"linear\" or \"log\"";
    return false;
  }
  lr.log_pool = pool == "log";
  const auto by_coverage = blend->find("weight_by_coverage");
  if (by_coverage == blend->end() || !by_coverage->is_boolean()) {
    *error = prefix + ".blend.weight_by_coverage: missing or not true/false";
    return false;
  }
  lr.weight_by_coverage = by_coverage->get<bool>();
  return true;
}

bool parse_weights(const json& doc, NeuralTreeWeights* w, std::string* error) {
  const auto header = doc.find("header");
  if (header == doc.end() || !header->is_object()) {
    *error = "header: missing";
    return false;
  }
  if (header->value("format", std::string()) != "qsg_neural_tree_weights") {
    *error = "header.format: expected \"qsg_neural_tree_weights\"";
    return false;
  }
  int version = 0;
  if (!read_int(*header, "version", "header.version", 0, 1 << 30, &version, error)) return false;
  if (version != NeuralTreeWeights::kFormatVersion) {
    // Version 1 held the neural tree alone, version 2 an LR head without furniture footprints, version 3 no view
    // heads: each would give other labels than the ones the CV and labels_eval measured.
    *error = "header.version: " + std::to_string(version) + " unsupported (this build reads version " +
             std::to_string(NeuralTreeWeights::kFormatVersion) +
             ", the neural tree with its logistic-regression head on counts, box and footprints and the view heads; "
             "write it with bench/neural_tree/train_neural_tree.py train)";
    return false;
  }
  int num_layers = 0, num_types = 0;
  if (!read_int(doc, "input_dim", "input_dim", 1, 4096, &w->input_dim, error) ||
      !read_int(doc, "hidden", "hidden", 1, 1024, &w->hidden, error) ||
      !read_int(doc, "num_layers", "num_layers", 1, 16, &num_layers, error) ||
      !read_int(doc, "num_classes", "num_classes", 1, 256, &w->num_classes, error) ||
      !read_int(doc, "num_types", "num_types", kNumHTreeNodeTypes, kNumHTreeNodeTypes, &num_types, error) ||
      !read_int(doc, "word_dim", "word_dim", 0, 4096, &w->word_dim, error))
    return false;
  const auto ms = doc.find("min_size_m");
  if (ms == doc.end() || !ms->is_number() || !(ms->get<double>() > 0.0)) {
    *error = "min_size_m: missing or not a positive number";
    return false;
  }
  w->min_size_m = ms->get<float>();
  const auto ps = doc.find("position_scale");
  if (ps == doc.end() || !ps->is_number() || !std::isfinite(ps->get<double>())) {
    *error = "position_scale: missing or not a finite number";
    return false;
  }
  w->position_scale = ps->get<float>();
  const std::string aggregation = doc.value("aggregation", std::string());
  if (aggregation != "mean" && aggregation != "sum") {
    *error = "aggregation: expected \"mean\" or \"sum\"";
    return false;
  }
  w->sum_aggregation = aggregation == "sum";
  const auto off = doc.find("offsets");
  if (off == doc.end() || !off->is_object()) {
    *error = "offsets: missing";
    return false;
  }
  auto& o = w->offsets;
  const int d = w->input_dim;
  if (!read_int(*off, "type", "offsets.type", 0, d - num_types, &o.type, error) ||
      !read_int(*off, "word", "offsets.word", 0, d - w->word_dim, &o.word, error) ||
      !read_int(*off, "object_size", "offsets.object_size", 0, d - 3, &o.object_size, error) ||
      !read_int(*off, "object_relative_position", "offsets.object_relative_position", 0, d - 3,
                &o.object_relative_position, error) ||
      !read_int(*off, "room_size", "offsets.room_size", 0, d - 3, &o.room_size, error) ||
      !read_int(*off, "room_object_count", "offsets.room_object_count", 0, d - 1, &o.room_object_count, error) ||
      !read_int(*off, "object_label_count", "offsets.object_label_count", -1, d - 1, &o.object_label_count, error))
    return false;
  const auto classes = doc.find("classes");
  const auto mapped = doc.find("class_room_labels");
  if (classes == doc.end() || !classes->is_array() || classes->size() != static_cast<std::size_t>(w->num_classes)) {
    *error = "classes: expected " + std::to_string(w->num_classes) + " names";
    return false;
  }
  if (mapped == doc.end() || !mapped->is_array() || mapped->size() != classes->size()) {
    *error = "class_room_labels: expected " + std::to_string(w->num_classes) + " names";
    return false;
  }
  for (std::size_t i = 0; i < classes->size(); ++i) {
    if (!(*classes)[i].is_string() || !(*mapped)[i].is_string()) {
      *error = "classes[" + std::to_string(i) + "]: not a string";
      return false;
    }
    w->classes.push_back((*classes)[i].get<std::string>());
    const std::string name = (*mapped)[i].get<std::string>();
    const semantics::RoomLabel label = semantics::room_label_from_name(name.c_str());
    if (label == semantics::kInvalidLabel) {
      *error = "class_room_labels[" + std::to_string(i) + "]: \"" + name + "\" is not a room label";
      return false;
    }
    w->class_room_labels.push_back(label);
  }
  const auto words = doc.find("words");
  if (words == doc.end() || !words->is_object()) {
    *error = "words: missing";
    return false;
  }
  w->words.resize(static_cast<Eigen::Index>(words->size()), w->word_dim);
  int row = 0;
  for (auto it = words->begin(); it != words->end(); ++it, ++row) {
    w->word_names.push_back(it.key());
    if (!read_floats(json{{"v", it.value()}}, "v", "words." + it.key(), static_cast<std::size_t>(w->word_dim),
                     w->words.row(row).data(), error))
      return false;
  }
  const auto members = doc.find("members");
  if (members == doc.end() || !members->is_array() || members->empty() || members->size() > 16) {
    *error = "members: expected an array of 1 to 16 networks";
    return false;
  }
  for (std::size_t m = 0; m < members->size(); ++m) {
    const json& mj = (*members)[m];
    const std::string prefix = "members[" + std::to_string(m) + "]";
    NeuralTreeWeights::Member member;
    const auto layers = mj.is_object() ? mj.find("layers") : mj.end();
    if (layers == mj.end() || !layers->is_array() || layers->size() != static_cast<std::size_t>(num_layers)) {
      *error = prefix + ".layers: expected " + std::to_string(num_layers) + " layers";
      return false;
    }
    int in = w->input_dim;
    for (int l = 0; l < num_layers; ++l) {
      const json& lj = (*layers)[l];
      const std::string field = prefix + ".layers[" + std::to_string(l) + "]";
      if (!lj.is_object()) {
        *error = field + ": not an object";
        return false;
      }
      int lin = 0, lout = 0;
      if (!read_int(lj, "in", field + ".in", in, in, &lin, error) ||
          !read_int(lj, "out", field + ".out", w->hidden, w->hidden, &lout, error))
        return false;
      NeuralTreeWeights::Layer layer;
      RowMatrixXf bias;
      if (!read_matrix(lj, "w_self", field, lout, lin, &layer.w_self, error) ||
          !read_matrix(lj, "b_self", field, 1, lout, &bias, error) ||
          !read_matrix(lj, "w_neigh", field, lout, lin, &layer.w_neigh, error) ||
          !read_matrix(lj, "w_edge", field, lout, 3, &layer.w_edge, error))
        return false;
      layer.b_self = bias.row(0).transpose();
      member.layers.push_back(std::move(layer));
      in = w->hidden;
    }
    const auto head = mj.find("head");
    if (head == mj.end() || !head->is_object()) {
      *error = prefix + ".head: missing";
      return false;
    }
    int hin = 0, hout = 0;
    RowMatrixXf hb;
    if (!read_int(*head, "in", prefix + ".head.in", w->hidden, w->hidden, &hin, error) ||
        !read_int(*head, "out", prefix + ".head.out", w->num_classes, w->num_classes, &hout, error) ||
        !read_matrix(*head, "w", prefix + ".head", hout, hin, &member.head_w, error) ||
        !read_matrix(*head, "b", prefix + ".head", 1, hout, &hb, error))
      return false;
    member.head_b = hb.row(0).transpose();
    w->members.push_back(std::move(member));
  }
  if (!parse_lr_head(doc, "lr_head", "lr_head", *w, &w->lr, error)) return false;
  // Version 4: the view heads (LR heads trained on the training rooms as one perception's label set shows them).
  const auto views = doc.find("view_heads");
  if (views == doc.end() || !views->is_array() || views->size() > 64) {
    *error = "view_heads: missing or not an array of at most 64 heads";
    return false;
  }
  w->views.clear();
  for (std::size_t i = 0; i < views->size(); ++i) {
    const json& v = (*views)[i];
    const std::string prefix = "view_heads[" + std::to_string(i) + "]";
    NeuralTreeWeights::ViewHead view;
    view.name = v.is_object() ? v.value("name", std::string()) : std::string();
    if (view.name.empty()) {
      *error = prefix + ".name: missing or empty";
      return false;
    }
    for (const NeuralTreeWeights::ViewHead& other : w->views)
      if (other.name == view.name) {
        *error = prefix + ".name: \"" + view.name + "\" listed twice";
        return false;
      }
    if (!parse_lr_head(v, "lr_head", prefix + ".lr_head", *w, &view.lr, error)) return false;
    w->views.push_back(std::move(view));
  }
  return true;
}

}  // namespace

Eigen::Vector3d offset_feature(const Eigen::Vector3d& d) {
  const double h = std::hypot(d.x(), d.y());
  return {h, d.z(), std::sqrt(h * h + d.z() * d.z())};
}

bool load_weights(const std::string& path, NeuralTreeWeights* out, std::string* error) {
  *out = NeuralTreeWeights();
  std::string reason;
  std::ifstream in(path);
  if (!in) {
    if (error) *error = path + ": cannot open the neural-tree weights file";
    return false;
  }
  std::stringstream text;
  text << in.rdbuf();
  try {
    const json doc = json::parse(text.str(), nullptr, /*allow_exceptions=*/false);
    if (doc.is_discarded() || !doc.is_object()) {
      reason = "not valid JSON (corrupt or truncated)";
    } else if (!parse_weights(doc, out, &reason) && reason.empty()) {
      reason = "invalid weights";
    }
  } catch (const std::exception& e) {
    reason = std::string("unexpected content: ") + e.what();
  }
  if (!reason.empty()) {
    *out = NeuralTreeWeights();
    if (error) *error = path + ": " + reason;
    return false;
  }
  return true;
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
