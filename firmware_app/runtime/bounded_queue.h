// A fixed-depth queue between the loop and a long-lived worker thread, with the drop policy the budget table
// declares (drop oldest, drop newest, collate) and counters for every drop. Storage is allocated once by
// init(); push and pop never allocate and never block the producer.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

#include "budgets/budget_types.h"

namespace qsg::runtime {

struct QueueStats {
  const char* name = "";
  std::uint32_t depth = 0;
  std::uint32_t size = 0;
  std::uint32_t high_water = 0;
  std::uint64_t pushed = 0;
  std::uint64_t popped = 0;
  std::uint64_t dropped = 0;   // elements lost to the drop policy (oldest or newest)
  std::uint64_t collated = 0;  // pushes merged into the newest queued element
  budgets::DropPolicy policy = budgets::DropPolicy::kDropOldest;
  void print(std::FILE* out) const {
    std::fprintf(out, "queue %s: depth=%u size=%u high_water=%u pushed=%llu popped=%llu dropped=%llu collated=%llu (%s)\n",
                 name, depth, size, high_water, (unsigned long long)pushed, (unsigned long long)popped,
                 (unsigned long long)dropped, (unsigned long long)collated, budgets::to_string(policy));
  }
};

template <typename T>
class BoundedQueue {
 public:
  // Merges a new element into the newest queued one (collate policy).
  using Collate = void (*)(T& queued, T&& incoming);
  // Told about every element the policy drops (for example to return a frame buffer to its pool).
  using OnDrop = void (*)(void* user, T&& dropped);

  explicit BoundedQueue(const char* name = "queue") { stats_.name = name; }
  BoundedQueue(const BoundedQueue&) = delete;
  BoundedQueue& operator=(const BoundedQueue&) = delete;

  // Start-up only.
  bool init(std::uint32_t depth, budgets::DropPolicy policy, Collate collate, std::string* error) {
    if (depth == 0 || depth > 1024) {
      if (error != nullptr) *error = std::string("queue ") + stats_.name + ": depth must be in [1, 1024]";
      return false;
    }
    if (policy == budgets::DropPolicy::kCollate && collate == nullptr) {
      if (error != nullptr) *error = std::string("queue ") + stats_.name + ": the collate policy needs a merge function";
      return false;
    }
    slots_ = std::make_unique<T[]>(depth);
    stats_.depth = depth;
    stats_.policy = policy;
    collate_ = collate;
    return true;
  }

  // Never blocks. False when the element (or an older one) was dropped; the queue stays usable.
  bool push(T&& value) {
    bool kept = true;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.pushed;
      if (closed_) {
        if (on_drop_ != nullptr) on_drop_(on_drop_user_, std::move(value));
        return false;
      }
      if (stats_.size == stats_.depth) {
        switch (stats_.policy) {
          case budgets::DropPolicy::kDropNewest:
            ++stats_.dropped;
            if (on_drop_ != nullptr) on_drop_(on_drop_user_, std::move(value));
            return false;
          case budgets::DropPolicy::kCollate:
            collate_(slots_[(head_ + stats_.size - 1) % stats_.depth], std::move(value));
            ++stats_.collated;
            return true;
          case budgets::DropPolicy::kDropOldest:
            if (on_drop_ != nullptr) on_drop_(on_drop_user_, std::move(slots_[head_]));
            head_ = (head_ + 1) % stats_.depth;
            --stats_.size;
            ++stats_.dropped;
            kept = false;
            break;
        }
      }
      slots_[(head_ + stats_.size) % stats_.depth] = std::move(value);
      ++stats_.size;
      if (stats_.size > stats_.high_water) stats_.high_water = stats_.size;
    }
    ready_.notify_one();
    return kept;
  }

  bool try_pop(T* out) {
    std::lock_guard<std::mutex> lock(mutex_);
    return pop_locked(out);
  }

  // Pops the oldest element only when pred(oldest) holds (for example: it waited too long).
  template <typename Pred>
  bool try_pop_if(Pred&& pred, T* out) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stats_.size == 0 || !pred(static_cast<const T&>(slots_[head_]))) return false;
    return pop_locked(out);
  }

  // For worker threads: waits up to timeout_ns for an element; false on timeout or when closed and empty.
  bool pop_wait(T* out, std::int64_t timeout_ns) {
    std::unique_lock<std::mutex> lock(mutex_);
    ready_.wait_for(lock, std::chrono::nanoseconds(timeout_ns), [this] { return stats_.size > 0 || closed_; });
    return pop_locked(out);
  }

  // Wakes waiting consumers; later pushes are refused, queued elements can still be popped.
  void close() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closed_ = true;
    }
    ready_.notify_all();
  }

  void set_on_drop(OnDrop on_drop, void* user) {
    std::lock_guard<std::mutex> lock(mutex_);
    on_drop_ = on_drop;
    on_drop_user_ = user;
  }

  QueueStats stats() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return stats_;
  }

 private:
  bool pop_locked(T* out) {
    if (stats_.size == 0) return false;
    *out = std::move(slots_[head_]);
    head_ = (head_ + 1) % stats_.depth;
    --stats_.size;
    ++stats_.popped;
    return true;
  }

  std::unique_ptr<T[]> slots_;
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::uint32_t head_ = 0;
  bool closed_ = false;
  Collate collate_ = nullptr;
  OnDrop on_drop_ = nullptr;
  void* on_drop_user_ = nullptr;
  QueueStats stats_;
};

}  // namespace qsg::runtime
