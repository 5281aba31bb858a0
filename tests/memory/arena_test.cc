// Arena: planned carve, budget check, exact end check, refusal after seal.
#include "core/memory/arena.h"

#include <gtest/gtest.h>

#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <new>

#include "tests/support/emulation.h"

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

// Minor page faults this thread has taken so far (Linux: RUSAGE_THREAD).
std::uint64_t thread_minor_faults() {
  rusage usage{};
  getrusage(RUSAGE_THREAD, &usage);
  return static_cast<std::uint64_t>(usage.ru_minflt);
}

bool sanitized() {
#if defined(__SANITIZE_ADDRESS__)
  return true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(memory_sanitizer)
  return true;
#endif
#endif
  return false;
}

// create() touches every page of the arena, so writing all of it afterwards (what the real-time path does over a
// mission) takes no first-touch page fault; the same write over a fresh heap block of the same size takes one per
// page, which shows the count can see them. Page-fault counts, not time.
TEST(ArenaTest, CreatePreFaultsEveryPage) {
  if (qsg::testing::running_emulated() || sanitized())
    GTEST_SKIP() << "page-fault counts are the emulator's or the sanitizer's own under qemu-user or ASan";
  const std::size_t page = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
  const std::size_t bytes = 4096 * page;  // 16 MB with 4 KB pages: mmap'd by malloc, fresh pages either way
  ArenaPlan plan;
  plan.add_array<std::uint8_t>(bytes);
  Arena arena;
  std::string error;
  ASSERT_TRUE(arena.create("prefaulted", plan, bytes, &error)) << error;
  auto* carved = arena.carve_array<std::uint8_t>(bytes);
  ASSERT_NE(carved, nullptr);
  ASSERT_TRUE(arena.seal());
  std::uint64_t before = thread_minor_faults();
  for (std::size_t i = 0; i < bytes; i += page) carved[i] = static_cast<std::uint8_t>(i / page);
  const std::uint64_t arena_faults = thread_minor_faults() - before;

  // A fresh anonymous mapping of the same size, in small pages (no transparent huge pages), not pre-faulted.
  void* map = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  ASSERT_NE(map, MAP_FAILED);
  ::madvise(map, bytes, MADV_NOHUGEPAGE);
  auto* fresh = static_cast<std::uint8_t*>(map);
  before = thread_minor_faults();
  for (std::size_t i = 0; i < bytes; i += page) fresh[i] = static_cast<std::uint8_t>(i / page);
  const std::uint64_t fresh_faults = thread_minor_faults() - before;
  EXPECT_EQ(fresh[page], 1u);
  ::munmap(map, bytes);

  EXPECT_GE(fresh_faults, 4096u / 2) << "a fresh mapping's pages fault on first touch (else the count is blind here)";
  EXPECT_LE(arena_faults, 8u) << "the arena's pages were touched at create(): a write now must not fault";
}

}  // namespace
}  // namespace qsg::memory
