// The nearest-place index kept up to date place by place (issue 37): places are inserted, moved and removed one at
// a time, so keeping it current costs what changed (the places of the active window), not the whole building. A
// grid of vertical columns (cell_m x cell_m in the plan, every height in one column) holds each place in one
// column's list; a query visits the columns ring by ring around the query point until the k-th best distance is
// inside the ring. Fixed capacity, carved once from one arena: after init() nothing allocates. Ties in distance are
// broken by node id, so the answer depends on the index's content only, not on the order it was built in.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "core/frontend/nearest_place_index.h"
#include "core/memory/arena.h"
#include "core/memory/fixed_hash_map.h"
#include "core/memory/resource_stats.h"
#include "core/scene_graph/node_id.h"

namespace qsg::frontend {

class IncrementalPlaceIndex {
 public:
  static constexpr std::size_t kMaxK = NearestPlaceIndex::kMaxK;
  static constexpr double kDefaultCellM = 1.0;
  // A query that has not found its k places within this many rings of columns scans every entry instead.
  static constexpr std::int64_t kMaxRings = 48;

  IncrementalPlaceIndex() = default;
  IncrementalPlaceIndex(const IncrementalPlaceIndex&) = delete;
  IncrementalPlaceIndex& operator=(const IncrementalPlaceIndex&) = delete;

  static memory::ArenaPlan plan(const NearestPlaceCapacities& capacities);
  // cell_m: the columns' side (places are about 1 m apart; a query for k = 8 then looks at a few columns).
  bool init(const NearestPlaceCapacities& capacities, std::size_t budget_bytes, std::string* error,
            double cell_m = kDefaultCellM);
  bool initialized() const { return capacity_ > 0; }

  // Inserts the place at p, or moves it there when it is held. False (and counted under failed) when the index is
  // full or p is not finite (a held place with a non-finite position is removed).
  bool upsert(scene_graph::NodeId id, const Eigen::Vector3d& p);
  // Removes the place; false when it was not held.
  bool remove(scene_graph::NodeId id);
  bool contains(scene_graph::NodeId id) const { return slot_of_.contains(id); }
  // Where the index holds the place (false when it does not).
  bool position(scene_graph::NodeId id, Eigen::Vector3d* p) const;
  void clear();

  // The k (<= kMaxK) nearest held places to q accepted by keep(id), nearest first (equal distances: smaller id
  // first); returns how many were written.
  template <typename Keep>
  std::size_t nearest(const Eigen::Vector3d& q, std::size_t k, PlaceNeighbor* out, Keep&& keep) const;
  std::size_t nearest(const Eigen::Vector3d& q, std::size_t k, PlaceNeighbor* out) const {
    return nearest(q, k, out, [](scene_graph::NodeId) { return true; });
  }

  // Visits up to max_entries slots, round robin from where the last sweep stopped; for each held place,
  // fn(id, position, &moved_to) returns 0 to keep it, 1 to remove it, 2 to move it to moved_to (a bounded,
  // incremental consistency check against the scene graph). Returns the places visited.
  template <typename Fn>
  std::size_t sweep(std::size_t max_entries, Fn&& fn);

  std::size_t size() const { return size_; }
  std::size_t capacity() const { return capacity_; }
  std::uint64_t failed() const { return failed_; }
  void set_name(const char* name) { name_ = name; }
  memory::ResourceStats stats() const { return {name_, "points", capacity_, size_, high_water_, failed_}; }

 private:
  static constexpr std::uint32_t kNil = std::numeric_limits<std::uint32_t>::max();
  struct Entry {
    double p[3];
    scene_graph::NodeId id;
    std::uint32_t next;  // next entry in the column, or kNil; in the free list, the next free entry
    std::int32_t cx, cy;
    bool used;
  };
  memory::Index3 column_of(double x, double y) const;
  void link(std::uint32_t e);
  void unlink(std::uint32_t e);
  struct Best;
  template <typename Keep>
  void scan_column(std::int32_t cx, std::int32_t cy, const double* q, Best* best, Keep& keep) const;

  memory::Arena arena_;
  Entry* entries_ = nullptr;
  memory::FixedHashMap<scene_graph::NodeId, std::uint32_t, memory::U64Hash> slot_of_{"frontend.place_index.ids"};
  memory::FixedHashMap<memory::Index3, std::uint32_t, memory::Index3Hash> column_head_{"frontend.place_index.columns"};
  std::uint32_t free_ = kNil;
  std::size_t capacity_ = 0;
  std::size_t size_ = 0;
  std::size_t high_water_ = 0;
  std::uint64_t failed_ = 0;
  std::size_t sweep_cursor_ = 0;
  double cell_m_ = kDefaultCellM;
  // The columns ever used (grow-only): a query's rings stop once they cover them.
  std::int32_t min_cx_ = 0, max_cx_ = -1, min_cy_ = 0, max_cy_ = -1;
  const char* name_ = "frontend.place_index";
};

// ---- templates ----

struct IncrementalPlaceIndex::Best {
  std::size_t k = 1;
  std::size_t n = 0;
  std::size_t seen = 0;  // entries looked at
  double d2[kMaxK];
  scene_graph::NodeId id[kMaxK];
  double worst() const { return n < k ? std::numeric_limits<double>::infinity() : d2[n - 1]; }
  static bool before(double da, scene_graph::NodeId ia, double db, scene_graph::NodeId ib) {
    return da < db || (da == db && ia < ib);
  }
  void offer(double d, scene_graph::NodeId i) {
    if (n == k && !before(d, i, d2[n - 1], id[n - 1])) return;
    std::size_t j = n < k ? n++ : n - 1;
    while (j > 0 && before(d, i, d2[j - 1], id[j - 1])) {
      d2[j] = d2[j - 1];
      id[j] = id[j - 1];
      --j;
    }
    d2[j] = d;
    id[j] = i;
  }
};

template <typename Keep>
void IncrementalPlaceIndex::scan_column(std::int32_t cx, std::int32_t cy, const double* q, Best* best,
                                        Keep& keep) const {
  const std::uint32_t* head = column_head_.find(memory::Index3{cx, cy, 0});
  if (head == nullptr) return;
  for (std::uint32_t e = *head; e != kNil; e = entries_[e].next) {
    const Entry& en = entries_[e];
    ++best->seen;
    const double dx = en.p[0] - q[0], dy = en.p[1] - q[1], dz = en.p[2] - q[2];
    const double d2 = dx * dx + dy * dy + dz * dz;
    if (best->n == best->k && d2 > best->worst()) continue;
    if (keep(en.id)) best->offer(d2, en.id);
  }
}

template <typename Keep>
std::size_t IncrementalPlaceIndex::nearest(const Eigen::Vector3d& q, std::size_t k, PlaceNeighbor* out,
                                           Keep&& keep) const {
  if (size_ == 0 || k == 0 || out == nullptr || !q.allFinite()) return 0;
  Best best;
  best.k = std::min(k, kMaxK);
  const double qq[3] = {q.x(), q.y(), q.z()};
  const memory::Index3 c = column_of(q.x(), q.y());
  // Rings of columns at Chebyshev distance r from the query's column: every point of ring r + 1 lies at least
  // r x cell_m from q in the plan, so the search stops when the k-th best is nearer than that, or when the rings
  // cover every column ever used.
  const std::int64_t reach = std::max<std::int64_t>(
      std::max<std::int64_t>(std::int64_t(c.x) - min_cx_, std::int64_t(max_cx_) - c.x),
      std::max<std::int64_t>(std::int64_t(c.y) - min_cy_, std::int64_t(max_cy_) - c.y));
  bool done = false;
  for (std::int64_t r = 0; r <= std::min<std::int64_t>(reach, kMaxRings) && !done; ++r) {
    if (r == 0) {
      scan_column(c.x, c.y, qq, &best, keep);
    } else {
      const std::int32_t ri = static_cast<std::int32_t>(r);
      for (std::int32_t dx = -ri; dx <= ri; ++dx) {
        scan_column(c.x + dx, c.y - ri, qq, &best, keep);
        scan_column(c.x + dx, c.y + ri, qq, &best, keep);
      }
      for (std::int32_t dy = -ri + 1; dy <= ri - 1; ++dy) {
        scan_column(c.x - ri, c.y + dy, qq, &best, keep);
        scan_column(c.x + ri, c.y + dy, qq, &best, keep);
      }
    }
    const double ring_m = static_cast<double>(r) * cell_m_;
    done = r == reach || best.seen == size_ || (best.n == best.k && best.worst() <= ring_m * ring_m);
  }
  if (!done) {
    // Far from every place (beyond kMaxRings columns): every entry, once.
    best.n = 0;
    for (std::size_t e = 0; e < high_water_; ++e) {
      if (!entries_[e].used) continue;
      const Entry& en = entries_[e];
      const double dx = en.p[0] - qq[0], dy = en.p[1] - qq[1], dz = en.p[2] - qq[2];
      const double d2 = dx * dx + dy * dy + dz * dz;
      if ((best.n < best.k || d2 <= best.worst()) && keep(en.id)) best.offer(d2, en.id);
    }
  }
  for (std::size_t i = 0; i < best.n; ++i) {
    out[i].id = best.id[i];
    out[i].distance_m = std::sqrt(best.d2[i]);
  }
  return best.n;
}

template <typename Fn>
std::size_t IncrementalPlaceIndex::sweep(std::size_t max_entries, Fn&& fn) {
  // Slots above the high-water mark were never used (free slots are handed out lowest first from a fresh index).
  std::size_t visited = 0;
  for (std::size_t step = 0; step < max_entries && size_ > 0; ++step) {
    if (sweep_cursor_ >= high_water_) sweep_cursor_ = 0;
    const std::uint32_t e = static_cast<std::uint32_t>(sweep_cursor_++);
    if (!entries_[e].used) continue;
    ++visited;
    Eigen::Vector3d moved_to;
    const Eigen::Vector3d p(entries_[e].p[0], entries_[e].p[1], entries_[e].p[2]);
    const scene_graph::NodeId id = entries_[e].id;
    const int action = fn(id, p, &moved_to);
    if (action == 1) remove(id);
    else if (action == 2) upsert(id, moved_to);
  }
  return visited;
}

}  // namespace qsg::frontend
