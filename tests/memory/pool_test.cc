// Pool: stable handles, reuse, statistics, both overflow policies.
#include "core/memory/pool.h"

#include <gtest/gtest.h>

#include <set>

#include "tests/support/allocation_counter.h"

namespace qsg::memory {
namespace {

struct Item {
  int value = 0;
  explicit Item(int v = 0) : value(v) {}
};

class PoolTest : public ::testing::Test {
 protected:
  void make(Pool<Item>& pool, std::size_t capacity) {
    ArenaPlan plan;
    Pool<Item>::plan(plan, capacity);
    ASSERT_TRUE(arena_.create("pool_test", plan, 1 << 20, nullptr));
    ASSERT_TRUE(pool.carve(arena_, capacity));
    ASSERT_TRUE(arena_.seal());
  }
  Arena arena_;
};

TEST_F(PoolTest, AcquireReleaseReuseAndStats) {
  Pool<Item> pool("items");
  make(pool, 4);
  std::set<std::uint32_t> handles;
  for (int i = 0; i < 4; ++i) handles.insert(pool.acquire(i));
  EXPECT_EQ(handles.size(), 4u);
  EXPECT_TRUE(pool.full());
  pool.release(*handles.begin());
  EXPECT_EQ(pool.size(), 3u);
  const std::uint32_t again = pool.acquire(42);
  EXPECT_EQ(again, *handles.begin());
  EXPECT_EQ(pool[again].value, 42);
  const ResourceStats s = pool.stats();
  EXPECT_STREQ(s.name, "items");
  EXPECT_EQ(s.capacity, 4u);
  EXPECT_EQ(s.in_use, 4u);
  EXPECT_EQ(s.high_water, 4u);
  EXPECT_EQ(s.failed, 0u);
}

TEST_F(PoolTest, RefusePolicyCountsAndReturnsInvalid) {
  Pool<Item> pool("refusing", OverflowPolicy::kRefuse);
  make(pool, 2);
  pool.acquire(1);
  pool.acquire(2);
  EXPECT_EQ(pool.acquire(3), kInvalidHandle);
  EXPECT_EQ(pool.acquire(4), kInvalidHandle);
  EXPECT_EQ(pool.stats().failed, 2u);
  EXPECT_EQ(pool.size(), 2u);
}

TEST_F(PoolTest, AbortPolicyDies) {
  Pool<Item> pool("aborting", OverflowPolicy::kAbort);
  make(pool, 1);
  pool.acquire(1);
  EXPECT_DEATH(pool.acquire(2), "'aborting' is full");
}

TEST_F(PoolTest, SteadyStateChurnDoesNotAllocate) {
  Pool<Item> pool("churn");
  make(pool, 64);
  EXPECT_NO_ALLOCATIONS({
    for (int round = 0; round < 100; ++round) {
      std::uint32_t h[64];
      for (int i = 0; i < 64; ++i) h[i] = pool.acquire(i);
      for (int i = 0; i < 64; ++i) pool.release(h[i]);
    }
  });
  EXPECT_EQ(pool.size(), 0u);
}

}  // namespace
}  // namespace qsg::memory
