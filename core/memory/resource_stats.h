// Usage statistics and the overflow policy shared by every bounded resource (arena, pool, container, hash, queue).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>

#ifndef QSG_OVERFLOW_ABORT
#define QSG_OVERFLOW_ABORT 0
#endif

namespace qsg::memory {

// What a bounded resource does when a request does not fit. One default per build (CMake option
// QSG_OVERFLOW_ABORT: on in debug and test builds, off in release); a resource may be given an explicit policy.
enum class OverflowPolicy : std::uint8_t {
  kAbort,   // print what overflowed and abort: a test or debug build must not hide a budget error
  kRefuse,  // count the failed request, log it (rate-limited) and return failure to the caller
};

inline constexpr OverflowPolicy kBuildOverflowPolicy =
    QSG_OVERFLOW_ABORT ? OverflowPolicy::kAbort : OverflowPolicy::kRefuse;

const char* to_string(OverflowPolicy policy);

// Snapshot of one resource, as reported in telemetry and asserted on in tests.
struct ResourceStats {
  const char* name = "";
  const char* unit = "";        // "bytes", "slots", "elements", ...
  std::size_t capacity = 0;     // in `unit`
  std::size_t in_use = 0;
  std::size_t high_water = 0;
  std::uint64_t failed = 0;     // requests refused because the resource was full

  void print(std::FILE* out) const;
};

// The counters a resource keeps next to its state; cheap enough for the real-time path.
class UsageCounter {
 public:
  UsageCounter(const char* name, const char* unit, std::size_t capacity,
               OverflowPolicy policy = kBuildOverflowPolicy)
      : name_(name), unit_(unit), capacity_(capacity), policy_(policy) {}

  void set_in_use(std::size_t in_use) {
    in_use_ = in_use;
    if (in_use_ > high_water_) high_water_ = in_use_;
  }
  void reset_high_water() { high_water_ = in_use_; }
  void set_capacity(std::size_t capacity) { capacity_ = capacity; }
  void set_name(const char* name) { name_ = name; }

  // Records a refused request of `requested` units. Aborts under kAbort; otherwise counts, logs the
  // 1st, 2nd, 4th, 8th, ... failure (no allocation, bounded output) and returns false for the caller.
  bool refuse(std::size_t requested);
  // Records `n` requests a caller refused on the resource's behalf because it saw the resource full before asking
  // (a stage that checks for room first, so that a full store is a counted degradation in every build): counted in
  // `failed` like refuse(), so the store's own name shows it, but never aborts and never logs (the caller logs).
  void count_refused(std::uint64_t n = 1) { failed_ += n; }

  ResourceStats stats() const { return {name_, unit_, capacity_, in_use_, high_water_, failed_}; }
  OverflowPolicy policy() const { return policy_; }
  std::size_t capacity() const { return capacity_; }
  std::size_t in_use() const { return in_use_; }
  std::size_t high_water() const { return high_water_; }
  std::uint64_t failed() const { return failed_; }
  const char* name() const { return name_; }

 private:
  const char* name_;
  const char* unit_;
  std::size_t capacity_;
  std::size_t in_use_ = 0;
  std::size_t high_water_ = 0;
  std::uint64_t failed_ = 0;
  OverflowPolicy policy_;
};

}  // namespace qsg::memory
