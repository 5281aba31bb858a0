#include "core/memory/prefault.h"

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <array>
#include <cstdint>
#include <vector>

#include "tests/support/allocation_counter.h"
#include "tests/support/emulation.h"

namespace qsg::memory {
namespace {

std::uint64_t thread_minor_faults() {
  rusage usage{};
  getrusage(RUSAGE_THREAD, &usage);
  return static_cast<std::uint64_t>(usage.ru_minflt);
}

struct Big {  // default construction writes nothing, as an Eigen vector's
  std::array<double, 64> values;
};

TEST(PrefaultTest, KeepsSizeCapacityAndTheElementsThere) {
  std::vector<int> v{1, 2, 3};
  v.reserve(5000);
  const int* data = v.data();
  prefault_capacity(&v);
  EXPECT_EQ(v.size(), 3u);
  EXPECT_GE(v.capacity(), 5000u);
  EXPECT_EQ(v.data(), data) << "no reallocation";
  EXPECT_EQ(v, (std::vector<int>{1, 2, 3}));
}

// Filling a reserved vector faults its pages in one by one; after prefault_capacity it takes (next to) none, and
// allocates nothing.
TEST(PrefaultTest, FillingAPrefaultedVectorTakesNoPageFault) {
  if (qsg::testing::running_emulated()) GTEST_SKIP() << "under qemu-user the page faults counted are the emulator's";
  if (qsg::testing::address_sanitizer()) GTEST_SKIP() << "AddressSanitizer maps its shadow memory on first use";
  constexpr std::size_t kCount = 4096;  // 2 MB of elements
  const auto fill = [](std::vector<Big>* v) {
    const std::uint64_t before = thread_minor_faults();
    for (std::size_t i = 0; i < kCount; ++i) v->push_back(Big{});
    return thread_minor_faults() - before;
  };
  std::vector<Big> cold;
  cold.reserve(kCount);
  const std::uint64_t cold_faults = fill(&cold);
  std::vector<Big> warm;
  warm.reserve(kCount);
  prefault_capacity(&warm);
  std::uint64_t warm_faults = 0;
  EXPECT_NO_ALLOCATIONS(warm_faults = fill(&warm));
  EXPECT_GT(cold_faults, 100u) << "the cold fill should fault its 2 MB in";
  EXPECT_LT(warm_faults, 8u);
}

}  // namespace
}  // namespace qsg::memory
