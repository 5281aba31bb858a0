// Fixed-capacity open-addressing hash maps (linear probing, backward-shift erase: no tombstones, so probe
// lengths do not degrade with churn), and the spatial hash keyed by integer 3D indices (voxel-block index).
#pragma once

#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "core/memory/arena.h"
#include "core/memory/resource_stats.h"

namespace qsg::memory {

// Integer 3D index of a voxel block (or voxel). Plain struct: no Eigen in this header.
struct Index3 {
  std::int32_t x = 0;
  std::int32_t y = 0;
  std::int32_t z = 0;
  friend bool operator==(const Index3& a, const Index3& b) { return a.x == b.x && a.y == b.y && a.z == b.z; }
  friend bool operator!=(const Index3& a, const Index3& b) { return !(a == b); }
};

inline std::uint64_t mix64(std::uint64_t h) {  // the 64-bit finaliser of MurmurHash3
  h ^= h >> 33;
  h *= 0xff51afd7ed558ccdULL;
  h ^= h >> 33;
  h *= 0xc4ceb9fe1a85ec53ULL;
  h ^= h >> 33;
  return h;
}

struct Index3Hash {
  std::uint64_t operator()(const Index3& k) const {
    const std::uint64_t a = static_cast<std::uint32_t>(k.x);
    const std::uint64_t b = static_cast<std::uint32_t>(k.y);
    const std::uint64_t c = static_cast<std::uint32_t>(k.z);
    return mix64((a * 0x9E3779B97F4A7C15ULL) ^ (b * 0xC2B2AE3D27D4EB4FULL) ^ (c * 0x165667B19E3779F9ULL));
  }
};

struct U64Hash {
  std::uint64_t operator()(std::uint64_t k) const { return mix64(k); }
};

// Slot count is a power of two; `max_entries` (at most the slot count) bounds the load, so the budget
// decides both memory and the worst probe length. Key and Value must be trivially copyable.
template <typename Key, typename Value, typename Hasher>
class FixedHashMap {
  static_assert(std::is_trivially_copyable_v<Key> && std::is_trivially_copyable_v<Value>,
                "FixedHashMap stores plain data");

 public:
  explicit FixedHashMap(const char* name = "hash_map", OverflowPolicy policy = kBuildOverflowPolicy)
      : counter_(name, "entries", 0, policy) {}
  FixedHashMap(const FixedHashMap&) = delete;
  FixedHashMap& operator=(const FixedHashMap&) = delete;

  // Smallest power of two that keeps `max_entries` at or below 3/4 load.
  static std::size_t slots_for(std::size_t max_entries) {
    std::size_t slots = 1;
    while (slots * 3 < max_entries * 4) slots <<= 1;
    return slots;
  }
  static void plan(ArenaPlan& plan, std::size_t slot_count) {
    plan.add_array<Slot>(slot_count);
  }
  // slot_count must be a power of two (otherwise the map holds nothing); max_entries < slot_count.
  bool carve(Arena& arena, std::size_t slot_count, std::size_t max_entries) {
    auto* slots = static_cast<Slot*>(arena.carve_bytes(sizeof(Slot) * slot_count, alignof(Slot)));
    if (slots == nullptr) return false;
    bind(slots, slot_count, max_entries);
    return true;
  }
  // For caller-owned storage of `slot_count` slots (bytes = storage_bytes(slot_count)).
  static std::size_t storage_bytes(std::size_t slot_count) { return sizeof(Slot) * slot_count; }
  void bind(void* storage, std::size_t slot_count, std::size_t max_entries) {
    slots_ = static_cast<Slot*>(storage);
    mask_ = slot_count - 1;
    slot_count_ = (slot_count & mask_) == 0 && slot_count > 0 ? slot_count : 0;
    // At least one slot stays empty, so every probe run ends.
    const std::size_t limit = slot_count_ > 0 ? slot_count_ - 1 : 0;
    counter_.set_capacity(max_entries < limit ? max_entries : limit);
    clear();
  }

  // Inserts or overwrites; returns a pointer to the stored value, nullptr when full (per policy).
  Value* insert(const Key& key, const Value& value) {
    bool inserted = false;
    Value* v = find_or_insert(key, value, &inserted);
    if (v != nullptr && !inserted) *v = value;
    return v;
  }
  // Returns the existing value, or inserts `value`; *inserted says which.
  Value* find_or_insert(const Key& key, const Value& value, bool* inserted = nullptr) {
    if (slot_count_ == 0) {
      counter_.refuse(1);
      return nullptr;
    }
    std::size_t i = hasher_(key) & mask_;
    std::size_t probes = 0;
    while (slots_[i].used) {
      if (slots_[i].key == key) {
        if (inserted != nullptr) *inserted = false;
        return &slots_[i].value;
      }
      i = (i + 1) & mask_;
      ++probes;
    }
    if (size_ >= counter_.capacity()) {
      counter_.refuse(1);
      return nullptr;
    }
    slots_[i].used = 1;
    slots_[i].key = key;
    slots_[i].value = value;
    ++size_;
    counter_.set_in_use(size_);
    if (probes > max_probe_) max_probe_ = probes;
    if (inserted != nullptr) *inserted = true;
    return &slots_[i].value;
  }
  Value* find(const Key& key) {
    const std::size_t i = locate(key);
    return i == kNone ? nullptr : &slots_[i].value;
  }
  const Value* find(const Key& key) const {
    const std::size_t i = locate(key);
    return i == kNone ? nullptr : &slots_[i].value;
  }
  bool contains(const Key& key) const { return locate(key) != kNone; }

  // Backward-shift deletion: later entries of the probe run move up, so no tombstones accumulate.
  bool erase(const Key& key) {
    std::size_t hole = locate(key);
    if (hole == kNone) return false;
    std::size_t i = hole;
    while (true) {
      i = (i + 1) & mask_;
      if (!slots_[i].used) break;
      const std::size_t home = hasher_(slots_[i].key) & mask_;
      // Move slot i into the hole unless its home lies cyclically in (hole, i].
      const bool home_after_hole = ((i - home) & mask_) < ((i - hole) & mask_);
      if (!home_after_hole) {
        slots_[hole] = slots_[i];
        hole = i;
      }
    }
    slots_[hole].used = 0;
    --size_;
    counter_.set_in_use(size_);
    return true;
  }
  void clear() {
    for (std::size_t i = 0; i < slot_count_; ++i) slots_[i].used = 0;
    size_ = 0;
    max_probe_ = 0;
    counter_.set_in_use(0);
  }

  // Calls fn(const Key&, Value&) for every entry, in slot order. Do not insert or erase inside fn.
  template <typename Fn>
  void for_each(Fn&& fn) {
    for (std::size_t i = 0; i < slot_count_; ++i)
      if (slots_[i].used) fn(static_cast<const Key&>(slots_[i].key), slots_[i].value);
  }
  template <typename Fn>
  void for_each(Fn&& fn) const {
    for (std::size_t i = 0; i < slot_count_; ++i)
      if (slots_[i].used) fn(slots_[i].key, static_cast<const Value&>(slots_[i].value));
  }

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  std::size_t capacity() const { return counter_.capacity(); }
  std::size_t slot_count() const { return slot_count_; }
  double load_factor() const { return slot_count_ == 0 ? 0.0 : static_cast<double>(size_) / slot_count_; }
  std::size_t max_probe_length() const { return max_probe_; }
  ResourceStats stats() const { return counter_.stats(); }

 private:
  static constexpr std::size_t kNone = ~std::size_t{0};
  struct Slot {
    Key key;
    Value value;
    std::uint8_t used;
  };
  std::size_t locate(const Key& key) const {
    if (slot_count_ == 0) return kNone;
    std::size_t i = hasher_(key) & mask_;
    while (slots_[i].used) {
      if (slots_[i].key == key) return i;
      i = (i + 1) & mask_;
    }
    return kNone;
  }

  Slot* slots_ = nullptr;
  std::size_t mask_ = 0;
  std::size_t slot_count_ = 0;
  std::size_t size_ = 0;
  std::size_t max_probe_ = 0;
  Hasher hasher_{};
  UsageCounter counter_;
};

// The voxel-block index: integer block coordinates to a block-pool handle (or any plain value).
template <typename Value>
using SpatialHash = FixedHashMap<Index3, Value, Index3Hash>;

}  // namespace qsg::memory
