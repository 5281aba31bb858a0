// The extent split: extended clearance by a multi-source Dijkstra, per-room persistence seeding on it, and the
// split rooms flood-filled again among their seeds.
#include "core/rooms/refine/extent_split.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace qsg::rooms::refine {

namespace {
constexpr std::uint32_t kSplit = 0x80000000u;      // room_seeds_: the room is split
constexpr std::uint32_t kFirstSlot = 0x40000000u;  // room_seeds_: its first seed took the room's slot
}  // namespace

void ExtentSplit::plan(memory::ArenaPlan* p, std::size_t places, std::size_t rooms) {
  p->add_array<double>(places);
  p->add_array<std::uint32_t>(places);
  p->add_array<std::uint32_t>(rooms);
}

bool ExtentSplit::carve(memory::Arena& arena, std::size_t places, std::size_t rooms) {
  extent_ = arena.carve_array<double>(places);
  sub_seeds_ = arena.carve_array<std::uint32_t>(places);
  room_seeds_ = arena.carve_array<std::uint32_t>(rooms);
  return extent_ && sub_seeds_ && room_seeds_;
}

// A multi-source Dijkstra over the place edges with horizontal lengths, from every place below the saturation
// clearance; a saturated place adds its distance to them (none when no such place is connected to it).
void ExtentSplit::compute_extent(const ExtentSplitConfig& config, const PlacesGraph& places, Workspace* ws) {
  constexpr double kUnreached = std::numeric_limits<double>::infinity();
  const double* clearance = places.clearance;
  const double* position = places.position;
  double* depth = extent_;
  for (std::uint32_t i = 0; i < places.num_places; ++i)
    depth[i] = clearance[i] < config.saturation_m ? 0.0 : kUnreached;
  ws->heap_size = 0;
  std::uint32_t sequence = 0;
  // Max-heap on clearance_m, so the distance goes in negated. Each place relaxes its edges once (stale entries
  // are skipped), so at most one entry per directed edge: the heap's 2 x edges capacity holds them all.
  const auto relax = [&](std::uint32_t i) {
    places.for_each_edge(i, [&](const PlaceEdge&, std::uint32_t j) {
      const double d =
          depth[i] + std::hypot(position[3 * j] - position[3 * i], position[3 * j + 1] - position[3 * i + 1]);
      if (d < depth[j]) {
        depth[j] = d;
        ws->heap_push(HeapEntry{-d, sequence++, j, 0});
      }
    });
  };
  for (std::uint32_t i = 0; i < places.num_places; ++i)
    if (depth[i] == 0.0) relax(i);
  while (ws->heap_size > 0) {
    const HeapEntry top = ws->heap_pop();
    if (-top.clearance_m > depth[top.place]) continue;  // stale
    relax(top.place);
  }
  for (std::uint32_t i = 0; i < places.num_places; ++i)
    extent_[i] = clearance[i] + (depth[i] == kUnreached ? 0.0 : depth[i]);
}

// The persistence rule (as the finder's seeding) on the extended clearance, through each room's own edges: a seed
// records its room in sub_seeds_ and its places in ws->root_room; room_seeds_ counts each room's seeds. Returns
// the number of seeds.
std::uint32_t ExtentSplit::seed(const ExtentSplitConfig& config, const PlacesGraph& places, const Partition& rooms,
                                Workspace* ws) {
  const std::int32_t* room_of = rooms.room_of;
  const double top = config.max_extent_m;
  const double d_min = config.min_extent_m - kDilationTolerance;
  // A closed passage stays closed to the split too.
  const auto edge_extent = [&](const PlaceEdge& e) {
    return e.closed() ? kClosed : std::min(extent_[e.a], extent_[e.b]);
  };
  std::uint32_t* node_order = ws->order;
  std::uint32_t* edge_order = ws->order + places.num_places;
  std::size_t num_inner = 0;
  for (std::uint32_t i = 0; i < places.num_places; ++i) node_order[i] = i;
  for (std::uint32_t e = 0; e < places.num_edges; ++e)
    if (room_of[places.edges[e].a] >= 0 && room_of[places.edges[e].a] == room_of[places.edges[e].b])
      edge_order[num_inner++] = e;
  std::sort(node_order, node_order + places.num_places, [&](std::uint32_t a, std::uint32_t b) {
    return extent_[a] != extent_[b] ? extent_[a] > extent_[b] : a < b;
  });
  std::sort(edge_order, edge_order + num_inner, [&](std::uint32_t a, std::uint32_t b) {
    const double ea = edge_extent(places.edges[a]), eb = edge_extent(places.edges[b]);
    return ea != eb ? ea > eb : a < b;
  });
  std::fill(room_seeds_, room_seeds_ + rooms.num_rooms, 0u);
  for (std::uint32_t i = 0; i < places.num_places; ++i) {
    ws->parent[i] = kNoIndex;
    ws->root_room[i] = kNoIndex;  // the place's seed, if any
  }
  std::uint32_t num_seeds = 0;
  const auto emit = [&](std::uint32_t root) {
    ws->flag[root] = 1;
    if (room_of[root] < 0) return;
    sub_seeds_[num_seeds] = static_cast<std::uint32_t>(room_of[root]);  // the seed's room, for now
    ++room_seeds_[room_of[root]];
    for (std::uint32_t i = root; i != kNoIndex; i = ws->member_next[i]) ws->root_room[i] = num_seeds;
    ++num_seeds;
  };
  const auto worthy = [&](std::uint32_t root, double at_m) {
    return ws->flag[root] != 0 || (ws->size[root] >= config.min_component_size &&
                                   ws->birth[root] - at_m >= config.min_persistence_m - 1e-9);
  };
  const auto enter = [&](std::uint32_t i) {
    ws->parent[i] = i;
    ws->size[i] = 1;
    ws->birth[i] = std::min(extent_[i], top);
    ws->member_next[i] = kNoIndex;
    ws->member_tail[i] = i;
    ws->flag[i] = 0;
  };
  std::size_t next_node = 0;
  for (std::size_t k = 0; k < num_inner; ++k) {
    const PlaceEdge& e = places.edges[edge_order[k]];
    const double c = edge_extent(e);
    if (c < d_min) break;
    for (; next_node < places.num_places && extent_[node_order[next_node]] >= c; ++next_node)
      enter(node_order[next_node]);
    std::uint32_t ra = ws->find(e.a), rb = ws->find(e.b);
    if (ra == rb) continue;
    std::uint8_t seeds = ws->flag[ra] | ws->flag[rb];
    if (worthy(ra, c) && worthy(rb, c)) {
      if (ws->flag[ra] == 0) emit(ra);
      if (ws->flag[rb] == 0) emit(rb);
      seeds = 1;
    }
    ws->join(ra, rb, seeds);
  }
  for (; next_node < places.num_places && extent_[node_order[next_node]] >= d_min; ++next_node)
    enter(node_order[next_node]);
  for (std::size_t n = 0; n < next_node; ++n) {
    const std::uint32_t i = node_order[n];
    if (ws->parent[i] == i && ws->flag[i] == 0 && ws->size[i] >= config.min_component_size) emit(i);
  }
  return num_seeds;
}

Partition ExtentSplit::run(const ExtentSplitConfig& config, const PlacesGraph& places, Partition rooms,
                           Workspace* ws, ExtentSplitStats* stats) {
  compute_extent(config, places, ws);
  const std::uint32_t num_seeds = seed(config, places, rooms, ws);
  std::int32_t* room_of = rooms.room_of;
  // Slots: a room's first seed keeps its slot, each further one takes a new slot. room_seeds_[room] holds the
  // room's seed count in its low bits, then the two flags.
  const std::size_t num_rooms = rooms.num_rooms;
  for (std::uint32_t q = 0; q < num_seeds; ++q) {
    const std::uint32_t room = sub_seeds_[q];
    if (room_seeds_[room] < 2) {
      sub_seeds_[q] = room;  // one seed: the room stays as it is
      continue;
    }
    room_seeds_[room] |= kSplit;  // its places are re-filled below
    if ((room_seeds_[room] & kFirstSlot) == 0) {
      room_seeds_[room] |= kFirstSlot;
      sub_seeds_[q] = room;
      ++stats->rooms_split;
    } else if (rooms.num_rooms < rooms.max_rooms) {
      sub_seeds_[q] = static_cast<std::uint32_t>(rooms.num_rooms++);
      ++stats->split_rooms_added;
    } else {
      sub_seeds_[q] = room;  // no slot left: stays in its room
      ++stats->seeds_dropped;
    }
  }
  // Places of split rooms: seed members take their seed's slot, the others are filled again among them. parent
  // now holds each such place's room before the split (kNoIndex elsewhere), the bound of the fill.
  std::uint32_t* before = ws->parent;
  for (std::uint32_t i = 0; i < places.num_places; ++i) {
    before[i] = kNoIndex;
    const std::int32_t room = room_of[i];
    if (room < 0 || static_cast<std::size_t>(room) >= num_rooms || (room_seeds_[room] & kSplit) == 0) continue;
    before[i] = static_cast<std::uint32_t>(room);
    room_of[i] = ws->root_room[i] != kNoIndex ? static_cast<std::int32_t>(sub_seeds_[ws->root_room[i]]) : -1;
  }
  const auto edge_extent = [&](const PlaceEdge& e) {
    return e.closed() ? kClosed : std::min(extent_[e.a], extent_[e.b]);
  };
  ws->fill(places, room_of, edge_extent, [&](std::uint32_t from, std::uint32_t to) {
    return before[from] != kNoIndex && before[to] == before[from];
  });
  // A room is connected through its own edges, so the fill reaches all of it; should a place be left, it stays in
  // its room.
  for (std::uint32_t i = 0; i < places.num_places; ++i)
    if (before[i] != kNoIndex && room_of[i] < 0) room_of[i] = static_cast<std::int32_t>(before[i]);
  return rooms;
}

}  // namespace qsg::rooms::refine
