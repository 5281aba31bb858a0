// Limits on what a JSON document may ask of a reader before any of it is used: nesting depth and duplicated keys.
//
// nlohmann-json parses any depth and keeps the last of duplicated keys silently; a deep document is also
// destroyed recursively by the 3.7 release on JetPack 5, so 100,000 nested arrays overflow the stack. The guard
// is a parser callback: past the depth limit it discards the value (nothing deeper is built) and records a named
// error, and it records the first duplicated key with its path. Header-only, so each reader keeps nlohmann-json a
// private dependency. Readers run off the real-time path (start-up, conversion, simulation) and may use the heap.
#pragma once

#include <cstddef>
#include <new>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace qsg::json_guard {

// The deepest legitimate document read here (a world file's room footprints: root, rooms, room, footprint,
// polygon, point) is 6 levels; Spark-DSG and the app config are shallower.
inline constexpr int kDefaultMaxDepth = 32;  // range 8 .. 1000 (deeper risks the recursive destruction above)

struct Limits {
  int max_depth = kDefaultMaxDepth;     // containers nested deeper than this are an error
  bool reject_duplicate_keys = true;    // false: keep the last, as the JSON library does
};

// Why a parse failed: what kind of failure, a message without the library's "[json.exception...]" prefix, and
// the byte offset when the parser knows it (else std::string::npos).
struct ParseFailure {
  enum class Kind { kSyntax, kNumberRange, kTooDeep, kDuplicateKey, kTooLarge };
  Kind kind = Kind::kSyntax;
  std::string message;
  std::size_t byte = std::string::npos;
};

// "[json.exception.parse_error.101] parse error at ..." -> "parse error at ...".
inline std::string without_exception_prefix(const std::string& what) {
  if (what.rfind("[json.exception.", 0) == 0) {
    const std::size_t close = what.find("] ");
    if (close != std::string::npos) return what.substr(close + 2);
  }
  return what;
}

namespace detail {

template <typename Json>
class Guard {
 public:
  explicit Guard(const Limits& limits) : limits_(limits) {}

  bool on_event(int depth, typename Json::parse_event_t event, Json& parsed) {
    using Event = typename Json::parse_event_t;
    if (!error_.empty()) return false;  // discard everything after the first error
    switch (event) {
      case Event::object_start:
      case Event::array_start:
        note_child(depth);
        if (depth >= limits_.max_depth) {
          kind_ = ParseFailure::Kind::kTooDeep;
          error_ = where() + ": nested deeper than " + std::to_string(limits_.max_depth) + " levels (the reader's limit)";
          return false;
        }
        frames_.push_back(Frame{event == Event::object_start, {}, {}, 0});
        return true;
      case Event::object_end:
      case Event::array_end:
        if (!frames_.empty()) frames_.pop_back();
        return true;
      case Event::key:
        if (!frames_.empty() && parsed.is_string()) {
          Frame& f = frames_.back();
          f.key = parsed.template get<std::string>();
          if (!f.keys.insert(f.key).second && limits_.reject_duplicate_keys) {
            kind_ = ParseFailure::Kind::kDuplicateKey;
            error_ = where() + ": duplicated key";
            return false;
          }
        }
        return true;
      case Event::value:
        note_child(depth);
        return true;
    }
    return true;
  }

  const std::string& error() const { return error_; }
  ParseFailure::Kind kind() const { return kind_; }

 private:
  struct Frame {
    bool is_object = false;
    std::set<std::string> keys;
    std::string key;        // an object's current key
    std::size_t count = 0;  // an array's elements so far
  };

  // A value or container starting directly inside the innermost frame: counts array elements.
  void note_child(int depth) {
    if (!frames_.empty() && depth == static_cast<int>(frames_.size()) && !frames_.back().is_object) ++frames_.back().count;
  }

  // The path of the value being read, e.g. "rooms[3].footprint[0]" ("(top level)" for the root); past 8 levels
  // the rest is elided ("name[0][0][0][0][0][0][0]...").
  std::string where() const {
    constexpr std::size_t kShownLevels = 8;
    std::string path;
    for (std::size_t i = 0; i < frames_.size() && i < kShownLevels; ++i) {
      const Frame& f = frames_[i];
      if (f.is_object) path += (path.empty() ? "" : ".") + f.key;
      else path += "[" + std::to_string(f.count == 0 ? 0 : f.count - 1) + "]";
    }
    if (frames_.size() > kShownLevels) path += "...";
    return path.empty() ? "(top level)" : path;
  }

  Limits limits_;
  std::vector<Frame> frames_;
  std::string error_;
  ParseFailure::Kind kind_ = ParseFailure::Kind::kSyntax;
};

}  // namespace detail

// Parses text into *out under the limits. False with *failure set on a syntax error, a number outside the double
// range ("1e400"), a nesting deeper than the limit or a duplicated key; never throws.
template <typename Json>
bool parse(const std::string& text, const Limits& limits, Json* out, ParseFailure* failure) {
  detail::Guard<Json> guard(limits);
  try {
    Json parsed = Json::parse(
        text, [&guard](int depth, typename Json::parse_event_t event, Json& j) { return guard.on_event(depth, event, j); });
    if (!guard.error().empty()) {
      *failure = ParseFailure{guard.kind(), guard.error(), std::string::npos};
      return false;
    }
    *out = std::move(parsed);
    return true;
  } catch (const typename Json::parse_error& e) {
    *failure = ParseFailure{ParseFailure::Kind::kSyntax, without_exception_prefix(e.what()), e.byte};
  } catch (const typename Json::out_of_range& e) {  // 406: "number overflow parsing '1e400'"
    *failure = ParseFailure{ParseFailure::Kind::kNumberRange,
                            "a number outside the double range (" + without_exception_prefix(e.what()) + ")",
                            std::string::npos};
  } catch (const typename Json::exception& e) {
    *failure = ParseFailure{ParseFailure::Kind::kSyntax, without_exception_prefix(e.what()), std::string::npos};
  } catch (const std::bad_alloc&) {
    *failure = ParseFailure{ParseFailure::Kind::kTooLarge, "the document does not fit in memory", std::string::npos};
  }
  return false;
}

}  // namespace qsg::json_guard
