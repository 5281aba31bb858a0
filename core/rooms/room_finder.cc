// The room finder's spine: start-up, one update (read the places graph, the paper's filtration and seeds, the flood
// fill, our refinements, the rooms written), and reading the places graph.
#include "core/rooms/room_finder.h"

#include <algorithm>
#include <cmath>

namespace qsg::rooms {

namespace sg = scene_graph;

void Counters::print(std::FILE* out) const {
  std::fprintf(out,
               "rooms counters: updates %llu, no_places %llu, no_rooms %llu, truncated %llu, graph_refused %llu, "
               "seeds_dropped %llu, rooms_created %llu, rooms_removed %llu\n",
               static_cast<unsigned long long>(updates), static_cast<unsigned long long>(no_places),
               static_cast<unsigned long long>(no_rooms), static_cast<unsigned long long>(truncated),
               static_cast<unsigned long long>(graph_refused), static_cast<unsigned long long>(seeds_dropped),
               static_cast<unsigned long long>(rooms_created), static_cast<unsigned long long>(rooms_removed));
}

const char* to_string(Outcome outcome) {
  switch (outcome) {
    case Outcome::kOk: return "ok";
    case Outcome::kNotInitialized: return "not initialized";
    case Outcome::kNoGraph: return "no scene graph";
    case Outcome::kNoPlaces: return "no places";
    case Outcome::kNoRooms: return "no component reached the minimum size";
  }
  return "?";
}

RoomFinder::RoomFinder() = default;
RoomFinder::~RoomFinder() = default;

memory::ArenaPlan RoomFinder::plan(const Config& config, const Capacities& c) {
  using Map = memory::FixedHashMap<sg::NodeId, std::uint32_t, memory::U64Hash>;
  memory::ArenaPlan p;
  Map::plan(p, Map::slots_for(c.places));
  Map::plan(p, Map::slots_for(c.places));
  p.add_array<sg::NodeId>(c.places);
  p.add_array<double>(c.places);
  p.add_array<double>(3 * c.places);
  p.add_array<std::uint8_t>(c.places);
  p.add_array<PlaceEdge>(c.place_edges);
  p.add_array<std::uint32_t>(c.places + 1);
  p.add_array<std::uint32_t>(2 * c.place_edges);
  p.add_array<std::int32_t>(c.places);
  p.add_array<Match>(c.places);
  p.add_array<std::uint32_t>(std::max<std::size_t>(1, config.curve_samples()));
  p.add_array<sg::NodeId>(c.rooms);
  p.add_array<RoomAccumulator>(c.rooms);
  p.add_array<sg::NodeId>(c.rooms);
  p.add_array<std::uint8_t>(c.rooms);
  p.add_array<sg::RoomAttributes>(c.rooms);
  p.add_array<std::uint8_t>(c.rooms);
  Workspace::plan(&p, c.places, c.place_edges, c.rooms);
  refine::Refinements::plan(&p, c);
  Map::plan(p, Map::slots_for(c.rooms));
  p.add_array<Boundary>(c.places);
  p.add_array<RoomAccumulator>(c.rooms);
  p.add_array<std::int64_t>(3 * c.rooms);
  return p;
}

bool RoomFinder::init(const Config& config, const Capacities& c, std::size_t budget_bytes, std::string* error) {
  ready_ = false;
  std::string bad = config.check();
  if (bad.empty()) bad = c.check();
  if (!bad.empty()) {
    if (error != nullptr) *error = bad;
    return false;
  }
  const memory::ArenaPlan p = plan(config, c);
  std::string arena_error;
  if (!arena_.create("rooms", p, budget_bytes == 0 ? p.total_bytes() : budget_bytes, &arena_error)) {
    if (error != nullptr) *error = "rooms: " + arena_error;
    return false;
  }
  using Map = memory::FixedHashMap<sg::NodeId, std::uint32_t, memory::U64Hash>;
  bool ok = index_.carve(arena_, Map::slots_for(c.places), c.places) &&
            previous_.carve(arena_, Map::slots_for(c.places), c.places);
  place_ids_ = arena_.carve_array<sg::NodeId>(c.places);
  clearance_ = arena_.carve_array<double>(c.places);
  position_ = arena_.carve_array<double>(3 * c.places);
  active_ = arena_.carve_array<std::uint8_t>(c.places);
  edges_ = arena_.carve_array<PlaceEdge>(c.place_edges);
  adjacency_offset_ = arena_.carve_array<std::uint32_t>(c.places + 1);
  adjacency_ = arena_.carve_array<std::uint32_t>(2 * c.place_edges);
  room_of_ = arena_.carve_array<std::int32_t>(c.places);
  matches_ = arena_.carve_array<Match>(c.places);
  curve_ = arena_.carve_array<std::uint32_t>(std::max<std::size_t>(1, config.curve_samples()));
  room_ids_ = arena_.carve_array<sg::NodeId>(c.rooms);
  room_acc_ = arena_.carve_array<RoomAccumulator>(c.rooms);
  previous_ids_ = arena_.carve_array<sg::NodeId>(c.rooms);
  previous_taken_ = arena_.carve_array<std::uint8_t>(c.rooms);
  saved_ = arena_.carve_array<sg::RoomAttributes>(c.rooms);
  saved_valid_ = arena_.carve_array<std::uint8_t>(c.rooms);
  // Edge arrays of zero size would be a null carve; the plan never asks for those.
  ok = ok && place_ids_ && clearance_ && position_ && active_ && (edges_ || c.place_edges == 0) && adjacency_offset_ &&
       (adjacency_ || c.place_edges == 0) && room_of_ && matches_ && curve_ && room_ids_ && room_acc_ &&
       previous_ids_ && previous_taken_ && saved_ && saved_valid_;
  ok = ws_.carve(arena_, c.places, c.place_edges, c.rooms) && ok;
  ok = refine_.carve(arena_, c) && ok;
  ok = room_slot_.carve(arena_, Map::slots_for(c.rooms), c.rooms) && ok;
  boundary_ = arena_.carve_array<Boundary>(c.places);
  far_ = arena_.carve_array<RoomAccumulator>(c.rooms);
  far_units_ = arena_.carve_array<std::int64_t>(3 * c.rooms);
  ok = ok && boundary_ != nullptr && far_ != nullptr && far_units_ != nullptr;
  arena_.align_to_plan_boundary();
  if (!ok || !arena_.seal()) {
    if (error != nullptr) *error = "rooms: arena carve did not match its plan";
    return false;
  }
  config_ = config;
  capacities_ = c;
  building_id_ = sg::make_node_id(sg::kBuildingPrefix, config.building_index);
  counters_ = Counters{};
  num_rooms_ = num_previous_ = 0;
  curve_size_ = 0;
  next_room_index_ = 0;
  building_written_ = false;
  ready_ = true;
  return true;
}

PlacesGraph RoomFinder::places() const {
  PlacesGraph g;
  g.num_places = num_places_;
  g.ids = place_ids_;
  g.clearance = clearance_;
  g.position = position_;
  g.active = active_;
  g.num_edges = num_edges_;
  g.edges = edges_;
  g.adjacency_offset = adjacency_offset_;
  g.adjacency = adjacency_;
  g.capacity = capacities_.places;
  return g;
}

// No rooms this update: previous rooms (and the building) leave the graph.
UpdateResult RoomFinder::no_rooms(sg::SceneGraph* graph, Outcome outcome, UpdateResult r) {
  r.outcome = outcome;
  ++(outcome == Outcome::kNoPlaces ? counters_.no_places : counters_.no_rooms);
  counters_.seeds_dropped += r.seeds_dropped;
  remove_previous(graph, /*keep_taken=*/false, &r);
  r.places_unassigned = num_places_;
  return r;
}

UpdateResult RoomFinder::update(sg::SceneGraph* graph, std::uint64_t time_ns, const ClosedPassages* doors,
                                const SightLines* sight, bool window) {
  UpdateResult r;
  if (!ready_) return r;
  if (graph == nullptr || !graph->initialized()) {
    r.outcome = Outcome::kNoGraph;
    return r;
  }
  ++counters_.updates;
  if (sight != nullptr && sight->slices() == 0) sight = nullptr;  // no structure: nothing to close or see
  window_ = window && config_.window_updates;
  r.window = window_;
  read_places(graph, doors, config_.close_edges_through_walls ? sight : nullptr, &r);
  counters_.truncated += r.truncated;
  if (window_ && num_places_ == 0) {  // nothing in the window: every room stays as it is
    finish_window(graph, time_ns, &r);
    r.outcome = Outcome::kOk;
    return r;
  }
  // The paper: the filtration's Betti curve and its plateau (filtration.cc).
  compute_curve();
  const int chosen = num_places_ == 0 ? -1 : choose_plateau(curve_, curve_size_, config_.plateau_alpha);
  if (chosen < 0 && window_) return window_without_rooms(graph, time_ns, r);
  if (chosen < 0) return no_rooms(graph, num_places_ == 0 ? Outcome::kNoPlaces : Outcome::kNoRooms, r);
  r.dilation_m = dilation_at(static_cast<std::size_t>(chosen));
  r.betti_at_dilation = curve_[chosen];
  // Seeds: the paper's plateau, or ours (seeding.cc).
  std::size_t rooms =
      config_.seeding == Seeding::kPersistence ? seed_by_persistence(&r) : seed_rooms(r.dilation_m, &r);
  if (config_.seed_closed_regions) rooms = seed_closed_regions(rooms, &r);
  if (rooms == 0 && window_) return window_without_rooms(graph, time_ns, r);
  if (rooms == 0) return no_rooms(graph, Outcome::kNoRooms, r);
  // The paper's flood fill: the other places join the room whose frontier reaches them through the clearest edge.
  const PlacesGraph g = places();
  ws_.fill(g, room_of_, [](const PlaceEdge& e) { return e.clearance_m; },
           [](std::uint32_t, std::uint32_t) { return true; });
  // Ours: the refinement passes, in the order refine/refine.cc gives them.
  Partition partition{room_of_, rooms, capacities_.rooms};
  partition = refine_.run(config_, g, sight, partition, &ws_, &r);
  counters_.seeds_dropped += r.seeds_dropped;
  // The paper: room nodes, edges and the building (room_writer.cc).
  assign_ids(*graph, partition.num_rooms, &r);
  write_rooms(graph, partition.num_rooms, time_ns, &r);
  counters_.graph_refused += r.refused;
  r.outcome = Outcome::kOk;
  return r;
}

// The places in the order of their ids, and each place's edges in the order of the other end's id: the rooms are
// a function of the graph's content, not of the order its storage happens to visit nodes and edges in (ties among
// equal clearances are broken by index), so a graph saved and read back gives the same rooms as the one that was
// built live, with places added and removed over a run.
void RoomFinder::read_places(sg::SceneGraph* writable, const ClosedPassages* doors, const SightLines* sight,
                             UpdateResult* r) {
  const sg::SceneGraph& graph = *writable;  // written only by the window's choice (its open places)
  index_.clear();
  num_places_ = 0;
  num_edges_ = 0;
  num_boundary_ = 0;
  if (window_) {
    collect_window(writable, r);
  } else {
    if (config_.window_updates) collect_all_rooms(graph);  // every room may be taken over
    graph.for_each_node_of(sg::NodeKind::kPlace, [&](const sg::NodeRecord& n) {
      if (num_places_ == capacities_.places) {
        ++r->truncated;
        return;
      }
      place_ids_[num_places_++] = n.id;
    });
  }
  std::sort(place_ids_, place_ids_ + num_places_);
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    const sg::PlaceAttributes* a = graph.place(place_ids_[i]);
    // Non-finite or negative clearances count as 0 (negative edge clearances mark closed passages).
    clearance_[i] = std::isfinite(a->distance_m) ? std::max(0.0, a->distance_m) : 0.0;
    position_[3 * i + 0] = a->position_m.x();
    position_[3 * i + 1] = a->position_m.y();
    position_[3 * i + 2] = a->position_m.z();
    active_[i] = a->is_active ? 1 : 0;
    index_.insert(place_ids_[i], i);
  }
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    const std::size_t first = num_edges_;
    graph.for_each_neighbor(place_ids_[i], [&](sg::NodeId other, const sg::EdgeRecord& e) {
      const std::uint32_t* j = index_.find(other);
      if (j == nullptr && window_) note_boundary(graph, i, other, r);  // a kept room's place, perhaps
      if (j == nullptr || *j <= i) return;  // not a (read) place, or counted from the other end
      if (num_edges_ == capacities_.place_edges) {
        ++r->truncated;
        return;
      }
      double w = std::min(clearance_[i], clearance_[*j]);
      if (e.info.weighted && std::isfinite(e.info.weight)) w = std::min(w, e.info.weight);
      if ((e.info.weighted && e.info.weight <= 0.0) ||
          (doors != nullptr && doors->closes(place_position(i), place_position(*j)))) {
        w = kClosed;
        ++r->closed_edges;
      } else if (sight != nullptr && sight->crosses_structure(place_position(i), place_position(*j))) {
        w = kClosed;
        ++r->closed_edges;
        ++r->edges_through_walls;
      }
      edges_[num_edges_++] = PlaceEdge{i, *j, w};
    });
    // A place has a handful of edges: insertion sort by the other end (edges are then ordered by (a, b)).
    for (std::size_t k = first + 1; k < num_edges_; ++k)
      for (std::size_t m = k; m > first && edges_[m - 1].b > edges_[m].b; --m) std::swap(edges_[m - 1], edges_[m]);
  }
  build_adjacency();
  r->places = num_places_;
  r->place_edges = num_edges_;
}

// Adjacency in CSR form; the workspace's size array is the fill cursor.
void RoomFinder::build_adjacency() {
  std::fill(adjacency_offset_, adjacency_offset_ + num_places_ + 1, 0u);
  for (std::size_t e = 0; e < num_edges_; ++e) {
    ++adjacency_offset_[edges_[e].a + 1];
    ++adjacency_offset_[edges_[e].b + 1];
  }
  for (std::size_t i = 0; i < num_places_; ++i) adjacency_offset_[i + 1] += adjacency_offset_[i];
  std::uint32_t* cursor = ws_.size;
  std::copy(adjacency_offset_, adjacency_offset_ + num_places_, cursor);
  for (std::size_t e = 0; e < num_edges_; ++e) {
    adjacency_[cursor[edges_[e].a]++] = static_cast<std::uint32_t>(e);
    adjacency_[cursor[edges_[e].b]++] = static_cast<std::uint32_t>(e);
  }
}

}  // namespace qsg::rooms
