// The places' neighbour limit (kMaxClusterEdges): a place among more candidate neighbours than it can hold keeps the
// best (GVD before free-space before bridge, nearer before farther) and nothing is refused for want of a slot
// (issue 36: places.edges_refused grew over the soak, bench/results/soak.md).
#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <utility>
#include <memory>
#include <string>
#include <vector>

#include "core/places/places.h"
#include "tests/places/places_test_support.h"
#include "tests/places/places_test_world.h"
#include "tests/support/allocation_counter.h"

namespace qsg::places {
namespace {

using testing::Scanner;

// A room cluttered with small boxes at several heights (a storeroom: shelves, crates), scanned, then scanned again
// with the pose off by a drift: its GVD breaks into many small pieces whose free-space spheres overlap.
struct Cluttered {
  Scanner scanner;
  std::unique_ptr<Places> places;
};

// check_allocations: every update() of the drifted scans runs under the allocation counter.
std::unique_ptr<Cluttered> map_cluttered_room(const Config& config, bool check_allocations = false) {
  world::World w = testing::rooms_world({6.0}, 6.0, false);
  for (int i = 0; i < 7; ++i)
    for (int j = 0; j < 7; ++j) {
      if (i == 3 && j == 3) continue;  // room for the camera
      const double x = 0.5 + 0.8 * i, y = 0.5 + 0.8 * j, z = 0.2 + 0.35 * ((i * 3 + j) % 5);
      testing::add_box(&w, {x, y, z}, {x + 0.25, y + 0.25, z + 0.25});
    }
  auto m = std::make_unique<Cluttered>();
  std::string error;
  EXPECT_TRUE(m->scanner.init(w, 100.0, &error)) << error;
  m->places = testing::make_places(config);
  bool drifted = false;
  const auto update = [&](const Eigen::Vector3d& camera) {
    if (drifted && check_allocations) {
      EXPECT_NO_ALLOCATIONS(testing::run_to_completion(m->places.get(), m->scanner.tsdf(), camera));
    } else {
      testing::run_to_completion(m->places.get(), m->scanner.tsdf(), camera);
    }
  };
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(3.0, 3.0, 1.2), Eigen::Vector3d(1.5, 1.5, 1.2),
                                   Eigen::Vector3d(4.5, 4.5, 1.2)})
    EXPECT_TRUE(m->scanner.spin(p, 8, update));
  m->scanner.set_pose_error({0.15, -0.1, 0.05});
  drifted = true;
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(3.0, 3.0, 1.2), Eigen::Vector3d(4.5, 1.5, 1.2)})
    EXPECT_TRUE(m->scanner.spin(p, 8, update));
  return m;
}

// Before the limit kept the best edges, every candidate past it was refused: this room refused 76 (edges_refused),
// and a long mission's soak saw the count grow with every revisit (bench/results/soak.md). Now nothing is refused,
// the place keeps its best edges, the lists stay symmetric and within the limit, and the room stays one component.
TEST(PlacesDegreeTest, APlaceAtItsNeighbourLimitKeepsItsBestEdgesAndRefusesNone) {
  auto m = map_cluttered_room(Config{});
  const Counters& c = m->places->counters();
  EXPECT_GT(c.edges_pruned, 0u) << "the room must crowd some place past kMaxClusterEdges candidates";
  EXPECT_EQ(c.edges_refused, 0u);
  std::vector<PlaceInfo> places;
  m->places->places(&places);
  std::map<scene_graph::NodeId, const PlaceInfo*> by_id;
  for (const PlaceInfo& p : places) by_id[p.id] = &p;
  std::size_t at_limit = 0;
  for (const PlaceInfo& p : places) {
    std::vector<std::pair<scene_graph::NodeId, double>> all = p.edges;
    all.insert(all.end(), p.free_space_edges.begin(), p.free_space_edges.end());
    all.insert(all.end(), p.bridge_edges.begin(), p.bridge_edges.end());
    EXPECT_LE(all.size(), static_cast<std::size_t>(kMaxClusterEdges));
    at_limit += all.size() == static_cast<std::size_t>(kMaxClusterEdges) ? 1 : 0;
    for (const auto& e : all) {
      ASSERT_EQ(by_id.count(e.first), 1u);
      const PlaceInfo& q = *by_id[e.first];
      std::size_t back = 0;
      for (const auto* list : {&q.edges, &q.free_space_edges, &q.bridge_edges})
        for (const auto& f : *list) back += f.first == p.id ? 1 : 0;
      EXPECT_EQ(back, 1u) << "edge lists not symmetric";
    }
  }
  std::printf("cluttered room: %zu places, %zu at the limit, %llu candidates pruned\n", places.size(), at_limit,
              static_cast<unsigned long long>(c.edges_pruned));
  EXPECT_GT(at_limit, 0u);
  auto graph = testing::make_graph();
  m->places->sync(graph.get());
  EXPECT_EQ(testing::place_components(*graph), 1u) << "one room, one free-space region";
}

// The limit's policy works in the fixed edge arrays: the drifted scans, where it prunes, do not allocate.
TEST(PlacesDegreeTest, KeepingTheBestEdgesDoesNotAllocate) {
  auto m = map_cluttered_room(Config{}, true);
  EXPECT_GT(m->places->counters().edges_pruned, 0u);
  EXPECT_EQ(m->places->counters().edges_refused, 0u);
}

}  // namespace
}  // namespace qsg::places
