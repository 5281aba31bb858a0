// Process-wide count of heap allocations (malloc, calloc, realloc, memalign family), all threads, for benchmarks
// that report how many allocations a library call makes. -1 when the build cannot interpose malloc.
#pragma once

#include <cstdint>

namespace qsg::bench {

std::int64_t heap_allocations();
std::int64_t heap_allocated_bytes();  // requested bytes, summed (realloc counts its new size)

}  // namespace qsg::bench
