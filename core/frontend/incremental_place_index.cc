// The nearest-place index kept up to date place by place: columns of places in a fixed hash map.
#include "core/frontend/incremental_place_index.h"

#include <cmath>

namespace qsg::frontend {

namespace {
using IdMap = memory::FixedHashMap<scene_graph::NodeId, std::uint32_t, memory::U64Hash>;
using ColumnMap = memory::FixedHashMap<memory::Index3, std::uint32_t, memory::Index3Hash>;
}  // namespace

memory::ArenaPlan IncrementalPlaceIndex::plan(const NearestPlaceCapacities& c) {
  memory::ArenaPlan p;
  p.add_array<Entry>(c.places);
  IdMap::plan(p, IdMap::slots_for(c.places));
  ColumnMap::plan(p, ColumnMap::slots_for(c.places));
  return p;
}

bool IncrementalPlaceIndex::init(const NearestPlaceCapacities& c, std::size_t budget_bytes, std::string* error,
                                 double cell_m) {
  const auto fail = [&](const std::string& why) {
    if (error != nullptr) *error = "incremental place index: " + why;
    return false;
  };
  if (c.places == 0 || c.places >= kNil) return fail("capacities.places must be in [1, 2^32 - 1)");
  if (!(cell_m > 0.0) || !std::isfinite(cell_m)) return fail("cell_m must be a positive size");
  if (arena_.sealed()) return fail("init() called twice");
  if (!arena_.create("incremental_place_index", plan(c), budget_bytes, error)) return false;
  entries_ = arena_.carve_array<Entry>(c.places);
  const bool maps = slot_of_.carve(arena_, IdMap::slots_for(c.places), c.places) &&
                    column_head_.carve(arena_, ColumnMap::slots_for(c.places), c.places);
  if (entries_ == nullptr || !maps || !arena_.seal()) return fail("the arena carve did not match its plan");
  capacity_ = c.places;
  cell_m_ = cell_m;
  clear();
  return true;
}

void IncrementalPlaceIndex::clear() {
  slot_of_.clear();
  column_head_.clear();
  for (std::size_t i = 0; i < capacity_; ++i) {
    entries_[i].used = false;
    entries_[i].next = i + 1 < capacity_ ? static_cast<std::uint32_t>(i + 1) : kNil;
  }
  free_ = capacity_ > 0 ? 0u : kNil;
  size_ = 0;
  sweep_cursor_ = 0;
  min_cx_ = min_cy_ = 0;
  max_cx_ = max_cy_ = -1;
}

memory::Index3 IncrementalPlaceIndex::column_of(double x, double y) const {
  // Clamped so a far-away point (kilometres of drift) still maps to a column; its distance stays exact.
  const auto cell = [&](double v) {
    const double c = std::floor(v / cell_m_);
    return static_cast<std::int32_t>(std::max(-1.0e9, std::min(1.0e9, c)));
  };
  return memory::Index3{cell(x), cell(y), 0};
}

void IncrementalPlaceIndex::link(std::uint32_t e) {
  Entry& en = entries_[e];
  const memory::Index3 c = column_of(en.p[0], en.p[1]);
  en.cx = c.x;
  en.cy = c.y;
  bool inserted = false;
  std::uint32_t* head = column_head_.find_or_insert(c, kNil, &inserted);
  // The column map holds at most one column per entry, so it cannot be full while an entry is free.
  en.next = head != nullptr ? *head : kNil;
  if (head != nullptr) *head = e;
  if (max_cx_ < min_cx_) {
    min_cx_ = max_cx_ = c.x;
    min_cy_ = max_cy_ = c.y;
  } else {
    min_cx_ = std::min(min_cx_, c.x);
    max_cx_ = std::max(max_cx_, c.x);
    min_cy_ = std::min(min_cy_, c.y);
    max_cy_ = std::max(max_cy_, c.y);
  }
}

void IncrementalPlaceIndex::unlink(std::uint32_t e) {
  const memory::Index3 c{entries_[e].cx, entries_[e].cy, 0};
  std::uint32_t* head = column_head_.find(c);
  if (head == nullptr) return;
  std::uint32_t* at = head;
  while (*at != kNil && *at != e) at = &entries_[*at].next;
  if (*at == e) *at = entries_[e].next;
  if (*head == kNil) column_head_.erase(c);
}

bool IncrementalPlaceIndex::upsert(scene_graph::NodeId id, const Eigen::Vector3d& p) {
  if (capacity_ == 0) return false;
  if (!p.allFinite()) {
    remove(id);
    ++failed_;
    return false;
  }
  if (std::uint32_t* slot = slot_of_.find(id)) {
    Entry& en = entries_[*slot];
    const memory::Index3 c = column_of(p.x(), p.y());
    const bool same_column = c.x == en.cx && c.y == en.cy;
    if (!same_column) unlink(*slot);
    en.p[0] = p.x();
    en.p[1] = p.y();
    en.p[2] = p.z();
    if (!same_column) link(*slot);
    return true;
  }
  if (free_ == kNil) {
    ++failed_;
    return false;
  }
  const std::uint32_t e = free_;
  free_ = entries_[e].next;
  Entry& en = entries_[e];
  en.p[0] = p.x();
  en.p[1] = p.y();
  en.p[2] = p.z();
  en.id = id;
  en.used = true;
  link(e);
  slot_of_.insert(id, e);
  ++size_;
  high_water_ = std::max(high_water_, size_);
  return true;
}

bool IncrementalPlaceIndex::remove(scene_graph::NodeId id) {
  const std::uint32_t* slot = slot_of_.find(id);
  if (slot == nullptr) return false;
  const std::uint32_t e = *slot;
  unlink(e);
  slot_of_.erase(id);
  entries_[e].used = false;
  entries_[e].next = free_;
  free_ = e;
  --size_;
  return true;
}

bool IncrementalPlaceIndex::position(scene_graph::NodeId id, Eigen::Vector3d* p) const {
  const std::uint32_t* slot = slot_of_.find(id);
  if (slot == nullptr) return false;
  if (p != nullptr) *p = Eigen::Vector3d(entries_[*slot].p[0], entries_[*slot].p[1], entries_[*slot].p[2]);
  return true;
}

}  // namespace qsg::frontend
