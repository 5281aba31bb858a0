// The JSON form of a params::Schema: a strict loader and the full dump (qsg_app --dump-config). One object per
// section ({"places": {"voxel_factor": 2, ...}}), the root section's keys at the top. Whole-line // comments are
// allowed (nlohmann-json 3.7 on JetPack 5 cannot skip comments itself). Off the real-time path: start-up only.
#pragma once

#include <string>
#include <vector>

#include "core/params/params.h"

namespace qsg::params {

// Reads the keys present in `text` over the current values of `root`. Errors name the key: unknown keys, a
// duplicated key, a wrong type ("expected an integer in [0, 4294967295], got 2.5": an integer field takes JSON
// integers only, within its C++ type), nesting deeper than 32 levels, and a value out of its declared range. A
// real field whose range has no upper bound also takes the string "inf".
bool load_json(const std::vector<Section>& sections, void* root, const std::string& text, std::string* error);

// Every field of every section with its current value, one key a line, each after a comment line with its doc,
// unit, range and origin. load_json reads it back to the same values.
std::string dump_json(const std::vector<Section>& sections, const void* root, const std::string& header_comment);

template <typename R>
bool load_json(const Schema<R>& schema, R* root, const std::string& text, std::string* error) {
  return load_json(schema.sections(), root, text, error);
}
template <typename R>
std::string dump_json(const Schema<R>& schema, const R& root, const std::string& header_comment) {
  return dump_json(schema.sections(), &root, header_comment);
}

}  // namespace qsg::params
