// The allocation hook itself must be able to fail a test.
#include "tests/support/allocation_counter.h"

#include <gtest/gtest.h>
#include <gtest/gtest-spi.h>

#include <memory>
#include <vector>

namespace qsg::testing {
namespace {

TEST(AllocationCounterTest, CountsOperatorNew) {
  AllocationCounter counter;
  auto p = std::make_unique<int>(3);
  std::vector<double> v(100);
  // Keep the optimiser from eliding the allocations (clang does at -O3 when the objects go unused).
  asm volatile("" : : "r"(p.get()), "r"(v.data()) : "memory");
  EXPECT_GE(counter.allocations(), 2u);
  EXPECT_GE(counter.bytes(), sizeof(int) + 100 * sizeof(double));
}

TEST(AllocationCounterTest, MacroFailsWhenRegionAllocates) {
  EXPECT_NONFATAL_FAILURE(EXPECT_NO_ALLOCATIONS({ std::vector<int> v(10); }), "steady-state region allocated");
}

TEST(AllocationCounterTest, MacroPassesWhenRegionDoesNotAllocate) {
  int x = 0;
  EXPECT_NO_ALLOCATIONS({ for (int i = 0; i < 10; ++i) x += i; });
  EXPECT_EQ(x, 45);
}

}  // namespace
}  // namespace qsg::testing
