// The shared scratch of the room finder and its refinement passes.
#include "core/rooms/partition.h"

#include <algorithm>

namespace qsg::rooms {

namespace {
bool expands_before(const HeapEntry& x, const HeapEntry& y) {
  if (x.clearance_m != y.clearance_m) return x.clearance_m > y.clearance_m;
  return x.sequence < y.sequence;
}
}  // namespace

void Workspace::plan(memory::ArenaPlan* p, std::size_t places, std::size_t place_edges, std::size_t rooms) {
  p->add_array<std::uint32_t>(places + place_edges);
  p->add_array<std::uint32_t>(places);
  p->add_array<std::uint32_t>(places);
  p->add_array<double>(places);
  p->add_array<std::uint32_t>(places);
  p->add_array<std::uint32_t>(places);
  p->add_array<std::uint8_t>(places);
  p->add_array<std::uint32_t>(places);
  p->add_array<std::uint64_t>(std::max(places, place_edges) + places);
  p->add_array<std::uint32_t>(rooms);
  p->add_array<std::uint32_t>(rooms);
  p->add_array<HeapEntry>(2 * place_edges);
}

bool Workspace::carve(memory::Arena& arena, std::size_t places, std::size_t place_edges, std::size_t rooms) {
  order = arena.carve_array<std::uint32_t>(places + place_edges);
  parent = arena.carve_array<std::uint32_t>(places);
  size = arena.carve_array<std::uint32_t>(places);
  birth = arena.carve_array<double>(places);
  member_next = arena.carve_array<std::uint32_t>(places);
  member_tail = arena.carve_array<std::uint32_t>(places);
  flag = arena.carve_array<std::uint8_t>(places);
  root_room = arena.carve_array<std::uint32_t>(places);
  pairs = arena.carve_array<std::uint64_t>(std::max(places, place_edges) + places);
  room_parent = arena.carve_array<std::uint32_t>(rooms);
  room_scratch = arena.carve_array<std::uint32_t>(rooms);
  heap = arena.carve_array<HeapEntry>(2 * place_edges);  // null with no edges: the plan asks for none
  heap_capacity = 2 * place_edges;
  heap_size = 0;
  return order && parent && size && birth && member_next && member_tail && flag && root_room && pairs &&
         room_parent && room_scratch && (heap || place_edges == 0);
}

void Workspace::join(std::uint32_t ra, std::uint32_t rb, std::uint8_t seeds) {
  if (size[ra] < size[rb]) std::swap(ra, rb);
  parent[rb] = ra;
  size[ra] += size[rb];
  birth[ra] = std::max(birth[ra], birth[rb]);
  member_next[member_tail[ra]] = rb;
  member_tail[ra] = member_tail[rb];
  flag[ra] = seeds;
}

void Workspace::heap_push(const HeapEntry& e) {
  if (heap_size == heap_capacity) return;  // cannot happen: each place pushes its edges once
  std::size_t i = heap_size++;
  while (i > 0) {
    const std::size_t up = (i - 1) / 2;
    if (!expands_before(e, heap[up])) break;
    heap[i] = heap[up];
    i = up;
  }
  heap[i] = e;
}

HeapEntry Workspace::heap_pop() {
  const HeapEntry top = heap[0];
  const HeapEntry last = heap[--heap_size];
  std::size_t i = 0;
  for (;;) {
    const std::size_t l = 2 * i + 1, r = l + 1;
    if (l >= heap_size) break;
    const std::size_t c = r < heap_size && expands_before(heap[r], heap[l]) ? r : l;
    if (!expands_before(heap[c], last)) break;
    heap[i] = heap[c];
    i = c;
  }
  if (heap_size > 0) heap[i] = last;
  return top;
}

std::size_t Workspace::renumber_merged_rooms(const PlacesGraph& places, std::int32_t* room_of,
                                             std::size_t num_rooms) {
  std::size_t rooms = 0;
  for (std::size_t k = 0; k < num_rooms; ++k)
    if (find_room(static_cast<std::uint32_t>(k)) == k) room_scratch[k] = static_cast<std::uint32_t>(rooms++);
  for (std::uint32_t i = 0; i < places.num_places; ++i)
    if (room_of[i] >= 0)
      room_of[i] = static_cast<std::int32_t>(room_scratch[find_room(static_cast<std::uint32_t>(room_of[i]))]);
  return rooms;
}

}  // namespace qsg::rooms
