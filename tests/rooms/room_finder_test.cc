// RoomFinder on synthetic places graphs with known rooms: doors, a corridor, two floors, small components, the
// extent split and the corridor merge, the Betti curve against a brute-force reference, the plateau rule, the flood
// fill's order, the building node, stable ids across updates, bad input and full stores, and no heap allocation per
// update.
#include "core/rooms/room_finder.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <vector>

#include "core/doors/door_detector.h"
#include "core/doors/wall_sight.h"
#include "tests/rooms/synthetic_places.h"
#include "tests/support/allocation_counter.h"

namespace qsg::rooms {
namespace {

namespace sg = scene_graph;
using testing::GridPlan;
using testing::SyntheticPlaces;

sg::Capacities small_graph_capacities() { return testing::small_graph_capacities(); }

std::unique_ptr<sg::SceneGraph> make_graph(const sg::Capacities& c = small_graph_capacities()) {
  auto g = std::make_unique<sg::SceneGraph>();
  std::string error;
  EXPECT_TRUE(g->init(c, sg::SceneGraph::plan(c).total_bytes(), &error)) << error;
  return g;
}

std::unique_ptr<RoomFinder> make_finder(const Config& config = Config{},
                                        const Capacities& caps = Capacities::from_scene_graph(small_graph_capacities())) {
  auto f = std::make_unique<RoomFinder>();
  std::string error;
  EXPECT_TRUE(f->init(config, caps, 0, &error)) << error;
  return f;
}

using testing::rooms_by_tag;

// Every tag maps to exactly one room, and different tags to different rooms.
void expect_one_room_per_tag(const sg::SceneGraph& g, const SyntheticPlaces& s) {
  std::set<sg::NodeId> used;
  for (const auto& [tag, rooms] : rooms_by_tag(g, s)) {
    ASSERT_EQ(rooms.size(), 1u) << "places of ground-truth room " << tag << " were split";
    const sg::NodeId room = *rooms.begin();
    ASSERT_NE(room, sg::kNoNode) << "room " << tag << " has unassigned places";
    EXPECT_EQ(sg::node_prefix(room), sg::kRoomPrefix);
    EXPECT_TRUE(used.insert(room).second) << "two ground-truth rooms merged into " << sg::node_label(room);
  }
}

// Each tag's places are mostly (at least min_share) in one room, a different room per tag.
void expect_majority_room_per_tag(const sg::SceneGraph& g, const SyntheticPlaces& s, double min_share) {
  std::map<int, std::map<sg::NodeId, int>> counts;
  for (const auto& p : s.places)
    if (p.room >= 0) ++counts[p.room][g.parent(p.id)];
  std::set<sg::NodeId> used;
  for (const auto& [tag, rooms] : counts) {
    int total = 0, best = 0;
    sg::NodeId best_room = sg::kNoNode;
    for (const auto& [room, n] : rooms) {
      total += n;
      if (n > best) best = n, best_room = room;
    }
    EXPECT_NE(best_room, sg::kNoNode) << "tag " << tag;
    EXPECT_GE(best, min_share * total) << "tag " << tag << ": " << best << " of " << total << " places in one room";
    EXPECT_TRUE(used.insert(best_room).second) << "two tags share room " << sg::node_label(best_room);
  }
}

TEST(RoomFinderTest, TwoRoomsJoinedByANarrowDoorAreTwoRooms) {
  SyntheticPlaces s;
  testing::two_rooms_plan().add_to(&s, 1.0);
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  auto finder = make_finder();
  const UpdateResult r = finder->update(g.get());
  ASSERT_EQ(r.outcome, Outcome::kOk) << to_string(r.outcome);
  EXPECT_EQ(r.rooms, 2u);
  EXPECT_EQ(g->num_nodes(sg::NodeKind::kRoom), 2u);
  EXPECT_EQ(r.places, s.places.size());
  EXPECT_EQ(r.places_assigned, s.places.size()) << "the flood fill reaches every place";
  EXPECT_EQ(r.places_unassigned, 0u);
  EXPECT_GE(r.dilation_m, 0.5 - 1e-9);
  EXPECT_LE(r.dilation_m, 1.2 + 1e-9);
  expect_one_room_per_tag(*g, s);
  // The rooms touch through the door: one room-room edge.
  EXPECT_EQ(r.room_edges, 1u);
  EXPECT_TRUE(g->has_edge(finder->room_id(0), finder->room_id(1)));
  // Each room sits at the centroid of its places, with its places as children.
  for (std::size_t k = 0; k < finder->num_rooms(); ++k) {
    const sg::NodeId room = finder->room_id(k);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    std::size_t n = 0;
    g->for_each_child(room, [&](sg::NodeId child) {
      ASSERT_EQ(sg::node_prefix(child), sg::kPlacePrefix);
      sum += g->place(child)->position_m;
      ++n;
    });
    ASSERT_GT(n, 0u);
    EXPECT_TRUE(g->room(room)->position_m.isApprox(sum / static_cast<double>(n), 1e-9));
    EXPECT_EQ(g->node(room)->num_children, n);
  }
}

TEST(RoomFinderTest, CorridorWithRoomsOffIt) {
  SyntheticPlaces s;
  testing::corridor_plan(3).add_to(&s, 0.5);
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  auto finder = make_finder();
  const UpdateResult r = finder->update(g.get());
  ASSERT_EQ(r.outcome, Outcome::kOk);
  EXPECT_EQ(r.rooms, 7u) << "six rooms and the corridor";
  expect_one_room_per_tag(*g, s);
  // Every side room touches the corridor and nothing else: 6 room-room edges, all to the corridor's room.
  const sg::NodeId corridor = *rooms_by_tag(*g, s)[0].begin();
  EXPECT_EQ(r.room_edges, 6u);
  std::size_t corridor_room_edges = 0;
  g->for_each_neighbor(corridor, [&](sg::NodeId other, const sg::EdgeRecord&) {
    corridor_room_edges += sg::node_prefix(other) == sg::kRoomPrefix ? 1 : 0;
  });
  EXPECT_EQ(corridor_room_edges, 6u);
}

// Two floors with the same footprint 3 m apart, joined by a narrow staircase (a chain of low-clearance places):
// a 2D slice would merge the floors; the 3D graph keeps four rooms.
TEST(RoomFinderTest, TwoFloorsJoinedByAStaircase) {
  SyntheticPlaces s;
  const GridPlan plan = testing::two_rooms_plan();
  plan.add_to(&s, 1.0);
  const std::size_t upstairs = s.places.size();
  plan.add_to(&s, 4.0);
  for (std::size_t i = upstairs; i < s.places.size(); ++i)
    if (s.places[i].room >= 0) s.places[i].room += 2;
  // Stairs from the west room's north-west corner below to the one above: 0.9 m wide, clearance 0.4 m.
  const auto nearest = [&](const Eigen::Vector3d& p) {
    std::size_t best = 0;
    for (std::size_t i = 0; i < s.places.size(); ++i)
      if ((s.places[i].position_m - p).norm() < (s.places[best].position_m - p).norm()) best = i;
    return best;
  };
  std::size_t prev = nearest({0.4, 4.1, 1.0});
  const std::size_t top = nearest({0.4, 4.1, 4.0});
  for (int k = 1; k < 12; ++k) {
    const std::size_t step = s.add_place({0.4 + 0.3 * k, 4.1, 1.0 + 0.25 * k}, 0.4);
    s.add_edge(prev, step, 0.4);
    prev = step;
  }
  s.add_edge(prev, top, 0.4);
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  auto finder = make_finder();
  const UpdateResult r = finder->update(g.get());
  ASSERT_EQ(r.outcome, Outcome::kOk);
  EXPECT_EQ(r.rooms, 4u);
  expect_one_room_per_tag(*g, s);
  std::size_t below = 0, above = 0;
  for (std::size_t k = 0; k < finder->num_rooms(); ++k) {
    const double z = g->room(finder->room_id(k))->position_m.z();
    below += z < 1.5 ? 1 : 0;
    above += z > 3.5 ? 1 : 0;
  }
  EXPECT_EQ(below, 2u);
  EXPECT_EQ(above, 2u);
  EXPECT_EQ(r.places_assigned, s.places.size()) << "the stair places are flood-filled into a room";
}

TEST(RoomFinderTest, ComponentsBelowTheMinimumSizeAreIgnored) {
  SyntheticPlaces s;
  testing::two_rooms_plan().add_to(&s, 1.0);
  // A detached chain of 10 high-clearance places (a fragment seen through a window, say).
  std::size_t prev = s.add_place({20.0, 20.0, 1.0}, 1.0);
  for (int k = 1; k < 10; ++k) {
    const std::size_t next = s.add_place({20.0 + 0.5 * k, 20.0, 1.0}, 1.0);
    s.add_edge(prev, next, 1.0);
    prev = next;
  }
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  auto finder = make_finder(Config::paper());  // 15 places
  const UpdateResult r = finder->update(g.get());
  ASSERT_EQ(r.outcome, Outcome::kOk);
  EXPECT_EQ(r.rooms, 2u);
  EXPECT_EQ(r.places_unassigned, 10u) << "a component without a seed gets no room";
  for (std::size_t i = 0; i < finder->curve_size(); ++i) EXPECT_LE(finder->betti_at(i), 2u) << "at sample " << i;
  // With a minimum of 10 it counts, and becomes a third room.
  Config c = Config::paper();
  c.min_component_size = 10;
  auto g2 = make_graph();
  ASSERT_TRUE(s.write(g2.get()));
  EXPECT_EQ(make_finder(c)->update(g2.get()).rooms, 3u);
}

// The persistence seeding alone (these plans' clearances are 2D distances, not capped by a ceiling; the extent
// split has its own tests below).
Config persistence_config() {
  Config c;
  c.seeding = Seeding::kPersistence;
  c.split_by_extent = false;
  return c;
}

// A 10 m x 6 m hall and a 2.25 m x 2.25 m office off it through a 0.75 m door. The hall keeps clearance far above
// d+, the office peaks at 1 m and holds 15+ places only below ~0.63 m, so the Betti curve is 1 over most of
// [d-, d+] and the paper's single plateau dilation sees one room; the office's own persistence (peak minus d-,
// its door being below d-) makes it a room of its own.
GridPlan hall_and_office_plan() {
  GridPlan plan(52, 26, testing::kCellM);
  plan.carve(1, 1, 41, 25, 0);   // hall
  plan.carve(42, 9, 51, 18, 1);  // office
  plan.carve(41, 12, 42, 15, -1);
  return plan;
}

TEST(RoomFinderTest, PersistenceSeedsASmallRoomThePlateauMisses) {
  SyntheticPlaces s;
  hall_and_office_plan().add_to(&s, 1.0);
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  const UpdateResult plateau = make_finder(Config::paper())->update(g.get());
  ASSERT_EQ(plateau.outcome, Outcome::kOk);
  EXPECT_EQ(plateau.rooms, 1u) << "the paper's global dilation merges the office into the hall";

  auto g2 = make_graph();
  ASSERT_TRUE(s.write(g2.get()));
  auto finder = make_finder(persistence_config());
  const UpdateResult r = finder->update(g2.get());
  ASSERT_EQ(r.outcome, Outcome::kOk) << to_string(r.outcome);
  EXPECT_EQ(r.rooms, 2u);
  EXPECT_EQ(r.seeds, 2u);
  EXPECT_EQ(r.places_assigned, s.places.size());
  expect_one_room_per_tag(*g2, s);
}

// Two 6 m x 6 m halls side by side: joined through a 2.5 m opening (a pinch: clearance ~1.1 m, persistence
// ~0.1 m) they are one room; through a 1 m doorway (clearance ~0.4 m) they are two.
GridPlan two_halls_plan(int opening_cells) {
  GridPlan plan(51, 26, testing::kCellM);
  plan.carve(1, 1, 25, 25, 0);
  plan.carve(26, 1, 50, 25, opening_cells >= 8 ? 0 : 1);
  plan.carve(25, 13 - opening_cells / 2, 26, 13 - opening_cells / 2 + opening_cells, -1);
  return plan;
}

TEST(RoomFinderTest, PersistenceSplitsAtDoorsNotAtPinches) {
  for (const int opening : {10, 4}) {
    SCOPED_TRACE(::testing::Message() << "opening of " << opening << " cells");
    SyntheticPlaces s;
    two_halls_plan(opening).add_to(&s, 1.0);
    auto g = make_graph();
    ASSERT_TRUE(s.write(g.get()));
    const UpdateResult r = make_finder(persistence_config())->update(g.get());
    ASSERT_EQ(r.outcome, Outcome::kOk);
    EXPECT_EQ(r.rooms, opening >= 8 ? 1u : 2u);
    expect_one_room_per_tag(*g, s);
  }
  // With no persistence required, even the pinch splits the halls.
  Config c = persistence_config();
  c.min_persistence_m = 0.0;
  SyntheticPlaces s;
  two_halls_plan(10).add_to(&s, 1.0);
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  EXPECT_EQ(make_finder(c)->update(g.get()).rooms, 2u);
}

TEST(RoomFinderTest, PersistenceKeepsRoomsJoinedWiderThanTheDoorLimitTogether) {
  SyntheticPlaces s;
  two_halls_plan(6).add_to(&s, 1.0);  // a 1.5 m opening: clearance ~0.6 m, persistence ~0.6 m
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  EXPECT_EQ(make_finder(persistence_config())->update(g.get()).rooms, 2u);
  Config c = persistence_config();
  c.max_door_clearance_m = 0.5;
  auto g2 = make_graph();
  ASSERT_TRUE(s.write(g2.get()));
  EXPECT_EQ(make_finder(c)->update(g2.get()).rooms, 1u);
  c.max_door_clearance_m = -1.0;
  std::string error;
  EXPECT_FALSE(RoomFinder().init(c, Capacities::from_scene_graph(small_graph_capacities()), 0, &error));
  EXPECT_NE(error.find("max_door_clearance_m"), std::string::npos) << error;
}

TEST(RoomFinderTest, PersistenceHandlesTheCorridorAndFloorsLikeThePlateau) {
  SyntheticPlaces s;
  testing::corridor_plan(3).add_to(&s, 0.5);
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  const UpdateResult r = make_finder(persistence_config())->update(g.get());
  ASSERT_EQ(r.outcome, Outcome::kOk);
  EXPECT_EQ(r.rooms, 7u) << "six rooms and the corridor";
  expect_one_room_per_tag(*g, s);
}

// Two 6.25 m halls (tags 0 and 1) joined by an opening 2.5 m wide (tag -1), every clearance capped at 1.25 m as a
// 2.5 m storey caps a real place's: the filtration sees no constriction between the halls.
GridPlan wide_opening_plan() {
  GridPlan plan(51, 26, testing::kCellM);
  plan.carve(1, 1, 25, 25, 0);
  plan.carve(26, 1, 50, 25, 1);
  plan.carve(25, 8, 26, 18, -1);
  return plan;
}
constexpr double kStoreyCapM = 1.25;

TEST(RoomFinderTest, ExtentSplitSeparatesHallsJoinedByAWideOpening) {
  SyntheticPlaces s;
  wide_opening_plan().add_to(&s, 1.0, Eigen::Vector2d::Zero(), kStoreyCapM);
  Config off;
  off.split_by_extent = false;
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  EXPECT_EQ(make_finder(off)->update(g.get()).rooms, 1u) << "capped clearance: one room without the split";

  auto g2 = make_graph();
  ASSERT_TRUE(s.write(g2.get()));
  const UpdateResult r = make_finder()->update(g2.get());
  ASSERT_EQ(r.outcome, Outcome::kOk);
  EXPECT_EQ(r.rooms, 2u);
  EXPECT_EQ(r.rooms_split, 1u);
  EXPECT_EQ(r.split_rooms_added, 1u);
  // The cut follows the opening up to its edge: a place or two beside it may go to the other hall.
  expect_majority_room_per_tag(*g2, s, 0.99);
  for (const auto& p : s.places) EXPECT_NE(g2->parent(p.id), sg::kNoNode) << "every place keeps a room";
}

TEST(RoomFinderTest, ExtentSplitKeepsAUniformCorridorWhole) {
  // 3 m x 20 m: the capped clearance and the extension are the same along it.
  GridPlan plan(82, 14, testing::kCellM);
  plan.carve(1, 1, 81, 13, 0);
  SyntheticPlaces s;
  plan.add_to(&s, 1.0, Eigen::Vector2d::Zero(), kStoreyCapM);
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  const UpdateResult r = make_finder()->update(g.get());
  EXPECT_EQ(r.rooms, 1u);
  EXPECT_EQ(r.rooms_split, 0u);
}

TEST(RoomFinderTest, ExtentSplitKeepsRoomsApartAndCountsAFullRoomStore) {
  // The halls and the corridor-with-rooms plan side by side (not connected): the corridor's rooms stay as they are.
  SyntheticPlaces s;
  wide_opening_plan().add_to(&s, 1.0, Eigen::Vector2d::Zero(), kStoreyCapM);
  const std::size_t first_corridor = s.places.size();
  testing::corridor_plan(2).add_to(&s, 1.0, Eigen::Vector2d(0.0, 20.0), kStoreyCapM);
  for (std::size_t i = first_corridor; i < s.places.size(); ++i)
    if (s.places[i].room >= 0) s.places[i].room += 10;
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  const UpdateResult r = make_finder()->update(g.get());
  ASSERT_EQ(r.outcome, Outcome::kOk);
  EXPECT_EQ(r.rooms, 2u + 5u) << "two halls, a corridor and four rooms";
  expect_majority_room_per_tag(*g, s, 0.99);
  // The corridor's rooms are exactly those of the seeding (the split never moves a place between rooms).
  std::map<int, std::set<sg::NodeId>> by_tag = rooms_by_tag(*g, s);
  for (int tag = 10; tag <= 14; ++tag) EXPECT_EQ(by_tag[tag].size(), 1u) << "tag " << tag;

  // One room slot: the merged halls cannot be split; the refused seed is counted, no place loses its room.
  Capacities one = Capacities::from_scene_graph(small_graph_capacities());
  one.rooms = 1;
  SyntheticPlaces halls;
  wide_opening_plan().add_to(&halls, 1.0, Eigen::Vector2d::Zero(), kStoreyCapM);
  auto g2 = make_graph();
  ASSERT_TRUE(halls.write(g2.get()));
  auto finder = make_finder(Config{}, one);
  const UpdateResult full = finder->update(g2.get());
  EXPECT_EQ(full.rooms, 1u);
  EXPECT_EQ(full.split_rooms_added, 0u);
  EXPECT_GE(full.seeds_dropped, 1u);
  EXPECT_GE(finder->counters().seeds_dropped, 1u);
  for (const auto& p : halls.places) EXPECT_NE(g2->parent(p.id), sg::kNoNode);
}

TEST(RoomFinderTest, ExtentSplitToleratesNonFiniteInput) {
  // A place at a NaN position and one of infinite clearance, joined to the halls: the halls still split, and
  // every place (the bad ones too) keeps a room.
  SyntheticPlaces s;
  wide_opening_plan().add_to(&s, 1.0, Eigen::Vector2d::Zero(), kStoreyCapM);
  const double nan = std::nan("");
  const std::size_t at_nan = s.add_place({nan, nan, nan}, 1.2, -1);
  const std::size_t unbounded = s.add_place({3.0, 3.0, 1.0}, HUGE_VAL, -1);
  s.add_edge(0, at_nan, 0.5);
  s.add_edge(at_nan, unbounded, 1.0);
  s.add_edge(unbounded, s.places.size() / 2, 1.0);
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  const UpdateResult r = make_finder()->update(g.get());
  ASSERT_EQ(r.outcome, Outcome::kOk);
  EXPECT_EQ(r.rooms_split, 1u);
  expect_majority_room_per_tag(*g, s, 0.99);
  for (const auto& p : s.places) EXPECT_NE(g->parent(p.id), sg::kNoNode);
}

TEST(RoomFinderTest, ExtentSplitSettingsAreChecked) {
  const auto refused = [](Config c, const char* field) {
    std::string error;
    EXPECT_FALSE(RoomFinder().init(c, Capacities::from_scene_graph(small_graph_capacities()), 0, &error)) << field;
    EXPECT_NE(error.find(field), std::string::npos) << error;
  };
  Config c;
  c.extent_saturation_m = -0.1;
  refused(c, "extent_saturation_m");
  c = Config{};
  c.split_min_extent_m = std::nan("");
  refused(c, "split_min_extent_m");
  c = Config{};
  c.split_max_extent_m = c.split_min_extent_m - 0.1;
  refused(c, "split_max_extent_m");
  c = Config{};
  c.split_min_persistence_m = -1.0;
  refused(c, "split_min_persistence_m");
  c = Config{};
  c.split_min_component_size = 0;
  refused(c, "split_min_component_size");
}

TEST(RoomFinderTest, CorridorPiecesJoinButTheRoomsOffThemStay) {
  SyntheticPlaces s;
  testing::pinched_corridor_plan(4).add_to(&s, 1.0, Eigen::Vector2d::Zero(), kStoreyCapM);
  // One update of a fresh finder with `config` over the scene in a fresh graph.
  const auto run = [&s](const Config& config, std::unique_ptr<sg::SceneGraph>* graph) {
    *graph = make_graph();
    EXPECT_TRUE(s.write(graph->get()));
    const UpdateResult r = make_finder(config)->update(graph->get());
    EXPECT_EQ(r.outcome, Outcome::kOk);
    return r;
  };
  Config off;
  off.merge_corridors = false;
  std::unique_ptr<sg::SceneGraph> g;
  const UpdateResult cut = run(off, &g);
  EXPECT_EQ(cut.corridor_merges, 0u);
  EXPECT_EQ(cut.rooms, 10u);
  const std::set<sg::NodeId> pieces = rooms_by_tag(*g, s)[0];
  ASSERT_EQ(pieces.size(), 2u) << "the scene must cut the corridor at its pinch";
  // The open place edges between the two pieces (a one-layer grid has fewer than a real graph's up to three layers
  // of places, so the default of 20 is not what this scene is about).
  std::uint32_t crossing = 0;
  for (const auto& e : s.edges) {
    const sg::NodeId a = g->parent(s.places[e.a].id), b = g->parent(s.places[e.b].id);
    crossing += a != b && pieces.count(a) != 0 && pieces.count(b) != 0 ? 1 : 0;
  }
  ASSERT_GE(crossing, 6u) << "at least the pinch's width in edges";

  Config on;
  on.corridor_min_open_edges = crossing;
  std::unique_ptr<sg::SceneGraph> g2;
  const UpdateResult joined = run(on, &g2);
  EXPECT_EQ(joined.corridor_merges, 1u);
  EXPECT_EQ(joined.rooms, 9u) << "the corridor and its eight rooms";
  expect_one_room_per_tag(*g2, s);
  EXPECT_EQ(joined.room_edges, 8u) << "each room touches the corridor only";

  // Each piece touches four rooms and the other piece: asking for six neighbours leaves the cut as it was, and so
  // does asking for one open edge more than cross between the pieces.
  Config picky = on;
  picky.corridor_min_neighbours = 6;
  Config narrow = on;
  narrow.corridor_min_open_edges = crossing + 1;
  for (const Config& c : {picky, narrow}) {
    SCOPED_TRACE(c.corridor_min_neighbours);
    std::unique_ptr<sg::SceneGraph> g3;
    const UpdateResult r = run(c, &g3);
    EXPECT_EQ(r.corridor_merges, 0u);
    EXPECT_EQ(r.rooms, 10u);
  }
}

TEST(RoomFinderTest, CorridorMergeSettingsAreChecked) {
  Config c;
  c.corridor_min_neighbours = 1;
  std::string error;
  EXPECT_FALSE(RoomFinder().init(c, Capacities::from_scene_graph(small_graph_capacities()), 0, &error));
  EXPECT_NE(error.find("corridor_min_neighbours"), std::string::npos) << error;
  for (const std::uint32_t edges : {0u, 65536u}) {  // open-edge counts saturate at 65535
    c = Config{};
    c.corridor_min_open_edges = edges;
    EXPECT_FALSE(RoomFinder().init(c, Capacities::from_scene_graph(small_graph_capacities()), 0, &error)) << edges;
    EXPECT_NE(error.find("corridor_min_open_edges"), std::string::npos) << error;
  }
  // Off, the rules that need the merge on are not checked; the declared ranges hold whatever the switch.
  c = Config{};
  c.merge_corridors = false;
  c.corridor_min_neighbours = 1;
  c.corridor_min_open_edges = 0;
  EXPECT_TRUE(RoomFinder().init(c, Capacities::from_scene_graph(small_graph_capacities()), 0, &error)) << error;
  c.corridor_min_open_edges = 65536;
  EXPECT_FALSE(RoomFinder().init(c, Capacities::from_scene_graph(small_graph_capacities()), 0, &error));
  EXPECT_NE(error.find("rooms.corridor_min_open_edges must be in [0, 65535]"), std::string::npos) << error;
}

// Brute force: for every sampled dilation, the components (BFS) of the places and edges that survive it.
std::vector<std::uint32_t> brute_force_curve(const SyntheticPlaces& s, const Config& c) {
  std::vector<std::uint32_t> curve;
  for (std::size_t k = 0; k < c.curve_samples(); ++k) {
    const double delta = c.min_dilation_m + static_cast<double>(k) * c.dilation_step_m - 1e-9;
    const std::size_t n = s.places.size();
    std::vector<std::vector<std::size_t>> adj(n);
    for (const auto& e : s.edges) {
      const double w = std::min({e.weight_m, s.places[e.a].clearance_m, s.places[e.b].clearance_m});
      if (w >= delta) {
        adj[e.a].push_back(e.b);
        adj[e.b].push_back(e.a);
      }
    }
    std::vector<bool> seen(n, false);
    std::uint32_t count = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (seen[i] || s.places[i].clearance_m < delta) continue;
      std::size_t size = 0;
      std::vector<std::size_t> stack{i};
      seen[i] = true;
      while (!stack.empty()) {
        const std::size_t u = stack.back();
        stack.pop_back();
        ++size;
        for (std::size_t v : adj[u])
          if (!seen[v]) {
            seen[v] = true;
            stack.push_back(v);
          }
      }
      count += size >= c.min_component_size ? 1 : 0;
    }
    curve.push_back(count);
  }
  return curve;
}

// Two 4 m x 4 m rooms joined by a corridor 0.75 m wide and 4 m long: its clearance (0.375 m) is below d-, so
// without doors the flood fill hands it to the rooms. Tags: rooms 0 and 1, corridor 2.
testing::GridPlan narrow_corridor_plan() {
  testing::GridPlan plan(50, 18, testing::kCellM);
  plan.carve(1, 1, 17, 17, 0);
  plan.carve(17, 7, 33, 10, 2);
  plan.carve(33, 1, 49, 17, 1);
  return plan;
}

// Closes (weight 0) every edge that crosses one of the corridor's two ends, as rooms::cut_place_edges does for a
// door found there. Returns the number closed.
std::size_t close_corridor_ends(SyntheticPlaces* s) {
  std::size_t closed = 0;
  for (testing::SyntheticEdge& e : s->edges) {
    const double xa = s->places[e.a].position_m.x(), xb = s->places[e.b].position_m.x();
    for (const double end_x : {17 * testing::kCellM, 33 * testing::kCellM})
      if ((xa < end_x) != (xb < end_x)) {
        e.weight_m = 0.0;
        ++closed;
      }
  }
  return closed;
}

// The online door stage's doors (a DoorSet, not weights in the graph) close the same passages: doors across the
// corridor's two ends make it a room, exactly as weight-0 edges there do, and leave the graph's weights alone.
TEST(RoomFinderTest, DoorsOfADoorSetCloseThePassagesTheyCross) {
  SyntheticPlaces s;
  narrow_corridor_plan().add_to(&s, 1.0);
  SyntheticPlaces weighted = s;
  const std::size_t closed = close_corridor_ends(&weighted);
  ASSERT_GT(closed, 0u);
  memory::Arena arena;
  DoorSet doors;
  std::string error;
  const DoorConfig config;
  ASSERT_TRUE(arena.create("doors", DoorSet::plan(4), DoorSet::plan(4).total_bytes(), &error)) << error;
  ASSERT_TRUE(doors.carve(arena, 4, config));
  for (const double end_x : {17 * testing::kCellM, 33 * testing::kCellM}) {
    Door d;
    d.a = Eigen::Vector2d(end_x, 7 * testing::kCellM);
    d.b = Eigen::Vector2d(end_x, 10 * testing::kCellM);
    d.z_m = 1.2;
    ASSERT_TRUE(doors.add(d));
  }
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  auto finder = make_finder();
  UpdateResult r;
  EXPECT_NO_ALLOCATIONS(r = finder->update(g.get(), 0, &doors));
  ASSERT_EQ(r.outcome, Outcome::kOk);
  EXPECT_EQ(r.rooms, 3u);
  EXPECT_EQ(r.closed_edges, closed);
  EXPECT_EQ(r.closed_region_rooms, 1u);
  expect_one_room_per_tag(*g, s);
  g->for_each_edge([](const scene_graph::EdgeRecord& e) { EXPECT_FALSE(e.info.weighted && e.info.weight <= 0.0); });
  // Without the set, the same graph gives two rooms again.
  EXPECT_EQ(finder->update(g.get()).rooms, 2u);
}

TEST(RoomFinderTest, ClosedPassagesMakeARegionWithoutSeedARoom) {
  // Without doors: two rooms, the corridor shared between them.
  {
    SyntheticPlaces s;
    narrow_corridor_plan().add_to(&s, 1.0);
    auto g = make_graph();
    ASSERT_TRUE(s.write(g.get()));
    const UpdateResult r = make_finder()->update(g.get());
    ASSERT_EQ(r.outcome, Outcome::kOk);
    EXPECT_EQ(r.rooms, 2u);
    EXPECT_EQ(r.closed_edges, 0u);
    EXPECT_EQ(r.closed_region_rooms, 0u);
  }
  // Doors found at both ends: the corridor is a room of its own.
  SyntheticPlaces s;
  narrow_corridor_plan().add_to(&s, 1.0);
  const std::size_t closed = close_corridor_ends(&s);
  ASSERT_GT(closed, 0u);
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  const UpdateResult r = make_finder()->update(g.get());
  ASSERT_EQ(r.outcome, Outcome::kOk);
  EXPECT_EQ(r.rooms, 3u);
  EXPECT_EQ(r.closed_edges, closed);
  EXPECT_EQ(r.closed_region_rooms, 1u);
  EXPECT_EQ(r.places_assigned, s.places.size());
  expect_one_room_per_tag(*g, s);
  // The corridor's room touches both rooms: closed passages are still where rooms meet.
  EXPECT_EQ(r.room_edges, 2u);

  // Each finder below works on a graph of its own (a graph's rooms belong to the finder that wrote them).
  const auto fresh = [&]() {
    auto graph = make_graph();
    EXPECT_TRUE(s.write(graph.get()));
    return graph;
  };
  // Off (the paper's setting), the closed corridor has no seed and the fill still hands it out.
  Config off;
  off.seed_closed_regions = false;
  EXPECT_FALSE(Config::paper().seed_closed_regions);
  const UpdateResult r_off = make_finder(off)->update(fresh().get());
  EXPECT_EQ(r_off.rooms, 2u);
  EXPECT_EQ(r_off.closed_region_rooms, 0u);
  EXPECT_EQ(r_off.places_assigned, s.places.size());

  // A region smaller than min_component_size stays without a room of its own (48 corridor places < 100).
  Config big;
  big.min_component_size = 100;
  const UpdateResult r_big = make_finder(big)->update(fresh().get());
  EXPECT_EQ(r_big.rooms, 2u);
  EXPECT_EQ(r_big.closed_region_rooms, 0u);
  EXPECT_EQ(r_big.places_assigned, s.places.size());

  // A full room store refuses the region's room and counts it; every place still gets a room.
  Capacities two = Capacities::from_scene_graph(small_graph_capacities());
  two.rooms = 2;
  const UpdateResult r_full = make_finder(Config{}, two)->update(fresh().get());
  EXPECT_EQ(r_full.rooms, 2u);
  EXPECT_EQ(r_full.closed_region_rooms, 0u);
  EXPECT_GE(r_full.seeds_dropped, 1u);
  EXPECT_EQ(r_full.places_assigned, s.places.size());

  // Seeding closed-off regions allocates nothing either.
  auto finder = make_finder();
  auto g2 = fresh();
  UpdateResult again;
  EXPECT_NO_ALLOCATIONS(again = finder->update(g2.get()));
  EXPECT_EQ(again.closed_region_rooms, 1u);
}

// Sight lines over a grid plan's occupied cells (one slice at 1.2 m; the places sit at 1.0 m). The walls are
// thickened by one 0.05 m cell only: the plan's places sit 0.125 m from its walls, closer than any real place.
WallSight sight_of(const GridPlan& plan, int width, int height) {
  DoorConfig config;
  config.sight_wall_dilation_m = 0.05;
  DoorRaster raster;
  raster.cell_m = 0.05;
  const int per_cell = static_cast<int>(std::lround(plan.cell_m() / raster.cell_m));
  raster.cols = width * per_cell;
  raster.rows = height * per_cell;
  std::vector<std::uint8_t> wall(raster.cells(), 0);
  for (int r = 0; r < raster.rows; ++r)
    for (int c = 0; c < raster.cols; ++c)
      wall[static_cast<std::size_t>(r) * raster.cols + c] = plan.free(c / per_cell, r / per_cell) ? 0 : 1;
  WallSight sight;
  std::string error;
  EXPECT_TRUE(sight.add_slice(raster, wall.data(), 1.2, config, &error)) << error;
  return sight;
}

// Closes (weight 0) every edge that crosses x = x_m. Returns the number closed.
std::size_t close_line(SyntheticPlaces* s, double x_m) {
  std::size_t closed = 0;
  for (testing::SyntheticEdge& e : s->edges)
    if ((s->places[e.a].position_m.x() < x_m) != (s->places[e.b].position_m.x() < x_m)) {
      e.weight_m = 0.0;
      ++closed;
    }
  return closed;
}

// A hall that a false door line cuts in two is one room again when its halves see each other; two rooms with a
// wall between them stay two, though their door is closed too.
TEST(RoomFinderTest, RoomsThatSeeEachOtherAreMerged) {
  GridPlan hall(35, 18, testing::kCellM);
  hall.carve(1, 1, 34, 17, 0);
  SyntheticPlaces s;
  hall.add_to(&s, 1.0);
  ASSERT_GT(close_line(&s, 17 * testing::kCellM), 0u);
  const WallSight hall_sight = sight_of(hall, 35, 18);
  ASSERT_EQ(hall_sight.structure_components(0), 1u);  // the outer walls, one ring
  {
    auto g = make_graph();
    ASSERT_TRUE(s.write(g.get()));
    EXPECT_EQ(make_finder()->update(g.get()).rooms, 2u);  // no sight lines: the false door splits the hall
  }
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  auto finder = make_finder();
  UpdateResult r;
  EXPECT_NO_ALLOCATIONS(r = finder->update(g.get(), 0, nullptr, &hall_sight));
  ASSERT_EQ(r.outcome, Outcome::kOk);
  EXPECT_EQ(r.rooms, 1u);
  EXPECT_EQ(r.visible_merges, 1u);
  EXPECT_GE(r.visible_pairs, 1u);
  EXPECT_EQ(r.places_assigned, s.places.size());
  EXPECT_EQ(rooms_by_tag(*g, s)[0].size(), 1u);
  // Again (ids kept), and with every sight line required or a single sample: the same.
  EXPECT_NO_ALLOCATIONS(r = finder->update(g.get(), 0, nullptr, &hall_sight));
  EXPECT_EQ(r.rooms, 1u);
  EXPECT_EQ(r.rooms_kept, 1u);
  for (const auto& [share, samples] : {std::pair{1.0, 12u}, std::pair{0.8, 1u}, std::pair{0.8, 32u}}) {
    Config c;
    c.visible_min_share = share;
    c.visible_samples = samples;
    auto g2 = make_graph();
    ASSERT_TRUE(s.write(g2.get()));
    EXPECT_EQ(make_finder(c)->update(g2.get(), 0, nullptr, &hall_sight).rooms, 1u) << share << " " << samples;
  }
  // A window's sight lines (an online door pass's) close edges through walls but do not merge.
  WallSight window;
  std::string error;
  ASSERT_TRUE(window.add_structure(hall_sight.raster(0), hall_sight.structure(0), hall_sight.slice_z(0), DoorConfig{},
                                   &error, /*window=*/true))
      << error;
  ASSERT_TRUE(window.window());
  {
    auto gw = make_graph();
    ASSERT_TRUE(s.write(gw.get()));
    EXPECT_EQ(make_finder()->update(gw.get(), 0, nullptr, &window).rooms, 2u);
  }
  // Off: two rooms.
  Config off;
  off.merge_visible = false;
  auto g3 = make_graph();
  ASSERT_TRUE(s.write(g3.get()));
  r = make_finder(off)->update(g3.get(), 0, nullptr, &hall_sight);
  EXPECT_EQ(r.rooms, 2u);
  EXPECT_EQ(r.visible_merges, 0u);

  // Two rooms, a wall between them and their door closed: they see each other only through the door.
  SyntheticPlaces two;
  testing::two_rooms_plan().add_to(&two, 1.0);
  ASSERT_GT(close_line(&two, 17 * testing::kCellM), 0u);
  const WallSight two_sight = sight_of(testing::two_rooms_plan(), 35, 18);
  auto g4 = make_graph();
  ASSERT_TRUE(two.write(g4.get()));
  auto two_finder = make_finder();
  EXPECT_NO_ALLOCATIONS(r = two_finder->update(g4.get(), 0, nullptr, &two_sight));
  EXPECT_EQ(r.rooms, 2u);
  EXPECT_EQ(r.visible_merges, 0u);
  EXPECT_EQ(r.visible_pairs, 1u);
  expect_one_room_per_tag(*g4, two);
  // A hall's graph under the two rooms' walls: with sight lines its edges through the wall are read as closed (not
  // written: the graph's weights stay), except through the door; with close_edges_through_walls off, none.
  {
    SyntheticPlaces open_hall;
    hall.add_to(&open_hall, 1.0);
    auto g6 = make_graph();
    ASSERT_TRUE(open_hall.write(g6.get()));
    auto reader = make_finder();
    EXPECT_NO_ALLOCATIONS(r = reader->update(g6.get(), 0, nullptr, &two_sight));
    EXPECT_GT(r.edges_through_walls, 0u);
    EXPECT_EQ(r.closed_edges, r.edges_through_walls);
    // The hall's edges with an end in the wall's column (x in [4.25, 4.5) m): those in the door's rows stay open.
    std::size_t at_wall = 0;
    for (const testing::SyntheticEdge& e : open_hall.edges) {
      const auto in_column = [](const Eigen::Vector3d& p) { return p.x() > 4.25 && p.x() < 4.5; };
      at_wall += in_column(open_hall.places[e.a].position_m) || in_column(open_hall.places[e.b].position_m) ? 1 : 0;
    }
    EXPECT_LT(r.edges_through_walls, at_wall) << "the door's edges stay open";
    g6->for_each_edge([](const sg::EdgeRecord& e) { EXPECT_GT(e.info.weight, 0.0); });
    Config keep;
    keep.close_edges_through_walls = false;
    EXPECT_EQ(make_finder(keep)->update(g6.get(), 0, nullptr, &two_sight).edges_through_walls, 0u);
  }
  // Sight lines of another storey (beyond cut_max_dz_m of the places) see nothing: no merge.
  SyntheticPlaces upstairs;
  hall.add_to(&upstairs, 1.0 + 3.0);
  close_line(&upstairs, 17 * testing::kCellM);
  auto g5 = make_graph();
  ASSERT_TRUE(upstairs.write(g5.get()));
  EXPECT_EQ(make_finder()->update(g5.get(), 0, nullptr, &hall_sight).rooms, 2u);
}

// A hall that a false door line cuts in two, with a partition wall along the hall from each end wall (joined to
// the outer walls, so structure; two bays at each end, no constriction) that hides part of one half from the
// other: the whole halves' sight lines fall short of a strict share; near the line nothing stands between them.
TEST(RoomFinderTest, RoomsThatSeeEachOtherNearTheirBoundaryAreMerged) {
  // 16 m x 4 m (x in [0.25, 16.25)); partitions 5 m long along y = 2.25 from the west and the east end walls; the
  // false door at x = 8.25. Tags: 1 for the places within 2 m west of the line, 2 within 2 m east of it.
  GridPlan hall(66, 18, testing::kCellM);
  hall.carve(1, 1, 65, 17, 0);
  hall.carve(25, 1, 33, 17, 1);
  hall.carve(33, 1, 41, 17, 2);
  hall.carve(1, 9, 21, 10, GridPlan::kWall);
  hall.carve(45, 9, 65, 10, GridPlan::kWall);
  SyntheticPlaces s;
  hall.add_to(&s, 1.0);
  ASSERT_GT(close_line(&s, 33 * testing::kCellM), 0u);
  const WallSight sight = sight_of(hall, 66, 18);
  ASSERT_EQ(sight.structure_components(0), 1u);  // the outer walls with their partitions
  // Whether the places on both sides of the line share one room.
  const auto joined = [&](const Config& c, UpdateResult* out) {
    auto g = make_graph();
    EXPECT_TRUE(s.write(g.get()));
    auto finder = make_finder(c);
    UpdateResult r;
    EXPECT_NO_ALLOCATIONS(r = finder->update(g.get(), 0, nullptr, &sight));
    if (out != nullptr) *out = r;
    const auto by_tag = rooms_by_tag(*g, s);
    return by_tag.at(1).size() == 1 && by_tag.at(2).size() == 1 && *by_tag.at(1).begin() == *by_tag.at(2).begin();
  };
  Config strict;
  strict.visible_min_share = 0.95;
  Config whole_only = strict;
  whole_only.visible_local_radius_m = 0.0;
  UpdateResult r;
  EXPECT_FALSE(joined(whole_only, &r)) << "the whole halves' sight lines fall short";
  EXPECT_EQ(r.visible_near_merges, 0u);
  EXPECT_TRUE(joined(strict, &r));
  EXPECT_EQ(r.visible_merges, 1u);
  EXPECT_EQ(r.visible_near_merges, 1u);
  EXPECT_EQ(r.places_assigned, s.places.size());
  // Too few places near the line (more than either half has), or near lines from as far as the partitions (some
  // cross them) held to the strict share too: not joined.
  Config few = strict;
  few.visible_local_min_places = 10000;
  EXPECT_FALSE(joined(few, nullptr));
  Config far = strict;
  far.visible_local_radius_m = 8.0;
  far.visible_local_min_share = 0.95;
  EXPECT_FALSE(joined(far, nullptr));
  // The default share takes the whole halves (87 % clear) without the test near the line.
  EXPECT_TRUE(joined(Config{}, &r));
  EXPECT_EQ(r.visible_near_merges, 0u);
}

// Two halves of a hall with no place edge between them (the places graph left none) are not adjacent by their
// edges; their places' free-space spheres touch across the line in sight, so the merge pairs them all the same.
// With a wall on the line (in the sight lines only) they stay apart. The search finds exactly the touching pairs a
// brute force does, up to its capacity (the rest counted).
TEST(RoomFinderTest, RoomsWhosePlacesTouchInSightAreAdjacentWithoutAnEdge) {
  GridPlan hall(35, 18, testing::kCellM);
  hall.carve(1, 1, 17, 17, 1);
  hall.carve(17, 1, 34, 17, 2);
  SyntheticPlaces s;
  hall.add_to(&s, 1.0, Eigen::Vector2d::Zero(), 0.6);  // clearances capped as a 1.2 m storey would
  const double line_m = 17 * testing::kCellM;
  const auto across = [&](const testing::SyntheticEdge& e) {
    return (s.places[e.a].position_m.x() < line_m) != (s.places[e.b].position_m.x() < line_m);
  };
  s.edges.erase(std::remove_if(s.edges.begin(), s.edges.end(), across), s.edges.end());
  const double cap_m = Config{}.visible_touch_max_clearance_m;
  std::size_t touching = 0;
  for (const auto& a : s.places)
    for (const auto& b : s.places)
      if (a.room == 1 && b.room == 2 &&
          (a.position_m - b.position_m).norm() < std::min(a.clearance_m, cap_m) + std::min(b.clearance_m, cap_m))
        ++touching;
  ASSERT_GT(touching, 0u);
  const WallSight open_sight = sight_of(hall, 35, 18);
  GridPlan walled = hall;
  walled.carve(17, 1, 18, 17, GridPlan::kWall);
  const WallSight walled_sight = sight_of(walled, 35, 18);
  const auto joined = [&](const Config& c, const Capacities& caps, const WallSight& sight, UpdateResult* out) {
    auto g = make_graph();
    EXPECT_TRUE(s.write(g.get()));
    auto finder = make_finder(c, caps);
    UpdateResult r;
    EXPECT_NO_ALLOCATIONS(r = finder->update(g.get(), 0, nullptr, &sight));
    *out = r;
    const auto by_tag = rooms_by_tag(*g, s);
    EXPECT_EQ(by_tag.at(1).size(), 1u);
    EXPECT_EQ(by_tag.at(2).size(), 1u);
    return *by_tag.at(1).begin() == *by_tag.at(2).begin();
  };
  const Capacities caps = Capacities::from_scene_graph(small_graph_capacities());
  ASSERT_GE(caps.places, touching);
  UpdateResult r;
  Config off;
  off.visible_touching = false;
  EXPECT_FALSE(joined(off, caps, open_sight, &r)) << "no edge, no adjacency";
  EXPECT_EQ(r.visible_pairs, 0u);
  EXPECT_EQ(r.visible_touching_pairs, 0u);
  EXPECT_TRUE(joined(Config{}, caps, open_sight, &r));
  EXPECT_EQ(r.visible_merges, 1u);
  EXPECT_EQ(r.visible_touching_pairs, touching);
  EXPECT_EQ(r.visible_touching_dropped, 0u);
  EXPECT_EQ(r.places_assigned, s.places.size());
  EXPECT_FALSE(joined(Config{}, caps, walled_sight, &r)) << "touching, but not in sight";
  EXPECT_EQ(r.visible_touching_pairs, 0u);
  // Room for fewer pairs than touch: the first ones are kept (enough to pair the halves), the rest counted.
  Capacities tight = caps;
  tight.places = s.places.size();
  ASSERT_LT(tight.places, touching);
  EXPECT_TRUE(joined(Config{}, tight, open_sight, &r));
  EXPECT_EQ(r.visible_touching_pairs, tight.places);
  EXPECT_EQ(r.visible_touching_dropped, touching - tight.places);
}

TEST(RoomFinderTest, VisibilityMergeSettingsAreChecked) {
  const auto bad = [](auto set, const char* field) {
    Config c;
    set(&c);
    const std::string why = c.check();
    EXPECT_NE(why.find(field), std::string::npos) << why;
  };
  bad([](Config* c) { c->visible_min_share = 0.0; }, "visible_min_share");
  bad([](Config* c) { c->visible_min_share = 1.5; }, "visible_min_share");
  bad([](Config* c) { c->visible_min_share = std::nan(""); }, "visible_min_share");
  bad([](Config* c) { c->visible_samples = 0; }, "visible_samples");
  bad([](Config* c) { c->visible_samples = Config::kMaxVisibleSamples + 1; }, "visible_samples");
  bad([](Config* c) { c->visible_max_rounds = 0; }, "visible_max_rounds");
  bad([](Config* c) { c->visible_local_radius_m = -1.0; }, "visible_local_radius_m");
  bad([](Config* c) { c->visible_local_radius_m = std::nan(""); }, "visible_local_radius_m");
  bad([](Config* c) { c->visible_local_min_share = 0.0; }, "visible_local_min_share");
  bad([](Config* c) { c->visible_local_min_places = 0; }, "visible_local_min_places");
  bad([](Config* c) { c->visible_touch_max_clearance_m = 0.0; }, "visible_touch_max_clearance_m");
  bad([](Config* c) { c->visible_touch_max_clearance_m = std::nan(""); }, "visible_touch_max_clearance_m");
  Config off;
  off.merge_visible = false;
  off.visible_local_min_places = 0;  // needed only with the merge on
  EXPECT_EQ(off.check(), "");
  off.visible_samples = 0;  // a declared range holds whatever the switch (as in the app's JSON and --set)
  EXPECT_NE(off.check().find("rooms.visible_samples must be in [1, 32]"), std::string::npos) << off.check();
}

TEST(RoomFinderTest, BettiCurveMatchesBruteForce) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    SyntheticPlaces s;
    std::uniform_real_distribution<double> clearance(0.2, 1.5), pos(0.0, 20.0);
    const int n = 60 + trial * 10;
    for (int i = 0; i < n; ++i) s.add_place({pos(rng), pos(rng), 1.0}, clearance(rng));
    std::uniform_int_distribution<int> pick(0, n - 1);
    std::set<std::pair<int, int>> seen;
    for (int k = 0; k < 2 * n; ++k) {
      int a = pick(rng), b = pick(rng);
      if (a == b || !seen.insert({std::min(a, b), std::max(a, b)}).second) continue;
      // Weights below, equal to and (ignored) above the ends' clearance.
      const double w = std::min(s.places[a].clearance_m, s.places[b].clearance_m) * (k % 3 == 0 ? 1.0 : 0.8) +
                       (k % 7 == 0 ? 0.5 : 0.0);
      s.add_edge(static_cast<std::size_t>(a), static_cast<std::size_t>(b), w);
    }
    Config c;
    c.min_component_size = 1 + trial % 5;
    c.dilation_step_m = trial % 2 == 0 ? 0.01 : 0.05;
    auto g = make_graph();
    ASSERT_TRUE(s.write(g.get()));
    auto finder = make_finder(c);
    finder->update(g.get());
    const std::vector<std::uint32_t> expected = brute_force_curve(s, c);
    ASSERT_EQ(finder->curve_size(), expected.size());
    for (std::size_t k = 0; k < expected.size(); ++k)
      ASSERT_EQ(finder->betti_at(k), expected[k]) << "trial " << trial << " sample " << k << " delta "
                                                  << finder->dilation_at(k);
  }
}

TEST(RoomFinderTest, PlateauRuleFollowsThePaper) {
  // Intervals: 1 x 10 samples, 3 x 6, 5 x 2, 0 x 4.
  std::vector<std::uint32_t> b;
  for (int i = 0; i < 10; ++i) b.push_back(1);
  for (int i = 0; i < 6; ++i) b.push_back(3);
  for (int i = 0; i < 2; ++i) b.push_back(5);
  for (int i = 0; i < 4; ++i) b.push_back(0);
  EXPECT_EQ(choose_plateau(b.data(), b.size(), 1.0), 0) << "alpha 1: the most persistent interval";
  EXPECT_EQ(choose_plateau(b.data(), b.size(), 0.5), 10) << "longer than 5 samples: the 3-room interval";
  EXPECT_EQ(choose_plateau(b.data(), b.size(), 0.0), 16) << "alpha 0: the most components";
  const std::vector<std::uint32_t> zeros(8, 0);
  EXPECT_EQ(choose_plateau(zeros.data(), zeros.size(), 0.5), -1);
  // Equal counts in two runs: the longer wins.
  const std::vector<std::uint32_t> twice{2, 2, 1, 2, 2, 2, 1, 1};
  EXPECT_EQ(choose_plateau(twice.data(), twice.size(), 0.0), 3);
}

// Unassigned u and v between two seeds A and B: u-A 0.30, u-B 0.40, v-A 0.25, v-u 0.35. Largest clearance first
// gives u to B (0.40) and then v to B through u (0.35 before 0.25); nearest-seed-by-hops would give v to A.
TEST(RoomFinderTest, FloodFillExpandsLargestClearanceFirst) {
  SyntheticPlaces s;
  std::size_t a0 = 0, b0 = 0;
  for (int room = 0; room < 2; ++room) {
    std::size_t prev = SIZE_MAX;
    for (int k = 0; k < 16; ++k) {
      const std::size_t i = s.add_place({10.0 * room + 0.5 * k, 0.0, 1.0}, 1.0, room);
      if (prev != SIZE_MAX) s.add_edge(prev, i, 1.0);
      if (k == 0) (room == 0 ? a0 : b0) = i;
      prev = i;
    }
  }
  const std::size_t u = s.add_place({5.0, 1.0, 1.0}, 0.45);
  const std::size_t v = s.add_place({4.0, 1.0, 1.0}, 0.45);
  s.add_edge(u, a0, 0.30);
  s.add_edge(u, b0, 0.40);
  s.add_edge(v, a0, 0.25);
  s.add_edge(v, u, 0.35);
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  auto finder = make_finder();
  const UpdateResult r = finder->update(g.get());
  ASSERT_EQ(r.rooms, 2u);
  EXPECT_EQ(r.seeded_places, 32u);
  const sg::NodeId room_a = g->parent(s.places[a0].id), room_b = g->parent(s.places[b0].id);
  ASSERT_NE(room_a, room_b);
  EXPECT_EQ(g->parent(s.places[u].id), room_b);
  EXPECT_EQ(g->parent(s.places[v].id), room_b) << "v must be reached through u (0.35) before A's 0.25 edge";
  // A and B touch through u and v: one room-room edge.
  EXPECT_TRUE(g->has_edge(room_a, room_b));
}

TEST(RoomFinderTest, OneBuildingAtTheMeanOfTheRoomCentroids) {
  SyntheticPlaces s;
  testing::corridor_plan(2).add_to(&s, 0.5);
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  auto finder = make_finder();
  ASSERT_EQ(finder->update(g.get()).rooms, 5u);
  EXPECT_EQ(g->num_nodes(sg::NodeKind::kBuilding), 1u);
  const sg::NodeId b = finder->building_id();
  ASSERT_EQ(b, sg::make_node_id(sg::kBuildingPrefix, 0));
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < finder->num_rooms(); ++k) {
    EXPECT_EQ(g->parent(finder->room_id(k)), b) << "every room hangs below the building";
    sum += g->room(finder->room_id(k))->position_m;
  }
  EXPECT_EQ(g->node(b)->num_children, 5u);
  EXPECT_TRUE(g->building(b)->position_m.isApprox(sum / 5.0, 1e-9));
}

TEST(RoomFinderTest, UpdatesReplaceRoomsAndKeepIds) {
  SyntheticPlaces s;
  testing::corridor_plan(2).add_to(&s, 0.5);
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  auto finder = make_finder();
  ASSERT_EQ(finder->update(g.get()).rooms, 5u);
  std::map<int, sg::NodeId> first;
  for (const auto& [tag, rooms] : rooms_by_tag(*g, s)) first[tag] = *rooms.begin();
  // A classifier's label on one room survives the next update.
  g->room(first[1])->semantic_label = 7;
  const std::size_t edges = g->num_edges();
  const UpdateResult again = finder->update(g.get());
  EXPECT_EQ(again.rooms, 5u);
  EXPECT_EQ(again.rooms_kept, 5u);
  EXPECT_EQ(again.rooms_removed, 0u);
  EXPECT_EQ(g->num_nodes(sg::NodeKind::kRoom), 5u);
  EXPECT_EQ(g->num_edges(), edges) << "the same edges, not duplicates";
  for (const auto& [tag, rooms] : rooms_by_tag(*g, s)) EXPECT_EQ(*rooms.begin(), first[tag]) << "room " << tag;
  EXPECT_EQ(g->room(first[1])->semantic_label, 7u);
  // One side room's places disappear: its room goes, the others keep their ids.
  for (const auto& p : s.places)
    if (p.room == 4) g->remove_node(p.id);
  const UpdateResult third = finder->update(g.get());
  EXPECT_EQ(third.rooms, 4u);
  EXPECT_EQ(third.rooms_removed, 1u);
  EXPECT_FALSE(g->has_node(first[4]));
  for (int tag : {0, 1, 2, 3}) EXPECT_TRUE(g->room(first[tag]) != nullptr) << "room " << tag;
  EXPECT_EQ(g->node(finder->building_id())->num_children, 4u);
}

// Each place's room, named by the smallest place id in it (room node ids depend on update history, the partition
// must not).
std::map<sg::NodeId, sg::NodeId> partition(const sg::SceneGraph& g, const SyntheticPlaces& s) {
  std::map<sg::NodeId, sg::NodeId> first_place;
  for (const auto& p : s.places) {
    const sg::NodeId room = g.parent(p.id);
    auto it = first_place.find(room);
    if (it == first_place.end() || p.id < it->second) first_place[room] = p.id;
  }
  std::map<sg::NodeId, sg::NodeId> out;
  for (const auto& p : s.places) out[p.id] = first_place[g.parent(p.id)];
  return out;
}

// The rooms are a function of the graph's content. The same places and edges, inserted in another order into a
// graph whose storage already saw other places come and go (as a live run's does, and unlike the same graph read
// back from a file), give the same rooms. The grid plan's clearances are a few distinct values, so ties are many.
TEST(RoomFinderTest, RoomsDoNotDependOnTheGraphsStorageOrder) {
  SyntheticPlaces s;
  testing::corridor_plan(3).add_to(&s, 0.5);
  for (const Config& config : {Config{}, persistence_config()}) {
    auto built = make_graph();
    ASSERT_TRUE(s.write(built.get()));
    ASSERT_EQ(make_finder(config)->update(built.get()).outcome, Outcome::kOk);
    const auto expected = partition(*built, s);
    std::set<sg::NodeId> rooms;
    for (const auto& [place, room] : expected) rooms.insert(room);
    ASSERT_GE(rooms.size(), 5u);

    std::mt19937 rng(7);
    for (int trial = 0; trial < 4; ++trial) {
      auto live = make_graph();
      // Earlier places that a run later removed, interleaved with this run's places in a shuffled order.
      std::vector<std::size_t> order(s.places.size());
      for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
      std::shuffle(order.begin(), order.end(), rng);
      std::vector<sg::NodeId> gone;
      for (std::size_t k = 0; k < order.size(); ++k) {
        if (k % 3 == 0) {
          const sg::NodeId ghost = sg::make_node_id(sg::kPlacePrefix, 100000 + k);
          ASSERT_EQ(live->add_place(ghost, sg::PlaceAttributes{}), sg::Status::kOk);
          gone.push_back(ghost);
        }
        const testing::SyntheticPlace& p = s.places[order[k]];
        sg::PlaceAttributes a;
        a.position_m = p.position_m;
        a.distance_m = p.clearance_m;
        a.is_active = true;
        ASSERT_EQ(live->add_place(p.id, a), sg::Status::kOk);
      }
      for (const sg::NodeId ghost : gone) live->remove_node(ghost);
      std::vector<testing::SyntheticEdge> edges = s.edges;
      std::shuffle(edges.begin(), edges.end(), rng);
      for (const testing::SyntheticEdge& e : edges) {
        sg::EdgeAttributes info;
        info.weight = e.weight_m;
        info.weighted = true;
        const bool flip = (rng() & 1u) != 0;  // either end first
        ASSERT_EQ(live->add_edge(s.places[flip ? e.b : e.a].id, s.places[flip ? e.a : e.b].id, info),
                  sg::Status::kOk);
      }
      ASSERT_EQ(make_finder(config)->update(live.get()).outcome, Outcome::kOk);
      const auto got = partition(*live, s);
      std::size_t differ = 0;
      for (const auto& [place, room] : expected) differ += got.at(place) != room ? 1 : 0;
      EXPECT_EQ(differ, 0u) << "trial " << trial << ": places in another room than in the graph built in order";
    }
  }
}

TEST(RoomFinderTest, BadInputGivesACountedOutcome) {
  RoomFinder uninitialized;
  EXPECT_EQ(uninitialized.update(nullptr).outcome, Outcome::kNotInitialized);
  auto finder = make_finder();
  EXPECT_EQ(finder->update(nullptr).outcome, Outcome::kNoGraph);
  sg::SceneGraph not_initialized;
  EXPECT_EQ(finder->update(&not_initialized).outcome, Outcome::kNoGraph);
  auto g = make_graph();
  EXPECT_EQ(finder->update(g.get()).outcome, Outcome::kNoPlaces);
  EXPECT_EQ(finder->counters().no_places, 1u);
  // Places too narrow for any component at d-: no rooms, nothing written.
  SyntheticPlaces narrow;
  std::size_t prev = narrow.add_place({0, 0, 1}, 0.3);
  for (int k = 1; k < 30; ++k) {
    const std::size_t next = narrow.add_place({0.3 * k, 0, 1}, 0.3);
    narrow.add_edge(prev, next, 0.3);
    prev = next;
  }
  ASSERT_TRUE(narrow.write(g.get()));
  EXPECT_EQ(finder->update(g.get()).outcome, Outcome::kNoRooms);
  EXPECT_EQ(g->num_nodes(sg::NodeKind::kRoom), 0u);
  EXPECT_EQ(g->num_nodes(sg::NodeKind::kBuilding), 0u);
  // Rooms, then every place removed: the rooms and the building go too.
  auto g2 = make_graph();
  SyntheticPlaces s;
  testing::two_rooms_plan().add_to(&s, 1.0);
  ASSERT_TRUE(s.write(g2.get()));
  ASSERT_EQ(finder->update(g2.get()).rooms, 2u);
  for (const auto& p : s.places) g2->remove_node(p.id);
  const UpdateResult r = finder->update(g2.get());
  EXPECT_EQ(r.outcome, Outcome::kNoPlaces);
  EXPECT_EQ(r.rooms_removed, 2u);
  EXPECT_EQ(g2->num_nodes(), 0u);
  // Bad configurations are refused by field.
  std::string error;
  Config c;
  c.max_dilation_m = 0.1;
  EXPECT_FALSE(RoomFinder().init(c, Capacities::from_scene_graph(small_graph_capacities()), 0, &error));
  EXPECT_NE(error.find("max_dilation_m"), std::string::npos) << error;
  c = Config{};
  c.plateau_alpha = 1.5;
  EXPECT_FALSE(RoomFinder().init(c, Capacities::from_scene_graph(small_graph_capacities()), 0, &error));
  EXPECT_NE(error.find("plateau_alpha"), std::string::npos) << error;
  Capacities caps = Capacities::from_scene_graph(small_graph_capacities());
  caps.rooms = 0;
  EXPECT_FALSE(RoomFinder().init(Config{}, caps, 0, &error));
  EXPECT_NE(error.find("rooms"), std::string::npos) << error;
  caps.rooms = std::size_t{1} << 24;  // the corridor merge packs two room slots of 24 bits into one key
  EXPECT_FALSE(RoomFinder().init(Config{}, caps, 0, &error));
  EXPECT_NE(error.find("capacities.rooms"), std::string::npos) << error;
  EXPECT_FALSE(RoomFinder().init(Config{}, Capacities::from_scene_graph(small_graph_capacities()), 1024, &error))
      << "a budget below the plan";
}

TEST(RoomFinderTest, FullStoresAreCountedRefusalsNotCrashes) {
  SyntheticPlaces s;
  testing::corridor_plan(2).add_to(&s, 0.5);
  // Room for one room node only, and for the place edges plus 20 more edges.
  sg::Capacities c = small_graph_capacities();
  c.room_nodes = 1;
  c.edges = s.edges.size() + 20;
  auto g = make_graph(c);
  ASSERT_TRUE(s.write(g.get()));
  auto finder = make_finder(Config{}, Capacities::from_scene_graph(small_graph_capacities()));
  const UpdateResult r = finder->update(g.get());
  EXPECT_EQ(r.outcome, Outcome::kOk);
  EXPECT_EQ(r.rooms, 1u);
  EXPECT_GT(r.refused, 0u);
  EXPECT_GT(r.places_unassigned, 0u);
  EXPECT_EQ(g->num_nodes(sg::NodeKind::kRoom), 1u);
  EXPECT_LE(g->num_edges(), c.edges);
  EXPECT_GT(finder->counters().graph_refused, 0u);
  // The finder's own capacities: more places than it holds are ignored and counted.
  Capacities tiny;
  tiny.places = 100;
  tiny.place_edges = 100;
  tiny.rooms = 1;
  auto small = make_finder(Config{}, tiny);
  auto g2 = make_graph();
  ASSERT_TRUE(s.write(g2.get()));
  const UpdateResult r2 = small->update(g2.get());
  EXPECT_EQ(r2.places, 100u);
  EXPECT_GT(r2.truncated, 0u);
}

TEST(RoomFinderTest, UpdatesDoNotAllocate) {
  SyntheticPlaces s;
  testing::corridor_plan(3).add_to(&s, 0.5);
  auto g = make_graph();
  ASSERT_TRUE(s.write(g.get()));
  auto finder = make_finder();
  UpdateResult first, second;
  EXPECT_NO_ALLOCATIONS(first = finder->update(g.get()));
  EXPECT_NO_ALLOCATIONS(second = finder->update(g.get()));
  EXPECT_EQ(first.rooms, 7u);
  EXPECT_EQ(second.rooms_kept, 7u);
  auto persistence = make_finder(persistence_config());
  EXPECT_NO_ALLOCATIONS(first = persistence->update(g.get()));
  EXPECT_EQ(first.rooms, 7u);
  // A room split by its extent: the extended clearance, the second seeding and the fill use the arena only.
  SyntheticPlaces halls;
  wide_opening_plan().add_to(&halls, 1.0, Eigen::Vector2d::Zero(), kStoreyCapM);
  auto g2 = make_graph();
  ASSERT_TRUE(halls.write(g2.get()));
  auto splitting = make_finder();
  EXPECT_NO_ALLOCATIONS(first = splitting->update(g2.get()));
  EXPECT_NO_ALLOCATIONS(second = splitting->update(g2.get()));
  EXPECT_EQ(first.rooms_split, 1u);
  EXPECT_EQ(second.rooms_kept, 2u);
  // Corridor pieces merged: the boundary pairs, their sort and the renumbering use the arena only.
  SyntheticPlaces pinched;
  testing::pinched_corridor_plan(4).add_to(&pinched, 1.0, Eigen::Vector2d::Zero(), kStoreyCapM);
  auto g3 = make_graph();
  ASSERT_TRUE(pinched.write(g3.get()));
  Config merging;
  merging.corridor_min_open_edges = 6;
  auto merger = make_finder(merging);
  EXPECT_NO_ALLOCATIONS(first = merger->update(g3.get()));
  EXPECT_EQ(first.corridor_merges, 1u);
}

}  // namespace
}  // namespace qsg::rooms
