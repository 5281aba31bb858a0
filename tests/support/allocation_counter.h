// Test utility: the global allocator is hooked so a test can mark a steady-state region and fail if it allocates.
//
//   qsg::testing::AllocationCounter counter;   // counts this thread's operator new calls from here on
//   run_steady_state_tick();
//   EXPECT_EQ(counter.allocations(), 0u);
//
// or, for the common case, EXPECT_NO_ALLOCATIONS(statement);
#pragma once

#include <cstddef>
#include <cstdint>

namespace qsg::testing {

// Counts operator new / new[] (all overloads) on the constructing thread while alive. Nests.
class AllocationCounter {
 public:
  AllocationCounter();
  ~AllocationCounter();
  AllocationCounter(const AllocationCounter&) = delete;
  AllocationCounter& operator=(const AllocationCounter&) = delete;

  std::uint64_t allocations() const;
  std::uint64_t bytes() const;

 private:
  std::uint64_t start_count_;
  std::uint64_t start_bytes_;
};

// Totals for the calling thread since it started (for diagnostics).
std::uint64_t thread_allocation_count();
std::uint64_t thread_allocation_bytes();

}  // namespace qsg::testing

#define EXPECT_NO_ALLOCATIONS(statement)                                                   \
  do {                                                                                     \
    ::qsg::testing::AllocationCounter qsg_alloc_counter_;                                  \
    statement;                                                                             \
    EXPECT_EQ(qsg_alloc_counter_.allocations(), 0u)                                        \
        << "steady-state region allocated " << qsg_alloc_counter_.bytes() << " bytes: " #statement; \
  } while (0)
