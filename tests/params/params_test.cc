// The parameter facility: one table per Config gives the range check, the print, --set and the JSON form.
#include "core/params/params.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <set>
#include <string>

#include "core/objects/objects_params.h"
#include "core/params/params_json.h"
#include "core/places/places_params.h"
#include "core/reconstruction/reconstruction_params.h"
#include "core/doors/door_params.h"
#include "core/rooms/rooms_params.h"
#include "core/frontend/frontend_params.h"
#ifdef QSG_HAVE_BACKEND_STAGE
#include "core/backend/backend_params.h"
#include "core/backend/backend_stage_params.h"
#include "core/loop_closure/detector_params.h"
#endif

namespace qsg::params {
namespace {

enum class Mode { kFast, kCareful };

// A stage's Config and its table, as a stage declares them. Adding a setting here is the struct's line and the
// table's line; check, print, set and the JSON loader and dump take it from there (the test below uses them all).
struct StageConfig {
  double radius_m = 1.5;
  std::uint32_t samples = 12;
  bool merge = true;
  Mode mode = Mode::kCareful;
  std::string name = "stage";
  float share = 0.8f;
  double limit_m = std::numeric_limits<double>::infinity();
  double offset_m[3] = {0.0, 0.0, 0.25};
};

const Table<StageConfig>& stage_table() {
  static const Table<StageConfig> table = [] {
    Table<StageConfig> t;
    t.add("radius_m", &StageConfig::radius_m, "m", above(0, 10), Origin::kPaper, "the search radius");
    t.add("samples", &StageConfig::samples, "", in(1, 32), Origin::kRefinement, "samples per room");
    t.flag("merge", &StageConfig::merge, Origin::kRefinement, "merge what matches");
    t.choice("mode", &StageConfig::mode, {{"fast", Mode::kFast}, {"careful", Mode::kCareful}}, Origin::kProject,
             "how hard to look");
    t.add("name", &StageConfig::name, "", any(), Origin::kProject, "what to call it");
    t.add("share", &StageConfig::share, "", in(0, 1), Origin::kRefinement, "share of clear lines");
    t.add("limit_m", &StageConfig::limit_m, "m", at_least(0), Origin::kRefinement, "inf: no limit");
    t.array("offset_m", &StageConfig::offset_m, "m", in(-10, 10), Origin::kProject, "an offset");
    return t;
  }();
  return table;
}

std::vector<Section> stage_sections() { return sections_of("stage", stage_table()); }

TEST(ParamsTest, RangeCheckNamesKeyValueAndRange) {
  StageConfig c;
  EXPECT_EQ(check(stage_sections(), &c), "");
  c.radius_m = 0.0;
  EXPECT_EQ(check(stage_sections(), &c), "stage.radius_m must be in (0, 10] m, got 0");
  c.radius_m = 2.0;
  c.samples = 64;
  EXPECT_EQ(check(stage_sections(), &c), "stage.samples must be in [1, 32], got 64");
  c.samples = 4;
  c.offset_m[1] = 11.0;
  EXPECT_NE(check(stage_sections(), &c).find("stage.offset_m each element must be in [-10, 10] m"), std::string::npos);
}

TEST(ParamsTest, SetParsesEachTypeAndRefusesBadValuesByName) {
  StageConfig c;
  std::string error;
  ASSERT_TRUE(set(stage_sections(), &c, "stage.radius_m=2.5", &error)) << error;
  ASSERT_TRUE(set(stage_sections(), &c, "stage.samples=7", &error)) << error;
  ASSERT_TRUE(set(stage_sections(), &c, "stage.merge=0", &error)) << error;
  ASSERT_TRUE(set(stage_sections(), &c, "stage.mode=fast", &error)) << error;
  ASSERT_TRUE(set(stage_sections(), &c, "stage.name=hall way", &error)) << error;
  ASSERT_TRUE(set(stage_sections(), &c, "stage.offset_m=1,2,3", &error)) << error;
  EXPECT_EQ(c.radius_m, 2.5);
  EXPECT_EQ(c.samples, 7u);
  EXPECT_FALSE(c.merge);
  EXPECT_EQ(c.mode, Mode::kFast);
  EXPECT_EQ(c.name, "hall way");
  EXPECT_EQ(c.offset_m[2], 3.0);
  EXPECT_FALSE(set(stage_sections(), &c, "stage.samples=2.5", &error));
  EXPECT_EQ(error, "stage.samples: expected an integer in [0, 4294967295], got '2.5'");
  EXPECT_FALSE(set(stage_sections(), &c, "stage.samples=40", &error));
  EXPECT_EQ(error, "stage.samples: must be in [1, 32], got 40");
  EXPECT_FALSE(set(stage_sections(), &c, "stage.mode=lazy", &error));
  EXPECT_EQ(error, "stage.mode: expected fast or careful, got 'lazy'");
  EXPECT_FALSE(set(stage_sections(), &c, "stage.nope=1", &error));
  EXPECT_EQ(error, "stage.nope: unknown key");
  EXPECT_FALSE(set(stage_sections(), &c, "stage.offset_m=1,2", &error));
  EXPECT_EQ(c.samples, 7u) << "a refused value leaves the field as it was";
}

TEST(ParamsTest, JsonDumpReadsBackAndTheLoaderIsStrict) {
  StageConfig c;
  c.radius_m = 0.1;
  c.share = 0.15f;
  c.mode = Mode::kFast;
  const std::string text = dump_json(stage_sections(), &c, "a test");
  EXPECT_NE(text.find("\"limit_m\": \"inf\""), std::string::npos) << text;
  EXPECT_NE(text.find("\"share\": 0.15"), std::string::npos) << "floats print as the shortest float: " << text;
  EXPECT_NE(text.find("// samples per room | [1, 32] | refinement"), std::string::npos) << text;
  StageConfig back;
  std::string error;
  ASSERT_TRUE(load_json(stage_sections(), &back, text, &error)) << error;
  EXPECT_EQ(dump_json(stage_sections(), &back, "a test"), text);
  EXPECT_EQ(back.share, 0.15f);
  for (const auto& [json, expected] : {
           std::pair{"{\"stage\": {\"radius\": 1}}", "stage.radius: unknown key"},
           std::pair{"{\"stage\": {\"samples\": 2, \"samples\": 3}}", "stage.samples: duplicated key"},
           std::pair{"{\"stage\": {\"samples\": 2.5}}", "stage.samples: expected an integer in [0, 4294967295], got 2.5"},
           std::pair{"{\"stage\": {\"samples\": -1}}", "stage.samples: expected an integer in [0, 4294967295], got -1"},
           std::pair{"{\"stage\": {\"merge\": 1}}", "stage.merge: expected true or false"},
           std::pair{"{\"stage\": {\"mode\": \"lazy\"}}", "stage.mode: expected fast or careful, got 'lazy'"},
           std::pair{"{\"stage\": {\"share\": 1e39}}", "stage.share: expected a number within the range of its type"},
           std::pair{"{\"stage\": {\"offset_m\": [1, 2]}}", "stage.offset_m: expected an array of 3 numbers"},
           std::pair{"{\"stage\": 3}", "stage: expected an object"},
           std::pair{"{\"other\": {}}", "other: unknown key"},
       }) {
    StageConfig bad;
    EXPECT_FALSE(load_json(stage_sections(), &bad, json, &error)) << json;
    EXPECT_NE(error.find(expected), std::string::npos) << json << ": '" << error << "'";
  }
  // Out of range is the range check's, after loading: it names the key too.
  StageConfig far;
  ASSERT_TRUE(load_json(stage_sections(), &far, "{\"stage\": {\"samples\": 33}}", &error)) << error;
  EXPECT_EQ(check(stage_sections(), &far), "stage.samples must be in [1, 32], got 33");
}

TEST(ParamsTest, PrintShowsEveryFieldOnce) {
  StageConfig c;
  char buffer[4096] = {};
  std::FILE* out = fmemopen(buffer, sizeof buffer, "w");
  ASSERT_NE(out, nullptr);
  print(stage_sections(), &c, out);
  std::fclose(out);
  const std::string text = buffer;
  for (const Field& f : stage_table().fields())
    EXPECT_NE(text.find(" " + f.key + "="), std::string::npos) << f.key << " in " << text;
  EXPECT_NE(text.find("limit_m=inf"), std::string::npos) << text;
  EXPECT_NE(text.find("offset_m=[0,0,0.25]"), std::string::npos) << text;
}

TEST(ParamsTest, ShortestNumbers) {
  EXPECT_EQ(shortest(10.0), "10");
  EXPECT_EQ(shortest(1e9), "1e9");
  EXPECT_EQ(shortest(0.1), "0.1");
  EXPECT_EQ(shortest(1.0 / 30.0), "0.03333333333333333");
  EXPECT_EQ(shortest(0.15f, true), "0.15");
  EXPECT_EQ(shortest(0.785398163), "0.785398163");
}

// Every stage table: keys unique, a doc each, and the struct's defaults within the declared ranges.
template <typename C>
void expect_sound(const std::string& name, const Table<C>& table) {
  const C defaults{};
  const std::vector<Section> sections = sections_of(name, table);
  EXPECT_EQ(check(sections, &defaults), "") << name;
  std::set<std::string> keys;
  for (const Field& f : table.fields()) {
    EXPECT_TRUE(keys.insert(f.key).second) << name << "." << f.key << " declared twice";
    EXPECT_GT(std::string(f.doc).size(), 3u) << name << "." << f.key << " has no doc";
  }
}

TEST(ParamsTest, StageTablesAreSound) {
  expect_sound("places", places::params_table());
  expect_sound("rooms", rooms::params_table());
  expect_sound("doors", rooms::door_params_table());
  expect_sound("reconstruction", reconstruction::params_table());
  expect_sound("frontend", frontend::params_table());
  expect_sound("agents", agents::params_table());
  expect_sound("objects", objects::params_table());
  // The tables cover the stage Configs' settings: places 31, rooms 30 (the capacities are budgets'; the switches
  // merge_visible_in_window and box_from_free_space are gone), doors 27 of 29 (max_cells and bypass_max_places are
  // capacities, for budgets/). At least: a new setting adds its table line without touching this test.
  EXPECT_GE(places::params_table().fields().size(), 31u);
  EXPECT_GE(rooms::params_table().fields().size(), 30u);
  EXPECT_GE(rooms::door_params_table().fields().size(), 27u);
}

// Values just outside a field's declared range (and NaN for a real), each one the table itself refuses.
std::vector<Value> outside(const Field& f) {
  std::vector<Value> values;
  const auto add = [&](double x) {
    Value v;
    if (f.type == Type::kReal) {
      v.d = x;
    } else if (f.type == Type::kInteger) {
      if (std::isnan(x) || x < static_cast<double>(f.type_min) || x > static_cast<double>(f.type_max)) return;
      if (f.is_unsigned) v.u = static_cast<std::uint64_t>(x); else v.i = static_cast<std::int64_t>(x);
    } else {
      return;
    }
    if (!f.check(v).empty()) values.push_back(v);
  };
  if (std::isfinite(f.range.lo)) add(f.range.lo_open ? f.range.lo : f.range.lo - 1.0);
  if (std::isfinite(f.range.hi)) add(f.range.hi_open ? f.range.hi : f.range.hi + 1.0);
  add(std::nan(""));
  return values;
}

// A stage's check() refuses every value its table refuses, with the table's words: it takes its ranges from the
// table rather than restating them (a field whose check() skipped the table fails here).
template <typename C, typename CheckOf>
void expect_check_uses_table(const std::string& name, const Table<C>& table, CheckOf check_of) {
  std::size_t tried = 0;
  for (const Field& f : table.fields())
    for (const Value& v : outside(f)) {
      C c{};
      f.set(&c, v);
      const std::string why = check_of(c);
      EXPECT_NE(why.find(f.key + " " + f.check(v)), std::string::npos)
          << name << "." << f.key << " = " << f.text(v) << ": check() says '" << why << "'";
      ++tried;
    }
  EXPECT_GE(tried, table.fields().size() / 2) << name << ": too few numeric fields tried";
}

TEST(ParamsTest, StageChecksRefuseWhatTheirTablesRefuse) {
  expect_check_uses_table("places", places::params_table(), [](const places::Config& c) { return c.check(); });
  expect_check_uses_table("rooms", rooms::params_table(), [](const rooms::Config& c) { return c.check(); });
  expect_check_uses_table("doors", rooms::door_params_table(), [](const rooms::DoorConfig& c) {
    std::string why;
    return c.validate(&why) ? std::string() : why;
  });
  expect_check_uses_table("reconstruction", reconstruction::params_table(),
                          [](const reconstruction::Config& c) { return c.check(); });
  expect_check_uses_table("objects", objects::params_table(), [](const objects::Config& c) { return c.check(); });
  expect_check_uses_table("agents", agents::params_table(), [](const agents::Config& c) { return c.check(); });
  expect_check_uses_table("frontend", frontend::params_table(), [](const frontend::Config& c) { return c.check(); });
#ifdef QSG_HAVE_BACKEND_STAGE
  namespace lc = loop_closure;
  expect_check_uses_table("descriptor", lc::descriptor_params_table(), [](const lc::DescriptorConfig& c) {
    return c.check();
  });
  expect_check_uses_table("detector", lc::detector_params_table(), [](const lc::DetectorConfig& c) {
    return c.check();
  });
  expect_check_uses_table("local_map", lc::local_map_params_table(), [](const lc::LocalMapConfig& c) {
    return c.check();
  });
  expect_check_uses_table("icp", lc::icp_params_table(), [](const lc::IcpConfig& c) { return c.check(); });
  expect_check_uses_table("registration", lc::registration_params_table(), [](const lc::RegistrationConfig& c) {
    return c.check();
  });
  expect_check_uses_table("agent_graph", backend::agent_graph_params_table(), [](const backend::AgentGraphConfig& c) {
    return c.check();
  });
  expect_check_uses_table("deformation", backend::deformation_params_table(), [](const backend::DeformationConfig& c) {
    return c.check();
  });
  expect_check_uses_table("loop_closure", backend::loop_closure_params_table(),
                          [](const backend::LoopClosureConfig& c) { return c.check(); });
#endif
}

TEST(ParamsTest, PaperTagsAreVisible) {
  std::size_t paper = 0, refinement = 0;
  for (const Field& f : rooms::params_table().fields()) {
    paper += f.origin == Origin::kPaper;
    refinement += f.origin == Origin::kRefinement;
  }
  EXPECT_EQ(paper, 5u);
  EXPECT_GT(refinement, paper);
}

}  // namespace
}  // namespace qsg::params
