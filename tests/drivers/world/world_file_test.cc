// Tests of the JSON world file: exact round trips, the documented example, and errors that name file and field.
#include "drivers/world/world_file.h"

#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <utility>

#include "drivers/world/building_generator.h"
#include "drivers/world/world_geometry.h"
#include "drivers/world/world_query.h"
#include "tests/support/test_data.h"

namespace qsg::world {
namespace {

std::string temp_path(const std::string& name) {
  return ::testing::TempDir() + "qsg_world_file_" + std::to_string(getpid()) + "_" + name;
}

void expect_round_trip(const World& w, const std::string& name) {
  const std::string path = temp_path(name);
  std::string error;
  ASSERT_TRUE(write_world_file(w, path, &error)) << error;
  const WorldResult r = read_world_file(path);
  std::remove(path.c_str());
  ASSERT_TRUE(r.ok) << r.error;
  std::string diff;
  EXPECT_TRUE(worlds_equal(w, r.world, &diff)) << name << ": first difference at " << diff;
}

TEST(WorldFile, GeneratedBuildingsRoundTripExactly) {
  BuildingConfig c;
  c.num_rooms = 10;
  expect_round_trip(generate_building(c), "one_floor.json");
  c.two_floors = true;
  c.seed = 4;
  expect_round_trip(generate_building(c), "two_floors.json");
}

TEST(WorldFile, EveryShapeKindAndAwkwardNumbersRoundTrip) {
  World w;
  w.name = "odd \"name\" \xC3\xA9";
  Material m;
  m.label = semantics::kCushion;
  m.color = {{0, 255, 7}};
  m.texture = Texture::kChecker;
  m.texture_scale_m = 0.1f;
  BoxShape b;
  b.center_m = {1.0 / 3.0, -0.0, 1e-17};
  b.half_extents_m = {0.1, 1e3 / 7.0, 2.5};  // not exactly representable, within WorldFileLimits
  b.world_R_box = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
  w.add_box(b, m);
  w.add_box(yaw_box({1, 2, 3}, {0.4, 0.5, 0.6}, 2.0), m);
  CylinderShape c;
  c.base_center_m = {0.1, 0.2, 0.3};
  c.radius_m = 0.123456789012345678;
  w.add_cylinder(c, m);
  PrismShape p;
  p.polygon_m = {{0, 0}, {1, 0}, {0.5, std::sqrt(0.75)}};
  p.z_min_m = -1.0;
  p.z_max_m = 3.0;
  w.add_prism(p, m);
  PlaneShape pl;
  pl.normal = Eigen::Vector3d(0.1, 0.2, 0.9).normalized();
  w.add_plane(pl, m);
  Room r;
  r.id = 5;
  r.label = semantics::kSpa;
  r.footprint_m = {p.polygon_m, {{2, 2}, {3, 2}, {3, 3}}};
  r.floor_z_m = 2.7;
  r.floor_index = 1;
  w.rooms.push_back(r);
  Door d;
  d.a_m = {0.1, 0.2};
  d.b_m = {0.9, 0.2};
  d.room_a = 5;
  d.room_b = -1;
  w.doors.push_back(d);
  Object o;
  o.id = 0;
  o.label = semantics::kClothes;
  o.box = yaw_box({0.5, 0.5, 0.5}, {0.2, 0.2, 0.2}, -1.0);
  o.room_id = 5;
  w.objects.push_back(o);
  w.shapes[1].object_id = 0;
  w.shapes[1].room_id = 5;
  expect_round_trip(w, "kinds.json");
}

TEST(WorldFile, TheDocumentedExampleLoads) {
  const WorldResult r = read_world_file(::qsg::testing::repo_test_data("worlds/example_world.json"));
  ASSERT_TRUE(r.ok) << r.error;
  const World& w = r.world;
  EXPECT_EQ(w.name, "example_two_rooms");
  ASSERT_EQ(w.rooms.size(), 2u);
  EXPECT_EQ(w.rooms[0].label, semantics::kLivingRoom);
  EXPECT_EQ(w.rooms[1].label, semantics::kKitchen);
  EXPECT_DOUBLE_EQ(w.rooms[1].height_m, 2.5);  // default
  ASSERT_EQ(w.doors.size(), 1u);
  EXPECT_NEAR(w.doors[0].width_m(), 0.9, 1e-12);
  EXPECT_DOUBLE_EQ(w.doors[0].height_m, 2.0);
  ASSERT_EQ(w.objects.size(), 6u);
  EXPECT_EQ(w.objects[3].label, semantics::kPlant);
  // 4 raw shapes + 4 outer walls + the partition cut by the door (2 pieces and a lintel) + 5 object boxes.
  EXPECT_EQ(w.shapes.size(), 4u + 4u + 3u + 5u);
  const FreeSpaceIndex index(w);
  EXPECT_TRUE(index.is_free({5.0, 1.95, 1.0}, 0.3));   // the doorway
  EXPECT_FALSE(index.is_free({5.0, 1.95, 2.2}, 0.0));  // the lintel above it
  EXPECT_FALSE(index.is_free({5.0, 0.8, 1.0}, 0.0));   // the partition beside it
  EXPECT_EQ(room_at(w, 6.0, 1.0, 1.0), 1);
  // And it survives a round trip once loaded.
  expect_round_trip(w, "example.json");
}

struct BadCase {
  const char* text;
  const char* expected;  // substring of the error
};

TEST(WorldFile, MalformedInputNamesTheField) {
  const BadCase cases[] = {
      {R"({"version": 1, "rooms": [{"label": "kitchen", "footprint": [[[0,0],[1,0],[1]]]}]})",
       "rooms[0].footprint[0][2]: expected [x, y]"},
      {R"({"version": 1, "rooms": [{}, {}, {}, {"label": "kitchen", "footprint": [[[0,0],[1,0],[1,1],"x"]]}]})",
       "rooms[0].label: missing required field"},
      {R"({"version": 1, "rooms": [{"label": "kichen", "footprint": [[[0,0],[1,0],[1,1]]]}]})",
       "rooms[0].label: unknown room label 'kichen'"},
      {R"({"version": 1, "rooms": [{"label": "kitchen", "footprint": [[[0,0],[1,0],[1,1]]], "hieght": 2}]})",
       "rooms[0].hieght: unknown field"},
      {R"({"version": 1, "rooms": [{"label": "kitchen", "footprint": [[[0,0],[1,0]]]}]})",
       "rooms[0].footprint[0]: a polygon needs at least 3 points"},
      {R"({"rooms": []})", "version: missing required field"},
      {R"({"version": 2})", "version: unsupported version 2"},
      {R"({"version": 1, "format": "other"})", "format: expected \"qsg_world\""},
      {R"([1, 2])", "(top level): expected an object"},
      {R"({"version": 1, "doors": [{"a": [0,0], "b": [1,0], "room_a": 3}]})", "doors[0].room_a: no room with id 3"},
      {R"({"version": 1, "doors": [{"a": [0,0], "b": [1,0,2]}]})", "doors[0].b: expected [x, y]"},
      {R"({"version": 1, "objects": [{"label": "chair", "center": [0,0,0], "size": [1,1,1], "yaw": "north"}]})",
       "objects[0].yaw: expected a number"},
      {R"({"version": 1, "objects": [{"label": "chair", "center": [0,0,0], "size": [1,1,1], "yaw": 0, "rotation": [1,0,0,0]}]})",
       "objects[0].rotation: give either yaw or rotation"},
      {R"({"version": 1, "objects": [{"label": "chiar", "center": [0,0,0], "size": [1,1,1]}]})",
       "objects[0].label: unknown object label 'chiar'"},
      {R"({"version": 1, "shapes": [{"type": "box", "center": [0,0,0], "size": [1,1,1], "material": {"label": "wall", "color": [300, 0, 0]}}]})",
       "shapes[0].material.color[0]: must lie in [0, 255]"},
      {R"({"version": 1, "shapes": [{"type": "box", "center": [0,0,0], "size": [1,1,1], "material": {"label": "wall", "texture": "wood"}}]})",
       "shapes[0].material.texture: unknown texture 'wood'"},
      {R"({"version": 1, "shapes": [{"type": "box", "center": [0,0,0], "size": [1,1,1]}]})",
       "shapes[0].material: missing required field"},
      {R"({"version": 1, "shapes": [{"type": "sphere", "material": {"label": "wall"}}]})",
       "shapes[0].type: unknown shape type 'sphere'"},
      {R"({"version": 1, "shapes": [{"type": "cylinder", "base": [0,0,0], "radius": -1, "height": 1, "material": {"label": "wall"}}]})",
       "shapes[0].radius: must be positive"},
      {R"({"version": 1, "shapes": [{"type": "box", "center": [0,0,0], "size": [1,1,1], "object": 0, "material": {"label": "wall"}}]})",
       "shapes[0].object: no object with index 0"},
      {R"({"version": 1, "shapes": [{"type": "prism", "polygon": [[0,0],[1,0],[1,1]], "z_min": 1, "z_max": 0, "material": {"label": "wall"}}]})",
       "shapes[0].z_max: must exceed z_min"},
      {R"({"version": 1, "walls": [{"from": [0,0], "to": [0,0]}]})", "walls[0].to: wall has zero length"},
      {R"({"version": 1, "wall_polygons": [{"polygon": [[0,0],[1,0],[1,1]], "height": 0}]})",
       "wall_polygons[0].height: must be positive"},
  };
  for (const BadCase& c : cases) {
    const WorldResult r = parse_world_json(c.text, "bad.json");
    EXPECT_FALSE(r.ok) << c.text;
    EXPECT_EQ(r.error.rfind("bad.json: ", 0), 0u) << r.error;
    EXPECT_NE(r.error.find(c.expected), std::string::npos) << "expected '" << c.expected << "' in: " << r.error;
    EXPECT_TRUE(r.world.shapes.empty() && r.world.rooms.empty());
  }
}

TEST(WorldFile, SyntaxErrorsGiveLineAndColumn) {
  const WorldResult r = parse_world_json("{\n  \"version\": 1,\n  \"rooms\": [,]\n}\n", "broken.json");
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.error.rfind("broken.json:3:", 0), 0u) << r.error;
  EXPECT_NE(r.error.find("syntax error"), std::string::npos) << r.error;
  const WorldResult overflow = parse_world_json("{\"version\": 1,\n \"x\": 1e400}", "big.json");
  EXPECT_FALSE(overflow.ok);
  EXPECT_EQ(overflow.error.rfind("big.json:2:7: ", 0), 0u) << overflow.error;
  const WorldResult empty = parse_world_json("", "empty.json");
  EXPECT_FALSE(empty.ok);
  EXPECT_EQ(empty.error.rfind("empty.json:1:", 0), 0u) << empty.error;
}

// Regressions (issue 36): 100,000 nested arrays overflowed the stack with the JSON library's recursive
// destructor (nlohmann-json 3.7); shapes of 2^31 m and 1e308 m aborted the planner and the BVH build and 1e6 m
// took 11 GB. The reader now refuses them by a named limit before anything is built.
TEST(WorldFile, DeepNestingIsRefusedByName) {
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  const WorldResult r = parse_world_json("{\"version\": 1, \"name\": " + deep + "}", "deep.json");
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.error.rfind("deep.json: name[0]", 0), 0u) << r.error.substr(0, 200);
  EXPECT_NE(r.error.find("nested deeper than 32 levels"), std::string::npos) << r.error.substr(0, 200);
  // Legitimate depth (a room footprint: 6 levels) still reads.
  EXPECT_TRUE(parse_world_json(R"({"version": 1, "rooms": [{"label": "kitchen", "footprint": [[[0,0],[1,0],[1,1]]]}]})",
                               "ok.json")
                  .ok);
}

TEST(WorldFile, DuplicatedKeysAreErrors) {
  const WorldResult r = parse_world_json(R"({"version": 1, "rooms": [{"label": "kitchen", "label": "bedroom",
      "footprint": [[[0,0],[1,0],[1,1]]]}]})", "dup.json");
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.error, "dup.json: rooms[0].label: duplicated key");
}

TEST(WorldFile, HugeCoordinatesAndSizesAreRefusedByName) {
  const auto box_of = [](const std::string& size) {
    return R"({"version": 1, "rooms": [{"label": "kitchen", "footprint": [[[0,0],[4,0],[4,4],[0,4]]]}],
      "shapes": [{"type": "box", "center": [0, 0, 0], "size": [)" + size + R"(, 1, 1], "material": {"label": "wall"}}]})";
  };
  for (const auto& [size, shown] : {std::pair{"2147483648", "2147483648"}, std::pair{"1e308", "1e+308"},
                                    std::pair{"1e6", "1000000"}, std::pair{"-1000.5", "-1000.5"}}) {
    const WorldResult r = parse_world_json(box_of(size), "big.json");
    EXPECT_FALSE(r.ok) << size;
    EXPECT_EQ(r.error, std::string("big.json: shapes[0].size[0]: ") + shown +
                           " is beyond the world file's limit of 1000 (WorldFileLimits::max_abs_value_m: every "
                           "coordinate and size, in metres)");
    EXPECT_TRUE(r.world.shapes.empty());
  }
  EXPECT_TRUE(parse_world_json(box_of("1000"), "edge.json").ok);
  // Every kind of number is bounded: scalars, 2D points, rotations.
  const WorldResult radius = parse_world_json(
      R"({"version": 1, "shapes": [{"type": "cylinder", "base": [0,0,0], "radius": 5000, "height": 1, "material": {"label": "wall"}}]})",
      "r.json");
  EXPECT_NE(radius.error.find("shapes[0].radius: 5000 is beyond"), std::string::npos) << radius.error;
  const WorldResult door = parse_world_json(R"({"version": 1, "doors": [{"a": [0, 0], "b": [0, -2e9]}]})", "d.json");
  EXPECT_NE(door.error.find("doors[0].b[1]: -2000000000 is beyond"), std::string::npos) << door.error;
  const WorldResult yaw = parse_world_json(
      R"({"version": 1, "objects": [{"label": "chair", "center": [0,0,0], "size": [1,1,1], "yaw": 1e300}]})", "y.json");
  EXPECT_NE(yaw.error.find("objects[0].yaw: 1e+300 is beyond"), std::string::npos) << yaw.error;
  // The limit is the caller's to set.
  WorldFileLimits tight;
  tight.max_abs_value_m = 50.0;
  EXPECT_FALSE(parse_world_json(box_of("60"), "tight.json", tight).ok);
  EXPECT_TRUE(parse_world_json(box_of("60"), "tight.json").ok);
}

TEST(WorldFile, FileErrorsNameTheFile) {
  const std::string path = temp_path("malformed.json");
  {
    std::ofstream f(path);
    f << R"({"version": 1, "rooms": [{"label": "bedroom", "footprint": [[[0,0],[1,0],[1,1]]]}, )"
      << R"({"label": "bedroom", "footprint": [[[0,0],[1,0],[1,1],[0,"y"]]]}]})";
  }
  const WorldResult r = read_world_file(path);
  std::remove(path.c_str());
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.error, path + ": rooms[1].footprint[0][3]: expected [x, y]");
  const WorldResult missing = read_world_file("/nonexistent/world.json");
  EXPECT_FALSE(missing.ok);
  EXPECT_EQ(missing.error.rfind("/nonexistent/world.json: cannot open", 0), 0u) << missing.error;
  std::string error;
  EXPECT_FALSE(write_world_file(World(), "/nonexistent/out.json", &error));
  EXPECT_EQ(error.rfind("/nonexistent/out.json: ", 0), 0u) << error;
}

}  // namespace
}  // namespace qsg::world
