// Figures of an evaluation or benchmark program as JSON, comparable across commits and machines:
// [{"name", "value", "unit", "conditions", "commit"}, ...].
#pragma once

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "bench/commit.h"

namespace qsg::bench {

class Figures {
 public:
  explicit Figures(std::string conditions) : conditions_(std::move(conditions)) {}
  void add(const std::string& name, double value, const std::string& unit) {
    out_.push_back({{"name", name}, {"value", value}, {"unit", unit}, {"conditions", conditions_},
                    {"commit", git_commit()}});
  }
  // False (with a message on stderr) when the file cannot be written.
  bool write(const std::string& path) const {
    std::ofstream file(path);
    file << out_.dump(2) << "\n";
    if (!file) {
      std::fprintf(stderr, "%s: cannot write\n", path.c_str());
      return false;
    }
    std::printf("wrote %s\n", path.c_str());
    return true;
  }

 private:
  std::string conditions_;
  nlohmann::json out_ = nlohmann::json::array();
};

}  // namespace qsg::bench
