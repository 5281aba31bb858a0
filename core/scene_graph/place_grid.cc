// The closed places' spatial hash and their rooms' sums (place_grid.h).
#include "core/scene_graph/place_grid.h"

#include <algorithm>
#include <limits>

namespace qsg::scene_graph {

namespace {
using CellMap = memory::FixedHashMap<memory::Index3, std::uint32_t, memory::Index3Hash>;
std::size_t at_least_one(std::size_t n) { return std::max<std::size_t>(1, n); }
}  // namespace

void ChildSums::reset() {
  for (int d = 0; d < 3; ++d) {
    sum[d] = 0;
    min[d] = std::numeric_limits<double>::max();
    max[d] = std::numeric_limits<double>::lowest();
  }
  count = 0;
}

std::int64_t child_sum_units(double position_m) {
  if (!std::isfinite(position_m)) return 0;
  const double x = std::max(-1e9, std::min(1e9, position_m));
  return static_cast<std::int64_t>(std::llround(x * kChildSumUnitsPerM));
}

void PlaceGrid::plan(memory::ArenaPlan& plan, std::size_t places, std::size_t rooms) {
  CellMap::plan(plan, CellMap::slots_for(at_least_one(places)));
  for (int k = 0; k < 4; ++k) plan.add_array<std::uint32_t>(at_least_one(places));
  plan.add_array<memory::Index3>(at_least_one(places));
  plan.add_array<ChildSums>(at_least_one(rooms));
}

bool PlaceGrid::carve(memory::Arena& arena, std::size_t places, std::size_t rooms) {
  bool ok = cells_.carve(arena, CellMap::slots_for(at_least_one(places)), at_least_one(places));
  next_ = arena.carve_array<std::uint32_t>(at_least_one(places));
  prev_ = arena.carve_array<std::uint32_t>(at_least_one(places));
  node_ = arena.carve_array<std::uint32_t>(at_least_one(places));
  room_ = arena.carve_array<std::uint32_t>(at_least_one(places));
  cell_ = arena.carve_array<memory::Index3>(at_least_one(places));
  sums_ = arena.carve_array<ChildSums>(at_least_one(rooms));
  ok = ok && next_ && prev_ && node_ && room_ && cell_ && sums_;
  places_ = at_least_one(places);
  rooms_ = at_least_one(rooms);
  if (ok) clear();
  return ok;
}

void PlaceGrid::clear() {
  cells_.clear();
  std::fill(room_, room_ + places_, memory::kInvalidHandle);
  for (std::size_t r = 0; r < rooms_; ++r) sums_[r].reset();
  filed_ = 0;
  for (int d = 0; d < 3; ++d) {
    bounds_lo_[d] = std::numeric_limits<std::int32_t>::max();
    bounds_hi_[d] = std::numeric_limits<std::int32_t>::min();
  }
}

void PlaceGrid::file(std::uint32_t place, std::uint32_t node, std::uint32_t room, const PlaceAttributes& a) {
  const Eigen::Vector3d& p = a.position_m;
  const memory::Index3 cell{cell_of(p.x()), cell_of(p.y()), cell_of(p.z())};
  // At most one cell per filed place, and the map holds one per place: the insert cannot be refused.
  std::uint32_t* head = cells_.find_or_insert(cell, memory::kInvalidHandle);
  next_[place] = *head;
  prev_[place] = memory::kInvalidHandle;
  if (*head != memory::kInvalidHandle) prev_[*head] = place;
  *head = place;
  node_[place] = node;
  room_[place] = room;
  cell_[place] = cell;
  ++filed_;
  const std::int32_t c[3] = {cell.x, cell.y, cell.z};
  for (int d = 0; d < 3; ++d) {
    bounds_lo_[d] = std::min(bounds_lo_[d], c[d]);
    bounds_hi_[d] = std::max(bounds_hi_[d], c[d]);
  }
  ChildSums& s = sums_[room];
  if (s.count == 0) s.reset();  // the box starts again with the room's first closed child
  const double radius = free_space_radius_m(a);
  for (int d = 0; d < 3; ++d) {
    s.sum[d] += child_sum_units(p[d]);
    s.min[d] = std::min(s.min[d], p[d] - radius);
    s.max[d] = std::max(s.max[d], p[d] + radius);
  }
  ++s.count;
}

void PlaceGrid::unfile(std::uint32_t place, const PlaceAttributes& a) {
  if (!filed(place)) return;
  if (prev_[place] != memory::kInvalidHandle) {
    next_[prev_[place]] = next_[place];
  } else if (next_[place] != memory::kInvalidHandle) {
    *cells_.find(cell_[place]) = next_[place];
  } else {
    cells_.erase(cell_[place]);
  }
  if (next_[place] != memory::kInvalidHandle) prev_[next_[place]] = prev_[place];
  ChildSums& s = sums_[room_[place]];
  for (int d = 0; d < 3; ++d) s.sum[d] -= child_sum_units(a.position_m[d]);
  --s.count;
  room_[place] = memory::kInvalidHandle;
  --filed_;
}

}  // namespace qsg::scene_graph
