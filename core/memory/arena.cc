// Arena implementation: one aligned allocation, a bump pointer and the exact end check.
#include "core/memory/arena.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <utility>

namespace qsg::memory {

Arena& Arena::operator=(Arena&& other) noexcept {
  if (this != &other) {
    release();
    base_ = std::exchange(other.base_, nullptr);
    capacity_ = std::exchange(other.capacity_, 0);
    cursor_ = std::exchange(other.cursor_, 0);
    budget_bytes_ = std::exchange(other.budget_bytes_, 0);
    sealed_ = std::exchange(other.sealed_, false);
    counter_ = other.counter_;
  }
  return *this;
}

Arena::~Arena() { release(); }

void Arena::release() {
  if (base_ != nullptr) ::operator delete(base_, std::align_val_t{kArenaAlignment});
  base_ = nullptr;
  capacity_ = cursor_ = 0;
  sealed_ = false;
}

bool Arena::create(const char* name, const ArenaPlan& plan, std::size_t budget_bytes, std::string* error) {
  release();
  const std::size_t bytes = plan.total_bytes();
  counter_ = UsageCounter(name, "bytes", bytes);
  budget_bytes_ = budget_bytes;
  if (bytes > budget_bytes) {
    if (error != nullptr) {
      *error = std::string("arena '") + name + "' needs " + std::to_string(bytes) + " bytes for " +
               std::to_string(plan.entries()) + " buffers but the budget table allows " +
               std::to_string(budget_bytes) + " bytes; raise its arena_bytes in budgets/ or lower its capacities";
    }
    return false;
  }
  if (bytes > 0) {
    base_ = static_cast<unsigned char*>(::operator new(bytes, std::align_val_t{kArenaAlignment}, std::nothrow));
    if (base_ == nullptr) {
      if (error != nullptr) *error = std::string("arena '") + name + "': the system refused " + std::to_string(bytes) + " bytes";
      return false;
    }
    // Pre-fault: touch every page now, so the real-time path never takes a first-touch page fault and the resident
    // set reaches its size at start-up (a run's memory is then flat from the first tick, and any later growth is real).
    std::memset(base_, 0, bytes);
  }
  capacity_ = bytes;
  return true;
}

void* Arena::carve_bytes(std::size_t bytes, std::size_t alignment) {
  const std::size_t start = align_up(cursor_, alignment);
  if (sealed_ || start + bytes > capacity_) {
    counter_.refuse(bytes);
    return nullptr;
  }
  cursor_ = start + bytes;
  counter_.set_in_use(cursor_);
  // A zero-byte request still gets a unique, aligned, non-null address inside (or at the end of) the arena.
  return base_ != nullptr ? base_ + start : static_cast<void*>(this);
}

void Arena::align_to_plan_boundary() {
  cursor_ = align_up(cursor_, kArenaAlignment);
  counter_.set_in_use(cursor_);
}

bool Arena::seal() {
  align_to_plan_boundary();
  sealed_ = true;
  if (cursor_ == capacity_) return true;
  std::fprintf(stderr, "qsg: arena '%s' carve ended at byte %zu of %zu: the plan and the carve disagree\n", name(),
               cursor_, capacity_);
  if (counter_.policy() == OverflowPolicy::kAbort) std::abort();
  return false;
}

}  // namespace qsg::memory
