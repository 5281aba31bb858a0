// Scene graph: layers, hierarchy rules, edges, removal, mesh connections, capacity and allocation behaviour.
#include "core/scene_graph/scene_graph.h"

#include <gtest/gtest.h>

#include <map>
#include <random>
#include <set>
#include <vector>

#include "tests/scene_graph/test_graph.h"
#include "tests/support/allocation_counter.h"

namespace qsg::scene_graph {
namespace {

using testing::make_graph;
using testing::place_at;

const NodeId kP0 = make_node_id('p', 0);
const NodeId kP1 = make_node_id('p', 1);
const NodeId kO0 = make_node_id('O', 0);
const NodeId kR0 = make_node_id('R', 0);
const NodeId kR1 = make_node_id('R', 1);
const NodeId kB0 = make_node_id('B', 0);
const NodeId kA0 = make_node_id('a', 0);

TEST(SceneGraphTest, NodesLandOnTheirSparkDsgLayers) {
  auto g = make_graph();
  ASSERT_EQ(g->add_place(kP0, place_at(0, 0, 1)), Status::kOk);
  ASSERT_EQ(g->add_object(kO0, ObjectAttributes{}), Status::kOk);
  ASSERT_EQ(g->add_room(kR0, RoomAttributes{}), Status::kOk);
  ASSERT_EQ(g->add_building(kB0, BuildingAttributes{}), Status::kOk);
  ASSERT_EQ(g->add_agent(kA0, 'a', AgentAttributes{}), Status::kOk);
  EXPECT_EQ(g->node(kO0)->layer.layer, 2);
  EXPECT_EQ(g->node(kA0)->layer.layer, 2);
  EXPECT_EQ(g->node(kA0)->layer.partition, 'a');
  EXPECT_EQ(g->node(kP0)->layer.layer, 3);
  EXPECT_EQ(g->node(kR0)->layer.layer, 4);
  EXPECT_EQ(g->node(kB0)->layer.layer, 5);
  EXPECT_EQ(g->add_place(kP0, place_at(1, 1, 1)), Status::kDuplicateNode);
  EXPECT_EQ(g->num_nodes(), 5u);
  EXPECT_NE(g->place(kP0), nullptr);
  EXPECT_EQ(g->room(kP0), nullptr) << "typed access checks the kind";
}

TEST(SceneGraphTest, HierarchyRulesAreEnforced) {
  auto g = make_graph();
  g->add_place(kP0, place_at(0, 0, 1));
  g->add_place(kP1, place_at(1, 0, 1));
  g->add_object(kO0, ObjectAttributes{});
  g->add_room(kR0, RoomAttributes{});
  g->add_room(kR1, RoomAttributes{});
  g->add_building(kB0, BuildingAttributes{});
  g->add_agent(kA0, 'a', AgentAttributes{});

  EXPECT_EQ(g->add_edge(kP0, kP0), Status::kSelfLoop);
  EXPECT_EQ(g->add_edge(kP0, make_node_id('p', 99)), Status::kMissingNode);
  EXPECT_EQ(g->add_edge(kO0, kR0), Status::kLayersNotAdjacent) << "locality: objects (2) to rooms (4)";
  EXPECT_EQ(g->add_edge(kO0, kA0), Status::kPartitionMismatch);
  ASSERT_EQ(g->add_edge(kP0, kP1, {0.5, true}), Status::kOk);
  EXPECT_EQ(g->add_edge(kP1, kP0), Status::kDuplicateEdge) << "undirected";
  ASSERT_EQ(g->add_edge(kR0, kP0), Status::kOk);
  EXPECT_EQ(g->parent(kP0), kR0);
  EXPECT_EQ(g->add_edge(kP0, kR1), Status::kParentExists) << "single parent";
  ASSERT_EQ(g->add_edge(kO0, kP0), Status::kOk);
  EXPECT_EQ(g->parent(kO0), kP0);
  ASSERT_EQ(g->add_edge(kB0, kR0), Status::kOk);
  ASSERT_EQ(g->add_edge(kA0, kP1), Status::kOk);
  EXPECT_EQ(g->parent(kA0), kP1);
  EXPECT_EQ(g->num_layer_edges(true), 4u);
  EXPECT_EQ(g->num_layer_edges(false), 1u);
  EXPECT_DOUBLE_EQ(g->edge(kP1, kP0)->info.weight, 0.5);

  std::set<NodeId> children;
  g->for_each_child(kP0, [&](NodeId c) { children.insert(c); });
  EXPECT_EQ(children, (std::set<NodeId>{kO0}));

  // Removing the parent edge frees the child for a new parent.
  EXPECT_TRUE(g->remove_edge(kP0, kR0));
  EXPECT_EQ(g->parent(kP0), kNoNode);
  EXPECT_EQ(g->add_edge(kP0, kR1), Status::kOk);
}

// A revisited place merged into the live one: siblings, children and the parent move; shared edges, the edge
// between the two and a second parent are dropped; the merged node is gone.
TEST(SceneGraphTest, MergeIntoMovesEdgesAndRemovesTheNode) {
  auto g = make_graph();
  const NodeId kP2 = make_node_id('p', 2), kP3 = make_node_id('p', 3);
  g->add_place(kP0, place_at(0, 0, 1));  // live
  g->add_place(kP1, place_at(0.2, 0, 1));  // revisited, to merge
  g->add_place(kP2, place_at(1, 0, 1));
  g->add_place(kP3, place_at(-1, 0, 1));
  g->add_object(kO0, ObjectAttributes{});
  g->add_room(kR0, RoomAttributes{});
  g->add_room(kR1, RoomAttributes{});
  ASSERT_EQ(g->add_edge(kP1, kP2, {0.7, true}), Status::kOk);  // moves, weight kept
  ASSERT_EQ(g->add_edge(kP1, kP3, {0.3, true}), Status::kOk);  // kP0 has it already: dropped
  ASSERT_EQ(g->add_edge(kP0, kP3, {0.9, true}), Status::kOk);
  ASSERT_EQ(g->add_edge(kP0, kP1), Status::kOk);                // the edge between the two: dropped
  ASSERT_EQ(g->add_edge(kO0, kP1), Status::kOk);                // child: moves
  ASSERT_EQ(g->add_edge(kR1, kP1), Status::kOk);                // second parent: dropped
  ASSERT_EQ(g->add_edge(kR0, kP0), Status::kOk);

  const SceneGraph::MergeResult r = g->merge_into(kP0, kP1);
  EXPECT_EQ(r.status, Status::kOk);
  EXPECT_EQ(r.moved, 2u);
  EXPECT_EQ(r.dropped, 3u);
  EXPECT_EQ(r.refused, 0u);
  EXPECT_FALSE(g->has_node(kP1));
  ASSERT_TRUE(g->has_edge(kP0, kP2));
  EXPECT_DOUBLE_EQ(g->edge(kP0, kP2)->info.weight, 0.7);
  EXPECT_DOUBLE_EQ(g->edge(kP0, kP3)->info.weight, 0.9) << "the live node's own edge wins";
  EXPECT_EQ(g->parent(kO0), kP0);
  EXPECT_EQ(g->parent(kP0), kR0);
  EXPECT_EQ(g->node(kR1)->num_children, 0u);
  EXPECT_EQ(g->num_edges(), 4u);

  EXPECT_EQ(g->merge_into(kP0, kP1).status, Status::kMissingNode);
  EXPECT_EQ(g->merge_into(kP0, kP0).status, Status::kSelfLoop);
  EXPECT_EQ(g->merge_into(kP0, kR0).status, Status::kWrongKind);
  EXPECT_TRUE(g->has_node(kR0)) << "a refused merge changes nothing";
}

TEST(SceneGraphTest, AdjacencyMatchesReferenceUnderRandomEdits) {
  auto g = make_graph();
  constexpr int kN = 60;
  for (int i = 0; i < kN; ++i) ASSERT_EQ(g->add_place(make_node_id('p', i), place_at(i, 0, 1)), Status::kOk);
  std::map<NodeId, std::set<NodeId>> reference;
  std::mt19937 rng(3);
  for (int step = 0; step < 20000; ++step) {
    const NodeId a = make_node_id('p', rng() % kN);
    const NodeId b = make_node_id('p', rng() % kN);
    if (a == b) continue;
    if (rng() % 2 == 0) {
      const Status s = g->add_edge(a, b);
      const bool had = reference[a].count(b) != 0;
      ASSERT_EQ(s, had ? Status::kDuplicateEdge : Status::kOk);
      reference[a].insert(b);
      reference[b].insert(a);
    } else {
      const bool had = reference[a].count(b) != 0;
      ASSERT_EQ(g->remove_edge(a, b), had);
      reference[a].erase(b);
      reference[b].erase(a);
    }
  }
  std::size_t edge_ends = 0;
  for (int i = 0; i < kN; ++i) {
    const NodeId id = make_node_id('p', i);
    std::set<NodeId> got;
    g->for_each_neighbor(id, [&](NodeId n, const EdgeRecord&) { EXPECT_TRUE(got.insert(n).second); });
    EXPECT_EQ(got, reference[id]) << node_label(id);
    EXPECT_EQ(g->node(id)->degree, reference[id].size());
    edge_ends += got.size();
  }
  EXPECT_EQ(g->num_edges() * 2, edge_ends);
  // Removing nodes removes their edges and leaves the rest consistent.
  for (int i = 0; i < kN; i += 3) ASSERT_TRUE(g->remove_node(make_node_id('p', i)));
  g->for_each_edge([&](const EdgeRecord& e) {
    EXPECT_TRUE(g->has_node(e.source));
    EXPECT_TRUE(g->has_node(e.target));
  });
}

TEST(SceneGraphTest, ObjectMeshConnectionsSpanChunksAndAreFreed) {
  auto g = make_graph();
  ASSERT_EQ(g->add_object(kO0, ObjectAttributes{}), Status::kOk);
  for (std::uint32_t v = 0; v < 1000; ++v) ASSERT_TRUE(g->append_mesh_connection(kO0, v * 3));
  std::vector<std::uint32_t> got;
  g->for_each_mesh_connection(kO0, [&](std::uint32_t v) { got.push_back(v); });
  ASSERT_EQ(got.size(), 1000u);
  for (std::uint32_t v = 0; v < 1000; ++v) EXPECT_EQ(got[v], v * 3);
  std::size_t chunks_in_use = 0;
  g->for_each_resource([&](const memory::ResourceStats& s) {
    if (std::string(s.name) == "scene_graph.mesh_chunks") chunks_in_use = s.in_use;
  });
  EXPECT_EQ(chunks_in_use, (1000 + kMeshChunkValues - 1) / kMeshChunkValues);
  ASSERT_TRUE(g->remove_node(kO0));
  g->for_each_resource([&](const memory::ResourceStats& s) {
    if (std::string(s.name) == "scene_graph.mesh_chunks") {
      EXPECT_EQ(s.in_use, 0u);
    }
  });
}

TEST(SceneGraphTest, InitRefusesABudgetTooSmall) {
  SceneGraph g;
  std::string error;
  EXPECT_FALSE(g.init(testing::small_capacities(), 1024, &error));
  EXPECT_NE(error.find("scene_graph"), std::string::npos);
  EXPECT_FALSE(g.initialized());
}

TEST(SceneGraphTest, FullStoreAbortsOrRefusesPerBuildPolicy) {
  Capacities c = testing::small_capacities();
  c.room_nodes = 1;
  auto g = make_graph(c);
  ASSERT_EQ(g->add_room(kR0, RoomAttributes{}), Status::kOk);
  if (memory::kBuildOverflowPolicy == memory::OverflowPolicy::kAbort) {
    EXPECT_DEATH(g->add_room(kR1, RoomAttributes{}), "scene_graph.rooms' is full");
  } else {
    EXPECT_EQ(g->add_room(kR1, RoomAttributes{}), Status::kFull);
    EXPECT_FALSE(g->has_node(kR1));
    std::uint64_t failed = 0;
    g->for_each_resource([&](const memory::ResourceStats& s) {
      if (std::string(s.name) == "scene_graph.rooms") failed = s.failed;
    });
    EXPECT_EQ(failed, 1u);
  }
}

// A stage that sees a store full before asking (so that a full graph is a counted degradation in every build)
// counts the request on that store: its own `failed`, never an abort, whatever the build's overflow policy.
TEST(SceneGraphTest, RefusalsCountedByACallerLandOnTheFullStore) {
  Capacities c = testing::small_capacities();
  c.place_nodes = 1;
  auto g = make_graph(c);
  ASSERT_EQ(g->add_place(make_node_id('p', 0), place_at(0, 0, 1.0)), Status::kOk);
  g->count_refused_node(NodeKind::kPlace);
  g->count_refused_node(NodeKind::kPlace, 2);
  g->count_refused_edge();
  std::map<std::string, std::uint64_t> failed;
  g->for_each_resource([&](const memory::ResourceStats& s) { failed[s.name] = s.failed; });
  EXPECT_EQ(failed["scene_graph.places"], 3u);
  EXPECT_EQ(failed["scene_graph.nodes"], 0u);
  // The edge table has room here, so the refusal is its ends' adjacency chunks'.
  EXPECT_EQ(failed["scene_graph.adjacency_chunks"], 1u);
  EXPECT_EQ(failed["scene_graph.edges"], 0u);
  EXPECT_TRUE(g->has_node(make_node_id('p', 0)));
}

TEST(SceneGraphTest, SteadyStateUpdatesDoNotAllocate) {
  auto g = make_graph();
  // Warm-up is not needed: every store was carved at init().
  EXPECT_NO_ALLOCATIONS({
    for (int round = 0; round < 5; ++round) {
      for (int i = 0; i < 200; ++i) g->add_place(make_node_id('p', i), place_at(i, round, 1.0));
      for (int i = 1; i < 200; ++i) g->add_edge(make_node_id('p', i - 1), make_node_id('p', i), {1.0, true});
      g->add_room(kR0, RoomAttributes{});
      for (int i = 0; i < 200; ++i) g->add_edge(kR0, make_node_id('p', i));
      g->add_object(kO0, ObjectAttributes{});
      for (std::uint32_t v = 0; v < 500; ++v) g->append_mesh_connection(kO0, v);
      for (int i = 0; i < 200; ++i) g->remove_node(make_node_id('p', i));
      g->remove_node(kR0);
      g->remove_node(kO0);
    }
  });
  EXPECT_EQ(g->num_nodes(), 0u);
  EXPECT_EQ(g->num_edges(), 0u);
}

TEST(SceneGraphTest, BudgetCapacitiesInitialize) {
  SceneGraph g;
  std::string error;
  ASSERT_TRUE(g.init(capacities_from_budget(), arena_bytes_from_budget(), &error)) << error;
  EXPECT_EQ(g.capacities().object_nodes, capacities_from_budget().object_nodes);
}

// The open places (issue 37): after random adds, removals, parent edges made and dropped and is_active written
// through the writable access, for_each_open_place visits exactly the places that are active or have no parent, in
// for_each_node's order; for_each_node_of and for_each_child_record agree with the scans they replace.
TEST(SceneGraphTest, OpenPlacesAreTheActiveAndTheParentless) {
  auto g = make_graph();
  std::mt19937 rng(7);
  std::vector<NodeId> places, rooms;
  for (int i = 0; i < 4; ++i) {
    rooms.push_back(make_node_id('R', i));
    ASSERT_EQ(g->add_room(rooms.back(), RoomAttributes{}), Status::kOk);
  }
  std::uint64_t next = 0;
  for (int step = 0; step < 4000; ++step) {
    const int op = static_cast<int>(rng() % 6);
    if (op == 0 || places.size() < 8) {  // a new place, active or not
      PlaceAttributes p = place_at(static_cast<double>(next), 0.0, 1.0);
      p.is_active = rng() % 2 == 0;
      places.push_back(make_node_id('p', next++));
      ASSERT_EQ(g->add_place(places.back(), p), Status::kOk);
    } else if (op == 1) {  // a place removed
      const std::size_t k = rng() % places.size();
      ASSERT_TRUE(g->remove_node(places[k]));
      places.erase(places.begin() + static_cast<long>(k));
    } else if (op == 2) {  // a room takes a place
      const NodeId p = places[rng() % places.size()];
      if (g->parent(p) == kNoNode) {
        ASSERT_EQ(g->add_edge(rooms[rng() % rooms.size()], p), Status::kOk);
      }
    } else if (op == 3) {  // a place leaves its room
      const NodeId p = places[rng() % places.size()];
      if (g->parent(p) != kNoNode) {
        ASSERT_TRUE(g->remove_edge(g->parent(p), p));
      }
    } else if (op == 4) {  // is_active written (the writable access)
      g->place(places[rng() % places.size()])->is_active = rng() % 2 == 0;
    } else if (rng() % 50 == 0) {  // a room goes, with its parent edges
      const std::size_t k = rng() % rooms.size();
      ASSERT_TRUE(g->remove_node(rooms[k]));
      ASSERT_EQ(g->add_room(rooms[k], RoomAttributes{}), Status::kOk);
    }
    if (step % 97 != 0) continue;
    std::vector<NodeId> expected, open, of_kind;
    g->for_each_node([&](const NodeRecord& n) {
      if (n.kind != NodeKind::kPlace) return;
      of_kind.push_back(n.id);
      if (g->place_of(n)->is_active || n.parent == kNoNode) expected.push_back(n.id);
    });
    g->for_each_open_place([&](const NodeRecord& n, const PlaceAttributes& a) {
      EXPECT_TRUE(a.is_active || n.parent == kNoNode);
      open.push_back(n.id);
    });
    ASSERT_EQ(open, expected) << "step " << step;
    EXPECT_EQ(g->open_places_stats().in_use, expected.size());
    std::vector<NodeId> listed;
    g->for_each_node_of(NodeKind::kPlace, [&](const NodeRecord& n) { listed.push_back(n.id); });
    EXPECT_EQ(listed, of_kind);
    for (NodeId r : rooms) {
      std::set<NodeId> children, records;
      g->for_each_child(r, [&](NodeId c) { children.insert(c); });
      g->for_each_child_record(r, [&](std::uint32_t slot, const NodeRecord& c) {
        EXPECT_EQ(&g->node_at(slot), &c);
        records.insert(c.id);
      });
      EXPECT_EQ(records, children);
    }
  }
  // Reading a place through the const graph does not open it; writing through the writable access does.
  const NodeId p = places.front();
  if (g->parent(p) == kNoNode) {
    ASSERT_EQ(g->add_edge(rooms[0], p), Status::kOk);
  }
  g->place(p)->is_active = false;
  g->for_each_open_place([&](const NodeRecord&, const PlaceAttributes&) {});
  const std::size_t closed = g->open_places_stats().in_use;
  EXPECT_FALSE(static_cast<const SceneGraph&>(*g).place(p)->is_active);
  EXPECT_EQ(g->open_places_stats().in_use, closed);
  g->place(p)->is_active = true;
  EXPECT_EQ(g->open_places_stats().in_use, closed + 1);
  bool seen = false;
  g->for_each_open_place([&](const NodeRecord& n, const PlaceAttributes&) { seen = seen || n.id == p; });
  EXPECT_TRUE(seen);
  g->clear();
  EXPECT_EQ(g->open_places_stats().in_use, 0u);
}

// The grid of closed places and the rooms' sums (issue 37) agree with a scan after random adds, removals, parent
// edges made and dropped, rooms removed, and positions, clearances and is_active written through the writable
// access: the places in a box are exactly those a scan finds (at any time), and once the open places were iterated
// the grid holds exactly the inactive places with a parent and each room's sums are its closed children's.
TEST(SceneGraphTest, PlaceGridAgreesWithAScan) {
  auto g = make_graph();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> coord(-12.0, 12.0);
  std::vector<NodeId> places, rooms;
  for (int i = 0; i < 6; ++i) {
    rooms.push_back(make_node_id('R', i));
    ASSERT_EQ(g->add_room(rooms.back(), RoomAttributes{}), Status::kOk);
  }
  const auto random_place = [&] {
    PlaceAttributes p = place_at(coord(rng), coord(rng), 0.1 + 0.1 * static_cast<double>(rng() % 10));
    p.position_m.z() = static_cast<double>(rng() % 3) * 2.5;
    p.is_active = rng() % 3 == 0;
    return p;
  };
  std::uint64_t next = 0;
  std::size_t checks = 0;
  for (int step = 0; step < 6000; ++step) {
    const int op = static_cast<int>(rng() % 7);
    if ((op == 0 || places.size() < 16) && places.size() < 400) {
      places.push_back(make_node_id('p', next++));
      ASSERT_EQ(g->add_place(places.back(), random_place()), Status::kOk);
    } else if (op == 1 && !places.empty()) {
      const std::size_t k = rng() % places.size();
      ASSERT_TRUE(g->remove_node(places[k]));
      places.erase(places.begin() + static_cast<long>(k));
    } else if (op == 2) {
      const NodeId p = places[rng() % places.size()];
      if (g->parent(p) == kNoNode) {
        ASSERT_EQ(g->add_edge(rooms[rng() % rooms.size()], p), Status::kOk);
      }
    } else if (op == 3) {
      const NodeId p = places[rng() % places.size()];
      if (g->parent(p) != kNoNode && rng() % 3 == 0) {
        ASSERT_TRUE(g->remove_edge(g->parent(p), p));
      }
    } else if (op == 4) {  // moved (a loop closure's correction), clearance and activity rewritten
      PlaceAttributes* a = g->place(places[rng() % places.size()]);
      const PlaceAttributes moved = random_place();
      if (rng() % 2 == 0) a->position_m = moved.position_m;
      a->distance_m = moved.distance_m;
      a->is_active = moved.is_active;
    } else if (op == 5 && rng() % 40 == 0) {
      const std::size_t k = rng() % rooms.size();
      ASSERT_TRUE(g->remove_node(rooms[k]));
      ASSERT_EQ(g->add_room(rooms[k], RoomAttributes{}), Status::kOk);
    } else if (op == 6 && rng() % 4 == 0) {  // the room finder's window: the open places iterated, closed ones filed
      g->for_each_open_place([](const NodeRecord&, const PlaceAttributes&) {});
    }
    if (step % 23 != 0) continue;
    ++checks;
    // A random box (sometimes empty, sometimes larger than the grid): the places in it, each once.
    double lo[3], hi[3];
    for (int d = 0; d < 3; ++d) {
      lo[d] = coord(rng) * (d == 2 ? 0.4 : 1.0);
      hi[d] = lo[d] + std::abs(coord(rng)) * (step % 5 == 0 ? 10.0 : 0.5);
    }
    if (step % 7 == 0) hi[0] = lo[0] - 1.0;
    const auto inside = [&](const PlaceAttributes& a) {
      for (int d = 0; d < 3; ++d)
        if (!(a.position_m[d] >= lo[d] && a.position_m[d] <= hi[d])) return false;
      return true;
    };
    std::multiset<NodeId> expected, found;
    g->for_each_node_of(NodeKind::kPlace, [&](const NodeRecord& n) {
      if (inside(*g->place_of(n))) expected.insert(n.id);
    });
    g->for_each_place_in_box(lo, hi, [&](std::uint32_t slot, const NodeRecord& n, const PlaceAttributes& a) {
      EXPECT_EQ(&g->node_at(slot), &n);
      EXPECT_EQ(g->place_of(n), &a);
      found.insert(n.id);
    });
    ASSERT_EQ(found, expected) << "step " << step;
    if (step % 2 != 0) continue;
    // After the open places' iteration: the grid holds exactly the closed places, the rooms' sums are theirs.
    g->for_each_open_place([](const NodeRecord&, const PlaceAttributes&) {});
    std::set<NodeId> closed_in_box, near;
    std::size_t closed = 0;
    std::map<NodeId, ChildSums> sums;
    for (NodeId r : rooms) sums[r].reset();
    g->for_each_node_of(NodeKind::kPlace, [&](const NodeRecord& n) {
      const PlaceAttributes& a = *g->place_of(n);
      if (a.is_active || n.parent == kNoNode) return;
      ++closed;
      if (inside(a)) closed_in_box.insert(n.id);
      ChildSums& s = sums[n.parent];
      for (int d = 0; d < 3; ++d) s.sum[d] += child_sum_units(a.position_m[d]);
      ++s.count;
    });
    EXPECT_EQ(g->num_closed_places(), closed);
    g->for_each_closed_place_near(lo, hi, [&](std::uint32_t, const NodeRecord& n, const PlaceAttributes& a) {
      EXPECT_FALSE(a.is_active || n.parent == kNoNode) << "an open place in the grid";
      EXPECT_TRUE(near.insert(n.id).second) << "a place in the grid twice";
    });
    for (NodeId id : closed_in_box) EXPECT_EQ(near.count(id), 1u) << "a closed place in the box not found";
    for (NodeId r : rooms) {
      const ChildSums& s = g->closed_child_sums(r);
      ASSERT_EQ(s.count, sums[r].count) << "room " << r << " step " << step;
      for (int d = 0; d < 3; ++d) EXPECT_EQ(s.sum[d], sums[r].sum[d]);
    }
  }
  EXPECT_GT(checks, 200u);
  // Each room's box holds its closed children's spheres.
  g->for_each_open_place([](const NodeRecord&, const PlaceAttributes&) {});
  const SceneGraph& cg = *g;
  for (NodeId r : rooms) {
    const ChildSums& s = cg.closed_child_sums(r);
    cg.for_each_child(r, [&](NodeId c) {
      const PlaceAttributes& a = *cg.place(c);
      if (a.is_active) return;
      for (int d = 0; d < 3; ++d) {
        EXPECT_LE(s.min[d], a.position_m[d] - a.distance_m);
        EXPECT_GE(s.max[d], a.position_m[d] + a.distance_m);
      }
    });
  }
  std::size_t cells = 0;
  g->for_each_resource([&](const memory::ResourceStats& st) {
    if (std::string(st.name) == "scene_graph.place_grid") cells = st.in_use;
  });
  EXPECT_GT(cells, 0u);
  EXPECT_LE(cells, g->num_closed_places());
}

}  // namespace
}  // namespace qsg::scene_graph
