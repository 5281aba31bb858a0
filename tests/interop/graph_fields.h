// A scene graph flattened to named, typed fields per node and per edge, from either side of the interoperability
// check: this project's reading (SceneGraph) and Spark-DSG's (DynamicSceneGraph). Two readings of one graph agree
// when every node and edge has the same fields with equal values (floats within what Spark-DSG's float storage
// keeps). Test-only: built in the Spark-DSG stage, never part of the product.
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <utility>

namespace qsg::interop {

struct Field {
  bool is_number = false;
  double number = 0.0;
  double tolerance = 0.0;  // absolute
  std::string text;        // integers, strings and booleans, compared exactly
};

using Fields = std::map<std::string, Field>;  // "position[0]" -> value
struct FlatGraph {
  std::map<std::uint64_t, Fields> nodes;
  std::map<std::pair<std::uint64_t, std::uint64_t>, Fields> edges;  // (smaller id, larger id)
};

inline void put_text(Fields& f, const std::string& name, const std::string& value) { f[name].text = value; }
inline void put_int(Fields& f, const std::string& name, std::uint64_t value) { put_text(f, name, std::to_string(value)); }
inline void put_bool(Fields& f, const std::string& name, bool value) { put_text(f, name, value ? "true" : "false"); }
// A value Spark-DSG keeps as a double: equal to the last bits of a printed double.
inline void put_double(Fields& f, const std::string& name, double value) {
  Field& x = f[name];
  x.is_number = true;
  x.number = value;
  x.tolerance = 1e-12 * std::max(1.0, std::abs(value));
}
// A value Spark-DSG keeps as a float (boxes): equal within a float's precision.
inline void put_float(Fields& f, const std::string& name, double value) {
  Field& x = f[name];
  x.is_number = true;
  x.number = value;
  x.tolerance = 2e-6 * std::max(1.0, std::abs(value));
}

struct Comparison {
  std::size_t nodes = 0, edges = 0, fields = 0, differences = 0;
  std::string first_differences;  // up to 20 lines
};

inline Comparison compare(const FlatGraph& a, const FlatGraph& b, const std::string& a_name, const std::string& b_name) {
  Comparison c;
  const auto report = [&](const std::string& line) {
    if (++c.differences <= 20) c.first_differences += "  " + line + "\n";
  };
  const auto compare_fields = [&](const std::string& what, const Fields& fa, const Fields& fb) {
    for (const auto& [name, x] : fa) {
      const auto it = fb.find(name);
      if (it == fb.end()) {
        report(what + " " + name + ": only in " + a_name);
        continue;
      }
      ++c.fields;
      const Field& y = it->second;
      const bool equal = x.is_number ? y.is_number && std::abs(x.number - y.number) <= std::max(x.tolerance, y.tolerance)
                                     : !y.is_number && x.text == y.text;
      if (!equal) {
        const auto show = [](const Field& f) { return f.is_number ? std::to_string(f.number) : "'" + f.text + "'"; };
        report(what + " " + name + ": " + a_name + " " + show(x) + ", " + b_name + " " + show(y));
      }
    }
    for (const auto& [name, y] : fb)
      if (fa.count(name) == 0) report(what + " " + name + ": only in " + b_name);
  };
  for (const auto& [id, fa] : a.nodes) {
    const auto it = b.nodes.find(id);
    if (it == b.nodes.end()) {
      report("node " + std::to_string(id) + ": only in " + a_name);
      continue;
    }
    ++c.nodes;
    compare_fields("node " + std::to_string(id), fa, it->second);
  }
  for (const auto& [id, fb] : b.nodes)
    if (a.nodes.count(id) == 0) report("node " + std::to_string(id) + ": only in " + b_name);
  for (const auto& [key, fa] : a.edges) {
    const std::string what = "edge " + std::to_string(key.first) + "-" + std::to_string(key.second);
    const auto it = b.edges.find(key);
    if (it == b.edges.end()) {
      report(what + ": only in " + a_name);
      continue;
    }
    ++c.edges;
    compare_fields(what, fa, it->second);
  }
  for (const auto& [key, fb] : b.edges)
    if (a.edges.count(key) == 0)
      report("edge " + std::to_string(key.first) + "-" + std::to_string(key.second) + ": only in " + b_name);
  return c;
}

}  // namespace qsg::interop
