// Start-up only: the pages of a std::vector's reserved capacity are faulted in now, as an arena's are (arena.h),
// so filling it later (the real-time path, the backend thread) takes no first-touch page fault and the resident set
// reaches its size at start-up. The elements past size() are constructed, a zero byte is written on each of their
// pages, and they are destroyed again (trivially: nothing they hold outlives them); size and capacity stay.
#pragma once

#include <cstddef>
#include <type_traits>
#include <vector>

namespace qsg::memory {

template <typename T, typename A>
void prefault_capacity(std::vector<T, A>* v) {
  static_assert(std::is_trivially_destructible_v<T>, "prefault_capacity writes over the elements it constructs");
  constexpr std::size_t kPage = 4096;
  const std::size_t size = v->size();
  v->resize(v->capacity());
  auto* bytes = reinterpret_cast<volatile unsigned char*>(v->data());
  for (std::size_t at = size * sizeof(T); at < v->size() * sizeof(T); at += kPage) bytes[at] = 0;
  v->resize(size);
}

}  // namespace qsg::memory
