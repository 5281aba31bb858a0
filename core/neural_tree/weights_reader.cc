// The room classifier's weights file (load_weights, room_classifier.h): JSON with base64 float arrays, every shape
// checked against the header's dimensions, each failure an error naming the field.
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/neural_tree/label_map.h"
#include "core/neural_tree/room_classifier.h"

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

// One network of the ensemble: its message-passing layers and its head.
bool parse_member(const json& mj, const std::string& prefix, int num_layers, const NeuralTreeWeights& weights,
                  NeuralTreeWeights::Member* member_out, std::string* error) {
  NeuralTreeWeights::Member& member = *member_out;
  const auto layers = mj.is_object() ? mj.find("layers") : mj.end();
  if (layers == mj.end() || !layers->is_array() || layers->size() != static_cast<std::size_t>(num_layers)) {
    *error = prefix + ".layers: expected " + std::to_string(num_layers) + " layers";
    return false;
  }
  int in = weights.input_dim;
  for (int l = 0; l < num_layers; ++l) {
    const json& lj = (*layers)[l];
    const std::string field = prefix + ".layers[" + std::to_string(l) + "]";
    if (!lj.is_object()) {
      *error = field + ": not an object";
      return false;
    }
    int lin = 0, lout = 0;
    if (!read_int(lj, "in", field + ".in", in, in, &lin, error) ||
        !read_int(lj, "out", field + ".out", weights.hidden, weights.hidden, &lout, error))
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
    in = weights.hidden;
  }
  const auto head = mj.find("head");
  if (head == mj.end() || !head->is_object()) {
    *error = prefix + ".head: missing";
    return false;
  }
  int hin = 0, hout = 0;
  RowMatrixXf hb;
  if (!read_int(*head, "in", prefix + ".head.in", weights.hidden, weights.hidden, &hin, error) ||
      !read_int(*head, "out", prefix + ".head.out", weights.num_classes, weights.num_classes, &hout, error) ||
      !read_matrix(*head, "w", prefix + ".head", hout, hin, &member.head_w, error) ||
      !read_matrix(*head, "b", prefix + ".head", 1, hout, &hb, error))
    return false;
  member.head_b = hb.row(0).transpose();
  return true;
}

// Version 4: the view heads (LR heads trained on the training rooms as one perception's label set shows them).
bool parse_view_heads(const json& doc, NeuralTreeWeights* w, std::string* error) {
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
    NeuralTreeWeights::Member member;
    if (!parse_member((*members)[m], "members[" + std::to_string(m) + "]", num_layers, *w, &member, error)) return false;
    w->members.push_back(std::move(member));
  }
  if (!parse_lr_head(doc, "lr_head", "lr_head", *w, &w->lr, error)) return false;
  return parse_view_heads(doc, w, error);
}

}  // namespace

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

}  // namespace qsg::neural_tree
