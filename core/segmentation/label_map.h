// Mapping from a segmentation network's classes to the scene graph's mpcat40 labels, read from a JSON file.
//
// File format (firmware_app/config/segmentation_pascal_voc.json is the shipped example):
//   {
//     "network": "espnetv2_s2_pascal384",
//     "classes": [ {"name": "background", "label": "unlabeled", "note": "why"}, ... ]
//   }
// Classes are listed in the network's output order; "label" is an mpcat40 name from core/semantics/labels.h;
// "note" is optional free text. Any other key is an error, so a misspelt key cannot silently fall back.
#pragma once

#include <array>
#include <cstdio>
#include <string>
#include <vector>

#include "core/semantics/labels.h"

namespace qsg::segmentation {

// Class indices are stored as uint8 at network resolution, so a network has at most this many classes.
inline constexpr int kMaxNetworkClasses = 256;

class LabelMap {
 public:
  // Reads and validates `path`. On failure returns false, leaves the map empty and sets *error to a message
  // naming the file and the offending field (or the JSON line and column).
  bool load(const std::string& path, std::string* error);
  // Same from text; `source` names the text in error messages.
  bool parse(const std::string& json_text, const std::string& source, std::string* error);

  // Fails with a message naming the file when the map does not have exactly `network_classes` classes.
  bool check_class_count(int network_classes, std::string* error) const;

  bool empty() const { return names_.empty(); }
  int num_classes() const { return static_cast<int>(names_.size()); }
  const std::string& network() const { return network_; }
  const std::string& source() const { return source_; }
  const std::string& class_name(int network_class) const { return names_.at(static_cast<std::size_t>(network_class)); }
  // Scene-graph label of a network class; kUnlabeled for a class outside the map.
  semantics::Label label(int network_class) const {
    if (network_class < 0 || network_class >= num_classes()) return semantics::kUnlabeled;
    return labels_[static_cast<std::size_t>(network_class)];
  }
  // Network class of a class name; -1 when absent.
  int class_index(const std::string& name) const;

  void print(std::FILE* out) const;

 private:
  void clear();

  std::string source_;
  std::string network_;
  std::vector<std::string> names_;
  std::array<semantics::Label, kMaxNetworkClasses> labels_{};
};

}  // namespace qsg::segmentation
