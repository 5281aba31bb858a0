// Fixed-capacity vectors: capacity in the type (FixedVector<T, N>) or from an arena (ArenaVector<T>),
// every operation on the size-erased base VectorView<T>, so functions take a view of any capacity.
#pragma once

#include <cstddef>
#include <cstdint>
#include <new>
#include <type_traits>
#include <utility>

#include "core/memory/arena.h"
#include "core/memory/resource_stats.h"

namespace qsg::memory {

template <typename T>
class VectorView {
 public:
  using value_type = T;
  using iterator = T*;
  using const_iterator = const T*;

  VectorView(const VectorView&) = delete;
  VectorView& operator=(const VectorView&) = delete;

  std::size_t size() const { return size_; }
  std::size_t capacity() const { return counter_.capacity(); }
  bool empty() const { return size_ == 0; }
  bool full() const { return size_ == counter_.capacity(); }

  T* data() { return data_; }
  const T* data() const { return data_; }
  T& operator[](std::size_t i) { return data_[i]; }
  const T& operator[](std::size_t i) const { return data_[i]; }
  T& back() { return data_[size_ - 1]; }
  const T& back() const { return data_[size_ - 1]; }
  iterator begin() { return data_; }
  iterator end() { return data_ + size_; }
  const_iterator begin() const { return data_; }
  const_iterator end() const { return data_ + size_; }

  // Returns false (per the overflow policy) when full; the vector is unchanged then.
  bool push_back(const T& value) { return emplace_back(value) != nullptr; }
  bool push_back(T&& value) { return emplace_back(std::move(value)) != nullptr; }
  template <typename... Args>
  T* emplace_back(Args&&... args) {
    if (size_ == counter_.capacity()) {
      counter_.refuse(1);
      return nullptr;
    }
    T* slot = new (data_ + size_) T(std::forward<Args>(args)...);
    ++size_;
    counter_.set_in_use(size_);
    return slot;
  }
  void pop_back() {
    data_[--size_].~T();
    counter_.set_in_use(size_);
  }
  // O(1) removal that does not keep order.
  void swap_erase(std::size_t i) {
    if (i + 1 != size_) data_[i] = std::move(data_[size_ - 1]);
    pop_back();
  }
  // Order-keeping removal.
  void erase(std::size_t i) {
    for (std::size_t k = i; k + 1 < size_; ++k) data_[k] = std::move(data_[k + 1]);
    pop_back();
  }
  void clear() {
    if constexpr (!std::is_trivially_destructible_v<T>) {
      for (std::size_t i = 0; i < size_; ++i) data_[i].~T();
    }
    size_ = 0;
    counter_.set_in_use(0);
  }
  // Copies another view's elements; refuses (and leaves this unchanged) when they do not fit.
  bool assign(const VectorView& other) {
    if (other.size() > capacity()) return counter_.refuse(other.size());
    clear();
    for (const T& v : other) emplace_back(v);
    return true;
  }

  const char* name() const { return counter_.name(); }
  void set_name(const char* name) { counter_.set_name(name); }
  ResourceStats stats() const { return counter_.stats(); }

 protected:
  VectorView(T* storage, std::size_t capacity, const char* name, OverflowPolicy policy)
      : data_(storage), counter_(name, "elements", capacity, policy) {}
  ~VectorView() { clear(); }
  void rebind(T* storage, std::size_t capacity) {
    clear();
    data_ = storage;
    counter_.set_capacity(capacity);
  }

 private:
  T* data_;
  std::size_t size_ = 0;
  UsageCounter counter_;
};

// Capacity in the type; storage inline.
template <typename T, std::size_t N>
class FixedVector : public VectorView<T> {
 public:
  explicit FixedVector(const char* name = "fixed_vector", OverflowPolicy policy = kBuildOverflowPolicy)
      : VectorView<T>(reinterpret_cast<T*>(storage_), N, name, policy) {}
  FixedVector(const FixedVector& other) : FixedVector(other.name()) { this->assign(other); }
  FixedVector& operator=(const FixedVector& other) {
    if (this != &other) this->assign(other);
    return *this;
  }

 private:
  alignas(T) unsigned char storage_[sizeof(T) * N];
};

// Capacity chosen at start-up; storage carved from an arena (or any caller-owned buffer).
template <typename T>
class ArenaVector : public VectorView<T> {
 public:
  explicit ArenaVector(const char* name = "arena_vector", OverflowPolicy policy = kBuildOverflowPolicy)
      : VectorView<T>(nullptr, 0, name, policy) {}

  static void plan(ArenaPlan& plan, std::size_t capacity) { plan.add_bytes(sizeof(T) * capacity, alignof(T)); }
  // Takes its storage from the arena; false when the arena refused.
  bool carve(Arena& arena, std::size_t capacity) {
    void* raw = arena.carve_bytes(sizeof(T) * capacity, alignof(T));
    if (raw == nullptr) return false;
    this->rebind(static_cast<T*>(raw), capacity);
    return true;
  }
  void bind(T* storage, std::size_t capacity) { this->rebind(storage, capacity); }
};

}  // namespace qsg::memory
