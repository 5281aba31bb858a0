// Arena: planned carve, budget check, exact end check, refusal after seal.
#include "core/memory/arena.h"

#include <gtest/gtest.h>

#include <cstdint>

namespace qsg::memory {
namespace {

TEST(ArenaTest, PlanAndCarveEndExactly) {
  ArenaPlan plan;
  plan.add_array<std::uint8_t>(3);
  plan.add_array<double>(5);
  plan.add_array<std::uint32_t>(7);
  Arena arena;
  std::string error;
  ASSERT_TRUE(arena.create("test", plan, 1 << 20, &error)) << error;
  EXPECT_EQ(arena.capacity_bytes(), plan.total_bytes());
  auto* a = arena.carve_array<std::uint8_t>(3);
  auto* b = arena.carve_array<double>(5);
  auto* c = arena.carve_array<std::uint32_t>(7);
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(b) % alignof(double), 0u);
  EXPECT_TRUE(arena.seal());
  EXPECT_EQ(arena.used_bytes(), arena.capacity_bytes());
  EXPECT_EQ(arena.stats().high_water, arena.capacity_bytes());
  EXPECT_EQ(arena.stats().failed, 0u);
}

TEST(ArenaTest, RefusesPlanOverBudgetWithReason) {
  ArenaPlan plan;
  plan.add_array<double>(1000);
  Arena arena;
  std::string error;
  EXPECT_FALSE(arena.create("small", plan, 100, &error));
  EXPECT_NE(error.find("small"), std::string::npos);
  EXPECT_NE(error.find("8000"), std::string::npos);
}

TEST(ArenaTest, NestedPlansCompose) {
  ArenaPlan inner;
  inner.add_array<std::uint8_t>(1);
  ArenaPlan outer;
  outer.add_array<std::uint8_t>(1);
  outer.add_plan(inner);
  outer.add_array<std::uint16_t>(1);
  Arena arena;
  ASSERT_TRUE(arena.create("nested", outer, 1 << 10, nullptr));
  arena.carve_array<std::uint8_t>(1);
  arena.align_to_plan_boundary();
  arena.carve_array<std::uint8_t>(1);
  arena.align_to_plan_boundary();
  arena.carve_array<std::uint16_t>(1);
  EXPECT_TRUE(arena.seal());
}

TEST(ArenaTest, CarveMismatchIsCaughtBySeal) {
  ArenaPlan plan;
  plan.add_array<double>(16);
  Arena arena;
  ASSERT_TRUE(arena.create("mismatch", plan, 1 << 10, nullptr));
  arena.carve_array<double>(8);  // carves less than planned
  if (kBuildOverflowPolicy == OverflowPolicy::kAbort) {
    EXPECT_DEATH(arena.seal(), "carve ended at byte");
  } else {
    EXPECT_FALSE(arena.seal());
  }
}

TEST(ArenaTest, OverflowAbortsWithClearMessage) {
  ArenaPlan plan;
  plan.add_array<double>(2);
  Arena arena;
  ASSERT_TRUE(arena.create("tiny", plan, 1 << 10, nullptr));
  if (kBuildOverflowPolicy == OverflowPolicy::kAbort) {
    EXPECT_DEATH(arena.carve_array<double>(100), "'tiny' is full");
  } else {  // release builds count and refuse
    EXPECT_EQ(arena.carve_array<double>(100), nullptr);
    EXPECT_EQ(arena.stats().failed, 1u);
  }
}

TEST(ArenaTest, NothingCarvesAfterSeal) {
  ArenaPlan plan;
  Arena arena;
  ASSERT_TRUE(arena.create("sealed", plan, 0, nullptr));
  EXPECT_TRUE(arena.seal());
  if (kBuildOverflowPolicy == OverflowPolicy::kAbort) {
    EXPECT_DEATH(arena.carve_bytes(8, 8), "'sealed' is full");
  } else {
    EXPECT_EQ(arena.carve_bytes(8, 8), nullptr);
  }
}

}  // namespace
}  // namespace qsg::memory
