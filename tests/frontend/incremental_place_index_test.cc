// The incremental nearest-place index against brute force after many random inserts, moves and removals, without
// allocating; its capacity, failures, filter, far queries and sweep.
#include "core/frontend/incremental_place_index.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "tests/support/allocation_counter.h"

namespace qsg::frontend {
namespace {

using scene_graph::make_node_id;
using scene_graph::NodeId;

std::unique_ptr<IncrementalPlaceIndex> make_index(std::size_t capacity, double cell_m = 1.0) {
  auto index = std::make_unique<IncrementalPlaceIndex>();
  std::string error;
  const NearestPlaceCapacities c{capacity};
  EXPECT_TRUE(index->init(c, IncrementalPlaceIndex::plan(c).total_bytes(), &error, cell_m)) << error;
  return index;
}

// The k nearest of `held` to q by (distance, id), among those keep accepts.
template <typename Keep>
std::vector<std::pair<double, NodeId>> brute_force(const std::map<NodeId, Eigen::Vector3d>& held,
                                                   const Eigen::Vector3d& q, std::size_t k, Keep keep) {
  std::vector<std::pair<double, NodeId>> all;
  for (const auto& [id, p] : held)
    if (keep(id)) all.emplace_back((p - q).squaredNorm(), id);
  std::sort(all.begin(), all.end());
  if (all.size() > k) all.resize(k);
  return all;
}

void expect_same(const IncrementalPlaceIndex& index, const std::map<NodeId, Eigen::Vector3d>& held,
                 const Eigen::Vector3d& q, std::size_t k) {
  const auto truth = brute_force(held, q, k, [](NodeId) { return true; });
  PlaceNeighbor out[IncrementalPlaceIndex::kMaxK];
  const std::size_t n = index.nearest(q, k, out);
  ASSERT_EQ(n, truth.size()) << "query " << q.transpose();
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_EQ(out[i].id, truth[i].second) << "neighbour " << i << " of query " << q.transpose();
    EXPECT_DOUBLE_EQ(out[i].distance_m, std::sqrt(truth[i].first));
  }
}

TEST(IncrementalPlaceIndexTest, SameNeighboursAsBruteForceAfterManyRandomUpdates) {
  std::mt19937 rng(37);
  auto index = make_index(3000);
  std::map<NodeId, Eigen::Vector3d> held;
  std::uniform_real_distribution<double> x(-40.0, 40.0), y(-15.0, 15.0), z(0.0, 6.0), u(0.0, 1.0);
  std::uniform_real_distribution<double> jitter(-2.0, 2.0);
  std::uint64_t next_id = 1;
  const auto random_held = [&]() {
    auto it = held.begin();
    std::advance(it, std::uniform_int_distribution<std::size_t>(0, held.size() - 1)(rng));
    return it->first;
  };
  for (int round = 0; round < 40; ++round) {
    // A burst of changes: mostly inserts early, then as many removals and moves as inserts.
    for (int op = 0; op < 400; ++op) {
      const double r = u(rng);
      if (held.empty() || (r < 0.5 && held.size() < 2500)) {
        const NodeId id = make_node_id('p', next_id++);
        const Eigen::Vector3d p(x(rng), y(rng), z(rng));
        ASSERT_TRUE(index->upsert(id, p));
        held[id] = p;
      } else if (r < 0.75) {
        const NodeId id = random_held();
        ASSERT_TRUE(index->remove(id));
        held.erase(id);
      } else {
        // A move: small (the same or the next column) or across the map.
        const NodeId id = random_held();
        const Eigen::Vector3d p = u(rng) < 0.5 ? Eigen::Vector3d(held[id] + Eigen::Vector3d(jitter(rng), jitter(rng), 0.0))
                                               : Eigen::Vector3d(x(rng), y(rng), z(rng));
        ASSERT_TRUE(index->upsert(id, p));
        held[id] = p;
      }
    }
    ASSERT_EQ(index->size(), held.size());
    for (int q = 0; q < 50; ++q) {
      const Eigen::Vector3d query(1.2 * x(rng), 1.2 * y(rng), z(rng));  // some outside the points' box
      for (const std::size_t k : {1u, 8u, 16u}) expect_same(*index, held, query, k);
    }
  }
  // Emptied completely, then refilled: the same answers.
  while (!held.empty()) {
    const NodeId id = held.begin()->first;
    ASSERT_TRUE(index->remove(id));
    held.erase(id);
  }
  EXPECT_EQ(index->size(), 0u);
  PlaceNeighbor out[4];
  EXPECT_EQ(index->nearest(Eigen::Vector3d::Zero(), 4, out), 0u);
  for (int i = 0; i < 200; ++i) {
    const NodeId id = make_node_id('p', next_id++);
    held[id] = Eigen::Vector3d(x(rng), y(rng), z(rng));
    ASSERT_TRUE(index->upsert(id, held[id]));
  }
  for (int q = 0; q < 50; ++q) expect_same(*index, held, Eigen::Vector3d(x(rng), y(rng), z(rng)), 8);
}

TEST(IncrementalPlaceIndexTest, UpdatesAndQueriesDoNotAllocate) {
  auto index = make_index(1000);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  PlaceNeighbor out[8];
  std::size_t found = 0;
  {
    testing::AllocationCounter counter;
    for (int i = 0; i < 3000; ++i) {
      const NodeId id = make_node_id('p', static_cast<std::uint64_t>(i % 900));
      if (i % 7 == 3) index->remove(id);
      else index->upsert(id, Eigen::Vector3d(u(rng), u(rng), 0.0));
      found += index->nearest(Eigen::Vector3d(u(rng), u(rng), 0.0), 8, out);
    }
    index->sweep(100, [](NodeId, const Eigen::Vector3d&, Eigen::Vector3d*) { return 0; });
    EXPECT_EQ(counter.allocations(), 0u);
  }
  EXPECT_GT(found, 0u);
}

TEST(IncrementalPlaceIndexTest, FullIndexCountsRefusalsAndReportsItsUse) {
  auto index = make_index(10);
  for (int i = 0; i < 10; ++i) EXPECT_TRUE(index->upsert(make_node_id('p', i), Eigen::Vector3d(i, 0, 0)));
  EXPECT_FALSE(index->upsert(make_node_id('p', 10), Eigen::Vector3d(10, 0, 0)));
  EXPECT_TRUE(index->upsert(make_node_id('p', 3), Eigen::Vector3d(3, 5, 0)));  // a move still fits
  EXPECT_TRUE(index->remove(make_node_id('p', 0)));
  EXPECT_FALSE(index->remove(make_node_id('p', 0)));
  EXPECT_TRUE(index->upsert(make_node_id('p', 10), Eigen::Vector3d(10, 0, 0)));
  // A non-finite position is refused; a held place given one leaves the index.
  EXPECT_FALSE(index->upsert(make_node_id('p', 4), Eigen::Vector3d(std::nan(""), 0, 0)));
  EXPECT_FALSE(index->contains(make_node_id('p', 4)));
  index->set_name("test.index");
  const memory::ResourceStats s = index->stats();
  EXPECT_STREQ(s.name, "test.index");
  EXPECT_EQ(s.capacity, 10u);
  EXPECT_EQ(s.in_use, 9u);
  EXPECT_EQ(s.high_water, 10u);
  EXPECT_EQ(s.failed, 2u);
  Eigen::Vector3d p;
  ASSERT_TRUE(index->position(make_node_id('p', 3), &p));
  EXPECT_EQ(p, Eigen::Vector3d(3, 5, 0));
  EXPECT_FALSE(index->position(make_node_id('p', 0), &p));
}

TEST(IncrementalPlaceIndexTest, FilterSkipsPlacesAndFarQueriesStillFindTheNearest) {
  auto index = make_index(100);
  std::map<NodeId, Eigen::Vector3d> held;
  for (int i = 0; i < 20; ++i) {
    held[make_node_id('p', i)] = Eigen::Vector3d(0.5 * i, 0.0, 0.0);
    index->upsert(make_node_id('p', i), held[make_node_id('p', i)]);
  }
  // One place kilometres away (a drifted pose): its own column, far beyond the rings a query walks.
  held[make_node_id('p', 99)] = Eigen::Vector3d(5000.0, -3000.0, 0.0);
  index->upsert(make_node_id('p', 99), held[make_node_id('p', 99)]);
  const auto even = [](NodeId id) { return scene_graph::node_index(id) % 2 == 0; };
  PlaceNeighbor out[8];
  const Eigen::Vector3d q(3.1, 0.4, 0.0);
  const std::size_t n = index->nearest(q, 5, out, even);
  const auto truth = brute_force(held, q, 5, even);
  ASSERT_EQ(n, truth.size());
  for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(out[i].id, truth[i].second);
  // Near the far place and far from the rest: both ends are found (the nearest first).
  for (const Eigen::Vector3d& far : {Eigen::Vector3d(4990.0, -2990.0, 0.0), Eigen::Vector3d(2500.0, -1500.0, 0.0)})
    expect_same(*index, held, far, 3);
  // Equal distances: the smaller id first, whatever the insertion order.
  auto ties = make_index(10);
  ties->upsert(make_node_id('p', 7), Eigen::Vector3d(1, 0, 0));
  ties->upsert(make_node_id('p', 2), Eigen::Vector3d(-1, 0, 0));
  ASSERT_EQ(ties->nearest(Eigen::Vector3d::Zero(), 1, out), 1u);
  EXPECT_EQ(out[0].id, make_node_id('p', 2));
}

TEST(IncrementalPlaceIndexTest, SweepRemovesAndMovesWhatTheCallerSays) {
  auto index = make_index(64);
  for (int i = 0; i < 40; ++i) index->upsert(make_node_id('p', i), Eigen::Vector3d(i, 0, 0));
  std::size_t visited = 0;
  // Sweeps of 32 and 8 slots cover the 40 held places once: ids divisible by 5 are gone, those by 3 moved up 10 m.
  for (const std::size_t slots : {32u, 8u})
    visited += index->sweep(slots, [](NodeId id, const Eigen::Vector3d& p, Eigen::Vector3d* moved_to) {
      const std::uint64_t i = scene_graph::node_index(id);
      if (i % 5 == 0) return 1;
      if (i % 3 == 0 && p.y() == 0.0) return *moved_to = p + Eigen::Vector3d(0, 10, 0), 2;
      return 0;
    });
  EXPECT_EQ(visited, 40u);
  EXPECT_EQ(index->size(), 32u);
  EXPECT_FALSE(index->contains(make_node_id('p', 10)));
  Eigen::Vector3d p;
  ASSERT_TRUE(index->position(make_node_id('p', 9), &p));
  EXPECT_EQ(p, Eigen::Vector3d(9, 10, 0));
  PlaceNeighbor out[1];
  ASSERT_EQ(index->nearest(Eigen::Vector3d(9, 10, 0), 1, out), 1u);
  EXPECT_EQ(out[0].id, make_node_id('p', 9));
}

TEST(IncrementalPlaceIndexTest, BadInitIsAClearError) {
  IncrementalPlaceIndex index;
  std::string error;
  EXPECT_FALSE(index.init(NearestPlaceCapacities{0}, 1 << 20, &error));
  EXPECT_NE(error.find("capacities.places"), std::string::npos) << error;
  EXPECT_FALSE(index.init(NearestPlaceCapacities{10}, 1 << 20, &error, 0.0));
  EXPECT_NE(error.find("cell_m"), std::string::npos) << error;
  EXPECT_FALSE(index.upsert(make_node_id('p', 1), Eigen::Vector3d::Zero()));  // not initialised: refused
}

}  // namespace
}  // namespace qsg::frontend
