// Fixed pools of objects with stable 32-bit handles, on arena (or caller-owned) storage.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <new>
#include <utility>

#include "core/memory/arena.h"
#include "core/memory/resource_stats.h"

namespace qsg::memory {

inline constexpr std::uint32_t kInvalidHandle = std::numeric_limits<std::uint32_t>::max();

// Slots are reused through an intrusive free list; a handle stays valid until it is released.
// acquire() and release() are O(1) and never allocate.
template <typename T>
class Pool {
 public:
  explicit Pool(const char* name = "pool", OverflowPolicy policy = kBuildOverflowPolicy)
      : counter_(name, "slots", 0, policy) {}
  Pool(const Pool&) = delete;
  Pool& operator=(const Pool&) = delete;
  ~Pool() { clear(); }

  static void plan(ArenaPlan& plan, std::size_t capacity) {
    plan.add_array<Slot>(capacity);
    plan.add_array<std::uint32_t>(capacity);
    plan.add_array<std::uint8_t>(capacity);
  }
  bool carve(Arena& arena, std::size_t capacity) {
    clear();
    auto* slots = static_cast<Slot*>(arena.carve_bytes(sizeof(Slot) * capacity, alignof(Slot)));
    auto* next = static_cast<std::uint32_t*>(arena.carve_bytes(sizeof(std::uint32_t) * capacity, alignof(std::uint32_t)));
    auto* live = static_cast<std::uint8_t*>(arena.carve_bytes(capacity, 1));
    if (slots == nullptr || next == nullptr || live == nullptr) return false;
    slots_ = slots;
    next_ = next;
    live_ = live;
    counter_.set_capacity(capacity);
    reset_free_list();
    return true;
  }

  // Constructs a T in a free slot; returns its handle or kInvalidHandle when the pool is full.
  template <typename... Args>
  std::uint32_t acquire(Args&&... args) {
    if (free_head_ == kInvalidHandle) {
      counter_.refuse(1);
      return kInvalidHandle;
    }
    const std::uint32_t h = free_head_;
    free_head_ = next_[h];
    new (&slots_[h]) T(std::forward<Args>(args)...);
    live_[h] = 1;
    counter_.set_in_use(counter_.in_use() + 1);
    return h;
  }
  void release(std::uint32_t h) {
    if (!live(h)) return;
    get(h).~T();
    live_[h] = 0;
    next_[h] = free_head_;
    free_head_ = h;
    counter_.set_in_use(counter_.in_use() - 1);
  }
  void clear() {
    for (std::size_t h = 0; h < capacity(); ++h) {
      if (live_[h]) get(static_cast<std::uint32_t>(h)).~T();
    }
    reset_free_list();
  }

  // Records a request the caller refused on the pool's behalf (e.g. a multi-slot operation that would not fit).
  bool refuse(std::size_t requested = 1) { return counter_.refuse(requested); }
  // Counts a request the caller did not make because it saw the pool full (UsageCounter::count_refused).
  void count_refused(std::uint64_t n = 1) { counter_.count_refused(n); }

  bool live(std::uint32_t h) const { return h < capacity() && live_[h] != 0; }
  T& operator[](std::uint32_t h) { return get(h); }
  const T& operator[](std::uint32_t h) const { return *std::launder(reinterpret_cast<const T*>(&slots_[h])); }
  std::size_t size() const { return counter_.in_use(); }
  std::size_t capacity() const { return counter_.capacity(); }
  bool full() const { return free_head_ == kInvalidHandle; }
  ResourceStats stats() const { return counter_.stats(); }

  // Calls fn(handle, T&) for each live slot in handle order.
  template <typename Fn>
  void for_each(Fn&& fn) {
    for (std::uint32_t h = 0; h < capacity(); ++h)
      if (live_[h]) fn(h, get(h));
  }
  template <typename Fn>
  void for_each(Fn&& fn) const {
    for (std::uint32_t h = 0; h < capacity(); ++h)
      if (live_[h]) fn(h, (*this)[h]);
  }

 private:
  struct alignas(T) Slot {
    unsigned char bytes[sizeof(T)];
  };
  T& get(std::uint32_t h) { return *std::launder(reinterpret_cast<T*>(&slots_[h])); }
  void reset_free_list() {
    const std::size_t n = capacity();
    for (std::size_t h = 0; h < n; ++h) {
      live_[h] = 0;
      next_[h] = h + 1 < n ? static_cast<std::uint32_t>(h + 1) : kInvalidHandle;
    }
    free_head_ = n > 0 ? 0 : kInvalidHandle;
    counter_.set_in_use(0);
  }

  Slot* slots_ = nullptr;
  std::uint32_t* next_ = nullptr;
  std::uint8_t* live_ = nullptr;
  std::uint32_t free_head_ = kInvalidHandle;
  UsageCounter counter_;
};

}  // namespace qsg::memory
