// Room updates over the active window (Config::window_updates, issue 37): which places an update reads, which rooms
// it may replace, the room-room edges to the rooms it keeps, and the building over every room. A window update
// (RoomFinder::update with window true) reads the active places, the places of the rooms holding one (within
// Config::window_room_margin_m of the active places' box) and the places without a room, and replaces only the
// rooms holding an active place; the others keep their nodes and edges, and the room-room edges from the window's
// rooms to them are written again. A room read in part keeps its node and its far places. UpdateResult::places is
// then the window's count, UpdateResult::rooms every room in the graph.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "core/rooms/room_finder.h"

namespace qsg::rooms {

namespace sg = scene_graph;

// The rooms that hold an active place are open (this update replaces them); the window's places are the active
// ones, those without a room, and those of the open rooms within window_room_margin_m of the active places' box.
// An open room's farther places are not read: they keep it (a partial room), and far_ sums them for its node.
// Rooms whose places are all inactive keep theirs. No scan of the places layer, and no walk of a long room: the
// active places and those without a room come from the graph's open places (SceneGraph::for_each_open_place), the
// open rooms' others from the graph's grid of closed places (SceneGraph::for_each_closed_place_near).
void RoomFinder::collect_window(sg::SceneGraph* graph, UpdateResult* r) {
  room_slot_.clear();
  num_previous_ = 0;
  double lo[3], hi[3];
  for (int d = 0; d < 3; ++d) {
    lo[d] = std::numeric_limits<double>::infinity();
    hi[d] = -lo[d];
  }
  // The open places: active ones set the box and open their rooms; they and the places without a room are read.
  graph->for_each_open_place([&](const sg::NodeRecord& n, const sg::PlaceAttributes& a) {
    ++r->places_visited;
    if (num_places_ == capacities_.places) {
      ++r->truncated;
    } else {
      place_ids_[num_places_++] = n.id;
    }
    if (!a.is_active) return;  // without a room
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], a.position_m[d]);
      hi[d] = std::max(hi[d], a.position_m[d]);
    }
    if (n.parent == sg::kNoNode || room_slot_.contains(n.parent) || graph->room(n.parent) == nullptr) return;
    if (num_previous_ == capacities_.rooms) return;  // cannot happen: the rooms are the finder's own
    room_slot_.insert(n.parent, static_cast<std::uint32_t>(num_previous_));
    far_[num_previous_].reset();
    previous_ids_[num_previous_++] = n.parent;
  });
  r->rooms_open = num_previous_;
  if (num_previous_ == 0) return;
  // The open rooms' closed places (their inactive ones): those in the margin are read, found in the graph's grid;
  // the far ones are the graph's sums of the room's closed places less the read ones (exact: fixed point).
  const double margin = config_.window_room_margin_m;
  double near_lo[3], near_hi[3];
  for (int d = 0; d < 3; ++d) {
    near_lo[d] = lo[d] - margin;
    near_hi[d] = hi[d] + margin;
  }
  for (std::size_t k = 0; k < num_previous_; ++k) {
    const sg::ChildSums& s = graph->closed_child_sums(previous_ids_[k]);
    std::copy(s.sum, s.sum + 3, &far_units_[3 * k]);
    for (int d = 0; d < 3; ++d) {
      far_[k].min[d] = s.min[d];
      far_[k].max[d] = s.max[d];
    }
    far_[k].count = s.count;
  }
  graph->for_each_closed_place_near(near_lo, near_hi, [&](std::uint32_t, const sg::NodeRecord& n,
                                                          const sg::PlaceAttributes& a) {
    ++r->places_visited;
    const std::uint32_t* k = room_slot_.find(n.parent);
    if (k == nullptr) return;  // a kept room's place
    for (int d = 0; d < 3; ++d)
      if (!(a.position_m[d] >= near_lo[d] && a.position_m[d] <= near_hi[d])) return;  // in the cell, not the box
    if (num_places_ == capacities_.places) {  // stays in the far part
      ++r->truncated;
      return;
    }
    place_ids_[num_places_++] = n.id;
    for (int d = 0; d < 3; ++d) far_units_[3 * *k + d] -= sg::child_sum_units(a.position_m[d]);
    --far_[*k].count;
  });
  for (std::size_t k = 0; k < num_previous_; ++k) {
    RoomAccumulator& f = far_[k];
    if (f.count == 0) {
      f.reset();
      continue;
    }
    // The box is the room's closed places' box (it only grows while the room keeps a closed place: a near place
    // that leaves the room may stay in it until the room is read whole).
    for (int d = 0; d < 3; ++d) f.sum[d] = static_cast<double>(far_units_[3 * k + d]) / sg::kChildSumUnitsPerM;
    r->places_kept += f.count;
    ++r->rooms_partial;
  }
}

// Whether room is an open room this window update reads only in part (its slot in *slot).
bool RoomFinder::partial_slot(sg::NodeId room, std::uint32_t* slot) const {
  if (!window_) return false;
  const std::uint32_t* k = room_slot_.find(room);
  if (k == nullptr || *k >= num_previous_ || far_[*k].count == 0) return false;
  *slot = *k;
  return true;
}

// A partial room's read places that this update puts in another room (or in none) leave it; the node stays with
// its far places. Removing one parent edge scans the room's adjacency, but few places change room per update.
void RoomFinder::detach_partial(sg::SceneGraph* graph) {
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    const sg::NodeId room = graph->parent(place_ids_[i]);
    std::uint32_t slot = 0;
    if (room == sg::kNoNode || !partial_slot(room, &slot)) continue;
    const std::int32_t s = room_of_[i];
    if (s >= 0 && static_cast<std::size_t>(s) < capacities_.rooms && room_ids_[s] == room) continue;
    graph->remove_edge(room, place_ids_[i]);
  }
}

// A partial room no new room took over: it stays with its far places only, kept as a room away from the robot is.
void RoomFinder::keep_far_part(sg::SceneGraph* graph, std::uint32_t slot) {
  sg::RoomAttributes* a = graph->room(previous_ids_[slot]);
  if (a == nullptr) return;
  const RoomAccumulator& f = far_[slot];
  const double n = static_cast<double>(f.count);
  a->position_m = Eigen::Vector3d(f.sum[0] / n, f.sum[1] / n, f.sum[2] / n);
  a->bounding_box = sg::BoundingBox::aabb(Eigen::Vector3d(f.min[0], f.min[1], f.min[2]),
                                          Eigen::Vector3d(f.max[0], f.max[1], f.max[2]));
  a->is_active = false;
}

// A whole update with window updates on: every room in the graph may be taken over (matched by its places).
void RoomFinder::collect_all_rooms(const sg::SceneGraph& graph) {
  room_slot_.clear();
  num_previous_ = 0;
  graph.for_each_node_of(sg::NodeKind::kRoom, [&](const sg::NodeRecord& n) {
    if (num_previous_ == capacities_.rooms) return;
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
  graph->for_each_node_of(sg::NodeKind::kRoom, [&](const sg::NodeRecord& n) {
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
  std::fill(room_of_, room_of_ + num_places_, -1);
  detach_partial(graph);
  remove_previous(graph, /*keep_taken=*/true, &r);
  r.places_unassigned = num_places_;
  finish_window(graph, time_ns, &r);
  r.outcome = Outcome::kNoRooms;
  return r;
}

}  // namespace qsg::rooms
