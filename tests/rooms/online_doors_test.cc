// The online door stage: the wall map (painting, repainting a block, slicing, a full tile pool), the DoorSet (the
// room finder's test agrees with cut_place_edges' on random edges), and a window pass that finds the door the final
// stage finds, without allocating, and replaces only the doors of its window's interior; a found door that the
// window's places graph goes round is not kept.
#include "core/doors/online_doors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/rooms/room_finder.h"
#include "tests/rooms/door_scene.h"
#include "tests/support/allocation_counter.h"

namespace qsg::rooms {
namespace {

using testing::places_graph;
using testing::Scene;
using testing::two_rooms;

OnlineDoorCapacities small_capacities() {
  OnlineDoorCapacities c;
  c.wall_tiles = 64;
  c.window_side = 320;  // 16 m
  c.places = 512;
  c.doors = 16;
  c.candidates = 256;
  c.place_edges = 2048;
  return c;
}

void paint(const Scene& s, WallMap* map) {
  for (const Eigen::Vector3f& v : s.surface) map->add(v.x(), v.y(), v.z());
}

PassResult pass(OnlineDoors* online, const Scene& s, const Eigen::Vector3d& robot) {
  online->begin_pass(robot);
  for (const Eigen::Vector3d& p : s.places) online->add_place(p);
  online->rasterize();
  return online->detect();
}

TEST(WallMap, PaintsSlicesAndRepaintsABlock) {
  memory::Arena arena;
  WallMap map;
  std::string error;
  // 8 m x 4 m x 2.5 m: 6 x 3 x 2 tiles of 1.6 m.
  const memory::ArenaPlan plan = WallMap::plan(64);
  ASSERT_TRUE(arena.create("wall_map", plan, plan.total_bytes(), &error)) << error;
  ASSERT_TRUE(map.carve(arena, 64, 0.05));
  const Scene s = two_rooms(1.6, 2.5);
  paint(s, &map);
  DoorRaster r;
  r.lo = Eigen::Vector2d(-0.5, -0.5);
  r.cols = r.rows = 200;
  r.cell_m = 0.05;
  std::vector<std::uint8_t> wall(r.cells());
  map.slice(r, 1.2, 0.4, 0.3, wall.data());
  const auto at = [&](double x, double y) {
    int c = 0, q = 0;
    EXPECT_TRUE(r.cell_of(x, y, &c, &q));
    return wall[static_cast<std::size_t>(q) * r.cols + c];
  };
  EXPECT_EQ(at(4.01, 1.0), 1) << "the wall between the rooms";
  EXPECT_EQ(at(4.01, 2.0), 0) << "the door";
  EXPECT_EQ(at(2.0, 2.0), 0) << "floor and ceiling only";
  EXPECT_EQ(at(0.01, 2.0), 1) << "an outer wall";
  // A slice near the ceiling sees the ceiling but it spans no height: no wall there either.
  map.slice(r, 2.5, 0.4, 0.3, wall.data());
  EXPECT_EQ(at(2.0, 2.0), 0);
  // Repainting a block: its volume cleared, the wall at x = 4, y in [0.8, 1.6) gone; the rest stays.
  map.clear_box(Eigen::Vector3d(3.2, 0.8, 0.0), Eigen::Vector3d(4.8, 1.6, 3.2));
  map.slice(r, 1.2, 0.4, 0.3, wall.data());
  EXPECT_EQ(at(4.01, 1.0), 0);
  EXPECT_EQ(at(4.01, 0.5), 1);
  EXPECT_EQ(at(4.01, 3.0), 1);
  paint(s, &map);
  map.slice(r, 1.2, 0.4, 0.3, wall.data());
  EXPECT_EQ(at(4.01, 1.0), 1);
  EXPECT_EQ(map.tile_stats().failed, 0u);
  EXPECT_EQ(map.tile_stats().in_use, 36u);
}

TEST(WallMap, AFullTilePoolIsCountedNotFatal) {
  memory::Arena arena;
  WallMap map;
  std::string error;
  const memory::ArenaPlan plan = WallMap::plan(2);
  ASSERT_TRUE(arena.create("wall_map", plan, plan.total_bytes(), &error)) << error;
  ASSERT_TRUE(map.carve(arena, 2, 0.05));
  EXPECT_TRUE(map.add(0.1f, 0.1f, 0.1f));
  EXPECT_TRUE(map.add(5.1f, 0.1f, 0.1f));  // a second tile (tiles are 1.6 m wide)
  EXPECT_FALSE(map.add(10.1f, 0.1f, 0.1f)) << "a third tile does not fit";
  EXPECT_FALSE(map.add(std::nanf(""), 0.1f, 0.1f));
  EXPECT_TRUE(map.add(0.2f, 0.1f, 0.1f)) << "an existing tile still takes vertices";
  EXPECT_EQ(map.tile_stats().in_use, 2u);
  EXPECT_EQ(map.tile_stats().failed, 1u);
  EXPECT_EQ(map.dropped_vertices(), 1u);
}

TEST(DoorSet, ClosesExactlyTheEdgesCutPlaceEdgesWould) {
  const DoorConfig config;
  memory::Arena arena;
  DoorSet set;
  std::string error;
  const memory::ArenaPlan plan = DoorSet::plan(40);
  ASSERT_TRUE(arena.create("door_set", plan, plan.total_bytes(), &error)) << error;
  ASSERT_TRUE(set.carve(arena, 40, config));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pos(-20.0, 20.0), len(0.5, 2.5), ang(0.0, 2.0 * M_PI), dz(-2.0, 2.0);
  std::vector<Door> doors;
  for (int i = 0; i < 40; ++i) {
    Door d;
    d.a = Eigen::Vector2d(pos(rng), pos(rng));
    const double t = ang(rng);
    d.b = d.a + len(rng) * Eigen::Vector2d(std::cos(t), std::sin(t));
    d.z_m = 1.2;
    doors.push_back(d);
    ASSERT_TRUE(set.add(d));
  }
  Door extra;
  EXPECT_FALSE(set.add(extra)) << "full";
  EXPECT_EQ(set.stats().failed, 1u);
  std::size_t closed = 0;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector3d a(pos(rng), pos(rng), 1.0 + dz(rng));
    const double t = ang(rng);
    const double l = i % 100 == 0 ? 30.0 : 0.3 + 2.0 * std::abs(std::sin(t * 7.0));  // some long edges too
    const Eigen::Vector3d b = a + Eigen::Vector3d(l * std::cos(t), l * std::sin(t), 0.3 * dz(rng));
    bool expected = false;
    for (const Door& d : doors) expected = expected || door_closes_edge(d, config, a, b);
    ASSERT_EQ(set.closes(a, b), expected) << "edge " << i;
    closed += expected ? 1 : 0;
  }
  EXPECT_GT(closed, 100u) << "the random edges must cross doors often enough to test something";
  // Removal keeps the index right.
  const std::size_t removed = set.remove_if([](const Door& d) { return d.a.x() < 0.0; });
  EXPECT_GT(removed, 0u);
  std::vector<Door> kept;
  for (const Door& d : doors)
    if (d.a.x() >= 0.0) kept.push_back(d);
  ASSERT_EQ(set.size(), kept.size());
  for (int i = 0; i < 5000; ++i) {
    const Eigen::Vector3d a(pos(rng), pos(rng), 1.0);
    const Eigen::Vector3d b = a + Eigen::Vector3d(len(rng), len(rng) - 1.5, 0.0);
    bool expected = false;
    for (const Door& d : kept) expected = expected || door_closes_edge(d, config, a, b);
    ASSERT_EQ(set.closes(a, b), expected);
  }
}

TEST(OnlineDoors, AWindowPassFindsTheFinalStagesDoorWithoutAllocating) {
  OnlineDoors online;
  std::string error;
  ASSERT_TRUE(online.init(DoorConfig{}, small_capacities(), 0, &error)) << error;
  const Scene s = two_rooms(1.6, 2.5);
  paint(s, &online.wall_map());
  const Eigen::Vector3d robot(2.0, 2.0, 0.5);  // the slice: 1.2 m
  PassResult r;
  EXPECT_EQ(online.sight().slices(), 0u);
  EXPECT_NO_ALLOCATIONS(r = pass(&online, s, robot));
  ASSERT_TRUE(r.ran);
  EXPECT_DOUBLE_EQ(r.slice_z_m, 1.2);
  // The same pass built the window's sight lines: the wall at x = 4 blocks them, its door does not, and a place
  // edge through it near the ceiling crosses it.
  ASSERT_EQ(online.sight().slices(), 1u);
  EXPECT_GT(r.sight_structure_cells, 0u);
  EXPECT_EQ(r.sight_structure_cells, online.sight().structure_cells(0));
  EXPECT_FALSE(online.sight().sees(Eigen::Vector3d(2, 0.75, 1), Eigen::Vector3d(6, 0.75, 1)));
  EXPECT_TRUE(online.sight().sees(Eigen::Vector3d(2, 2.05, 1), Eigen::Vector3d(6, 2.05, 1)));
  EXPECT_TRUE(online.sight().crosses_structure(Eigen::Vector3d(3.75, 0.75, 2.3), Eigen::Vector3d(4.25, 0.75, 2.3)));
  // Outside the window: not judged.
  EXPECT_FALSE(online.sight().sees(Eigen::Vector3d(2, 2, 1), Eigen::Vector3d(60, 2, 1)));
  EXPECT_EQ(r.places, s.places.size());
  ASSERT_EQ(online.doors().size(), 1u);
  std::vector<Door> final_doors;
  ASSERT_TRUE(detect_doors(s.surface, s.places, 1.2, DoorConfig{}, &final_doors, nullptr, &error)) << error;
  ASSERT_EQ(final_doors.size(), 1u);
  EXPECT_LT((0.5 * (online.doors()[0].a + online.doors()[0].b) - 0.5 * (final_doors[0].a + final_doors[0].b)).norm(),
            0.1);
  EXPECT_NEAR(online.doors()[0].width_m(), final_doors[0].width_m(), 0.1);
  // The room finder reads the edges through it as closed.
  const Eigen::Vector3d left(3.75, 2.25, 1.0), right(4.25, 2.25, 1.0), wall_side(4.25, 0.75, 1.0);
  EXPECT_TRUE(online.doors().closes(left, right));
  EXPECT_FALSE(online.doors().closes(Eigen::Vector3d(3.75, 0.75, 1.0), wall_side));
  // The same window again: the door is found again, not added twice.
  r = pass(&online, s, robot);
  EXPECT_EQ(r.matched, 1u);
  EXPECT_EQ(r.added, 0u);
  ASSERT_EQ(online.doors().size(), 1u);
  // The door walled up: one pass that misses it keeps it (DoorConfig::online_misses_to_drop, 2), the second drops it.
  Scene closed = two_rooms(1.6, 2.5);
  closed.wall(4, 1.6, 4, 2.5);
  paint(closed, &online.wall_map());
  r = pass(&online, closed, robot);
  EXPECT_EQ(r.missed, 1u);
  EXPECT_EQ(r.removed, 0u);
  ASSERT_EQ(online.doors().size(), 1u);
  EXPECT_EQ(online.doors().misses(0), 1);
  EXPECT_TRUE(online.doors().closes(left, right)) << "kept through one missed pass";
  r = pass(&online, closed, robot);
  EXPECT_EQ(r.removed, 1u);
  EXPECT_EQ(online.doors().size(), 0u);
  // With online_misses_to_drop 1 each pass replaces its window's doors.
  DoorConfig at_once;
  at_once.online_misses_to_drop = 1;
  OnlineDoors replace;
  ASSERT_TRUE(replace.init(at_once, small_capacities(), 0, &error)) << error;
  paint(s, &replace.wall_map());
  ASSERT_TRUE(pass(&replace, s, robot).ran);
  ASSERT_EQ(replace.doors().size(), 1u);
  paint(closed, &replace.wall_map());
  EXPECT_EQ(pass(&replace, closed, robot).removed, 1u);
  EXPECT_EQ(replace.doors().size(), 0u);
}

PassResult pass_with_graph(OnlineDoors* online, const scene_graph::SceneGraph& graph, const Eigen::Vector3d& robot) {
  online->begin_pass(robot);
  online->add_places(graph);
  online->rasterize();
  return online->detect();
}

TEST(OnlineDoors, AFoundDoorThePlacesGoRoundIsNotKept) {
  const Scene s = two_rooms(1.6, 2.5);
  const Eigen::Vector3d robot(2.0, 2.0, 0.5);
  std::string error;
  // The places cross the wall only through the door: the door is kept, and the pass does not allocate.
  {
    OnlineDoors online;
    ASSERT_TRUE(online.init(DoorConfig{}, small_capacities(), 0, &error)) << error;
    paint(s, &online.wall_map());
    const auto graph = places_graph(s, 4.0, 1.6, 2.5);
    PassResult r;
    EXPECT_NO_ALLOCATIONS(r = pass_with_graph(&online, *graph, robot));
    ASSERT_TRUE(r.ran);
    EXPECT_EQ(r.bypassed, 0u);
    EXPECT_EQ(r.bypass_refused, 0u);
    EXPECT_EQ(online.doors().size(), 1u);
  }
  // Places that link through the wall beside the door go round it (2.5 m from y = 1.75 by y = 0.75): the found door
  // is not kept (the final stage's drop_bypassed_doors drops it too).
  {
    OnlineDoors online;
    ASSERT_TRUE(online.init(DoorConfig{}, small_capacities(), 0, &error)) << error;
    paint(s, &online.wall_map());
    const auto graph = places_graph(s, 4.0, 1.6, 2.5, true);
    const PassResult r = pass_with_graph(&online, *graph, robot);
    ASSERT_TRUE(r.ran);
    EXPECT_EQ(r.bypassed, 1u);
    EXPECT_EQ(r.found, 0u);
    EXPECT_EQ(online.doors().size(), 0u);
    std::vector<Door> final_doors;
    ASSERT_TRUE(detect_doors(s.surface, s.places, 1.2, DoorConfig{}, &final_doors, nullptr, &error)) << error;
    ASSERT_EQ(final_doors.size(), 1u);
    EXPECT_EQ(drop_bypassed_doors(&final_doors, DoorConfig{}, *graph), 1u);
    // The check off: kept.
    DoorConfig off;
    off.bypass_max_m = 0.0;
    OnlineDoors keep;
    ASSERT_TRUE(keep.init(off, small_capacities(), 0, &error)) << error;
    paint(s, &keep.wall_map());
    EXPECT_EQ(pass_with_graph(&keep, *graph, robot).bypassed, 0u);
    EXPECT_EQ(keep.doors().size(), 1u);
  }
  // A window graph too small for the place edges: the edges beyond it are refused and counted, and without them no
  // path goes round, so the door is kept (never dropped on a partial graph's say-so alone).
  {
    OnlineDoorCapacities tiny = small_capacities();
    tiny.place_edges = 8;
    OnlineDoors online;
    ASSERT_TRUE(online.init(DoorConfig{}, tiny, 0, &error)) << error;
    paint(s, &online.wall_map());
    const auto graph = places_graph(s, 4.0, 1.6, 2.5, true);
    const PassResult r = pass_with_graph(&online, *graph, robot);
    ASSERT_TRUE(r.ran);
    EXPECT_GT(r.bypass_refused, 0u);
    EXPECT_EQ(online.doors().size(), 1u);
  }
}

// add_places finds the window's places in the graph's grid of closed places and its open places (issue 37: not a
// scan of the places layer) and takes them as a scan of every place would: the same places in the node table's order
// (with more than the capacity, the first ones), whether the places are open or closed, and none of another storey
// or outside the window.
TEST(OnlineDoors, AddPlacesTakesWhatAScanOfEveryPlaceTakes) {
  namespace sg = scene_graph;
  const Scene s = two_rooms(1.6, 2.5);
  const Eigen::Vector3d robot(2.0, 2.0, 0.5);
  for (const std::size_t capacity : {std::size_t{512}, std::size_t{40}}) {
    OnlineDoorCapacities c = small_capacities();
    c.places = capacity;
    std::string error;
    OnlineDoors scan, open, closed;
    for (OnlineDoors* o : {&scan, &open, &closed}) {
      ASSERT_TRUE(o->init(DoorConfig{}, c, 0, &error)) << error;
      paint(s, &o->wall_map());
    }
    const PassResult expected = pass(&scan, s, robot);
    ASSERT_TRUE(expected.ran);
    auto graph = places_graph(s, 4.0, 1.6, 2.5);
    // Places of another storey and far away: never taken.
    for (std::size_t i = 0; i < s.places.size(); ++i) {
      sg::PlaceAttributes a;
      a.position_m = s.places[i] + Eigen::Vector3d(i % 2 == 0 ? 0.0 : 100.0, 0.0, i % 2 == 0 ? 3.0 : 0.0);
      ASSERT_EQ(graph->add_place(sg::make_node_id(sg::kPlacePrefix, 10000 + i), a), sg::Status::kOk);
    }
    const PassResult all_open = pass_with_graph(&open, *graph, robot);
    // Every other place (and every far one) closed: inactive, in a room.
    const sg::NodeId room = sg::make_node_id(sg::kRoomPrefix, 0);
    ASSERT_EQ(graph->add_room(room, sg::RoomAttributes{}), sg::Status::kOk);
    std::size_t in_room = 0;
    graph->for_each_node_of(sg::NodeKind::kPlace, [&](const sg::NodeRecord& n) {
      if (sg::node_index(n.id) % 2 == 0 && graph->add_edge(room, n.id) == sg::Status::kOk) ++in_room;
    });
    graph->for_each_open_place([](const sg::NodeRecord&, const sg::PlaceAttributes&) {});
    ASSERT_EQ(graph->num_closed_places(), in_room);
    const PassResult some_closed = pass_with_graph(&closed, *graph, robot);
    for (const PassResult* r : {&all_open, &some_closed}) {
      ASSERT_TRUE(r->ran);
      EXPECT_EQ(r->places, expected.places) << "capacity " << capacity;
      EXPECT_EQ(r->places_dropped, expected.places_dropped) << "capacity " << capacity;
      EXPECT_EQ(r->found, expected.found) << "capacity " << capacity;
      EXPECT_EQ(r->stats.candidates, expected.stats.candidates) << "capacity " << capacity;
      EXPECT_EQ(r->stats.free_cells, expected.stats.free_cells) << "capacity " << capacity;
    }
    EXPECT_EQ(expected.places + expected.places_dropped, s.places.size());
    if (capacity < s.places.size()) {
      EXPECT_GT(expected.places_dropped, 0u);
    }
    EXPECT_EQ(closed.doors().size(), scan.doors().size());
  }
}

TEST(DoorSet, AWindowUpdateMatchesNearestFirstCountsMissesAndLeavesDoorsOutOfScope) {
  DoorConfig config;
  config.cut_extension_m = 0.0;  // edges close exactly on the door lines
  memory::Arena arena;
  std::string error;
  const memory::ArenaPlan plan = DoorSet::plan(4);
  ASSERT_TRUE(arena.create("door_set_window", plan, plan.total_bytes(), &error)) << error;
  DoorSet set;
  ASSERT_TRUE(set.carve(arena, 4, config));
  const auto door = [](double x, double y) {
    Door d;
    d.a = Eigen::Vector2d(x - 0.4, y);
    d.b = Eigen::Vector2d(x + 0.4, y);
    d.z_m = 1.2;
    return d;
  };
  ASSERT_TRUE(set.add(door(0.0, 0.0)));
  ASSERT_TRUE(set.add(door(1.0, 0.0)));
  ASSERT_TRUE(set.add(door(20.0, 0.0)));  // out of scope
  const auto in_scope = [](const Door& d) { return d.a.x() < 10.0; };
  // Found: one 0.45 m from the second door and 1.45 m from the first, both within the match distance (it goes to
  // the nearer), and one new.
  const Door found[] = {door(1.45, 0.0), door(5.0, 5.0)};
  DoorSet::WindowUpdate u;
  EXPECT_NO_ALLOCATIONS(u = set.update_window(found, 2, in_scope, 2.0, 2));
  EXPECT_EQ(u.matched, 1u);
  EXPECT_EQ(u.added, 1u);
  EXPECT_EQ(u.missed, 1u);  // the door at 0
  EXPECT_EQ(u.removed, 0u);
  ASSERT_EQ(set.size(), 4u);
  EXPECT_EQ(set.misses(0), 1);
  EXPECT_NEAR(set[1].a.x(), 1.05, 1e-12) << "the found line replaces the kept one";
  EXPECT_EQ(set.misses(1), 0);
  // The index follows the moved door: an edge through its new line is closed, one through its old line only is not.
  EXPECT_TRUE(set.closes(Eigen::Vector3d(1.7, -0.3, 1.0), Eigen::Vector3d(1.7, 0.3, 1.0)));
  EXPECT_FALSE(set.closes(Eigen::Vector3d(0.8, -0.3, 1.0), Eigen::Vector3d(0.8, 0.3, 1.0)));
  // An empty pass: every door in scope misses; the one at 0 reaches 2 and goes, the door at 20 stays untouched.
  u = set.update_window(found, 0, in_scope, 2.0, 2);
  EXPECT_EQ(u.removed, 1u);
  EXPECT_EQ(u.missed, 2u);
  ASSERT_EQ(set.size(), 3u);
  bool far_kept = false;
  for (std::size_t i = 0; i < set.size(); ++i)
    if (set[i].a.x() > 10.0) far_kept = set.misses(i) == 0;
  EXPECT_TRUE(far_kept);
  // Full: a new door is refused and counted, the doors already kept stay.
  const Door more[] = {door(7.0, 7.0), door(8.0, 8.0)};
  u = set.update_window(more, 2, in_scope, 0.5, 5);
  EXPECT_EQ(u.added, 1u);
  EXPECT_EQ(u.refused, 1u);
  EXPECT_EQ(set.size(), 4u);
  EXPECT_EQ(set.stats().failed, 1u);
}

TEST(OnlineDoors, APassReplacesOnlyItsInteriorsDoorsOnItsStorey) {
  OnlineDoors online;
  std::string error;
  ASSERT_TRUE(online.init(DoorConfig{}, small_capacities(), 0, &error)) << error;
  const Scene s = two_rooms(1.6, 2.5);
  paint(s, &online.wall_map());
  ASSERT_TRUE(pass(&online, s, Eigen::Vector3d(2.0, 2.0, 0.5)).ran);
  ASSERT_EQ(online.doors().size(), 1u);
  // Far away (the door outside the window) and a storey up (over the door, beyond half a storey separation): the
  // door stays.
  EXPECT_TRUE(pass(&online, s, Eigen::Vector3d(30.0, 2.0, 0.5)).ran);
  EXPECT_EQ(online.doors().size(), 1u);
  const PassResult climbing = pass(&online, s, Eigen::Vector3d(2.0, 2.0, 1.7));
  EXPECT_TRUE(climbing.climbing) << "1.2 m up since the previous pass: on the stairs";
  EXPECT_FALSE(climbing.ran);
  EXPECT_EQ(online.doors().size(), 1u);
  const PassResult landing = pass(&online, s, Eigen::Vector3d(2.0, 2.0, 3.5));
  EXPECT_TRUE(landing.climbing);
  const PassResult up = pass(&online, s, Eigen::Vector3d(2.0, 2.0, 3.55));
  EXPECT_FALSE(up.climbing) << "within storey_bin_m of the previous pass";
  EXPECT_TRUE(up.ran);
  EXPECT_EQ(up.removed, 0u);
  EXPECT_EQ(online.doors().size(), 1u);
  ASSERT_TRUE(pass(&online, s, Eigen::Vector3d(2.0, 2.0, 0.5)).climbing);  // back down: the next pass runs
  // A window whose interior does not reach the door (it lies within the mapped radius of the edge): kept, not
  // re-found.
  const PassResult edge = pass(&online, s, Eigen::Vector3d(4.0 + 8.0 - 1.0, 2.0, 0.5));
  EXPECT_EQ(edge.removed, 0u);
  EXPECT_EQ(online.doors().size(), 1u);
  online.clear_doors();
  EXPECT_EQ(online.doors().size(), 0u);
}

TEST(OnlineDoors, BadConfigAndCapacitiesAreClearErrors) {
  OnlineDoors online;
  std::string error;
  OnlineDoorCapacities c = small_capacities();
  c.window_side = 4;
  EXPECT_FALSE(online.init(DoorConfig{}, c, 0, &error));
  EXPECT_NE(error.find("window_side"), std::string::npos) << error;
  DoorConfig tall;
  tall.slice_half_band_m = 1.0;  // 40 cells: more than a word of bins
  EXPECT_FALSE(online.init(tall, small_capacities(), 0, &error));
  EXPECT_NE(error.find("band"), std::string::npos) << error;
  EXPECT_FALSE(online.init(DoorConfig{}, small_capacities(), 1024, &error)) << "the budget is too small";
  EXPECT_NE(error.find("budget"), std::string::npos) << error;
  EXPECT_FALSE(online.initialized());
  // Not initialised: a pass does nothing.
  online.begin_pass(Eigen::Vector3d::Zero());
  EXPECT_FALSE(online.detect().ran);
  // NaN robot position: no pass.
  ASSERT_TRUE(online.init(DoorConfig{}, small_capacities(), 0, &error)) << error;
  online.begin_pass(Eigen::Vector3d(std::nan(""), 0.0, 0.0));
  EXPECT_FALSE(online.detect().ran);
}

}  // namespace
}  // namespace qsg::rooms
