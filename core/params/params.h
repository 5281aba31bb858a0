// One declaration per setting. Each stage's Config declares its fields once, in one table (params::Table<Config>):
// key, unit, range, whether it is the paper's parameter or a project refinement, and a one-line doc; the default
// is the struct's own. From the tables alone come the range check (check), the printed configuration (print),
// command-line overrides (set: "--set rooms.visible_min_share=0.7"), and, in params_json.h, the JSON loader and
// the full default configuration (qsg_app --dump-config, which writes firmware_app/config/default.json).
// Rules between fields (min <= max, one switch needing another) stay in the Config's own check().
// Capacities are not settings: they live in budgets/<board>.json only.
#pragma once

#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace qsg::params {

// Where a setting comes from: the paper's algorithm (Hughes et al., Hydra), or a refinement this project added
// (its doc says why, its folder's README gives the measured figure), or plumbing of this project (paths, devices,
// rates) that neither the paper nor a refinement is about.
enum class Origin : std::uint8_t { kPaper, kRefinement, kProject };
const char* to_string(Origin origin);

enum class Type : std::uint8_t { kBool, kInteger, kReal, kText, kChoice, kRealArray };

// The allowed values of a number: [lo, hi], either end open. Infinite ends: no bound.
struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;
  bool hi_open = false;
  bool contains(double v) const;
  std::string text() const;  // "[0, 1]", "(0, 60]", ">= 0", "any"
};
inline Range in(double lo, double hi) { return Range{lo, hi, false, false}; }       // [lo, hi]
inline Range above(double lo, double hi) { return Range{lo, hi, true, false}; }     // (lo, hi]
inline Range at_least(double lo) { return Range{lo, std::numeric_limits<double>::infinity(), false, false}; }
inline Range any() { return Range{}; }

// A parameter's value, whatever its type.
struct Value {
  bool b = false;
  std::int64_t i = 0;        // kInteger, signed types
  std::uint64_t u = 0;       // kInteger, unsigned types
  double d = 0.0;            // kReal
  std::string s;             // kText, kChoice (the choice's name)
  std::vector<double> array; // kRealArray
};

struct Field {
  std::string key;  // within its section: "visible_min_share"
  Type type = Type::kReal;
  const char* unit = "";
  Range range;
  Origin origin = Origin::kProject;
  const char* doc = "";
  std::vector<std::string> choices;  // kChoice: the names, in declaration order
  std::size_t array_size = 0;        // kRealArray
  // kInteger: the C++ type's limits (a JSON value outside them is a type error, not a range error).
  bool is_unsigned = false;
  std::int64_t type_min = 0;
  std::uint64_t type_max = 0;
  bool single_precision = false;     // kReal stored as float: printed as the shortest float
  // On the object the field's table is for (its section's root, for a composed schema).
  std::function<Value(const void*)> get;
  std::function<void(void*, const Value&)> set;

  double number(const Value& v) const;  // kInteger or kReal as a double (for the range)
  std::string text(const Value& v) const;  // as printed and as --set reads it
  // Reads the text form ("0.7", "true", "persistence", "0,0,1"): false with why when it is not one of this type.
  bool parse(const std::string& text, Value* out, std::string* why) const;
  // Empty when the value is within range (and a choice one of the names), else "must be in ..., got ...".
  std::string check(const Value& v) const;
};

// The fields of one Config type C, in declaration order.
template <typename C>
class Table {
 public:
  // A bool, integer, floating-point or string member.
  template <typename T>
  Table& add(const char* key, T C::*member, const char* unit, Range range, Origin origin, const char* doc) {
    Field f = base(key, unit, range, origin, doc);
    if constexpr (std::is_same_v<T, bool>) {
      f.type = Type::kBool;
      f.get = [member](const void* c) { Value v; v.b = static_cast<const C*>(c)->*member; return v; };
      f.set = [member](void* c, const Value& v) { static_cast<C*>(c)->*member = v.b; };
    } else if constexpr (std::is_integral_v<T>) {
      f.type = Type::kInteger;
      f.is_unsigned = std::is_unsigned_v<T>;
      f.type_min = static_cast<std::int64_t>(std::numeric_limits<T>::min());
      f.type_max = static_cast<std::uint64_t>(std::numeric_limits<T>::max());
      f.get = [member](const void* c) {
        Value v;
        const T x = static_cast<const C*>(c)->*member;
        if constexpr (std::is_unsigned_v<T>) v.u = x; else v.i = x;
        return v;
      };
      f.set = [member](void* c, const Value& v) {
        if constexpr (std::is_unsigned_v<T>) static_cast<C*>(c)->*member = static_cast<T>(v.u);
        else static_cast<C*>(c)->*member = static_cast<T>(v.i);
      };
    } else if constexpr (std::is_floating_point_v<T>) {
      f.type = Type::kReal;
      f.single_precision = sizeof(T) < sizeof(double);
      f.get = [member](const void* c) { Value v; v.d = static_cast<double>(static_cast<const C*>(c)->*member); return v; };
      f.set = [member](void* c, const Value& v) { static_cast<C*>(c)->*member = static_cast<T>(v.d); };
    } else {
      static_assert(std::is_same_v<T, std::string>, "params: a bool, integer, floating-point or string member");
      f.type = Type::kText;
      f.get = [member](const void* c) { Value v; v.s = static_cast<const C*>(c)->*member; return v; };
      f.set = [member](void* c, const Value& v) { static_cast<C*>(c)->*member = v.s; };
    }
    fields_.push_back(std::move(f));
    return *this;
  }

  // A switch.
  Table& flag(const char* key, bool C::*member, Origin origin, const char* doc) {
    return add(key, member, "", any(), origin, doc);
  }

  // An enum member with its names.
  template <typename E>
  Table& choice(const char* key, E C::*member, std::vector<std::pair<std::string, E>> names, Origin origin,
                const char* doc) {
    Field f = base(key, "", any(), origin, doc);
    f.type = Type::kChoice;
    for (const auto& n : names) f.choices.push_back(n.first);
    f.get = [member, names](const void* c) {
      Value v;
      for (const auto& n : names)
        if (n.second == static_cast<const C*>(c)->*member) v.s = n.first;
      return v;
    };
    f.set = [member, names](void* c, const Value& v) {
      for (const auto& n : names)
        if (n.first == v.s) static_cast<C*>(c)->*member = n.second;
    };
    fields_.push_back(std::move(f));
    return *this;
  }

  // A fixed-size array of doubles; each element within range.
  template <std::size_t N>
  Table& array(const char* key, double (C::*member)[N], const char* unit, Range range, Origin origin,
               const char* doc) {
    Field f = base(key, unit, range, origin, doc);
    f.type = Type::kRealArray;
    f.array_size = N;
    f.get = [member](const void* c) {
      Value v;
      const double* a = static_cast<const C*>(c)->*member;
      v.array.assign(a, a + N);
      return v;
    };
    f.set = [member](void* c, const Value& v) {
      for (std::size_t k = 0; k < N && k < v.array.size(); ++k) (static_cast<C*>(c)->*member)[k] = v.array[k];
    };
    fields_.push_back(std::move(f));
    return *this;
  }

  // Every field of another table, on a part of C (a member struct, or a member of one): part(c) gives it.
  template <typename S, typename Part>
  Table& include(const Table<S>& sub, Part part) {
    for (const Field& g : sub.fields()) {
      Field f = g;
      f.get = [get = g.get, part](const void* c) { return get(&part(*const_cast<C*>(static_cast<const C*>(c)))); };
      f.set = [set = g.set, part](void* c, const Value& v) { set(&part(*static_cast<C*>(c)), v); };
      fields_.push_back(std::move(f));
    }
    return *this;
  }

  const std::vector<Field>& fields() const { return fields_; }

 private:
  static Field base(const char* key, const char* unit, Range range, Origin origin, const char* doc) {
    Field f;
    f.key = key;
    f.unit = unit;
    f.range = range;
    f.origin = origin;
    f.doc = doc;
    return f;
  }
  std::vector<Field> fields_;
};

// A named group of fields on one root object: a JSON section ("places"), or "" for the root's own keys.
struct Section {
  std::string name;
  std::vector<Field> fields;
  const Field* find(const std::string& key) const;
};

// The sections of a root type R: the app's whole configuration, or an evaluation's stage Configs.
template <typename R>
class Schema {
 public:
  // Adds (or extends) a section with a table on R itself.
  Schema& section(const std::string& name, const Table<R>& table) {
    Section* s = find_or_add(name);
    for (const Field& f : table.fields()) s->fields.push_back(f);
    return *this;
  }
  // Adds (or extends) a section with a table on a part of R.
  template <typename S, typename Part>
  Schema& section(const std::string& name, const Table<S>& table, Part part) {
    return section(name, Table<R>().include(table, part));
  }
  const std::vector<Section>& sections() const { return sections_; }

 private:
  Section* find_or_add(const std::string& name) {
    for (Section& s : sections_)
      if (s.name == name) return &s;
    sections_.push_back(Section{name, {}});
    return &sections_.back();
  }
  std::vector<Section> sections_;
};

// "section.key" (or "key" in the root section).
std::string path_of(const Section& section, const Field& field);

// Empty when every field is within its range, else "rooms.visible_min_share must be in (0, 1], got 0".
std::string check(const std::vector<Section>& sections, const void* root);
// The same over one table's fields on `root`, the key prefixed with "section." when a section is given.
std::string check_fields(const std::vector<Field>& fields, const void* root, const char* section);
// One line per section: "rooms: seeding=persistence min_persistence_m=0.4 ..." (wrapped near 118 columns).
void print(const std::vector<Section>& sections, const void* root, std::FILE* out);
// "section.key=value": sets one field (type- and range-checked); false with a message naming the key otherwise.
bool set(const std::vector<Section>& sections, void* root, const std::string& assignment, std::string* error);
// The fields a set() would accept, "section.key (unit, range, origin): doc" per line, for --help.
void print_help(const std::vector<Section>& sections, std::FILE* out);

// A table's fields as one section, for a single Config.
template <typename C>
std::vector<Section> sections_of(const std::string& name, const Table<C>& table) {
  return {Section{name, table.fields()}};
}

template <typename R>
std::string check(const Schema<R>& schema, const R& root) { return check(schema.sections(), &root); }
// A stage Config's per-field check, from its table: its check() calls this first and then tests only the rules
// between fields. "max_distance_m must be in (0, 20] m, got 0" (with a section: "rooms.min_dilation_m ...").
// Allocates nothing while every value is within range.
template <typename C>
std::string check(const Table<C>& table, const C& config, const char* section = "") {
  return check_fields(table.fields(), &config, section);
}
template <typename R>
void print(const Schema<R>& schema, const R& root, std::FILE* out) { print(schema.sections(), &root, out); }
template <typename R>
bool set(const Schema<R>& schema, R* root, const std::string& assignment, std::string* error) {
  return set(schema.sections(), root, assignment, error);
}

// The shortest text that reads back as the same double (or float): 0.1, 1e9, 0.785398163.
std::string shortest(double v, bool single_precision = false);

}  // namespace qsg::params
