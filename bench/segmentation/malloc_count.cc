// Counts every heap allocation of the process by interposing glibc's malloc family (operator new, cv::fastMalloc
// and OpenCV's worker threads all end up here), forwarding to glibc's own implementation.
#include "bench/segmentation/malloc_count.h"

#if defined(QSG_COUNT_MALLOC) && !defined(__SANITIZE_ADDRESS__)

#include <atomic>
#include <cerrno>
#include <cstddef>

extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t n, std::size_t size);
void* __libc_realloc(void* p, std::size_t size);
void* __libc_memalign(std::size_t alignment, std::size_t size);
}

namespace {
std::atomic<std::int64_t> g_allocations{0};
std::atomic<std::int64_t> g_bytes{0};
void count(std::size_t bytes) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  g_bytes.fetch_add(static_cast<std::int64_t>(bytes), std::memory_order_relaxed);
}
}  // namespace

extern "C" {
void* malloc(std::size_t size) {
  count(size);
  return __libc_malloc(size);
}
void* calloc(std::size_t n, std::size_t size) {
  count(n * size);
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t size) {
  count(size);
  return __libc_realloc(p, size);
}
void* memalign(std::size_t alignment, std::size_t size) {
  count(size);
  return __libc_memalign(alignment, size);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) {
  count(size);
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) {
  if (alignment % sizeof(void*) != 0 || (alignment & (alignment - 1)) != 0) return EINVAL;
  count(size);
  void* p = __libc_memalign(alignment, size);
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}
}

namespace qsg::bench {
std::int64_t heap_allocations() { return g_allocations.load(std::memory_order_relaxed); }
std::int64_t heap_allocated_bytes() { return g_bytes.load(std::memory_order_relaxed); }
}  // namespace qsg::bench

#else

namespace qsg::bench {
std::int64_t heap_allocations() { return -1; }
std::int64_t heap_allocated_bytes() { return -1; }
}  // namespace qsg::bench

#endif
