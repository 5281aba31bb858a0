// Overflow handling and printing for bounded resources.
#include "core/memory/resource_stats.h"

#include <cinttypes>
#include <cstdlib>

namespace qsg::memory {

const char* to_string(OverflowPolicy policy) {
  return policy == OverflowPolicy::kAbort ? "abort" : "refuse";
}

void ResourceStats::print(std::FILE* out) const {
  std::fprintf(out, "%-28s capacity %10zu %-8s in use %10zu  high water %10zu  failed %8" PRIu64 "\n", name,
               capacity, unit, in_use, high_water, failed);
}

bool UsageCounter::refuse(std::size_t requested) {
  ++failed_;
  if (policy_ == OverflowPolicy::kAbort) {
    std::fprintf(stderr,
                 "qsg: FATAL: '%s' is full: requested %zu %s with %zu of %zu in use. "
                 "Raise its capacity in the board's budget table (budgets/) or reduce the load.\n",
                 name_, requested, unit_, in_use_, capacity_);
    std::fflush(stderr);
    std::abort();
  }
  if ((failed_ & (failed_ - 1)) == 0) {  // 1, 2, 4, 8, ...: bounded logging on a hot failure path
    std::fprintf(stderr, "qsg: warning: '%s' is full (%zu of %zu %s); refused %" PRIu64 " request(s) so far\n",
                 name_, in_use_, capacity_, unit_, failed_);
  }
  return false;
}

}  // namespace qsg::memory
