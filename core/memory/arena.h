// Named arenas: one allocation per subsystem at start-up, carved into sub-pools, sealed with an exact end check.
//
// Start-up works in two steps, as flight-software buffer managers do:
//   1. the subsystem describes every buffer it needs in an ArenaPlan (name, element count, alignment);
//   2. Arena::create() checks the plan against the board's byte budget, makes one allocation of exactly the
//      planned size and touches every page of it (pre-faulted: the real-time path takes no first-touch page
//      fault), the subsystem carves its buffers in the same order, and seal() asserts that the carve pointer
//      ended exactly at the arena's end (a plan and a carve that disagree are a bug, caught at start-up).
// After seal() nothing can be carved: the real-time path never allocates.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <string>
#include <type_traits>

#include "core/memory/resource_stats.h"

namespace qsg::memory {

inline constexpr std::size_t kArenaAlignment = 64;  // cache line; every carve is at most this aligned

inline constexpr std::size_t align_up(std::size_t value, std::size_t alignment) {
  return (value + alignment - 1) / alignment * alignment;
}

// The list of buffers a subsystem will carve, in carve order.
class ArenaPlan {
 public:
  void add_bytes(std::size_t bytes, std::size_t alignment) {
    total_bytes_ = align_up(total_bytes_, alignment) + bytes;
    ++entries_;
  }
  template <typename T>
  void add_array(std::size_t count) {
    static_assert(alignof(T) <= kArenaAlignment, "over-aligned type");
    add_bytes(sizeof(T) * count, alignof(T));
  }
  void add_plan(const ArenaPlan& other) {  // a nested component carved from the same arena
    total_bytes_ = align_up(total_bytes_, kArenaAlignment) + other.total_bytes();
    entries_ += other.entries_;
  }
  // Bytes the arena must hold; rounded to the arena alignment so nested plans compose exactly.
  std::size_t total_bytes() const { return align_up(total_bytes_, kArenaAlignment); }
  std::size_t entries() const { return entries_; }

 private:
  std::size_t total_bytes_ = 0;
  std::size_t entries_ = 0;
};

class Arena {
 public:
  Arena() = default;
  Arena(const Arena&) = delete;
  Arena& operator=(const Arena&) = delete;
  Arena(Arena&& other) noexcept { *this = std::move(other); }
  Arena& operator=(Arena&& other) noexcept;
  ~Arena();

  // Allocates exactly plan.total_bytes() if that fits `budget_bytes`; otherwise returns false and says
  // why in *error (start-up only: this is the one place an arena touches the heap).
  bool create(const char* name, const ArenaPlan& plan, std::size_t budget_bytes, std::string* error);

  // Takes the next `bytes` at `alignment`. Returns nullptr (per the overflow policy) when it does not fit,
  // or after seal().
  void* carve_bytes(std::size_t bytes, std::size_t alignment);

  // Carves and default-constructs `count` objects of T. The arena never runs destructors: T must be
  // trivially destructible, or its owner must destroy the objects before the arena goes.
  template <typename T>
  T* carve_array(std::size_t count) {
    static_assert(alignof(T) <= kArenaAlignment, "over-aligned type");
    void* raw = carve_bytes(sizeof(T) * count, alignof(T));
    if (raw == nullptr) return nullptr;
    T* first = static_cast<T*>(raw);
    for (std::size_t i = 0; i < count; ++i) new (first + i) T();
    return first;
  }

  // Pads the carve pointer to the arena alignment (the end of a nested plan).
  void align_to_plan_boundary();

  // The exact end check: returns false (and aborts under kAbort) when the carve did not end exactly at
  // the end of the arena. After seal() no more carving is possible.
  bool seal();

  bool sealed() const { return sealed_; }
  const char* name() const { return counter_.name(); }
  std::size_t capacity_bytes() const { return capacity_; }
  std::size_t used_bytes() const { return cursor_; }
  std::size_t budget_bytes() const { return budget_bytes_; }
  ResourceStats stats() const { return counter_.stats(); }

 private:
  void release();

  unsigned char* base_ = nullptr;
  std::size_t capacity_ = 0;
  std::size_t cursor_ = 0;
  std::size_t budget_bytes_ = 0;
  bool sealed_ = false;
  UsageCounter counter_{"arena", "bytes", 0};
};

}  // namespace qsg::memory
