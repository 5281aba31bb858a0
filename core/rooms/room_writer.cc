// The paper's last step: room nodes (centroid, box), room-place and room-room edges, the building node over all
// rooms; room ids kept across updates where a new room overlaps an old one most.
#include <algorithm>
#include <cstring>
#include <limits>

#include "core/rooms/room_finder.h"

namespace qsg::rooms {

namespace sg = scene_graph;

// A new room takes the id of the previous room it shares most places with (each id once, largest overlaps
// first); the others get fresh ids.
void RoomFinder::assign_ids(const sg::SceneGraph& graph, std::size_t num_rooms, UpdateResult* r) {
  std::fill(room_ids_, room_ids_ + num_rooms, sg::kNoNode);
  std::fill(previous_taken_, previous_taken_ + num_previous_, std::uint8_t{0});
  std::size_t n = 0;
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    if (room_of_[i] < 0) continue;
    std::uint32_t prev = 0;
    if (!previous_room_of(graph, i, &prev) || prev >= num_previous_ || previous_ids_[prev] == sg::kNoNode) continue;
    ws_.pairs[n++] = (static_cast<std::uint64_t>(room_of_[i]) << 32) | prev;
  }
  std::sort(ws_.pairs, ws_.pairs + n);
  std::size_t num_matches = 0;
  for (std::size_t k = 0; k < n;) {
    std::size_t j = k;
    while (j < n && ws_.pairs[j] == ws_.pairs[k]) ++j;
    matches_[num_matches++] = Match{static_cast<std::uint32_t>(j - k), static_cast<std::uint32_t>(ws_.pairs[k] >> 32),
                                    static_cast<std::uint32_t>(ws_.pairs[k] & 0xffffffffu)};
    k = j;
  }
  std::sort(matches_, matches_ + num_matches, [](const Match& a, const Match& b) {
    if (a.count != b.count) return a.count > b.count;
    if (a.room != b.room) return a.room < b.room;
    return a.previous < b.previous;
  });
  for (std::size_t k = 0; k < num_matches; ++k) {
    const Match& m = matches_[k];
    if (room_ids_[m.room] != sg::kNoNode || previous_taken_[m.previous]) continue;
    room_ids_[m.room] = previous_ids_[m.previous];
    previous_taken_[m.previous] = 1;
    ++r->rooms_kept;
  }
  for (std::size_t s = 0; s < num_rooms; ++s) {
    if (room_ids_[s] != sg::kNoNode) continue;
    sg::NodeId id = sg::make_node_id(sg::kRoomPrefix, next_room_index_++);
    while (graph.has_node(id)) id = sg::make_node_id(sg::kRoomPrefix, next_room_index_++);  // someone else's
    room_ids_[s] = id;
    ++counters_.rooms_created;
  }
}

// Previous rooms no new room took over leave the graph (with their edges). Without new rooms (keep_taken false)
// every previous room goes, and the building with them.
void RoomFinder::remove_previous(sg::SceneGraph* graph, bool keep_taken, UpdateResult* r) {
  for (std::size_t p = 0; p < num_previous_; ++p) {
    if ((keep_taken && previous_taken_[p] != 0) || previous_ids_[p] == sg::kNoNode) continue;
    std::uint32_t slot = 0;
    if (partial_slot(previous_ids_[p], &slot)) {  // its far places keep it
      keep_far_part(graph, slot);
      continue;
    }
    if (graph->room(previous_ids_[p]) != nullptr && graph->remove_node(previous_ids_[p])) {
      ++r->rooms_removed;
      ++counters_.rooms_removed;
    }
  }
  if (!keep_taken) {
    if (building_written_ && graph->building(building_id_) != nullptr) graph->remove_node(building_id_);
    building_written_ = false;
    num_previous_ = 0;
    num_rooms_ = 0;
    previous_.clear();
  }
}

bool RoomFinder::edge_fits(sg::SceneGraph* graph, sg::NodeId a, sg::NodeId b) {
  const sg::NodeRecord* na = graph->node(a);
  const sg::NodeRecord* nb = graph->node(b);
  if (na == nullptr || nb == nullptr) return false;
  const std::size_t need = (na->degree % sg::kAdjacencyChunkEdges == 0 ? 1u : 0u) +
                           (nb->degree % sg::kAdjacencyChunkEdges == 0 ? 1u : 0u);
  return graph->num_edges() < graph->capacities().edges && free_chunks_ >= need;
}

bool RoomFinder::add_edge(sg::SceneGraph* graph, sg::NodeId a, sg::NodeId b, UpdateResult* r) {
  // Checked here so a full graph is a counted refusal in every build (the stores' own policy may abort).
  if (!edge_fits(graph, a, b)) {
    if (graph->node(a) != nullptr && graph->node(b) != nullptr) graph->count_refused_edge();  // the store's own name
    ++r->refused;
    return false;
  }
  const std::size_t need = (graph->node(a)->degree % sg::kAdjacencyChunkEdges == 0 ? 1u : 0u) +
                           (graph->node(b)->degree % sg::kAdjacencyChunkEdges == 0 ? 1u : 0u);
  const sg::Status st = graph->add_edge(a, b);
  if (st == sg::Status::kOk) {
    free_chunks_ -= need;
    return true;
  }
  if (st != sg::Status::kDuplicateEdge) ++r->refused;
  return st == sg::Status::kDuplicateEdge;
}

void RoomFinder::write_rooms(sg::SceneGraph* graph, std::size_t num_rooms, std::uint64_t time_ns, UpdateResult* r) {
  if (r->rooms_partial > 0) detach_partial(graph);
  remove_previous(graph, /*keep_taken=*/true, r);
  // Kept rooms are removed and re-added under the same id with their labels: remove_node() drops a node's edges
  // newest first in O(degree), where removing them one by one would scan the room's adjacency for each. A partial
  // room stays (its far places keep their edges to it) and its attributes are rewritten in place.
  for (std::size_t s = 0; s < num_rooms; ++s) {
    saved_valid_[s] = 0;
    if (const sg::RoomAttributes* existing = graph->room(room_ids_[s])) {
      saved_[s] = *existing;
      std::uint32_t slot = 0;
      saved_valid_[s] = partial_slot(room_ids_[s], &slot) ? 2 : 1;
      if (saved_valid_[s] == 1) graph->remove_node(room_ids_[s]);
    }
  }
  free_chunks_ = 0;
  graph->for_each_resource([&](const memory::ResourceStats& st) {
    if (std::strcmp(st.name, "scene_graph.adjacency_chunks") == 0) free_chunks_ = st.capacity - st.in_use;
  });
  accumulate_rooms(num_rooms);
  Eigen::Vector3d centroid_sum = Eigen::Vector3d::Zero();
  const std::size_t written = write_room_nodes(graph, num_rooms, time_ns, &centroid_sum, r);
  // A window update's building spans the kept rooms too: finish_window writes it.
  const bool have_building = window_ ? building_written_ && graph->building(building_id_) != nullptr
                                     : write_building(graph, written, centroid_sum, time_ns, r);
  write_edges(graph, num_rooms, have_building, r);

  // Remember this update's rooms for the next one's ids.
  previous_.clear();
  for (std::uint32_t i = 0; i < num_places_; ++i)
    if (room_of_[i] >= 0 && room_ids_[room_of_[i]] != sg::kNoNode)
      previous_.insert(place_ids_[i], static_cast<std::uint32_t>(room_of_[i]));
  std::copy(room_ids_, room_ids_ + num_rooms, previous_ids_);
  num_previous_ = num_rooms;
  if (window_) {
    finish_window(graph, time_ns, r);  // edges to the kept rooms, the building; the room list is every room
    return;
  }
  num_rooms_ = 0;
  for (std::size_t s = 0; s < num_rooms; ++s)
    if (room_ids_[s] != sg::kNoNode) room_ids_[num_rooms_++] = room_ids_[s];
  r->rooms = num_rooms_;
}

// Centroid, bounds and activity of every room. The box holds each place's free-space sphere (radius: its
// clearance), so it spans the room's free space rather than only the GVD inside it (which stays a clearance away
// from every wall, floor and ceiling), as the room boxes the room classifier was trained on do.
void RoomFinder::RoomAccumulator::reset() {
  for (int d = 0; d < 3; ++d) {
    sum[d] = 0.0;
    min[d] = std::numeric_limits<double>::max();
    max[d] = std::numeric_limits<double>::lowest();
  }
  count = 0;
  active = false;
}

void RoomFinder::RoomAccumulator::add(const double* position, double radius) {
  for (int d = 0; d < 3; ++d) {
    sum[d] += position[d];
    min[d] = std::min(min[d], position[d] - radius);
    max[d] = std::max(max[d], position[d] + radius);
  }
  ++count;
}

void RoomFinder::RoomAccumulator::add(const RoomAccumulator& other) {
  for (int d = 0; d < 3; ++d) {
    sum[d] += other.sum[d];
    min[d] = std::min(min[d], other.min[d]);
    max[d] = std::max(max[d], other.max[d]);
  }
  count += other.count;
}

void RoomFinder::accumulate_rooms(std::size_t num_rooms) {
  for (std::size_t s = 0; s < num_rooms; ++s) room_acc_[s].reset();
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    if (room_of_[i] < 0) continue;
    RoomAccumulator& a = room_acc_[room_of_[i]];
    a.add(&position_[3 * i], std::max(0.0, clearance_[i]));
    a.active = a.active || active_[i] != 0;
  }
  for (std::size_t s = 0; s < num_rooms; ++s) {  // a partial room's far places (never active)
    std::uint32_t slot = 0;
    if (saved_valid_[s] == 2 && partial_slot(room_ids_[s], &slot)) room_acc_[s].add(far_[slot]);
  }
}

// Room nodes: attributes replaced, labels of kept rooms preserved for the classifier. Returns the rooms written
// and adds their centroids to *centroid_sum.
std::size_t RoomFinder::write_room_nodes(sg::SceneGraph* graph, std::size_t num_rooms, std::uint64_t time_ns,
                                         Eigen::Vector3d* centroid_sum, UpdateResult* r) {
  const sg::Capacities& gc = graph->capacities();
  std::size_t written = 0;
  for (std::size_t s = 0; s < num_rooms; ++s) {
    const RoomAccumulator& a = room_acc_[s];
    const double n = static_cast<double>(std::max<std::uint32_t>(1, a.count));
    sg::RoomAttributes attrs;
    attrs.position_m = Eigen::Vector3d(a.sum[0] / n, a.sum[1] / n, a.sum[2] / n);
    attrs.bounding_box = sg::BoundingBox::aabb(Eigen::Vector3d(a.min[0], a.min[1], a.min[2]),
                                               Eigen::Vector3d(a.max[0], a.max[1], a.max[2]));
    attrs.last_update_time_ns = time_ns;
    attrs.is_active = a.active;
    char name[32];
    const int len = std::snprintf(name, sizeof(name), "R(%llu)",
                                  static_cast<unsigned long long>(sg::node_index(room_ids_[s])));
    attrs.name.assign(name, static_cast<std::size_t>(std::max(0, std::min<int>(len, 31))));
    if (saved_valid_[s]) {
      attrs.semantic_label = saved_[s].semantic_label;
      attrs.class_probabilities = saved_[s].class_probabilities;
      attrs.color = saved_[s].color;
    }
    if (saved_valid_[s] == 2) {  // a partial room: its node and its far places' edges stay
      *graph->room(room_ids_[s]) = attrs;
      *centroid_sum += attrs.position_m;
      ++written;
      continue;
    }
    if (graph->num_nodes(sg::NodeKind::kRoom) >= gc.room_nodes || graph->num_nodes() >= gc.nodes() ||
        graph->add_room(room_ids_[s], attrs) != sg::Status::kOk) {
      if (graph->num_nodes(sg::NodeKind::kRoom) >= gc.room_nodes || graph->num_nodes() >= gc.nodes())
        graph->count_refused_node(sg::NodeKind::kRoom);  // shown under the store's own name
      ++r->refused;
      room_ids_[s] = sg::kNoNode;
      continue;
    }
    *centroid_sum += attrs.position_m;
    ++written;
  }
  return written;
}

// The building at the mean of the room centroids; without rooms written, the previous building goes. Returns
// whether the building is in the graph.
bool RoomFinder::write_building(sg::SceneGraph* graph, std::size_t written, const Eigen::Vector3d& centroid_sum,
                                std::uint64_t time_ns, UpdateResult* r) {
  const sg::Capacities& gc = graph->capacities();
  bool have_building = false;
  if (written > 0) {
    sg::BuildingAttributes b;
    b.position_m = centroid_sum / static_cast<double>(written);
    b.last_update_time_ns = time_ns;
    b.is_active = true;
    char name[32];
    const int len =
        std::snprintf(name, sizeof(name), "B(%llu)", static_cast<unsigned long long>(config_.building_index));
    b.name.assign(name, static_cast<std::size_t>(std::max(0, std::min<int>(len, 31))));
    if (sg::BuildingAttributes* existing = graph->building(building_id_)) {
      b.semantic_label = existing->semantic_label;
      b.color = existing->color;
      *existing = b;
      have_building = true;
    } else if (!graph->has_node(building_id_) && graph->num_nodes(sg::NodeKind::kBuilding) < gc.building_nodes &&
               graph->num_nodes() < gc.nodes() && graph->add_building(building_id_, b) == sg::Status::kOk) {
      have_building = true;
    } else {
      if (graph->num_nodes(sg::NodeKind::kBuilding) >= gc.building_nodes || graph->num_nodes() >= gc.nodes())
        graph->count_refused_node(sg::NodeKind::kBuilding);  // shown under the store's own name
      ++r->refused;
    }
  } else if (building_written_ && graph->building(building_id_) != nullptr) {
    graph->remove_node(building_id_);
  }
  building_written_ = have_building;
  return have_building;
}

// Room -> place (the room becomes the place's parent), room - room where places touch, building -> room.
void RoomFinder::write_edges(sg::SceneGraph* graph, std::size_t num_rooms, bool have_building, UpdateResult* r) {
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    const std::int32_t s = room_of_[i];
    if (s < 0 || room_ids_[s] == sg::kNoNode) {
      ++r->places_unassigned;
      continue;
    }
    const sg::NodeId parent = graph->parent(place_ids_[i]);
    if (parent == room_ids_[s]) {  // a partial room's place that stays in it
      ++r->places_assigned;
      continue;
    }
    if (parent != sg::kNoNode) {  // another writer's room owns it
      ++r->places_unassigned;
      continue;
    }
    if (add_edge(graph, room_ids_[s], place_ids_[i], r)) ++r->places_assigned;
    else ++r->places_unassigned;
  }
  std::uint64_t* pairs = ws_.pairs;
  std::size_t n = 0;
  for (std::size_t e = 0; e < num_edges_; ++e) {
    const std::int32_t a = room_of_[edges_[e].a], b = room_of_[edges_[e].b];
    if (a < 0 || b < 0 || a == b) continue;
    const std::uint64_t lo = static_cast<std::uint64_t>(std::min(a, b)), hi = static_cast<std::uint64_t>(std::max(a, b));
    pairs[n++] = (lo << 32) | hi;
  }
  std::sort(pairs, pairs + n);
  n = static_cast<std::size_t>(std::unique(pairs, pairs + n) - pairs);
  for (std::size_t k = 0; k < n; ++k) {
    const sg::NodeId a = room_ids_[pairs[k] >> 32], b = room_ids_[pairs[k] & 0xffffffffu];
    if (a == sg::kNoNode || b == sg::kNoNode) continue;
    if (add_edge(graph, a, b, r)) ++r->room_edges;
  }
  if (have_building)
    for (std::size_t s = 0; s < num_rooms; ++s)
      if (room_ids_[s] != sg::kNoNode) add_edge(graph, building_id_, room_ids_[s], r);
}

}  // namespace qsg::rooms
