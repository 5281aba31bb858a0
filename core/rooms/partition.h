// What the room finder's steps and the refinement passes (core/rooms/refine/) share: the places graph one update
// read (PlacesGraph, read-only after reading), a partition of its places into rooms (Partition), and the scratch
// arrays every step reuses (Workspace: union-find, the flood fill's heap, merge-tree lists, pair keys, room slots),
// carved once from the finder's arena. Nothing in the Workspace is kept from one step to the next.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "core/memory/arena.h"
#include "core/scene_graph/node_id.h"

namespace qsg::rooms {

inline constexpr std::uint32_t kNoIndex = std::numeric_limits<std::uint32_t>::max();
// Grid dilations are d- + i x step in double; a clearance equal to a grid value must count as alive.
inline constexpr double kDilationTolerance = 1e-9;
// The clearance of a closed passage (edge weight <= 0, a door stage's mark): below every dilation and every open
// edge (clearances are >= 0), so the filtration never crosses it and the flood fill takes it last.
inline constexpr double kClosed = -1.0;

struct PlaceEdge {
  std::uint32_t a;
  std::uint32_t b;
  // min(edge weight, clearance of both ends): an edge never outlives its ends. kClosed for a closed passage.
  double clearance_m;
  bool closed() const { return clearance_m < 0.0; }
};

// The places of one update, local index i < num_places in the order of their ids, and their edges ordered by
// (a, b) with a < b, with a CSR adjacency.
struct PlacesGraph {
  std::size_t num_places = 0;
  const scene_graph::NodeId* ids = nullptr;
  const double* clearance = nullptr;  // metres, >= 0
  const double* position = nullptr;   // x, y, z per place
  const std::uint8_t* active = nullptr;
  std::size_t num_edges = 0;
  const PlaceEdge* edges = nullptr;
  const std::uint32_t* adjacency_offset = nullptr;  // place i's edges are adjacency[offset[i], offset[i + 1])
  const std::uint32_t* adjacency = nullptr;         // edge indices
  std::size_t capacity = 0;                         // places the stores hold (Capacities::places)

  Eigen::Vector3d position_of(std::uint32_t i) const {
    return Eigen::Vector3d(position[3 * i], position[3 * i + 1], position[3 * i + 2]);
  }
  // fn(edge, other end) for every place edge of place i.
  template <typename Fn>
  void for_each_edge(std::uint32_t i, Fn&& fn) const {
    for (std::uint32_t k = adjacency_offset[i]; k < adjacency_offset[i + 1]; ++k) {
      const PlaceEdge& e = edges[adjacency[k]];
      fn(e, e.a == i ? e.b : e.a);
    }
  }
};

// Places into rooms: room_of[i] is place i's room slot (< num_rooms) or -1. A pass rewrites room_of in place and
// returns the partition with its new number of rooms; it never adds a slot at or beyond max_rooms.
struct Partition {
  std::int32_t* room_of = nullptr;
  std::size_t num_rooms = 0;
  std::size_t max_rooms = 0;
};

struct HeapEntry {
  double clearance_m;
  std::uint32_t sequence;  // push order: among equal clearances the earlier frontier wins (breadth-first)
  std::uint32_t place;
  std::uint32_t room;
};

// The shared scratch, sized by the places, place edges and rooms the finder holds.
class Workspace {
 public:
  static void plan(memory::ArenaPlan* p, std::size_t places, std::size_t place_edges, std::size_t rooms);
  bool carve(memory::Arena& arena, std::size_t places, std::size_t place_edges, std::size_t rooms);

  // Union-find over places (parent, size) with path halving.
  std::uint32_t find(std::uint32_t i) {
    while (parent[i] != i) {
      parent[i] = parent[parent[i]];
      i = parent[i];
    }
    return i;
  }
  // Merge-tree union: the smaller component joins the larger, which keeps the larger birth, both member lists and
  // the given seed flag.
  void join(std::uint32_t ra, std::uint32_t rb, std::uint8_t flag);

  // Max-heap on clearance, ties in push order (deterministic).
  void heap_push(const HeapEntry& e);
  HeapEntry heap_pop();

  // Every place outside a room that may_enter(from, to) allows joins the room whose frontier reaches it through the
  // edge of largest value(edge) first (ties: push order).
  template <typename Value, typename MayEnter>
  void fill(const PlacesGraph& places, std::int32_t* room_of, Value value, MayEnter may_enter);

  // Union-find over room slots (room_parent), for the merges.
  std::uint32_t find_room(std::uint32_t slot) {
    while (room_parent[slot] != slot) {
      room_parent[slot] = room_parent[room_parent[slot]];
      slot = room_parent[slot];
    }
    return slot;
  }
  // Dense slots in the order of the surviving rooms' old slots (room_parent says who merged into whom);
  // room_scratch becomes old root -> new slot. Returns the new number of rooms.
  std::size_t renumber_merged_rooms(const PlacesGraph& places, std::int32_t* room_of, std::size_t num_rooms);

  std::uint32_t* order = nullptr;         // places + edges: sort orders
  std::uint32_t* parent = nullptr;        // per place: union-find
  std::uint32_t* size = nullptr;          // per place
  double* birth = nullptr;                // per place root: largest clearance (merge tree)
  std::uint32_t* member_next = nullptr;   // per place: member lists (next / tail)
  std::uint32_t* member_tail = nullptr;
  std::uint8_t* flag = nullptr;           // per place root: holds seeds
  std::uint32_t* root_room = nullptr;     // per place root: its seed slot, or kNoIndex
  std::uint64_t* pairs = nullptr;         // max(places, edges) + places: sortable keys
  std::uint32_t* room_parent = nullptr;   // per room slot
  std::uint32_t* room_scratch = nullptr;  // per room slot
  HeapEntry* heap = nullptr;              // 2 x edges
  std::size_t heap_size = 0;
  std::size_t heap_capacity = 0;
};

template <typename Value, typename MayEnter>
void Workspace::fill(const PlacesGraph& places, std::int32_t* room_of, Value value, MayEnter may_enter) {
  heap_size = 0;
  std::uint32_t sequence = 0;
  const auto push_frontier = [&](std::uint32_t i) {
    places.for_each_edge(i, [&](const PlaceEdge& e, std::uint32_t j) {
      if (room_of[j] < 0 && may_enter(i, j))
        heap_push(HeapEntry{value(e), sequence++, j, static_cast<std::uint32_t>(room_of[i])});
    });
  };
  for (std::uint32_t i = 0; i < places.num_places; ++i)
    if (room_of[i] >= 0) push_frontier(i);
  while (heap_size > 0) {
    const HeapEntry top = heap_pop();
    if (room_of[top.place] >= 0) continue;
    room_of[top.place] = static_cast<std::int32_t>(top.room);
    push_frontier(top.place);
  }
}

}  // namespace qsg::rooms
