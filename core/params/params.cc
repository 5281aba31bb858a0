#include "core/params/params.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace qsg::params {

const char* to_string(Origin origin) {
  switch (origin) {
    case Origin::kPaper: return "paper";
    case Origin::kRefinement: return "refinement";
    case Origin::kProject: return "project";
  }
  return "?";
}

std::string shortest(double v, bool single_precision) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[64];
  for (int precision = 1; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    const double back = std::strtod(buf, nullptr);
    if (single_precision ? static_cast<float>(back) == static_cast<float>(v) : back == v) break;
  }
  // "1e+09" -> "1e9", "1e-05" -> "1e-5"; then the shorter of that and the fixed form (10, not 1e1).
  std::string s = buf;
  const std::size_t e = s.find('e');
  if (e != std::string::npos) {
    std::string mantissa = s.substr(0, e), exponent = s.substr(e + 1);
    bool negative = false;
    if (!exponent.empty() && (exponent[0] == '+' || exponent[0] == '-')) {
      negative = exponent[0] == '-';
      exponent.erase(0, 1);
    }
    while (exponent.size() > 1 && exponent[0] == '0') exponent.erase(0, 1);
    s = mantissa + "e" + (negative ? "-" : "") + exponent;
    for (int decimals = 0; decimals <= 20; ++decimals) {
      std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
      const double back = std::strtod(buf, nullptr);
      if (single_precision ? static_cast<float>(back) == static_cast<float>(v) : back == v) {
        if (std::string(buf).size() <= s.size()) s = buf;
        break;
      }
    }
  }
  return s;
}

bool Range::contains(double v) const {
  if (std::isnan(v)) return false;
  if (lo_open ? !(v > lo) : !(v >= lo)) return false;
  if (hi_open ? !(v < hi) : !(v <= hi)) return false;
  return true;
}

std::string Range::text() const {
  const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  if (has_lo && has_hi)
    return std::string(lo_open ? "(" : "[") + shortest(lo) + ", " + shortest(hi) + (hi_open ? ")" : "]");
  if (has_lo) return std::string(lo_open ? "> " : ">= ") + shortest(lo);
  if (has_hi) return std::string(hi_open ? "< " : "<= ") + shortest(hi);
  return "any";
}

double Field::number(const Value& v) const {
  if (type == Type::kInteger) return is_unsigned ? static_cast<double>(v.u) : static_cast<double>(v.i);
  return v.d;
}

std::string Field::text(const Value& v) const {
  switch (type) {
    case Type::kBool: return v.b ? "true" : "false";
    case Type::kInteger: return is_unsigned ? std::to_string(v.u) : std::to_string(v.i);
    case Type::kReal: return shortest(v.d, single_precision);
    case Type::kText:
    case Type::kChoice: return v.s;
    case Type::kRealArray: {
      std::string s;
      for (std::size_t k = 0; k < v.array.size(); ++k) s += (k ? "," : "") + shortest(v.array[k]);
      return s;
    }
  }
  return "?";
}

namespace {

bool parse_real(const std::string& text, double* out) {
  if (text.empty()) return false;
  errno = 0;
  char* end = nullptr;
  *out = std::strtod(text.c_str(), &end);
  return end != text.c_str() && *end == '\0' && errno != ERANGE;
}

std::string choices_text(const std::vector<std::string>& choices) {
  std::string s;
  for (std::size_t k = 0; k < choices.size(); ++k)
    s += (k == 0 ? "" : k + 1 == choices.size() ? " or " : ", ") + choices[k];
  return s;
}

}  // namespace

bool Field::parse(const std::string& text, Value* out, std::string* why) const {
  switch (type) {
    case Type::kBool:
      if (text == "true" || text == "1") return out->b = true, true;
      if (text == "false" || text == "0") return out->b = false, true;
      return *why = "expected true or false (1 or 0), got '" + text + "'", false;
    case Type::kInteger: {
      errno = 0;
      char* end = nullptr;
      const std::string limits = "[" + std::to_string(type_min) + ", " + std::to_string(type_max) + "]";
      if (is_unsigned) {
        if (text.empty() || text[0] == '-') return *why = "expected an integer in " + limits + ", got '" + text + "'", false;
        const unsigned long long u = std::strtoull(text.c_str(), &end, 10);
        if (end == text.c_str() || *end != '\0' || errno == ERANGE || u > type_max)
          return *why = "expected an integer in " + limits + ", got '" + text + "'", false;
        out->u = u;
      } else {
        const long long i = std::strtoll(text.c_str(), &end, 10);
        if (end == text.c_str() || *end != '\0' || errno == ERANGE || i < type_min ||
            (i > 0 && static_cast<std::uint64_t>(i) > type_max))
          return *why = "expected an integer in " + limits + ", got '" + text + "'", false;
        out->i = i;
      }
      return true;
    }
    case Type::kReal:
      if (!parse_real(text, &out->d)) return *why = "expected a number, got '" + text + "'", false;
      return true;
    case Type::kText: out->s = text; return true;
    case Type::kChoice:
      for (const std::string& c : choices)
        if (c == text) return out->s = text, true;
      return *why = "expected " + choices_text(choices) + ", got '" + text + "'", false;
    case Type::kRealArray: {
      out->array.clear();
      std::size_t pos = 0;
      while (pos <= text.size()) {
        const std::size_t comma = text.find(',', pos);
        double d = 0.0;
        if (!parse_real(text.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos), &d)) break;
        out->array.push_back(d);
        if (comma == std::string::npos) break;
        pos = comma + 1;
      }
      if (out->array.size() != array_size)
        return *why = "expected " + std::to_string(array_size) + " numbers separated by commas, got '" + text + "'",
               false;
      return true;
    }
  }
  return false;
}

std::string Field::check(const Value& v) const {
  // Built only on failure: a check of values in range allocates nothing.
  const auto unit_text = [this] { return unit[0] != '\0' ? std::string(" ") + unit : std::string(); };
  switch (type) {
    case Type::kInteger:
    case Type::kReal:
      if (!range.contains(number(v))) return "must be in " + range.text() + unit_text() + ", got " + text(v);
      return {};
    case Type::kRealArray:
      for (double d : v.array)
        if (!range.contains(d)) return "each element must be in " + range.text() + unit_text() + ", got " + text(v);
      return {};
    case Type::kChoice:
      for (const std::string& c : choices)
        if (c == v.s) return {};
      return "expected " + choices_text(choices) + ", got '" + v.s + "'";
    case Type::kBool:
    case Type::kText: return {};
  }
  return {};
}

const Field* Section::find(const std::string& key) const {
  for (const Field& f : fields)
    if (f.key == key) return &f;
  return nullptr;
}

std::string path_of(const Section& section, const Field& field) {
  return section.name.empty() ? field.key : section.name + "." + field.key;
}

std::string check(const std::vector<Section>& sections, const void* root) {
  for (const Section& s : sections)
    if (std::string why = check_fields(s.fields, root, s.name.c_str()); !why.empty()) return why;
  return {};
}

std::string check_fields(const std::vector<Field>& fields, const void* root, const char* section) {
  for (const Field& f : fields)
    if (const std::string why = f.check(f.get(root)); !why.empty())
      return (section[0] != '\0' ? std::string(section) + "." : std::string()) + f.key + " " + why;
  return {};
}

void print(const std::vector<Section>& sections, const void* root, std::FILE* out) {
  for (const Section& s : sections) {
    std::string line = (s.name.empty() ? std::string("config") : s.name) + ":";
    const std::size_t indent = line.size();
    std::size_t width = line.size();
    for (const Field& f : s.fields) {
      std::string item = f.key + "=";
      const std::string value = f.text(f.get(root));
      item += (f.type == Type::kText && (value.empty() || value.find(' ') != std::string::npos)) ? "'" + value + "'"
              : f.type == Type::kRealArray ? "[" + value + "]"
                                            : value;
      if (width + 1 + item.size() > 118 && width > indent) {
        line += "\n" + std::string(indent, ' ');
        width = indent;
      }
      line += " " + item;
      width += 1 + item.size();
    }
    std::fprintf(out, "%s\n", line.c_str());
  }
}

bool set(const std::vector<Section>& sections, void* root, const std::string& assignment, std::string* error) {
  const std::size_t eq = assignment.find('=');
  if (eq == std::string::npos) return *error = "'" + assignment + "': expected section.key=value", false;
  const std::string path = assignment.substr(0, eq), text = assignment.substr(eq + 1);
  const std::size_t dot = path.find('.');
  const std::string section_name = dot == std::string::npos ? std::string() : path.substr(0, dot);
  const std::string key = dot == std::string::npos ? path : path.substr(dot + 1);
  for (const Section& s : sections) {
    if (s.name != section_name) continue;
    const Field* f = s.find(key);
    if (f == nullptr) break;
    Value v;
    std::string why;
    if (!f->parse(text, &v, &why) || !(why = f->check(v)).empty()) return *error = path + ": " + why, false;
    f->set(root, v);
    return true;
  }
  return *error = path + ": unknown key", false;
}

void print_help(const std::vector<Section>& sections, std::FILE* out) {
  for (const Section& s : sections)
    for (const Field& f : s.fields) {
      std::string what;
      if (f.type == Type::kBool) what = "true|false";
      else if (f.type == Type::kChoice) what = choices_text(f.choices);
      else if (f.type == Type::kText) what = "text";
      else what = f.range.text() + (f.unit[0] != '\0' ? std::string(" ") + f.unit : std::string());
      std::fprintf(out, "  %s (%s; %s): %s\n", path_of(s, f).c_str(), what.c_str(), to_string(f.origin), f.doc);
    }
}

}  // namespace qsg::params
