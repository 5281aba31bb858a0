// The visibility merge: rounds of sampled sight lines between adjacent rooms, the test near their boundary, and
// the touching free-space spheres that make rooms adjacent without a place edge.
#include "core/rooms/refine/visibility_merge.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace qsg::rooms::refine {

namespace {
constexpr std::uint64_t kShareMask = 0xffffu;
constexpr std::uint64_t kNearBit = 0x8000u;  // in a candidate's priority: qualifies as whole rooms

std::uint32_t lo_of(std::uint64_t x) { return static_cast<std::uint32_t>(x >> 40); }
std::uint32_t hi_of(std::uint64_t x) { return static_cast<std::uint32_t>((x >> 16) & 0xffffffu); }
std::uint64_t key(std::uint32_t a, std::uint32_t b) {
  return (static_cast<std::uint64_t>(std::min(a, b)) << 40) | (static_cast<std::uint64_t>(std::max(a, b)) << 16);
}

// The rank (in index order) of the j-th of m samples spread evenly over n places: floor(j (n - 1) / (m - 1)), or j
// itself when n <= m (every place taken).
std::uint64_t sample_rank(std::uint64_t n, std::uint64_t m, std::uint64_t j) {
  return n <= m ? j : (m == 1 ? 0 : j * (n - 1) / (m - 1));
}
}  // namespace

void VisibilityMerge::plan(memory::ArenaPlan* p, std::size_t places, std::size_t rooms) {
  p->add_array<std::uint32_t>(rooms * VisibilityMergeConfig::kMaxSamples);
  p->add_array<std::uint32_t>(rooms);
  p->add_array<std::uint32_t>(2 * places);
  p->add_array<std::uint8_t>(places);
  p->add_array<std::uint64_t>(places);
}

bool VisibilityMerge::carve(memory::Arena& arena, std::size_t places, std::size_t rooms) {
  places_capacity_ = places;
  sight_samples_ = arena.carve_array<std::uint32_t>(rooms * VisibilityMergeConfig::kMaxSamples);
  room_count_ = arena.carve_array<std::uint32_t>(rooms);
  near_list_ = arena.carve_array<std::uint32_t>(2 * places);
  near_mark_ = arena.carve_array<std::uint8_t>(places);
  touching_pairs_ = arena.carve_array<std::uint64_t>(places);
  return sight_samples_ && room_count_ && near_list_ && near_mark_ && touching_pairs_;
}

// Every room's samples: its places at ranks floor(j (n - 1) / (m - 1)), j < m, in index order (all of them when it
// has m or fewer); room_count_ ends as the samples per room.
void VisibilityMerge::take_samples(const VisibilityMergeConfig& config, const PlacesGraph& places,
                                   const Partition& rooms, Workspace* ws) {
  const std::uint32_t m = config.samples;
  const std::int32_t* room_of = rooms.room_of;
  std::uint32_t* seen = ws->room_scratch;  // per room: places seen so far (its rank)
  std::uint32_t* taken = ws->room_parent;  // per room: samples taken
  std::fill(room_count_, room_count_ + rooms.num_rooms, 0u);
  for (std::uint32_t i = 0; i < places.num_places; ++i)
    if (room_of[i] >= 0) ++room_count_[room_of[i]];
  std::fill(seen, seen + rooms.num_rooms, 0u);
  std::fill(taken, taken + rooms.num_rooms, 0u);
  for (std::uint32_t i = 0; i < places.num_places; ++i) {
    if (room_of[i] < 0) continue;
    const std::uint32_t k = static_cast<std::uint32_t>(room_of[i]);
    const std::uint64_t n = room_count_[k], rank = seen[k]++;
    // Sample j sits at rank floor(j (n - 1) / (m - 1)); several j can share a rank only when n < m (all taken).
    while (taken[k] < m && sample_rank(n, m, taken[k]) == rank)
      sight_samples_[static_cast<std::size_t>(k) * VisibilityMergeConfig::kMaxSamples + taken[k]++] = i;
  }
  for (std::size_t k = 0; k < rooms.num_rooms; ++k) room_count_[k] = taken[k];
}

// The adjacent pairs from the boundary edges and the touching place pairs (sorted and folded), each pair's share
// of clear sight lines, and the qualifying pairs with their priority in the record's low 16 bits: pairs that
// qualify as whole rooms (kNearBit set, then by share) before pairs that qualify near their boundary only (by that
// share); clearest first (ties: the lower pair).
std::size_t VisibilityMerge::candidates(const VisibilityMergeConfig& config, const PlacesGraph& places,
                                        const SightLines& sight, const Partition& rooms, Workspace* ws,
                                        VisibilityMergeStats* stats) {
  const std::uint64_t min_share =
      static_cast<std::uint64_t>(std::ceil(config.min_share * static_cast<double>(kShareMask)));
  const bool near_on = config.local_radius_m > 0.0;
  const std::uint64_t near_min_share =
      static_cast<std::uint64_t>(std::ceil(config.local_min_share * static_cast<double>(kShareMask)));
  const std::int32_t* room_of = rooms.room_of;
  std::uint64_t* pairs = ws->pairs;
  std::size_t n = 0;
  for (std::size_t e = 0; e < places.num_edges; ++e) {
    const std::int32_t a = room_of[places.edges[e].a], b = room_of[places.edges[e].b];
    if (a >= 0 && b >= 0 && a != b) pairs[n++] = key(static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b));
  }
  for (std::size_t k = 0; k < num_touching_pairs_; ++k) {
    const std::int32_t a = room_of[touching_pairs_[k] >> 32], b = room_of[touching_pairs_[k] & 0xffffffffu];
    if (a != b) pairs[n++] = key(static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b));
  }
  std::sort(pairs, pairs + n);
  n = static_cast<std::size_t>(std::unique(pairs, pairs + n) - pairs);
  std::size_t found = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t a = lo_of(pairs[k]), b = hi_of(pairs[k]);
    const std::uint32_t* sa = sight_samples_ + static_cast<std::size_t>(a) * VisibilityMergeConfig::kMaxSamples;
    const std::uint32_t* sb = sight_samples_ + static_cast<std::size_t>(b) * VisibilityMergeConfig::kMaxSamples;
    std::uint64_t clear = 0;
    for (std::uint32_t x = 0; x < room_count_[a]; ++x)
      for (std::uint32_t y = 0; y < room_count_[b]; ++y)
        clear += sight.sees(places.position_of(sa[x]), places.position_of(sb[y])) ? 1 : 0;
    const std::uint64_t lines = static_cast<std::uint64_t>(room_count_[a]) * room_count_[b];
    const std::uint64_t share = lines == 0 ? 0 : clear * kShareMask / lines;
    ++stats->pairs;
    std::uint64_t priority = 0;
    if (share >= min_share) {
      priority = kNearBit | (share >> 1);
    } else if (near_on) {
      const std::uint64_t near = near_boundary_share(config, places, sight, room_of, a, b, kShareMask);
      if (near > 0 && near >= near_min_share) priority = std::max<std::uint64_t>(1, near >> 1);
    }
    if (priority != 0) pairs[found++] = pairs[k] | priority;
  }
  std::sort(pairs, pairs + found, [&](std::uint64_t x, std::uint64_t y) {
    return (x & kShareMask) != (y & kShareMask) ? (x & kShareMask) > (y & kShareMask) : x < y;
  });
  return found;
}

Partition VisibilityMerge::run(const VisibilityMergeConfig& config, const PlacesGraph& places,
                               const SightLines& sight, Partition rooms, Workspace* ws, VisibilityMergeStats* stats) {
  std::size_t near_merged = 0;
  std::size_t merged_total = 0;
  find_touching_pairs(config, places, sight, rooms.room_of, ws, stats);
  for (std::uint32_t round = 0; round < config.max_rounds; ++round) {
    take_samples(config, places, rooms, ws);
    const std::size_t found = candidates(config, places, sight, rooms, ws, stats);
    if (found == 0) break;
    const std::uint64_t* pairs = ws->pairs;
    for (std::size_t k = 0; k < rooms.num_rooms; ++k) ws->room_parent[k] = static_cast<std::uint32_t>(k);
    std::fill(room_count_, room_count_ + rooms.num_rooms, 0u);  // per room: merged this round
    std::size_t merged = 0;
    for (std::size_t k = 0; k < found; ++k) {
      const std::uint32_t a = lo_of(pairs[k]), b = hi_of(pairs[k]);
      if (room_count_[a] != 0 || room_count_[b] != 0) continue;
      room_count_[a] = room_count_[b] = 1;
      ws->room_parent[b] = a;  // the lower slot stays
      ++merged;
      if ((pairs[k] & kNearBit) == 0) ++near_merged;
    }
    merged_total += merged;
    rooms.num_rooms = ws->renumber_merged_rooms(places, rooms.room_of, rooms.num_rooms);
  }
  stats->merges += merged_total;
  stats->near_merges += near_merged;
  return rooms;
}

// Layout of near_list_ (2 x places): [0, places) holds the boundary ends, b's from the front and a's from the back;
// [places, 2 places) the places near them, a's from the front and b's from the back. Marks are cleared on the way
// out, so the cost is the edges once plus each room's places times the other's ends.
std::uint64_t VisibilityMerge::near_boundary_share(const VisibilityMergeConfig& config, const PlacesGraph& places,
                                                   const SightLines& sight, const std::int32_t* room_of,
                                                   std::uint32_t a, std::uint32_t b, std::uint64_t share_scale) {
  const std::size_t cap = places_capacity_;
  std::uint32_t* ends = near_list_;
  std::uint32_t* near = near_list_ + cap;
  std::size_t ends_b = 0, ends_a = 0;
  const auto add_ends = [&](std::uint32_t u, std::uint32_t v) {
    const std::int32_t ru = room_of[u], rv = room_of[v];
    if (!((ru == static_cast<std::int32_t>(a) && rv == static_cast<std::int32_t>(b)) ||
          (ru == static_cast<std::int32_t>(b) && rv == static_cast<std::int32_t>(a))))
      return;
    if (ru == static_cast<std::int32_t>(b)) std::swap(u, v);  // u in a, v in b
    if ((near_mark_[v] & 1u) == 0) {
      near_mark_[v] |= 1u;
      ends[ends_b++] = v;
    }
    if ((near_mark_[u] & 2u) == 0) {
      near_mark_[u] |= 2u;
      ends[cap - 1 - ends_a++] = u;
    }
  };
  for (std::size_t e = 0; e < places.num_edges; ++e) add_ends(places.edges[e].a, places.edges[e].b);
  for (std::size_t k = 0; k < num_touching_pairs_; ++k)
    add_ends(static_cast<std::uint32_t>(touching_pairs_[k] >> 32),
             static_cast<std::uint32_t>(touching_pairs_[k] & 0xffffffffu));
  for (std::size_t k = 0; k < ends_b; ++k) near_mark_[ends[k]] = 0;
  for (std::size_t k = 0; k < ends_a; ++k) near_mark_[ends[cap - 1 - k]] = 0;
  const double r2 = config.local_radius_m * config.local_radius_m;
  const double* position = places.position;
  const auto close_to = [&](std::uint32_t i, const std::uint32_t* list, std::size_t n, bool backwards) {
    for (std::size_t k = 0; k < n; ++k) {
      const std::uint32_t j = backwards ? list[cap - 1 - k] : list[k];
      const double dx = position[3 * i] - position[3 * j], dy = position[3 * i + 1] - position[3 * j + 1];
      if (dx * dx + dy * dy <= r2) return true;
    }
    return false;
  };
  std::size_t near_a = 0, near_b = 0;
  for (std::uint32_t i = 0; i < places.num_places; ++i) {
    if (room_of[i] == static_cast<std::int32_t>(a) && close_to(i, ends, ends_b, false)) near[near_a++] = i;
    if (room_of[i] == static_cast<std::int32_t>(b) && close_to(i, ends, ends_a, true)) near[cap - 1 - near_b++] = i;
  }
  const std::size_t min_places = config.local_min_places;
  if (near_a < min_places || near_b < min_places) return 0;
  // The same even spread as the whole rooms' samples.
  const std::uint64_t m = config.samples;
  const std::size_t ma = std::min<std::size_t>(near_a, m), mb = std::min<std::size_t>(near_b, m);
  std::uint64_t clear = 0;
  for (std::size_t x = 0; x < ma; ++x)
    for (std::size_t y = 0; y < mb; ++y)
      clear += sight.sees(places.position_of(near[sample_rank(near_a, m, x)]),
                          places.position_of(near[cap - 1 - sample_rank(near_b, m, y)]))
                   ? 1
                   : 0;
  return clear * share_scale / (static_cast<std::uint64_t>(ma) * mb);
}

// Places are keyed by their plan cell (twice the largest clearance a side, so touching spheres lie in neighbouring
// cells) and sorted (in ws->pairs, free until the rounds); each place then looks through the 3 x 3 cells round its
// own for places of other rooms (a higher index: each pair once) whose sphere touches its own and that it sees. The
// cost is the places' sort, the distances to the places in those cells, and a sight line per touching pair of
// different rooms.
void VisibilityMerge::find_touching_pairs(const VisibilityMergeConfig& config, const PlacesGraph& places,
                                          const SightLines& sight, const std::int32_t* room_of, Workspace* ws,
                                          VisibilityMergeStats* stats) {
  num_touching_pairs_ = 0;
  if (!config.touching || places.num_places == 0) return;
  const double* clearance = places.clearance;
  const double* position = places.position;
  const auto usable = [&](std::uint32_t i) {
    return room_of[i] >= 0 && clearance[i] > 0.0 && std::isfinite(position[3 * i]) &&
           std::isfinite(position[3 * i + 1]) && std::isfinite(position[3 * i + 2]);
  };
  const auto radius = [&](std::uint32_t i) { return std::min(clearance[i], config.touch_max_clearance_m); };
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0, cell = 0.0;
  for (std::uint32_t i = 0; i < places.num_places; ++i) {
    if (!usable(i)) continue;
    cell = std::max(cell, 2.0 * radius(i));
    x0 = std::min(x0, position[3 * i]);
    x1 = std::max(x1, position[3 * i]);
    y0 = std::min(y0, position[3 * i + 1]);
    y1 = std::max(y1, position[3 * i + 1]);
  }
  if (!(x1 >= x0)) return;  // no usable place
  const double cols_d = std::floor((x1 - x0) / cell) + 1.0, rows_d = std::floor((y1 - y0) / cell) + 1.0;
  if (!(cols_d * rows_d < 4.0e9)) {  // the cell key is 32 bits: a map this large in cells is not looked through
    ++stats->touching_dropped;
    return;
  }
  const std::uint64_t cols = static_cast<std::uint64_t>(cols_d), rows = static_cast<std::uint64_t>(rows_d);
  std::uint64_t* const cell_keys = ws->pairs;
  std::size_t n = 0;
  for (std::uint32_t i = 0; i < places.num_places; ++i) {
    if (!usable(i)) continue;
    const std::uint64_t c = std::min(cols - 1, static_cast<std::uint64_t>((position[3 * i] - x0) / cell));
    const std::uint64_t w = std::min(rows - 1, static_cast<std::uint64_t>((position[3 * i + 1] - y0) / cell));
    cell_keys[n++] = ((w * cols + c) << 32) | i;
  }
  std::sort(cell_keys, cell_keys + n);
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t i = static_cast<std::uint32_t>(cell_keys[k] & 0xffffffffu);
    const std::uint64_t at = cell_keys[k] >> 32, row = at / cols, col = at % cols;
    for (std::uint64_t w = row == 0 ? 0 : row - 1; w <= std::min(rows - 1, row + 1); ++w) {
      const std::uint64_t first = w * cols + (col == 0 ? 0 : col - 1), last = w * cols + std::min(cols - 1, col + 1);
      for (const std::uint64_t* it = std::lower_bound(cell_keys, cell_keys + n, first << 32);
           it != cell_keys + n && (*it >> 32) <= last; ++it) {
        const std::uint32_t j = static_cast<std::uint32_t>(*it & 0xffffffffu);
        if (j <= i || room_of[j] == room_of[i]) continue;
        const double touch = radius(i) + radius(j);
        if ((places.position_of(i) - places.position_of(j)).squaredNorm() >= touch * touch ||
            !sight.sees(places.position_of(i), places.position_of(j)))
          continue;
        if (num_touching_pairs_ == places_capacity_) {
          ++stats->touching_dropped;
          continue;
        }
        touching_pairs_[num_touching_pairs_++] = (static_cast<std::uint64_t>(i) << 32) | j;
      }
    }
  }
  stats->touching_pairs += num_touching_pairs_;
}

}  // namespace qsg::rooms::refine
