// A small inline array with a fixed maximum size: plain data (trivially copyable when T is), for record fields.
// Use FixedVector when the container is a resource that must report usage; use this inside records.
#pragma once

#include <cstddef>
#include <cstdint>

namespace qsg::memory {

template <typename T, std::size_t N>
struct BoundedArray {
  static_assert(N < 256, "BoundedArray is for small inline arrays");
  T items[N] = {};
  std::uint8_t count = 0;

  static constexpr std::size_t capacity() { return N; }
  std::size_t size() const { return count; }
  bool empty() const { return count == 0; }
  // False (and unchanged) when full: the caller decides whether that is an error or a counted degradation.
  bool push_back(const T& v) {
    if (count == N) return false;
    items[count++] = v;
    return true;
  }
  void clear() { count = 0; }
  T& operator[](std::size_t i) { return items[i]; }
  const T& operator[](std::size_t i) const { return items[i]; }
  T* begin() { return items; }
  T* end() { return items + count; }
  const T* begin() const { return items; }
  const T* end() const { return items + count; }
  friend bool operator==(const BoundedArray& a, const BoundedArray& b) {
    if (a.count != b.count) return false;
    for (std::size_t i = 0; i < a.count; ++i)
      if (!(a.items[i] == b.items[i])) return false;
    return true;
  }
};

// A short string stored inline (names such as "R(12)").
template <std::size_t N>
struct InlineString {
  char chars[N] = {};
  std::uint8_t length = 0;

  static constexpr std::size_t capacity() { return N - 1; }
  bool assign(const char* s, std::size_t n) {
    if (n > capacity()) return false;
    for (std::size_t i = 0; i < n; ++i) chars[i] = s[i];
    chars[n] = '\0';
    length = static_cast<std::uint8_t>(n);
    return true;
  }
  const char* c_str() const { return chars; }
  std::size_t size() const { return length; }
  friend bool operator==(const InlineString& a, const InlineString& b) {
    if (a.length != b.length) return false;
    for (std::size_t i = 0; i < a.length; ++i)
      if (a.chars[i] != b.chars[i]) return false;
    return true;
  }
};

}  // namespace qsg::memory
