// Reads the JSON network-class -> mpcat40 label mapping and validates every field with a message naming it.
#include "core/segmentation/label_map.h"

#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

namespace qsg::segmentation {
namespace {

bool fail(std::string* error, const std::string& message) {
  if (error != nullptr) *error = message;
  return false;
}

const char* type_name(const nlohmann::json& j) { return j.type_name(); }

}  // namespace

void LabelMap::clear() {
  source_.clear();
  network_.clear();
  names_.clear();
  labels_.fill(semantics::kUnlabeled);
}

bool LabelMap::load(const std::string& path, std::string* error) {
  clear();
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail(error, path + ": cannot open label map file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return fail(error, path + ": read error");
  return parse(text.str(), path, error);
}

bool LabelMap::parse(const std::string& json_text, const std::string& source, std::string* error) {
  clear();
  nlohmann::json root;
  try {
    root = nlohmann::json::parse(json_text);
  } catch (const nlohmann::json::exception& e) {
    // e.what() carries "parse error at line L, column C: ...".
    return fail(error, source + ": malformed JSON: " + e.what());
  }
  if (!root.is_object()) return fail(error, source + ": top level must be an object, not " + type_name(root));

  for (auto it = root.begin(); it != root.end(); ++it) {
    if (it.key() != "network" && it.key() != "classes" && it.key() != "note")
      return fail(error, source + ": unknown field '" + it.key() + "' (expected network, classes, note)");
  }
  const auto network = root.find("network");
  if (network == root.end() || !network->is_string() || network->get<std::string>().empty())
    return fail(error, source + ": field 'network' must be a non-empty string");
  const auto classes = root.find("classes");
  if (classes == root.end() || !classes->is_array())
    return fail(error, source + ": field 'classes' must be an array of {name, label} objects");
  if (classes->empty() || classes->size() > static_cast<std::size_t>(kMaxNetworkClasses))
    return fail(error, source + ": field 'classes' must hold 1.." + std::to_string(kMaxNetworkClasses) +
                           " entries, has " + std::to_string(classes->size()));

  std::vector<std::string> names;
  std::array<semantics::Label, kMaxNetworkClasses> labels{};
  std::set<std::string> seen;
  for (std::size_t i = 0; i < classes->size(); ++i) {
    const nlohmann::json& entry = (*classes)[i];
    const std::string field = "classes[" + std::to_string(i) + "]";
    if (!entry.is_object()) return fail(error, source + ": " + field + " must be an object, not " + type_name(entry));
    for (auto it = entry.begin(); it != entry.end(); ++it) {
      if (it.key() != "name" && it.key() != "label" && it.key() != "note")
        return fail(error, source + ": " + field + ": unknown field '" + it.key() + "' (expected name, label, note)");
    }
    const auto name = entry.find("name");
    if (name == entry.end() || !name->is_string() || name->get<std::string>().empty())
      return fail(error, source + ": " + field + ".name must be a non-empty string");
    const std::string class_name = name->get<std::string>();
    if (!seen.insert(class_name).second)
      return fail(error, source + ": " + field + ".name '" + class_name + "' appears twice");
    const auto label = entry.find("label");
    if (label == entry.end() || !label->is_string())
      return fail(error, source + ": " + field + ".label (class '" + class_name + "') must be a string");
    const std::string label_name = label->get<std::string>();
    const semantics::Label id = semantics::object_label_from_name(label_name.c_str());
    if (id == semantics::kInvalidLabel)
      return fail(error, source + ": " + field + ".label (class '" + class_name + "'): unknown mpcat40 label '" +
                             label_name + "' (names as in core/semantics/labels.h, e.g. chair, tv_monitor)");
    if (const auto note = entry.find("note"); note != entry.end() && !note->is_string())
      return fail(error, source + ": " + field + ".note must be a string");
    labels[i] = id;
    names.push_back(class_name);
  }

  source_ = source;
  network_ = network->get<std::string>();
  names_ = std::move(names);
  labels_ = labels;
  return true;
}

bool LabelMap::check_class_count(int network_classes, std::string* error) const {
  if (network_classes == num_classes()) return true;
  return fail(error, source_ + ": label map '" + network_ + "' lists " + std::to_string(num_classes()) +
                         " classes but the network outputs " + std::to_string(network_classes));
}

int LabelMap::class_index(const std::string& name) const {
  for (std::size_t i = 0; i < names_.size(); ++i)
    if (names_[i] == name) return static_cast<int>(i);
  return -1;
}

void LabelMap::print(std::FILE* out) const {
  std::fprintf(out, "segmentation label map: network=%s source=%s classes=%d:", network_.c_str(), source_.c_str(),
               num_classes());
  for (int c = 0; c < num_classes(); ++c)
    std::fprintf(out, " %s->%s", names_[static_cast<std::size_t>(c)].c_str(), semantics::object_label(label(c)).name);
  std::fprintf(out, "\n");
}

}  // namespace qsg::segmentation
