// RoomFinder's window updates (Config::window_updates): an update during the run reads the active places and the
// rooms holding them and leaves the other rooms as they are, with their edges, until the robot comes back; the
// whole update after it finds what a fresh finder finds; no heap allocation.
#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <set>

#include "core/rooms/room_finder.h"
#include "tests/rooms/synthetic_places.h"
#include "tests/support/allocation_counter.h"

namespace qsg::rooms {
namespace {

namespace sg = scene_graph;
using testing::SyntheticPlaces;

sg::Capacities capacities() { return testing::small_graph_capacities(); }

std::unique_ptr<sg::SceneGraph> make_graph(const SyntheticPlaces& s) {
  auto g = std::make_unique<sg::SceneGraph>();
  std::string error;
  EXPECT_TRUE(g->init(capacities(), sg::SceneGraph::plan(capacities()).total_bytes(), &error)) << error;
  EXPECT_TRUE(s.write(g.get()));
  return g;
}

std::unique_ptr<RoomFinder> make_finder(bool window_updates) {
  auto f = std::make_unique<RoomFinder>();
  Config config;
  config.window_updates = window_updates;
  std::string error;
  EXPECT_TRUE(f->init(config, Capacities::from_scene_graph(capacities()), 0, &error)) << error;
  return f;
}

using testing::rooms_by_tag;

// Rooms as sets of places (ids aside), for comparing two partitions.
std::set<std::set<sg::NodeId>> partition(const sg::SceneGraph& g, const SyntheticPlaces& s) {
  std::map<sg::NodeId, std::set<sg::NodeId>> by_room;
  for (const auto& p : s.places)
    if (g.parent(p.id) != sg::kNoNode) by_room[g.parent(p.id)].insert(p.id);
  std::set<std::set<sg::NodeId>> out;
  for (auto& [room, places] : by_room) out.insert(places);
  return out;
}

TEST(RoomWindowTest, KeepsRoomsAwayFromTheRobotUntilItComesBack) {
  SyntheticPlaces s;
  testing::corridor_plan(4, 0.5).add_to(&s, 1.0, Eigen::Vector2d::Zero(), 1.25);
  auto g = make_graph(s);
  auto finder = make_finder(true);
  const UpdateResult first = finder->update(g.get(), 1, nullptr, nullptr, /*window=*/true);
  ASSERT_EQ(first.outcome, Outcome::kOk);
  ASSERT_EQ(first.rooms, 9u);  // 8 rooms and the corridor
  const auto before = rooms_by_tag(*g, s);
  for (const auto& [tag, rooms] : before) ASSERT_EQ(rooms.size(), 1u) << "tag " << tag;

  // The robot at the west end: the places east of x = 9 m left the window; rooms 5-8 (x > 9 m) hold none.
  const double cut_m = 9.0;
  for (const auto& p : s.places) g->place(p.id)->is_active = p.position_m.x() < cut_m;
  // A passage closed inside an east room (tag 7): a whole update would split that room, a window update does
  // not read it.
  int closed = 0;
  for (const auto& e : s.edges) {
    const auto &a = s.places[e.a], &b = s.places[e.b];
    if (a.room != 7 || b.room != 7) continue;
    if ((a.position_m.x() < 15.0) != (b.position_m.x() < 15.0)) {
      sg::EdgeAttributes info;
      info.weight = 0.0;
      info.weighted = true;
      ASSERT_TRUE(g->remove_edge(a.id, b.id));
      ASSERT_EQ(g->add_edge(a.id, b.id, info), sg::Status::kOk);
      ++closed;
    }
  }
  ASSERT_GT(closed, 0);

  UpdateResult r;
  EXPECT_NO_ALLOCATIONS(r = finder->update(g.get(), 2, nullptr, nullptr, /*window=*/true));
  EXPECT_EQ(r.outcome, Outcome::kOk);
  EXPECT_TRUE(r.window);
  EXPECT_LT(r.places, s.places.size()) << "the window update read every place";
  EXPECT_LT(r.rooms_open, 9u);
  EXPECT_GT(r.boundary_edges, 0u);
  EXPECT_EQ(r.rooms, 9u);
  const auto kept = rooms_by_tag(*g, s);
  EXPECT_EQ(kept, before) << "rooms changed: the kept ones must stay, the window's keep their ids";
  // Every room is the building's child, and the corridor still touches every room.
  const sg::NodeId building = finder->building_id();
  ASSERT_NE(building, sg::kNoNode);
  const sg::NodeId corridor = *before.at(0).begin();
  for (const auto& [tag, rooms] : before) {
    EXPECT_EQ(g->parent(*rooms.begin()), building) << "tag " << tag;
    if (tag != 0) {
      EXPECT_TRUE(g->has_edge(corridor, *rooms.begin())) << "corridor - room " << tag;
    }
  }
  // East rooms are inactive; the corridor (robot inside) active.
  EXPECT_FALSE(g->room(*before.at(7).begin())->is_active);
  EXPECT_TRUE(g->room(corridor)->is_active);

  // The robot comes back east: room 7 opens again and its closed passage splits it.
  for (const auto& p : s.places) g->place(p.id)->is_active = p.position_m.x() >= cut_m;
  r = finder->update(g.get(), 3, nullptr, nullptr, /*window=*/true);
  EXPECT_EQ(r.outcome, Outcome::kOk);
  EXPECT_EQ(rooms_by_tag(*g, s).at(7).size(), 2u) << "room 7 was not read again";

  // The whole update (the run's last) partitions as a fresh finder does on the same graph.
  const UpdateResult whole = finder->update(g.get(), 4);
  EXPECT_FALSE(whole.window);
  EXPECT_EQ(whole.places, s.places.size());
  const auto windowed = partition(*g, s);
  auto g2 = make_graph(s);
  for (const auto& e : s.edges) {  // the same closed passage
    const auto &a = s.places[e.a], &b = s.places[e.b];
    if (a.room == 7 && b.room == 7 && (a.position_m.x() < 15.0) != (b.position_m.x() < 15.0)) {
      sg::EdgeAttributes info;
      info.weight = 0.0;
      info.weighted = true;
      g2->remove_edge(a.id, b.id);
      g2->add_edge(a.id, b.id, info);
    }
  }
  for (const auto& p : s.places) g2->place(p.id)->is_active = g->place(p.id)->is_active;
  auto fresh = make_finder(false);
  ASSERT_EQ(fresh->update(g2.get(), 4).outcome, Outcome::kOk);
  EXPECT_EQ(windowed, partition(*g2, s));
}

// A corridor 36 m long is one room; with the robot at its west end a window update reads the corridor only within
// window_room_margin_m of the active places: its far part keeps its room (not read, edges untouched), the room's
// node still spans every place of it, and a passage closed in the far part changes nothing until the whole update,
// which partitions as a fresh finder does.
TEST(RoomWindowTest, ReadsOnlyTheNearPartOfALongRoom) {
  SyntheticPlaces s;
  testing::corridor_plan(8, 0.5).add_to(&s, 1.0, Eigen::Vector2d::Zero(), 1.25);
  auto g = make_graph(s);
  auto finder = make_finder(true);
  ASSERT_EQ(finder->config().window_room_margin_m, 5.0);
  ASSERT_EQ(finder->update(g.get(), 1, nullptr, nullptr, /*window=*/true).rooms, 17u);  // 16 rooms, the corridor
  const auto before = rooms_by_tag(*g, s);
  for (const auto& [tag, rooms] : before) ASSERT_EQ(rooms.size(), 1u) << "tag " << tag;
  const sg::NodeId corridor = *before.at(0).begin();

  // The robot at the west end: places west of x = 9 m active; the corridor's places east of 14 m are far.
  const double cut_m = 9.0, far_m = cut_m + 5.0 + 0.5;
  std::size_t far_corridor = 0;
  for (const auto& p : s.places) {
    g->place(p.id)->is_active = p.position_m.x() < cut_m;
    if (p.room == 0 && p.position_m.x() > far_m) ++far_corridor;
  }
  ASSERT_GT(far_corridor, 50u);
  // A passage closed across the corridor's far part: a whole update would cut it there.
  const auto close_far_passage = [&](sg::SceneGraph* graph) {
    int closed = 0;
    for (const auto& e : s.edges) {
      const auto &a = s.places[e.a], &b = s.places[e.b];
      if (a.room != 0 || b.room != 0 || (a.position_m.x() < 30.0) == (b.position_m.x() < 30.0)) continue;
      sg::EdgeAttributes info;
      info.weight = 0.0;
      info.weighted = true;
      graph->remove_edge(a.id, b.id);
      if (graph->add_edge(a.id, b.id, info) == sg::Status::kOk) ++closed;
    }
    return closed;
  };
  ASSERT_GT(close_far_passage(g.get()), 0);
  UpdateResult r;
  EXPECT_NO_ALLOCATIONS(r = finder->update(g.get(), 2, nullptr, nullptr, /*window=*/true));
  EXPECT_EQ(r.outcome, Outcome::kOk);
  EXPECT_EQ(r.rooms_partial, 1u);
  EXPECT_GE(r.places_kept, far_corridor);
  EXPECT_LE(r.places + r.places_kept, s.places.size());
  EXPECT_EQ(r.rooms, 17u);
  EXPECT_EQ(rooms_by_tag(*g, s), before) << "the corridor's far part left it, or a room changed";
  // The corridor's node spans all of it: centroid over every place of it, box over the far end too.
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double max_x = -1e9;
  std::size_t n = 0;
  for (const auto& p : s.places)
    if (g->parent(p.id) == corridor) {  // the corridor's places and the door places it took
      sum += p.position_m;
      max_x = std::max(max_x, p.position_m.x() + g->place(p.id)->distance_m);
      ++n;
    }
  const sg::RoomAttributes* c = g->room(corridor);
  ASSERT_NE(c, nullptr);
  EXPECT_LT((c->position_m - sum / static_cast<double>(n)).norm(), 1e-9);
  EXPECT_NEAR(c->bounding_box.max_m.x(), max_x, 1e-9);
  EXPECT_TRUE(c->is_active);

  // The robot walks to the east end: the corridor's west part is far now, its east part read again (the closed
  // passage cuts it), and the rooms in the west keep theirs.
  for (const auto& p : s.places) g->place(p.id)->is_active = p.position_m.x() > 27.0;
  r = finder->update(g.get(), 3, nullptr, nullptr, /*window=*/true);
  EXPECT_EQ(r.outcome, Outcome::kOk);
  EXPECT_GE(r.rooms_partial, 1u);
  EXPECT_EQ(rooms_by_tag(*g, s).at(0).size(), 2u) << "the corridor's east part was not read again";
  for (const auto& p : s.places) {
    if (p.room == 0 && p.position_m.x() < 10.0) {
      EXPECT_EQ(g->parent(p.id), corridor) << "a far place lost its room";
    }
  }

  // The whole update (the run's last) partitions as a fresh finder does on the same graph.
  const UpdateResult whole = finder->update(g.get(), 4);
  EXPECT_FALSE(whole.window);
  EXPECT_EQ(whole.rooms_partial, 0u);
  EXPECT_EQ(whole.places, s.places.size());
  auto g2 = make_graph(s);
  ASSERT_GT(close_far_passage(g2.get()), 0);
  for (const auto& p : s.places) g2->place(p.id)->is_active = g->place(p.id)->is_active;
  auto fresh = make_finder(false);
  ASSERT_EQ(fresh->update(g2.get(), 4).outcome, Outcome::kOk);
  EXPECT_EQ(partition(*g, s), partition(*g2, s));
}

TEST(RoomWindowTest, EmptyWindowKeepsEveryRoomAndWindowOffReadsEverything) {
  SyntheticPlaces s;
  testing::corridor_plan(2, 0.5).add_to(&s, 1.0, Eigen::Vector2d::Zero(), 1.25);
  auto g = make_graph(s);
  auto finder = make_finder(true);
  ASSERT_EQ(finder->update(g.get(), 1, nullptr, nullptr, true).rooms, 5u);
  const auto before = rooms_by_tag(*g, s);
  for (const auto& p : s.places) g->place(p.id)->is_active = false;  // the robot went elsewhere (no place active)
  const UpdateResult r = finder->update(g.get(), 2, nullptr, nullptr, true);
  EXPECT_EQ(r.outcome, Outcome::kOk);
  EXPECT_EQ(r.places, 0u);
  EXPECT_EQ(r.rooms, 5u);
  EXPECT_EQ(rooms_by_tag(*g, s), before);
  // With window_updates off, a window update is a whole one.
  auto off = make_finder(false);
  const UpdateResult w = off->update(g.get(), 3, nullptr, nullptr, true);
  EXPECT_FALSE(w.window);
  EXPECT_EQ(w.places, s.places.size());
}

// The window's choice visits the open places and the open rooms' places, not the building (issue 37): the same
// robot window in a building and in that building with three more copies of it far away gives the same places
// visited and read. A choice that scanned the places layer would visit four times as many in the second.
TEST(RoomWindowTest, ChoosesTheWindowWithoutVisitingTheBuilding) {
  const auto visited = [](int copies, std::size_t* places, UpdateResult* r) {
    SyntheticPlaces s;
    for (int c = 0; c < copies; ++c)
      testing::corridor_plan(4, 0.5).add_to(&s, 1.0, Eigen::Vector2d(200.0 * c, 0.0), 1.25);
    *places = s.places.size();
    auto g = make_graph(s);
    auto finder = make_finder(true);
    ASSERT_EQ(finder->update(g.get(), 1).outcome, Outcome::kOk);  // a whole update: every place gets its room
    for (const auto& p : s.places) g->place(p.id)->is_active = p.position_m.x() < 9.0;
    ASSERT_EQ(finder->update(g.get(), 2, nullptr, nullptr, /*window=*/true).outcome, Outcome::kOk);
    EXPECT_NO_ALLOCATIONS(*r = finder->update(g.get(), 3, nullptr, nullptr, /*window=*/true));
    ASSERT_EQ(r->outcome, Outcome::kOk);
  };
  std::size_t one = 0, four = 0;
  UpdateResult a, b;
  visited(1, &one, &a);
  visited(4, &four, &b);
  ASSERT_EQ(four, 4 * one);
  EXPECT_GT(a.places_visited, 0u);
  EXPECT_LT(a.places_visited, one) << "the window's choice visited every place";
  EXPECT_EQ(b.places_visited, a.places_visited) << "the window's choice grew with the building";
  EXPECT_EQ(b.places, a.places);
  EXPECT_EQ(b.rooms_open, a.rooms_open);
  EXPECT_EQ(b.rooms, 4 * a.rooms);
}

// A long room far from the robot costs nothing to keep (issue 37): the same robot window at the west end of a
// corridor building and of one whose corridor (and row of rooms) is 4x as long visits and reads the same places;
// the corridor's far part, 4x larger or more, comes from the graph's sums, and its node still spans all of it.
TEST(RoomWindowTest, AFarRoomFourTimesAsLongVisitsTheSame) {
  struct Run {
    UpdateResult r;
    std::size_t corridor_places = 0;
  };
  const auto run = [](int rooms_per_side, Run* out) {
    SyntheticPlaces s;
    testing::corridor_plan(rooms_per_side, 0.5).add_to(&s, 1.0, Eigen::Vector2d::Zero(), 1.25);
    auto g = make_graph(s);
    auto finder = make_finder(true);
    ASSERT_EQ(finder->update(g.get(), 1).outcome, Outcome::kOk);  // a whole update: every place gets its room
    const sg::NodeId corridor = *rooms_by_tag(*g, s).at(0).begin();
    for (const auto& p : s.places) g->place(p.id)->is_active = p.position_m.x() < 9.0;
    ASSERT_EQ(finder->update(g.get(), 2, nullptr, nullptr, /*window=*/true).outcome, Outcome::kOk);
    EXPECT_NO_ALLOCATIONS(out->r = finder->update(g.get(), 3, nullptr, nullptr, /*window=*/true));
    ASSERT_EQ(out->r.outcome, Outcome::kOk);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double max_x = -1e9;
    for (const auto& p : s.places)
      if (g->parent(p.id) == corridor) {
        sum += p.position_m;
        max_x = std::max(max_x, p.position_m.x() + g->place(p.id)->distance_m);
        ++out->corridor_places;
      }
    const sg::RoomAttributes* c = g->room(corridor);
    ASSERT_NE(c, nullptr);
    EXPECT_LT((c->position_m - sum / static_cast<double>(out->corridor_places)).norm(), 1e-9);
    EXPECT_NEAR(c->bounding_box.max_m.x(), max_x, 1e-9);
  };
  Run a, b;
  run(6, &a);
  run(24, &b);
  EXPECT_GT(b.corridor_places, 3 * a.corridor_places);
  EXPECT_EQ(a.r.rooms_partial, 1u);
  EXPECT_EQ(b.r.rooms_partial, 1u);
  EXPECT_GT(b.r.places_kept, 4 * a.r.places_kept) << "the corridor's far part did not grow";
  EXPECT_GT(a.r.places_visited, 0u);
  EXPECT_EQ(b.r.places_visited, a.r.places_visited) << "the window's choice grew with a far room";
  EXPECT_EQ(b.r.places, a.r.places);
  EXPECT_EQ(b.r.rooms_open, a.r.rooms_open);
}

}  // namespace
}  // namespace qsg::rooms
