// FixedHashMap / SpatialHash: against std::unordered_map under random churn, erase correctness, limits.
#include "core/memory/fixed_hash_map.h"

#include <gtest/gtest.h>

#include <random>
#include <unordered_map>
#include <vector>

#include "tests/support/allocation_counter.h"

namespace qsg::memory {
namespace {

struct KeyHash {
  std::size_t operator()(const Index3& k) const { return Index3Hash{}(k); }
};

class SpatialHashTest : public ::testing::Test {
 protected:
  void make(SpatialHash<std::uint32_t>& map, std::size_t slots, std::size_t max_entries) {
    ArenaPlan plan;
    SpatialHash<std::uint32_t>::plan(plan, slots);
    ASSERT_TRUE(arena_.create("hash_test", plan, 1 << 24, nullptr));
    ASSERT_TRUE(map.carve(arena_, slots, max_entries));
    ASSERT_TRUE(arena_.seal());
  }
  Arena arena_;
};

TEST_F(SpatialHashTest, MatchesReferenceUnderRandomChurn) {
  SpatialHash<std::uint32_t> map("blocks");
  make(map, 1024, 900);
  std::unordered_map<Index3, std::uint32_t, KeyHash> reference;
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> coord(-8, 8);
  for (int step = 0; step < 50000; ++step) {
    const Index3 k{coord(rng), coord(rng), coord(rng) / 4};
    const int op = static_cast<int>(rng() % 3);
    if (op == 0 && reference.size() < 900) {
      const auto v = static_cast<std::uint32_t>(step);
      ASSERT_NE(map.insert(k, v), nullptr);
      reference[k] = v;
    } else if (op == 1) {
      EXPECT_EQ(map.erase(k), reference.erase(k) == 1);
    } else {
      const std::uint32_t* found = map.find(k);
      const auto it = reference.find(k);
      ASSERT_EQ(found != nullptr, it != reference.end());
      if (found != nullptr) {
        EXPECT_EQ(*found, it->second);
      }
    }
    ASSERT_EQ(map.size(), reference.size());
  }
  std::size_t visited = 0;
  map.for_each([&](const Index3& k, std::uint32_t v) {
    ++visited;
    EXPECT_EQ(reference.at(k), v);
  });
  EXPECT_EQ(visited, reference.size());
}

TEST_F(SpatialHashTest, EraseKeepsCollidingEntriesReachable) {
  SpatialHash<std::uint32_t> map("collide");
  make(map, 16, 15);
  std::vector<Index3> keys;
  for (int i = 0; i < 15; ++i) keys.push_back({i, -i, 2 * i});
  for (std::size_t i = 0; i < keys.size(); ++i) ASSERT_NE(map.insert(keys[i], static_cast<std::uint32_t>(i)), nullptr);
  for (std::size_t i = 0; i < keys.size(); i += 2) ASSERT_TRUE(map.erase(keys[i]));
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const std::uint32_t* v = map.find(keys[i]);
    if (i % 2 == 0) {
      EXPECT_EQ(v, nullptr);
    } else {
      ASSERT_NE(v, nullptr) << "key " << i << " lost after erase";
      EXPECT_EQ(*v, i);
    }
  }
}

TEST_F(SpatialHashTest, FullMapRefusesAndReports) {
  SpatialHash<std::uint32_t> map("full", OverflowPolicy::kRefuse);
  make(map, 8, 100);  // capacity is clamped to slots - 1: a probe run always ends
  EXPECT_EQ(map.capacity(), 7u);
  for (int i = 0; i < 7; ++i) ASSERT_NE(map.insert({i, 0, 0}, 1), nullptr);
  EXPECT_EQ(map.insert({99, 0, 0}, 1), nullptr);
  EXPECT_EQ(map.stats().failed, 1u);
  EXPECT_EQ(map.find({98, 0, 0}), nullptr);  // terminates on a full table
  ASSERT_NE(map.insert({3, 0, 0}, 5), nullptr) << "overwriting an existing key needs no room";
  EXPECT_EQ(*map.find({3, 0, 0}), 5u);
}

TEST_F(SpatialHashTest, SlotsForKeepsLoadAtMostThreeQuarters) {
  for (std::size_t n : {1u, 3u, 100u, 1000u, 65536u}) {
    const std::size_t slots = SpatialHash<std::uint32_t>::slots_for(n);
    EXPECT_EQ(slots & (slots - 1), 0u);
    EXPECT_LE(n * 4, slots * 3);
  }
}

TEST_F(SpatialHashTest, SteadyStateDoesNotAllocate) {
  SpatialHash<std::uint32_t> map("steady");
  make(map, 4096, 3000);
  EXPECT_NO_ALLOCATIONS({
    for (int round = 0; round < 20; ++round) {
      for (int i = 0; i < 3000; ++i) map.insert({i, round, -i}, static_cast<std::uint32_t>(i));
      for (int i = 0; i < 3000; ++i) map.erase({i, round, -i});
    }
  });
  EXPECT_TRUE(map.empty());
  EXPECT_EQ(map.stats().high_water, 3000u);
}

}  // namespace
}  // namespace qsg::memory
