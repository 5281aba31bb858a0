// FixedVector / ArenaVector through the size-erased VectorView.
#include "core/memory/fixed_vector.h"

#include <gtest/gtest.h>

#include <string>

#include "tests/support/allocation_counter.h"

namespace qsg::memory {
namespace {

// Takes any capacity: no template parameter for the size.
int sum(const VectorView<int>& v) {
  int s = 0;
  for (int x : v) s += x;
  return s;
}
bool fill(VectorView<int>& v, int n) {
  for (int i = 0; i < n; ++i)
    if (!v.push_back(i)) return false;
  return true;
}

TEST(FixedVectorTest, SizeErasedViewWorksForAnyCapacity) {
  FixedVector<int, 4> small("small");
  FixedVector<int, 100> large("large");
  EXPECT_TRUE(fill(small, 4));
  EXPECT_TRUE(fill(large, 100));
  EXPECT_EQ(sum(small), 6);
  EXPECT_EQ(sum(large), 4950);
}

TEST(FixedVectorTest, RefuseKeepsContentAndCounts) {
  FixedVector<int, 3> v("refusing", OverflowPolicy::kRefuse);
  EXPECT_FALSE(fill(v, 5));
  EXPECT_EQ(v.size(), 3u);
  EXPECT_EQ(v.stats().failed, 1u);
  EXPECT_EQ(v.stats().high_water, 3u);
  v.swap_erase(0);
  EXPECT_EQ(v.size(), 2u);
  EXPECT_EQ(v[0], 2);
  v.erase(0);
  EXPECT_EQ(v[0], 1);
}

TEST(FixedVectorTest, AbortPolicyDies) {
  FixedVector<int, 1> v("one", OverflowPolicy::kAbort);
  v.push_back(1);
  EXPECT_DEATH(v.push_back(2), "'one' is full");
}

TEST(FixedVectorTest, NonTrivialElementsAreDestroyed) {
  FixedVector<std::string, 4> v("strings");
  v.push_back(std::string(100, 'x'));
  v.emplace_back(50, 'y');
  v.pop_back();
  v.clear();
  EXPECT_TRUE(v.empty());
}

TEST(FixedVectorTest, ArenaVectorCarvesAndDoesNotAllocate) {
  ArenaPlan plan;
  ArenaVector<double>::plan(plan, 256);
  Arena arena;
  ASSERT_TRUE(arena.create("vec", plan, 1 << 16, nullptr));
  ArenaVector<double> v("samples");
  ASSERT_TRUE(v.carve(arena, 256));
  ASSERT_TRUE(arena.seal());
  EXPECT_NO_ALLOCATIONS({
    for (int round = 0; round < 10; ++round) {
      for (int i = 0; i < 256; ++i) v.push_back(i * 0.5);
      v.clear();
    }
  });
  EXPECT_EQ(v.capacity(), 256u);
}

}  // namespace
}  // namespace qsg::memory
