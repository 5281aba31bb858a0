#include "core/params/params_json.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/json/json_guard.h"

namespace qsg::params {

namespace {

using Json = nlohmann::json;

// The JSON value as the field's type; false with why (no key) otherwise.
bool from_json(const Field& f, const Json& j, Value* v, std::string* why) {
  switch (f.type) {
    case Type::kBool:
      if (!j.is_boolean()) return *why = "expected true or false", false;
      v->b = j.get<bool>();
      return true;
    case Type::kInteger: {
      const std::string range = "[" + std::to_string(f.type_min) + ", " + std::to_string(f.type_max) + "]";
      if (!j.is_number_integer())
        return *why = "expected an integer in " + range + (j.is_number() ? ", got " + j.dump() : std::string()), false;
      bool fits = false;
      if (j.is_number_unsigned()) {
        fits = j.get<std::uint64_t>() <= f.type_max;
      } else {
        const std::int64_t i = j.get<std::int64_t>();
        fits = i >= 0 ? static_cast<std::uint64_t>(i) <= f.type_max : i >= f.type_min;
      }
      if (!fits) return *why = "expected an integer in " + range + ", got " + j.dump(), false;
      if (f.is_unsigned) v->u = j.get<std::uint64_t>();
      else v->i = j.get<std::int64_t>();
      return true;
    }
    case Type::kReal: {
      if (j.is_string() && !std::isfinite(f.range.hi) && (j.get<std::string>() == "inf"))
        return v->d = std::numeric_limits<double>::infinity(), true;
      if (!j.is_number()) return *why = "expected a number", false;
      const double d = j.get<double>();
      const double max = f.single_precision ? static_cast<double>(std::numeric_limits<float>::max())
                                            : std::numeric_limits<double>::max();
      if (!(std::abs(d) <= max)) return *why = "expected a number within the range of its type, got " + j.dump(), false;
      v->d = d;
      return true;
    }
    case Type::kText:
      if (!j.is_string()) return *why = "expected a string", false;
      v->s = j.get<std::string>();
      return true;
    case Type::kChoice:
      v->s = j.is_string() ? j.get<std::string>() : j.dump();

      if (const std::string bad = f.check(*v); !bad.empty()) return *why = bad, false;
      return true;
    case Type::kRealArray: {
      const std::string expected = "expected an array of " + std::to_string(f.array_size) + " numbers";
      if (!j.is_array() || j.size() != f.array_size) return *why = expected, false;
      v->array.clear();
      for (const Json& e : j) {
        if (!e.is_number()) return *why = expected, false;
        v->array.push_back(e.get<double>());
      }
      return true;
    }
  }
  return false;
}

bool read_fields(const Section& section, void* root, const Json& object, std::string* error) {
  for (auto it = object.begin(); it != object.end(); ++it) {
    const std::string path = section.name.empty() ? it.key() : section.name + "." + it.key();
    const Field* f = section.find(it.key());
    if (f == nullptr) return *error = path + ": unknown key", false;
    Value v;
    std::string why;
    if (!from_json(*f, it.value(), &v, &why)) return *error = path + ": " + why, false;
    f->set(root, v);
  }
  return true;
}

std::string json_text(const Field& f, const Value& v) {
  switch (f.type) {
    case Type::kBool: return v.b ? "true" : "false";
    case Type::kInteger: return f.text(v);
    case Type::kReal: return std::isinf(v.d) ? (v.d > 0 ? "\"inf\"" : "\"-inf\"") : shortest(v.d, f.single_precision);
    case Type::kText:
    case Type::kChoice: return Json(v.s).dump();
    case Type::kRealArray: {
      std::string s = "[";
      for (std::size_t k = 0; k < v.array.size(); ++k) s += (k ? ", " : "") + shortest(v.array[k]);
      return s + "]";
    }
  }
  return "null";
}

std::string comment(const Field& f) {
  std::string c = "// ";
  c += f.doc;
  if (f.type == Type::kChoice) {
    c += " | ";
    for (std::size_t k = 0; k < f.choices.size(); ++k) c += (k ? "|" : "") + f.choices[k];
  } else if ((f.type == Type::kInteger || f.type == Type::kReal || f.type == Type::kRealArray) &&
             f.range.text() != "any") {
    c += " | " + f.range.text();
    if (f.unit[0] != '\0') c += std::string(" ") + f.unit;
  } else if (f.unit[0] != '\0') {
    c += std::string(" | ") + f.unit;
  }
  return c + " | " + to_string(f.origin);
}

}  // namespace

bool load_json(const std::vector<Section>& sections, void* root, const std::string& text, std::string* error) {
  std::istringstream in(text);
  std::string without_comments, line;
  while (std::getline(in, line)) {
    const std::size_t first = line.find_first_not_of(" \t");
    if (first != std::string::npos && line.compare(first, 2, "//") == 0) line.clear();
    without_comments += line + "\n";
  }
  Json doc;
  if (json_guard::ParseFailure f; !json_guard::parse(without_comments, json_guard::Limits{}, &doc, &f)) {
    using Kind = json_guard::ParseFailure::Kind;
    if (f.kind == Kind::kDuplicateKey || f.kind == Kind::kTooDeep) return *error = f.message, false;
    return *error = "not valid JSON: " + f.message, false;
  }
  if (!doc.is_object()) return *error = "expected a JSON object", false;
  const Section* top = nullptr;
  for (const Section& s : sections)
    if (s.name.empty()) top = &s;
  for (auto it = doc.begin(); it != doc.end(); ++it) {
    const Section* section = nullptr;
    for (const Section& s : sections)
      if (!s.name.empty() && s.name == it.key()) section = &s;
    if (section != nullptr) {
      if (!it.value().is_object()) return *error = it.key() + ": expected an object", false;
      if (!read_fields(*section, root, it.value(), error)) return false;
      continue;
    }
    const Field* f = top != nullptr ? top->find(it.key()) : nullptr;
    if (f == nullptr) return *error = it.key() + ": unknown key", false;
    Value v;
    std::string why;
    if (!from_json(*f, it.value(), &v, &why)) return *error = it.key() + ": " + why, false;
    f->set(root, v);
  }
  return true;
}

std::string dump_json(const std::vector<Section>& sections, const void* root, const std::string& header_comment) {
  std::string out;
  std::istringstream header(header_comment);
  for (std::string line; std::getline(header, line);) out += "// " + line + "\n";
  out += "{";
  bool first_entry = true;
  const auto separate = [&] {
    out += first_entry ? "\n" : ",\n";
    first_entry = false;
  };
  for (const Section& s : sections) {
    if (!s.name.empty()) continue;
    for (const Field& f : s.fields) {
      separate();
      out += "  " + comment(f) + "\n  " + Json(f.key).dump() + ": " + json_text(f, f.get(root));
    }
  }
  for (const Section& s : sections) {
    if (s.name.empty() || s.fields.empty()) continue;
    separate();
    out += "  " + Json(s.name).dump() + ": {";
    for (std::size_t k = 0; k < s.fields.size(); ++k) {
      const Field& f = s.fields[k];
      out += std::string(k ? "," : "") + "\n    " + comment(f) + "\n    " + Json(f.key).dump() + ": " +
             json_text(f, f.get(root));
    }
    out += "\n  }";
  }
  return out + "\n}\n";
}

}  // namespace qsg::params
