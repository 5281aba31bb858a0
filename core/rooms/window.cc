// Room updates over the active window (Config::window_updates, issue 37): which places an update reads, which rooms
// it may replace, the room-room edges to the rooms it keeps, and the building over every room. A window update
// (RoomFinder::update with window true) reads the active places, the places of the rooms holding one and the
// places without a room, and replaces only the rooms holding an active place; the others keep their nodes and
// edges, and the room-room edges from the window's rooms to them are written again. UpdateResult::places is then
// the window's count, UpdateResult::rooms every room in the graph.
#include <algorithm>
#include <cstring>

#include "core/rooms/room_finder.h"

namespace qsg::rooms {

namespace sg = scene_graph;

// The rooms that hold an active place are open (this update replaces them); the window's places are the active
// ones, those of the open rooms and those without a room. Rooms whose places are all inactive keep theirs.
void RoomFinder::collect_window(const sg::SceneGraph& graph, UpdateResult* r) {
  room_slot_.clear();
  num_previous_ = 0;
  graph.for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind != sg::NodeKind::kPlace || n.parent == sg::kNoNode) return;
    const sg::PlaceAttributes* a = graph.place(n.id);
    if (a == nullptr || !a->is_active || room_slot_.contains(n.parent) || graph.room(n.parent) == nullptr) return;
    if (num_previous_ == capacities_.rooms) return;  // cannot happen: the rooms are the finder's own
    room_slot_.insert(n.parent, static_cast<std::uint32_t>(num_previous_));
    previous_ids_[num_previous_++] = n.parent;
  });
  r->rooms_open = num_previous_;
  graph.for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind != sg::NodeKind::kPlace) return;
    const bool in_window = n.parent == sg::kNoNode || graph.room(n.parent) == nullptr ||
                           room_slot_.contains(n.parent) || graph.place(n.id)->is_active;
    if (!in_window) return;
    if (num_places_ == capacities_.places) {
      ++r->truncated;
      return;
    }
    place_ids_[num_places_++] = n.id;
  });
}

// A whole update with window updates on: every room in the graph may be taken over (matched by its places).
void RoomFinder::collect_all_rooms(const sg::SceneGraph& graph) {
  room_slot_.clear();
  num_previous_ = 0;
  graph.for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind != sg::NodeKind::kRoom || num_previous_ == capacities_.rooms) return;
    room_slot_.insert(n.id, static_cast<std::uint32_t>(num_previous_));
    previous_ids_[num_previous_++] = n.id;
  });
}

// A place edge from window place i to a place outside the window: that place's room is a kept one, and the room
// that place i joins will be its neighbour.
void RoomFinder::note_boundary(const sg::SceneGraph& graph, std::uint32_t i, sg::NodeId other, UpdateResult* r) {
  if (sg::node_prefix(other) != sg::kPlacePrefix || graph.place(other) == nullptr) return;
  const sg::NodeId room = graph.parent(other);
  if (room == sg::kNoNode || graph.room(room) == nullptr) return;
  for (std::size_t k = num_boundary_; k > 0 && boundary_[k - 1].place == i; --k)
    if (boundary_[k - 1].room == room) return;  // this place's edges to that room: one is enough
  if (num_boundary_ == capacities_.places) {
    ++r->truncated;
    return;
  }
  boundary_[num_boundary_++] = Boundary{i, room};
  ++r->boundary_edges;
}

// The previous room of place i: with window updates, its room in the graph (among this update's previous rooms);
// otherwise the room the last update gave it.
bool RoomFinder::previous_room_of(const sg::SceneGraph& graph, std::uint32_t i, std::uint32_t* previous) const {
  if (config_.window_updates) {
    const std::uint32_t* k = room_slot_.find(graph.parent(place_ids_[i]));
    if (k == nullptr) return false;
    *previous = *k;
    return true;
  }
  const std::uint32_t* prev = previous_.find(place_ids_[i]);
  if (prev == nullptr) return false;
  *previous = *prev;
  return true;
}

// After a window update's rooms are written (or none were): the room-room edges to the kept rooms, the kept rooms
// marked inactive, the building over every room (at the mean of their centroids), and the finder's room list.
void RoomFinder::finish_window(sg::SceneGraph* graph, std::uint64_t time_ns, UpdateResult* r) {
  free_chunks_ = 0;
  graph->for_each_resource([&](const memory::ResourceStats& st) {
    if (std::strcmp(st.name, "scene_graph.adjacency_chunks") == 0) free_chunks_ = st.capacity - st.in_use;
  });
  for (std::size_t k = 0; k < num_boundary_; ++k) {
    const std::int32_t s = room_of_[boundary_[k].place];
    if (s < 0 || static_cast<std::size_t>(s) >= capacities_.rooms) continue;
    const sg::NodeId room = room_ids_[s];
    if (room == sg::kNoNode || room == boundary_[k].room || graph->room(room) == nullptr ||
        graph->room(boundary_[k].room) == nullptr)
      continue;
    if (add_edge(graph, room, boundary_[k].room, r)) ++r->room_edges;
  }
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  std::size_t rooms = 0;
  graph->for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind != sg::NodeKind::kRoom) return;
    sg::RoomAttributes* a = graph->room(n.id);
    if (a->last_update_time_ns != time_ns && a->is_active) a->is_active = false;  // kept: no active place
    sum += a->position_m;
    if (rooms < capacities_.rooms) room_ids_[rooms] = n.id;
    ++rooms;
  });
  const bool had_building = building_written_ && graph->building(building_id_) != nullptr;
  const bool have_building = write_building(graph, rooms, sum, time_ns, r);
  if (have_building && !had_building)
    for (std::size_t k = 0; k < std::min(rooms, capacities_.rooms); ++k) add_edge(graph, building_id_, room_ids_[k], r);
  num_rooms_ = std::min(rooms, capacities_.rooms);
  r->rooms = num_rooms_;
}

// A window update that found no room in the window: its open rooms go (their places are left without a room);
// the rest stay.
UpdateResult RoomFinder::window_without_rooms(sg::SceneGraph* graph, std::uint64_t time_ns, UpdateResult r) {
  ++counters_.no_rooms;
  counters_.seeds_dropped += r.seeds_dropped;
  std::fill(previous_taken_, previous_taken_ + num_previous_, std::uint8_t{0});
  remove_previous(graph, /*keep_taken=*/true, &r);
  std::fill(room_of_, room_of_ + num_places_, -1);
  r.places_unassigned = num_places_;
  finish_window(graph, time_ns, &r);
  r.outcome = Outcome::kNoRooms;
  return r;
}

}  // namespace qsg::rooms
