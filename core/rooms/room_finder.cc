// Rooms by persistent homology over the places graph, flood fill, and the room and building nodes.
#include "core/rooms/room_finder.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace qsg::rooms {

namespace sg = scene_graph;

namespace {
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
// Grid dilations are d- + i x step in double; a clearance equal to a grid value must count as alive.
constexpr double kDilationTolerance = 1e-9;
constexpr std::size_t kMaxCurveSamples = 100000;
// The clearance of a closed passage (edge weight <= 0, a door stage's mark): below every dilation and every open
// edge (clearances are >= 0), so the filtration never crosses it and the flood fill takes it last.
constexpr double kClosed = -1.0;
}  // namespace

struct RoomFinder::Edge {
  std::uint32_t a;
  std::uint32_t b;
  // min(edge weight, clearance of both ends): an edge never outlives its ends. kClosed for a closed passage.
  double clearance_m;
  bool closed() const { return clearance_m < 0.0; }
};

struct RoomFinder::HeapEntry {
  double clearance_m;
  std::uint32_t sequence;  // push order: among equal clearances the earlier frontier wins (breadth-first)
  std::uint32_t place;
  std::uint32_t room;
};

namespace {
// The rank (in index order) of the j-th of m samples spread evenly over n places: floor(j (n - 1) / (m - 1)), or j
// itself when n <= m (every place taken).
std::uint64_t sample_rank(std::uint64_t n, std::uint64_t m, std::uint64_t j) {
  return n <= m ? j : (m == 1 ? 0 : j * (n - 1) / (m - 1));
}

bool expands_before(const RoomFinder::HeapEntry& x, const RoomFinder::HeapEntry& y) {
  if (x.clearance_m != y.clearance_m) return x.clearance_m > y.clearance_m;
  return x.sequence < y.sequence;
}
}  // namespace

struct RoomFinder::Match {
  std::uint32_t count;
  std::uint32_t room;      // slot of this update
  std::uint32_t previous;  // slot of the previous update
};

struct RoomFinder::RoomAccumulator {
  double sum[3];
  double min[3];
  double max[3];
  std::uint32_t count;
  bool active;
};

// ---------------------------------------------------------------------------------------------------------------
// Config, capacities, counters.

Config Config::paper() {
  Config c;
  c.seeding = Seeding::kPlateau;
  c.min_component_size = 15;
  c.plateau_alpha = 0.5;
  c.split_by_extent = false;
  c.seed_closed_regions = false;
  c.merge_corridors = false;
  return c;
}

std::size_t Config::curve_samples() const {
  if (!(dilation_step_m > 0.0) || !(max_dilation_m >= min_dilation_m)) return 0;
  return static_cast<std::size_t>(std::floor((max_dilation_m - min_dilation_m) / dilation_step_m + 1e-6)) + 1;
}

const char* to_string(Seeding seeding) {
  return seeding == Seeding::kPersistence ? "persistence" : "plateau";
}

std::string Config::check() const {
  if (seeding != Seeding::kPlateau && seeding != Seeding::kPersistence) return "rooms.seeding: unknown value";
  if (!(max_door_clearance_m >= 0.0)) return "rooms.max_door_clearance_m: must be >= 0 (inf: no limit)";
  if (!std::isfinite(min_persistence_m) || min_persistence_m < 0.0)
    return "rooms.min_persistence_m: must be finite and >= 0, got " + std::to_string(min_persistence_m);
  if (!std::isfinite(min_dilation_m) || min_dilation_m < 0.0)
    return "rooms.min_dilation_m: must be finite and >= 0, got " + std::to_string(min_dilation_m);
  if (!std::isfinite(max_dilation_m) || max_dilation_m < min_dilation_m)
    return "rooms.max_dilation_m: must be finite and >= min_dilation_m, got " + std::to_string(max_dilation_m);
  if (!std::isfinite(dilation_step_m) || dilation_step_m <= 0.0)
    return "rooms.dilation_step_m: must be > 0, got " + std::to_string(dilation_step_m);
  if (curve_samples() > kMaxCurveSamples)
    return "rooms.dilation_step_m: " + std::to_string(curve_samples()) + " samples over [d-, d+], at most " +
           std::to_string(kMaxCurveSamples);
  if (min_component_size < 1) return "rooms.min_component_size: must be >= 1";
  if (!(plateau_alpha >= 0.0 && plateau_alpha <= 1.0))
    return "rooms.plateau_alpha: must be in [0, 1], got " + std::to_string(plateau_alpha);
  if (!std::isfinite(extent_saturation_m) || extent_saturation_m < 0.0)
    return "rooms.extent_saturation_m: must be finite and >= 0, got " + std::to_string(extent_saturation_m);
  if (!std::isfinite(split_min_extent_m) || split_min_extent_m < 0.0)
    return "rooms.split_min_extent_m: must be finite and >= 0, got " + std::to_string(split_min_extent_m);
  if (!std::isfinite(split_max_extent_m) || split_max_extent_m < split_min_extent_m)
    return "rooms.split_max_extent_m: must be finite and >= split_min_extent_m, got " +
           std::to_string(split_max_extent_m);
  if (!std::isfinite(split_min_persistence_m) || split_min_persistence_m < 0.0)
    return "rooms.split_min_persistence_m: must be finite and >= 0, got " + std::to_string(split_min_persistence_m);
  if (split_min_component_size < 1) return "rooms.split_min_component_size: must be >= 1";
  if (merge_corridors && corridor_min_neighbours < 2)
    return "rooms.corridor_min_neighbours: must be >= 2 (1 would merge every room with its corridor)";
  if (merge_corridors && (corridor_min_open_edges < 1 || corridor_min_open_edges > 65535))
    return "rooms.corridor_min_open_edges: must be in [1, 65535] (0 would merge through doors; counts saturate at "
           "65535)";
  if (merge_visible && !(visible_min_share > 0.0 && visible_min_share <= 1.0))
    return "rooms.visible_min_share: must be in (0, 1], got " + std::to_string(visible_min_share);
  if (merge_visible && (visible_samples < 1 || visible_samples > kMaxVisibleSamples))
    return "rooms.visible_samples: must be in [1, " + std::to_string(kMaxVisibleSamples) + "], got " +
           std::to_string(visible_samples);
  if (merge_visible && visible_max_rounds < 1) return "rooms.visible_max_rounds: must be >= 1";
  if (merge_visible && !(std::isfinite(visible_local_radius_m) && visible_local_radius_m >= 0.0))
    return "rooms.visible_local_radius_m: must be finite and >= 0, got " + std::to_string(visible_local_radius_m);
  if (merge_visible && visible_local_radius_m > 0.0 &&
      !(visible_local_min_share > 0.0 && visible_local_min_share <= 1.0))
    return "rooms.visible_local_min_share: must be in (0, 1], got " + std::to_string(visible_local_min_share);
  if (merge_visible && visible_local_radius_m > 0.0 && visible_local_min_places < 1)
    return "rooms.visible_local_min_places: must be >= 1";
  if (merge_visible && visible_touching &&
      !(std::isfinite(visible_touch_max_clearance_m) && visible_touch_max_clearance_m > 0.0))
    return "rooms.visible_touch_max_clearance_m: must be finite and > 0, got " +
           std::to_string(visible_touch_max_clearance_m);
  if (building_index > sg::kIndexMask) return "rooms.building_index: larger than a node index";
  return "";
}

void Config::print(std::FILE* out) const {
  std::fprintf(out,
               "rooms: seeding %s, dilation [%.3f, %.3f] m step %.3f m (%zu samples), min_component_size %u places, "
               "plateau_alpha %.2f, min_persistence_m %.2f, max_door_clearance_m %.2f, box_from_free_space %d, "
               "building B(%llu)\n",
               to_string(seeding), min_dilation_m, max_dilation_m, dilation_step_m, curve_samples(),
               min_component_size, plateau_alpha, min_persistence_m, max_door_clearance_m, box_from_free_space ? 1 : 0,
               static_cast<unsigned long long>(building_index));
  if (split_by_extent)
    std::fprintf(out,
                 "rooms: split by extent: saturation %.2f m, extent [%.2f, %.2f] m, min_persistence %.2f m, "
                 "min_component_size %u places\n",
                 extent_saturation_m, split_min_extent_m, split_max_extent_m, split_min_persistence_m,
                 split_min_component_size);
  else
    std::fprintf(out, "rooms: split by extent off\n");
  std::fprintf(out, "rooms: closed-off regions seed rooms: %s\n", seed_closed_regions ? "on" : "off");
  if (merge_corridors)
    std::fprintf(out, "rooms: corridor merge: rooms touching >= %u rooms, through >= %u open place edges\n",
                 corridor_min_neighbours, corridor_min_open_edges);
  else
    std::fprintf(out, "rooms: corridor merge off\n");
  if (merge_visible)
    std::fprintf(out,
                 "rooms: visibility merge (with sight lines): >= %.2f of %u x %u sight lines clear, <= %u rounds; "
                 "near the boundary (%.2f m, >= %u places a side): >= %.2f; rooms whose places' spheres touch in "
                 "sight adjacent: %s\n",
                 visible_min_share, visible_samples, visible_samples, visible_max_rounds, visible_local_radius_m,
                 visible_local_min_places, visible_local_min_share, visible_touching ? "yes" : "no");
  else
    std::fprintf(out, "rooms: visibility merge off\n");
}

Capacities Capacities::from_scene_graph(const sg::Capacities& graph) {
  Capacities c;
  c.places = graph.place_nodes;
  c.place_edges = graph.edges;
  c.rooms = graph.room_nodes;
  return c;
}

std::string Capacities::check() const {
  if (places == 0) return "rooms capacities.places: must be > 0";
  if (places >= kNone / 2) return "rooms capacities.places: too large";
  if (place_edges >= kNone / 2) return "rooms capacities.place_edges: too large";
  if (rooms == 0) return "rooms capacities.rooms: must be > 0";
  if (rooms >= (1u << 24)) return "rooms capacities.rooms: at most 2^24 - 1 (the corridor merge packs two slots)";
  return "";
}

void Capacities::print(std::FILE* out) const {
  std::fprintf(out, "rooms capacities: places %zu, place_edges %zu, rooms %zu\n", places, place_edges, rooms);
}

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

// ---------------------------------------------------------------------------------------------------------------
// Plateau rule.

int choose_plateau(const std::uint32_t* betti, std::size_t samples, double alpha) {
  // Longest run of a non-zero value first, then the candidates.
  std::size_t longest = 0;
  for (std::size_t i = 0; i < samples;) {
    std::size_t j = i;
    while (j < samples && betti[j] == betti[i]) ++j;
    if (betti[i] != 0) longest = std::max(longest, j - i);
    i = j;
  }
  if (longest == 0) return -1;
  // "Longer than alpha x the longest": strictly, except that the longest itself always qualifies (alpha = 1).
  const double threshold = alpha * static_cast<double>(longest);
  int best = -1;
  std::size_t best_length = 0;
  std::uint32_t best_value = 0;
  for (std::size_t i = 0; i < samples;) {
    std::size_t j = i;
    while (j < samples && betti[j] == betti[i]) ++j;
    const std::size_t length = j - i;
    const bool candidate = betti[i] != 0 && (static_cast<double>(length) > threshold || length == longest);
    if (candidate && (best < 0 || betti[i] > best_value || (betti[i] == best_value && length > best_length))) {
      best = static_cast<int>(i);
      best_length = length;
      best_value = betti[i];
    }
    i = j;
  }
  return best;
}

// ---------------------------------------------------------------------------------------------------------------
// Start-up.

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
  p.add_array<Edge>(c.place_edges);
  p.add_array<std::uint32_t>(c.places + 1);
  p.add_array<std::uint32_t>(2 * c.place_edges);
  p.add_array<std::uint32_t>(c.places + c.place_edges);
  p.add_array<std::uint32_t>(c.places);
  p.add_array<std::uint32_t>(c.places);
  p.add_array<std::int32_t>(c.places);
  p.add_array<HeapEntry>(2 * c.place_edges);
  p.add_array<std::uint64_t>(std::max(c.places, c.place_edges) + c.places);
  p.add_array<Match>(c.places);
  p.add_array<std::uint32_t>(std::max<std::size_t>(1, config.curve_samples()));
  p.add_array<sg::NodeId>(c.rooms);
  p.add_array<RoomAccumulator>(c.rooms);
  p.add_array<std::uint32_t>(c.places);
  p.add_array<sg::NodeId>(c.rooms);
  p.add_array<std::uint8_t>(c.rooms);
  p.add_array<sg::RoomAttributes>(c.rooms);
  p.add_array<std::uint8_t>(c.rooms);
  p.add_array<double>(c.places);
  p.add_array<std::uint32_t>(c.places);
  p.add_array<std::uint32_t>(c.places);
  p.add_array<std::uint8_t>(c.places);
  p.add_array<double>(c.places);
  p.add_array<std::uint32_t>(c.places);
  p.add_array<std::uint32_t>(c.rooms);
  p.add_array<std::uint32_t>(c.rooms);
  p.add_array<std::uint32_t>(c.rooms);
  p.add_array<std::uint32_t>(c.rooms * Config::kMaxVisibleSamples);
  p.add_array<std::uint32_t>(c.rooms);
  p.add_array<std::uint32_t>(2 * c.places);
  p.add_array<std::uint8_t>(c.places);
  p.add_array<std::uint64_t>(c.places);
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
  edges_ = arena_.carve_array<Edge>(c.place_edges);
  adjacency_offset_ = arena_.carve_array<std::uint32_t>(c.places + 1);
  adjacency_ = arena_.carve_array<std::uint32_t>(2 * c.place_edges);
  order_ = arena_.carve_array<std::uint32_t>(c.places + c.place_edges);
  parent_ = arena_.carve_array<std::uint32_t>(c.places);
  size_ = arena_.carve_array<std::uint32_t>(c.places);
  room_of_ = arena_.carve_array<std::int32_t>(c.places);
  heap_ = arena_.carve_array<HeapEntry>(2 * c.place_edges);
  // The room pairs of the place edges and, in merge_visible, of its touching place pairs too; before its rounds,
  // find_touching_pairs' sorted plan-cell keys (one per place).
  pairs_ = arena_.carve_array<std::uint64_t>(std::max(c.places, c.place_edges) + c.places);
  matches_ = arena_.carve_array<Match>(c.places);
  curve_ = arena_.carve_array<std::uint32_t>(std::max<std::size_t>(1, config.curve_samples()));
  room_ids_ = arena_.carve_array<sg::NodeId>(c.rooms);
  room_acc_ = arena_.carve_array<RoomAccumulator>(c.rooms);
  root_room_ = arena_.carve_array<std::uint32_t>(c.places);
  previous_ids_ = arena_.carve_array<sg::NodeId>(c.rooms);
  previous_taken_ = arena_.carve_array<std::uint8_t>(c.rooms);
  saved_ = arena_.carve_array<sg::RoomAttributes>(c.rooms);
  saved_valid_ = arena_.carve_array<std::uint8_t>(c.rooms);
  birth_ = arena_.carve_array<double>(c.places);
  member_next_ = arena_.carve_array<std::uint32_t>(c.places);
  member_tail_ = arena_.carve_array<std::uint32_t>(c.places);
  split_ = arena_.carve_array<std::uint8_t>(c.places);
  extent_ = arena_.carve_array<double>(c.places);
  sub_seeds_ = arena_.carve_array<std::uint32_t>(c.places);
  room_seeds_ = arena_.carve_array<std::uint32_t>(c.rooms);
  room_parent_ = arena_.carve_array<std::uint32_t>(c.rooms);
  room_neighbours_ = arena_.carve_array<std::uint32_t>(c.rooms);
  sight_samples_ = arena_.carve_array<std::uint32_t>(c.rooms * Config::kMaxVisibleSamples);
  room_count_ = arena_.carve_array<std::uint32_t>(c.rooms);
  near_list_ = arena_.carve_array<std::uint32_t>(2 * c.places);
  near_mark_ = arena_.carve_array<std::uint8_t>(c.places);
  touching_pairs_ = arena_.carve_array<std::uint64_t>(c.places);
  // A heap, matches or curve of zero size would be a null carve; the plan never asks for those.
  ok = ok && place_ids_ && clearance_ && position_ && active_ && (edges_ || c.place_edges == 0) && adjacency_offset_ &&
       (adjacency_ || c.place_edges == 0) && order_ && parent_ && size_ && room_of_ && (heap_ || c.place_edges == 0) &&
       pairs_ && matches_ && curve_ && room_ids_ && room_acc_ && root_room_ && previous_ids_ &&
       previous_taken_ && saved_ && saved_valid_ && birth_ && member_next_ && member_tail_ && split_ && extent_ &&
       sub_seeds_ && room_seeds_ && room_parent_ && room_neighbours_ && sight_samples_ && room_count_ && near_list_ &&
       near_mark_ && touching_pairs_;
  arena_.align_to_plan_boundary();
  if (!ok || !arena_.seal()) {
    if (error != nullptr) *error = "rooms: arena carve did not match its plan";
    return false;
  }
  config_ = config;
  capacities_ = c;
  heap_capacity_ = 2 * c.place_edges;
  building_id_ = sg::make_node_id(sg::kBuildingPrefix, config.building_index);
  counters_ = Counters{};
  num_rooms_ = num_previous_ = 0;
  curve_size_ = 0;
  next_room_index_ = 0;
  building_written_ = false;
  ready_ = true;
  return true;
}

// ---------------------------------------------------------------------------------------------------------------
// Update.

UpdateResult RoomFinder::update(sg::SceneGraph* graph, std::uint64_t time_ns, const DoorSet* doors,
                                const WallSight* sight) {
  UpdateResult r;
  if (!ready_) return r;
  if (graph == nullptr || !graph->initialized()) {
    r.outcome = Outcome::kNoGraph;
    return r;
  }
  ++counters_.updates;
  // Edges through long walls read as closed (Config::close_edges_through_walls); with no structure there is
  // nothing to close.
  const WallSight* walls =
      config_.close_edges_through_walls && sight != nullptr && sight->slices() > 0 ? sight : nullptr;
  read_places(*graph, doors, walls, &r);
  counters_.truncated += r.truncated;
  compute_curve();
  const int chosen = num_places_ == 0 ? -1 : choose_plateau(curve_, curve_size_, config_.plateau_alpha);
  if (chosen < 0) {
    r.outcome = num_places_ == 0 ? Outcome::kNoPlaces : Outcome::kNoRooms;
    ++(num_places_ == 0 ? counters_.no_places : counters_.no_rooms);
    remove_previous(graph, /*keep_taken=*/false, &r);
    r.places_unassigned = num_places_;
    return r;
  }
  r.dilation_m = dilation_at(static_cast<std::size_t>(chosen));
  r.betti_at_dilation = curve_[chosen];
  std::size_t rooms =
      config_.seeding == Seeding::kPersistence ? seed_by_persistence(&r) : seed_rooms(r.dilation_m, &r);
  if (config_.seed_closed_regions) rooms = seed_closed_regions(rooms, &r);
  if (rooms == 0) {
    r.outcome = Outcome::kNoRooms;
    ++counters_.no_rooms;
    remove_previous(graph, /*keep_taken=*/false, &r);
    r.places_unassigned = num_places_;
    return r;
  }
  flood_fill();
  if (config_.split_by_extent) rooms = split_by_extent(rooms, &r);
  if (config_.merge_corridors) rooms = merge_corridors(rooms, &r);
  if (config_.merge_visible && sight != nullptr && sight->slices() > 0 &&
      (!sight->window() || config_.merge_visible_in_window))
    rooms = merge_visible(rooms, *sight, &r);
  assign_ids(*graph, rooms, &r);
  write_rooms(graph, rooms, time_ns, &r);
  counters_.graph_refused += r.refused;
  r.outcome = Outcome::kOk;
  return r;
}

bool RoomFinder::read_places(const sg::SceneGraph& graph, const DoorSet* doors, const WallSight* sight,
                             UpdateResult* r) {
  index_.clear();
  num_places_ = 0;
  num_edges_ = 0;
  // The places in the order of their ids, and each place's edges in the order of the other end's id: the rooms are
  // a function of the graph's content, not of the order its storage happens to visit nodes and edges in (ties
  // among equal clearances are broken by index), so a graph saved and read back gives the same rooms as the one
  // that was built live, with places added and removed over a run.
  graph.for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind != sg::NodeKind::kPlace) return;
    if (num_places_ == capacities_.places) {
      ++r->truncated;
      return;
    }
    place_ids_[num_places_++] = n.id;
  });
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
      edges_[num_edges_++] = Edge{i, *j, w};
    });
    // A place has a handful of edges: insertion sort by the other end (edges are then ordered by (a, b)).
    for (std::size_t k = first + 1; k < num_edges_; ++k)
      for (std::size_t m = k; m > first && edges_[m - 1].b > edges_[m].b; --m) std::swap(edges_[m - 1], edges_[m]);
  }
  // Adjacency in CSR form; size_ is the fill cursor.
  std::fill(adjacency_offset_, adjacency_offset_ + num_places_ + 1, 0u);
  for (std::size_t e = 0; e < num_edges_; ++e) {
    ++adjacency_offset_[edges_[e].a + 1];
    ++adjacency_offset_[edges_[e].b + 1];
  }
  for (std::size_t i = 0; i < num_places_; ++i) adjacency_offset_[i + 1] += adjacency_offset_[i];
  std::copy(adjacency_offset_, adjacency_offset_ + num_places_, size_);
  for (std::size_t e = 0; e < num_edges_; ++e) {
    adjacency_[size_[edges_[e].a]++] = static_cast<std::uint32_t>(e);
    adjacency_[size_[edges_[e].b]++] = static_cast<std::uint32_t>(e);
  }
  r->places = num_places_;
  r->place_edges = num_edges_;
  return true;
}

std::uint32_t RoomFinder::find(std::uint32_t i) {
  while (parent_[i] != i) {
    parent_[i] = parent_[parent_[i]];
    i = parent_[i];
  }
  return i;
}

// Superlevel filtration: lowering the dilation from d+ to d- adds places and edges in order of decreasing
// clearance; union-find keeps the number of components of at least min_component_size places.
void RoomFinder::compute_curve() {
  curve_size_ = config_.curve_samples();
  std::uint32_t* node_order = order_;
  std::uint32_t* edge_order = order_ + num_places_;
  for (std::uint32_t i = 0; i < num_places_; ++i) node_order[i] = i;
  for (std::uint32_t e = 0; e < num_edges_; ++e) edge_order[e] = e;
  std::sort(node_order, node_order + num_places_, [&](std::uint32_t a, std::uint32_t b) {
    return clearance_[a] != clearance_[b] ? clearance_[a] > clearance_[b] : a < b;
  });
  std::sort(edge_order, edge_order + num_edges_, [&](std::uint32_t a, std::uint32_t b) {
    return edges_[a].clearance_m != edges_[b].clearance_m ? edges_[a].clearance_m > edges_[b].clearance_m : a < b;
  });
  const std::uint32_t m = config_.min_component_size;
  std::fill(parent_, parent_ + num_places_, kNone);
  std::size_t next_node = 0, next_edge = 0;
  std::uint32_t count = 0;
  for (std::size_t k = curve_size_; k-- > 0;) {
    const double delta = dilation_at(k) - kDilationTolerance;
    for (; next_node < num_places_ && clearance_[node_order[next_node]] >= delta; ++next_node) {
      const std::uint32_t i = node_order[next_node];
      parent_[i] = i;
      size_[i] = 1;
      if (m <= 1) ++count;
    }
    for (; next_edge < num_edges_ && edges_[edge_order[next_edge]].clearance_m >= delta; ++next_edge) {
      const Edge& e = edges_[edge_order[next_edge]];
      std::uint32_t ra = find(e.a), rb = find(e.b);
      if (ra == rb) continue;
      const bool big_a = size_[ra] >= m, big_b = size_[rb] >= m;
      if (size_[ra] < size_[rb]) std::swap(ra, rb);
      parent_[rb] = ra;
      size_[ra] += size_[rb];
      count = count + (size_[ra] >= m ? 1u : 0u) - (big_a ? 1u : 0u) - (big_b ? 1u : 0u);
    }
    curve_[k] = count;
  }
}

std::size_t RoomFinder::seed_rooms(double dilation_m, UpdateResult* r) {
  const double delta = dilation_m - kDilationTolerance;
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    parent_[i] = clearance_[i] >= delta ? i : kNone;
    size_[i] = 1;
    room_of_[i] = -1;
    root_room_[i] = kNone;
  }
  for (std::size_t k = 0; k < num_edges_; ++k) {
    const Edge& e = edges_[k];
    if (e.clearance_m < delta) continue;
    std::uint32_t ra = find(e.a), rb = find(e.b);
    if (ra == rb) continue;
    if (size_[ra] < size_[rb]) std::swap(ra, rb);
    parent_[rb] = ra;
    size_[ra] += size_[rb];
  }
  // Seed components, largest first when they do not all fit (order_ is free again).
  std::size_t seeds = 0;
  for (std::uint32_t i = 0; i < num_places_; ++i)
    if (parent_[i] == i && size_[i] >= config_.min_component_size) order_[seeds++] = i;
  if (seeds > capacities_.rooms) {
    std::sort(order_, order_ + seeds, [&](std::uint32_t a, std::uint32_t b) {
      return size_[a] != size_[b] ? size_[a] > size_[b] : a < b;
    });
    r->seeds_dropped = seeds - capacities_.rooms;
    counters_.seeds_dropped += r->seeds_dropped;
    seeds = capacities_.rooms;
    std::sort(order_, order_ + seeds);  // slots in place order, as without the cut
  }
  r->seeds = seeds + r->seeds_dropped;
  for (std::size_t s = 0; s < seeds; ++s) root_room_[order_[s]] = static_cast<std::uint32_t>(s);
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    if (parent_[i] == kNone) continue;
    const std::uint32_t slot = root_room_[find(i)];
    if (slot != kNone) {
      room_of_[i] = static_cast<std::int32_t>(slot);
      ++r->seeded_places;
    }
  }
  return seeds;
}

// Merge tree of the clearance filtration (order_ still holds compute_curve()'s sorted places and edges): places
// enter at their clearance (capped at d+), edges join components at their clearance, down to d-. When two
// components meet and both are seed-worthy (big and persistent enough, or already holding seeds), the ones not yet
// seeded become seeds with every place they hold; the merged component holds seeds from then on, so later places
// that reach it only through it are left to the flood fill. At d- every remaining component of the minimum size
// becomes a seed whatever its persistence: nothing joins it above d-, so it is a region of its own (a narrow
// corridor peaks not far above d-, yet is a room).
std::size_t RoomFinder::seed_by_persistence(UpdateResult* r) {
  const std::uint32_t* node_order = order_;
  const std::uint32_t* edge_order = order_ + num_places_;
  const double d_min = config_.min_dilation_m - kDilationTolerance;
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    parent_[i] = kNone;
    room_of_[i] = -1;
  }
  const auto worthy = [&](std::uint32_t root, double at_m) {
    return split_[root] != 0 ||
           (size_[root] >= config_.min_component_size && birth_[root] - at_m >= config_.min_persistence_m - 1e-9);
  };
  // A place enters the filtration as a component of its own, born at its clearance (capped at d+).
  const auto enter = [&](std::uint32_t i) {
    parent_[i] = i;
    size_[i] = 1;
    birth_[i] = std::min(clearance_[i], config_.max_dilation_m);
    member_next_[i] = kNone;
    member_tail_[i] = i;
    split_[i] = 0;
  };
  std::size_t seeds = 0;
  std::size_t next_node = 0;
  for (std::size_t k = 0; k < num_edges_; ++k) {
    const Edge& e = edges_[edge_order[k]];
    if (e.clearance_m < d_min) break;
    // Places at least as clear as this edge enter first (an edge's clearance never exceeds its ends').
    for (; next_node < num_places_ && clearance_[node_order[next_node]] >= e.clearance_m; ++next_node)
      enter(node_order[next_node]);
    std::uint32_t ra = find(e.a), rb = find(e.b);
    if (ra == rb) continue;
    std::uint8_t split = split_[ra] | split_[rb];
    if (e.clearance_m <= config_.max_door_clearance_m + 1e-9 && worthy(ra, e.clearance_m) &&
        worthy(rb, e.clearance_m)) {
      if (split_[ra] == 0) emit_seed(ra, &seeds, r);
      if (split_[rb] == 0) emit_seed(rb, &seeds, r);
      split = 1;
    }
    join(ra, rb, split);
  }
  // Places above d- that no edge above d- reached are components of their own.
  for (; next_node < num_places_ && clearance_[node_order[next_node]] >= d_min; ++next_node)
    enter(node_order[next_node]);
  for (std::size_t n = 0; n < next_node; ++n) {
    const std::uint32_t i = node_order[n];
    if (parent_[i] == i && split_[i] == 0 && size_[i] >= config_.min_component_size) emit_seed(i, &seeds, r);
  }
  r->seeds = seeds + r->seeds_dropped;
  return seeds;
}

// Closed-off regions (Config::seed_closed_regions): the components of the places graph without its closed edges;
// each that holds no seed and has at least min_component_size places becomes a seed with all its places (while the
// room capacity lasts; beyond it, counted as dropped). Returns the new number of seeds.
std::size_t RoomFinder::seed_closed_regions(std::size_t seeds, UpdateResult* r) {
  if (r->closed_edges == 0) return seeds;
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    parent_[i] = i;
    size_[i] = 1;
    split_[i] = 0;  // per root: holds a seed (or is refused)
    root_room_[i] = kNone;
  }
  for (std::size_t k = 0; k < num_edges_; ++k) {
    const Edge& e = edges_[k];
    if (e.closed()) continue;
    std::uint32_t ra = find(e.a), rb = find(e.b);
    if (ra == rb) continue;
    if (size_[ra] < size_[rb]) std::swap(ra, rb);
    parent_[rb] = ra;
    size_[ra] += size_[rb];
  }
  for (std::uint32_t i = 0; i < num_places_; ++i)
    if (room_of_[i] >= 0) split_[find(i)] = 1;
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    const std::uint32_t root = find(i);
    if (split_[root] != 0 || size_[root] < config_.min_component_size) continue;
    if (root_room_[root] == kNone) {
      if (seeds == capacities_.rooms) {
        split_[root] = 1;
        ++r->seeds_dropped;
        ++counters_.seeds_dropped;
        continue;
      }
      root_room_[root] = static_cast<std::uint32_t>(seeds++);
      ++r->closed_region_rooms;
      ++r->seeds;
    }
    room_of_[i] = static_cast<std::int32_t>(root_room_[root]);
    ++r->seeded_places;
  }
  return seeds;
}

void RoomFinder::emit_seed(std::uint32_t root, std::size_t* seeds, UpdateResult* r) {
  split_[root] = 1;
  if (*seeds == capacities_.rooms) {
    ++r->seeds_dropped;
    ++counters_.seeds_dropped;
    return;
  }
  const std::int32_t slot = static_cast<std::int32_t>((*seeds)++);
  for (std::uint32_t i = root; i != kNone; i = member_next_[i]) {
    room_of_[i] = slot;
    ++r->seeded_places;
  }
}

void RoomFinder::heap_push(const HeapEntry& e) {
  // Max-heap on clearance, ties in push order (deterministic).
  const auto before = expands_before;
  if (heap_size_ == heap_capacity_) return;  // cannot happen: each place pushes its edges once
  std::size_t i = heap_size_++;
  while (i > 0) {
    const std::size_t up = (i - 1) / 2;
    if (!before(e, heap_[up])) break;
    heap_[i] = heap_[up];
    i = up;
  }
  heap_[i] = e;
}

RoomFinder::HeapEntry RoomFinder::heap_pop() {
  const auto before = expands_before;
  const HeapEntry top = heap_[0];
  const HeapEntry last = heap_[--heap_size_];
  std::size_t i = 0;
  for (;;) {
    const std::size_t l = 2 * i + 1, rgt = l + 1;
    if (l >= heap_size_) break;
    const std::size_t c = rgt < heap_size_ && before(heap_[rgt], heap_[l]) ? rgt : l;
    if (!before(heap_[c], last)) break;
    heap_[i] = heap_[c];
    i = c;
  }
  if (heap_size_ > 0) heap_[i] = last;
  return top;
}

// Merge-tree union: the smaller component joins the larger, which keeps the larger birth, both member lists and
// the given seed flag.
void RoomFinder::join(std::uint32_t ra, std::uint32_t rb, std::uint8_t split) {
  if (size_[ra] < size_[rb]) std::swap(ra, rb);
  parent_[rb] = ra;
  size_[ra] += size_[rb];
  birth_[ra] = std::max(birth_[ra], birth_[rb]);
  member_next_[member_tail_[ra]] = rb;
  member_tail_[ra] = member_tail_[rb];
  split_[ra] = split;
}

// fn(edge, other end) for every place edge of place i (the CSR adjacency).
template <typename Fn>
void RoomFinder::for_each_place_edge(std::uint32_t i, Fn&& fn) const {
  for (std::uint32_t k = adjacency_offset_[i]; k < adjacency_offset_[i + 1]; ++k) {
    const Edge& e = edges_[adjacency_[k]];
    fn(e, e.a == i ? e.b : e.a);
  }
}

// Every unassigned place that may_enter(from, to) allows joins the room whose frontier reaches it through the edge
// of largest value(edge) first (ties: push order).
template <typename Value, typename MayEnter>
void RoomFinder::fill(Value value, MayEnter may_enter) {
  heap_size_ = 0;
  std::uint32_t sequence = 0;
  const auto push_frontier = [&](std::uint32_t i) {
    for_each_place_edge(i, [&](const Edge& e, std::uint32_t j) {
      if (room_of_[j] < 0 && may_enter(i, j))
        heap_push(HeapEntry{value(e), sequence++, j, static_cast<std::uint32_t>(room_of_[i])});
    });
  };
  for (std::uint32_t i = 0; i < num_places_; ++i)
    if (room_of_[i] >= 0) push_frontier(i);
  while (heap_size_ > 0) {
    const HeapEntry top = heap_pop();
    if (room_of_[top.place] >= 0) continue;
    room_of_[top.place] = static_cast<std::int32_t>(top.room);
    push_frontier(top.place);
  }
}

void RoomFinder::flood_fill() {
  fill([](const Edge& e) { return e.clearance_m; }, [](std::uint32_t, std::uint32_t) { return true; });
}

// Extended clearance (Config::split_by_extent): a multi-source Dijkstra over the place edges with horizontal
// lengths, from every place below the saturation clearance; a saturated place adds its distance to them (none when
// no such place is connected to it).
void RoomFinder::compute_extent() {
  constexpr double kUnreached = std::numeric_limits<double>::infinity();
  const double saturation = config_.extent_saturation_m;
  double* depth = extent_;
  for (std::uint32_t i = 0; i < num_places_; ++i) depth[i] = clearance_[i] < saturation ? 0.0 : kUnreached;
  heap_size_ = 0;
  std::uint32_t sequence = 0;
  // Max-heap on clearance_m, so the distance goes in negated. Each place relaxes its edges once (stale entries
  // are skipped), so at most one entry per directed edge: the heap's 2 x edges capacity holds them all.
  const auto relax = [&](std::uint32_t i) {
    for_each_place_edge(i, [&](const Edge&, std::uint32_t j) {
      const double d = depth[i] + std::hypot(position_[3 * j] - position_[3 * i],
                                             position_[3 * j + 1] - position_[3 * i + 1]);
      if (d < depth[j]) {
        depth[j] = d;
        heap_push(HeapEntry{-d, sequence++, j, 0});
      }
    });
  };
  for (std::uint32_t i = 0; i < num_places_; ++i)
    if (depth[i] == 0.0) relax(i);
  while (heap_size_ > 0) {
    const HeapEntry top = heap_pop();
    if (-top.clearance_m > depth[top.place]) continue;  // stale
    relax(top.place);
  }
  for (std::uint32_t i = 0; i < num_places_; ++i)
    extent_[i] = clearance_[i] + (depth[i] == kUnreached ? 0.0 : depth[i]);
}

// Re-seeds every room on the extended clearance through its own edges (the persistence rule of
// seed_by_persistence, with the split_* settings), splits the rooms that get two or more seeds (the first keeps the
// room's slot, the others take new slots while the room capacity lasts) and flood-fills their other places among
// their seeds through the room's own edges, largest extended clearance first. Returns the new number of rooms.
std::size_t RoomFinder::split_by_extent(std::size_t num_rooms, UpdateResult* r) {
  compute_extent();
  const double top = config_.split_max_extent_m;
  const double d_min = config_.split_min_extent_m - kDilationTolerance;
  // A closed passage stays closed to the split too.
  const auto edge_extent = [&](const Edge& e) { return e.closed() ? kClosed : std::min(extent_[e.a], extent_[e.b]); };
  std::uint32_t* node_order = order_;
  std::uint32_t* edge_order = order_ + num_places_;
  std::size_t num_inner = 0;
  for (std::uint32_t i = 0; i < num_places_; ++i) node_order[i] = i;
  for (std::uint32_t e = 0; e < num_edges_; ++e)
    if (room_of_[edges_[e].a] >= 0 && room_of_[edges_[e].a] == room_of_[edges_[e].b]) edge_order[num_inner++] = e;
  std::sort(node_order, node_order + num_places_, [&](std::uint32_t a, std::uint32_t b) {
    return extent_[a] != extent_[b] ? extent_[a] > extent_[b] : a < b;
  });
  std::sort(edge_order, edge_order + num_inner, [&](std::uint32_t a, std::uint32_t b) {
    const double ea = edge_extent(edges_[a]), eb = edge_extent(edges_[b]);
    return ea != eb ? ea > eb : a < b;
  });
  std::fill(room_seeds_, room_seeds_ + num_rooms, 0u);
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    parent_[i] = kNone;
    root_room_[i] = kNone;  // the place's seed, if any
  }
  std::uint32_t num_seeds = 0;
  const auto emit = [&](std::uint32_t root) {
    split_[root] = 1;
    if (room_of_[root] < 0) return;
    sub_seeds_[num_seeds] = static_cast<std::uint32_t>(room_of_[root]);  // the seed's room, for now
    ++room_seeds_[room_of_[root]];
    for (std::uint32_t i = root; i != kNone; i = member_next_[i]) root_room_[i] = num_seeds;
    ++num_seeds;
  };
  const auto worthy = [&](std::uint32_t root, double at_m) {
    return split_[root] != 0 || (size_[root] >= config_.split_min_component_size &&
                                 birth_[root] - at_m >= config_.split_min_persistence_m - 1e-9);
  };
  const auto enter = [&](std::uint32_t i) {
    parent_[i] = i;
    size_[i] = 1;
    birth_[i] = std::min(extent_[i], top);
    member_next_[i] = kNone;
    member_tail_[i] = i;
    split_[i] = 0;
  };
  std::size_t next_node = 0;
  for (std::size_t k = 0; k < num_inner; ++k) {
    const Edge& e = edges_[edge_order[k]];
    const double c = edge_extent(e);
    if (c < d_min) break;
    for (; next_node < num_places_ && extent_[node_order[next_node]] >= c; ++next_node) enter(node_order[next_node]);
    std::uint32_t ra = find(e.a), rb = find(e.b);
    if (ra == rb) continue;
    std::uint8_t split = split_[ra] | split_[rb];
    if (worthy(ra, c) && worthy(rb, c)) {
      if (split_[ra] == 0) emit(ra);
      if (split_[rb] == 0) emit(rb);
      split = 1;
    }
    join(ra, rb, split);
  }
  for (; next_node < num_places_ && extent_[node_order[next_node]] >= d_min; ++next_node) enter(node_order[next_node]);
  for (std::size_t n = 0; n < next_node; ++n) {
    const std::uint32_t i = node_order[n];
    if (parent_[i] == i && split_[i] == 0 && size_[i] >= config_.split_min_component_size) emit(i);
  }

  // Slots: a room's first seed keeps its slot, each further one takes a new slot. room_seeds_[room] holds the
  // room's seed count in its low bits, then two flags: split (bit 31) and first slot handed out (bit 30).
  std::size_t rooms = num_rooms;
  for (std::uint32_t q = 0; q < num_seeds; ++q) {
    const std::uint32_t room = sub_seeds_[q];
    if (room_seeds_[room] < 2) {
      sub_seeds_[q] = room;  // one seed: the room stays as it is
      continue;
    }
    room_seeds_[room] |= 0x80000000u;  // split: its places are re-filled below
    if ((room_seeds_[room] & 0x40000000u) == 0) {
      room_seeds_[room] |= 0x40000000u;  // the first seed keeps the slot
      sub_seeds_[q] = room;
      ++r->rooms_split;
    } else if (rooms < capacities_.rooms) {
      sub_seeds_[q] = static_cast<std::uint32_t>(rooms++);
      ++r->split_rooms_added;
    } else {
      sub_seeds_[q] = room;  // no slot left: stays in its room
      ++r->seeds_dropped;
      ++counters_.seeds_dropped;
    }
  }
  // Places of split rooms: seed members take their seed's slot, the others are filled again among them. parent_
  // now holds each such place's room before the split (kNone elsewhere), the bound of the fill.
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    parent_[i] = kNone;
    const std::int32_t room = room_of_[i];
    if (room < 0 || (room_seeds_[room] & 0x80000000u) == 0) continue;
    parent_[i] = static_cast<std::uint32_t>(room);
    room_of_[i] = root_room_[i] != kNone ? static_cast<std::int32_t>(sub_seeds_[root_room_[i]]) : -1;
  }
  fill(edge_extent, [&](std::uint32_t from, std::uint32_t to) {
    return parent_[from] != kNone && parent_[to] == parent_[from];
  });
  // A room is connected through its own edges, so the fill reaches all of it; should a place be left, it stays in
  // its room.
  for (std::uint32_t i = 0; i < num_places_; ++i)
    if (parent_[i] != kNone && room_of_[i] < 0) room_of_[i] = static_cast<std::int32_t>(parent_[i]);
  return rooms;
}

std::uint32_t RoomFinder::find_room(std::uint32_t slot) {
  while (room_parent_[slot] != slot) {
    room_parent_[slot] = room_parent_[room_parent_[slot]];
    slot = room_parent_[slot];
  }
  return slot;
}

// pairs_ holds one record per boundary edge at first: lower room slot << 40 | higher slot << 16 | open (0 or 1).
// Each round maps the records to the current merged rooms, sorts them and folds each pair's records into one (its
// open edges summed, saturating at 0xffff), so after the first round a round costs the number of room pairs, not
// of edges; it counts per room its distinct neighbours and merges the qualifying pair with the most open edges
// (ties: the lower pair). Slots are then renumbered densely.
std::size_t RoomFinder::merge_corridors(std::size_t num_rooms, UpdateResult* r) {
  constexpr std::uint64_t kCountMask = 0xffffu;
  const auto lo_of = [](std::uint64_t x) { return static_cast<std::uint32_t>(x >> 40); };
  const auto hi_of = [](std::uint64_t x) { return static_cast<std::uint32_t>((x >> 16) & 0xffffffu); };
  const auto record = [](std::uint32_t a, std::uint32_t b, std::uint64_t count) {
    return (static_cast<std::uint64_t>(std::min(a, b)) << 40) | (static_cast<std::uint64_t>(std::max(a, b)) << 16) |
           count;
  };
  std::size_t n = 0;
  for (std::size_t e = 0; e < num_edges_; ++e) {
    const std::int32_t a = room_of_[edges_[e].a], b = room_of_[edges_[e].b];
    if (a < 0 || b < 0 || a == b) continue;
    pairs_[n++] = record(static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b), edges_[e].closed() ? 0u : 1u);
  }
  for (std::size_t k = 0; k < num_rooms; ++k) room_parent_[k] = static_cast<std::uint32_t>(k);
  std::size_t merges = 0;
  for (;;) {
    std::size_t m = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const std::uint32_t a = find_room(lo_of(pairs_[k])), b = find_room(hi_of(pairs_[k]));
      if (a != b) pairs_[m++] = record(a, b, pairs_[k] & kCountMask);  // else inside one merged room now
    }
    std::sort(pairs_, pairs_ + m);
    n = 0;
    for (std::size_t k = 0; k < m;) {
      std::uint64_t open = 0;
      std::size_t j = k;
      for (; j < m && (pairs_[j] >> 16) == (pairs_[k] >> 16); ++j) open += pairs_[j] & kCountMask;
      pairs_[n++] = (pairs_[k] & ~kCountMask) | std::min(open, kCountMask);
      k = j;
    }
    std::fill(room_neighbours_, room_neighbours_ + num_rooms, 0u);
    for (std::size_t k = 0; k < n; ++k) {
      ++room_neighbours_[lo_of(pairs_[k])];
      ++room_neighbours_[hi_of(pairs_[k])];
    }
    std::uint64_t best_open = 0;
    std::size_t best = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const std::uint64_t open = pairs_[k] & kCountMask;
      if (open >= config_.corridor_min_open_edges && open > best_open &&
          room_neighbours_[lo_of(pairs_[k])] >= config_.corridor_min_neighbours &&
          room_neighbours_[hi_of(pairs_[k])] >= config_.corridor_min_neighbours) {
        best_open = open;
        best = k;
      }
    }
    if (best_open == 0) break;
    room_parent_[hi_of(pairs_[best])] = lo_of(pairs_[best]);  // the lower slot stays
    ++merges;
  }
  if (merges == 0) return num_rooms;
  r->corridor_merges += merges;
  return renumber_merged_rooms(num_rooms);
}

// Dense slots in the order of the surviving rooms' old slots (room_parent_ says who merged into whom);
// room_neighbours_ becomes old root -> new slot.
std::size_t RoomFinder::renumber_merged_rooms(std::size_t num_rooms) {
  std::size_t rooms = 0;
  for (std::size_t k = 0; k < num_rooms; ++k)
    if (find_room(static_cast<std::uint32_t>(k)) == k) room_neighbours_[k] = static_cast<std::uint32_t>(rooms++);
  for (std::uint32_t i = 0; i < num_places_; ++i)
    if (room_of_[i] >= 0)
      room_of_[i] = static_cast<std::int32_t>(room_neighbours_[find_room(static_cast<std::uint32_t>(room_of_[i]))]);
  return rooms;
}

// Each round: every room's samples (its places at ranks floor(j (n - 1) / (m - 1)), j < m, in index order: all of
// them when it has m or fewer), the adjacent pairs from the boundary edges and the touching place pairs (pairs_,
// sorted and folded), each pair's share of clear sight lines (kept in the record's low 16 bits, 0..65535), then the
// qualifying pairs clearest first (ties: the lower pair), each room merged once.
std::size_t RoomFinder::merge_visible(std::size_t num_rooms, const WallSight& sight, UpdateResult* r) {
  constexpr std::uint64_t kShareMask = 0xffffu;
  const auto lo_of = [](std::uint64_t x) { return static_cast<std::uint32_t>(x >> 40); };
  const auto hi_of = [](std::uint64_t x) { return static_cast<std::uint32_t>((x >> 16) & 0xffffffu); };
  const auto key = [](std::uint32_t a, std::uint32_t b) {
    return (static_cast<std::uint64_t>(std::min(a, b)) << 40) | (static_cast<std::uint64_t>(std::max(a, b)) << 16);
  };
  const std::uint32_t m = config_.visible_samples;
  const std::uint64_t min_share =
      static_cast<std::uint64_t>(std::ceil(config_.visible_min_share * static_cast<double>(kShareMask)));
  constexpr std::uint64_t kNearBit = 0x8000u;
  const bool near_on = config_.visible_local_radius_m > 0.0;
  const std::uint64_t near_min_share =
      static_cast<std::uint64_t>(std::ceil(config_.visible_local_min_share * static_cast<double>(kShareMask)));
  std::size_t near_merged = 0;
  std::size_t rooms = num_rooms;
  std::size_t merged_total = 0;
  find_touching_pairs(sight, r);
  for (std::uint32_t round = 0; round < config_.visible_max_rounds; ++round) {
    // Samples.
    std::fill(room_count_, room_count_ + rooms, 0u);
    for (std::uint32_t i = 0; i < num_places_; ++i)
      if (room_of_[i] >= 0) ++room_count_[room_of_[i]];
    std::fill(room_neighbours_, room_neighbours_ + rooms, 0u);  // per room: places seen so far (its rank)
    std::fill(room_parent_, room_parent_ + rooms, 0u);          // per room: samples taken
    for (std::uint32_t i = 0; i < num_places_; ++i) {
      if (room_of_[i] < 0) continue;
      const std::uint32_t k = static_cast<std::uint32_t>(room_of_[i]);
      const std::uint64_t n = room_count_[k], rank = room_neighbours_[k]++;
      std::uint32_t& taken = room_parent_[k];
      // Sample j sits at rank floor(j (n - 1) / (m - 1)); several j can share a rank only when n < m (all taken).
      while (taken < m && sample_rank(n, m, taken) == rank)
        sight_samples_[static_cast<std::size_t>(k) * Config::kMaxVisibleSamples + taken++] = i;
    }
    for (std::size_t k = 0; k < rooms; ++k) room_count_[k] = room_parent_[k];  // samples per room
    // Adjacent pairs.
    std::size_t n = 0;
    for (std::size_t e = 0; e < num_edges_; ++e) {
      const std::int32_t a = room_of_[edges_[e].a], b = room_of_[edges_[e].b];
      if (a >= 0 && b >= 0 && a != b) pairs_[n++] = key(static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b));
    }
    for (std::size_t k = 0; k < num_touching_pairs_; ++k) {
      const std::int32_t a = room_of_[touching_pairs_[k] >> 32], b = room_of_[touching_pairs_[k] & 0xffffffffu];
      if (a != b) pairs_[n++] = key(static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b));
    }
    std::sort(pairs_, pairs_ + n);
    n = static_cast<std::size_t>(std::unique(pairs_, pairs_ + n) - pairs_);
    // Shares.
    std::size_t candidates = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const std::uint32_t a = lo_of(pairs_[k]), b = hi_of(pairs_[k]);
      const std::uint32_t* sa = sight_samples_ + static_cast<std::size_t>(a) * Config::kMaxVisibleSamples;
      const std::uint32_t* sb = sight_samples_ + static_cast<std::size_t>(b) * Config::kMaxVisibleSamples;
      std::uint64_t clear = 0;
      for (std::uint32_t x = 0; x < room_count_[a]; ++x)
        for (std::uint32_t y = 0; y < room_count_[b]; ++y)
          clear += sight.sees(place_position(sa[x]), place_position(sb[y])) ? 1 : 0;
      const std::uint64_t lines = static_cast<std::uint64_t>(room_count_[a]) * room_count_[b];
      const std::uint64_t share = lines == 0 ? 0 : clear * kShareMask / lines;
      ++r->visible_pairs;
      // The record's priority: pairs that qualify as whole rooms (kNearBit set, then by share) before pairs that
      // qualify near their boundary only (by that share).
      std::uint64_t priority = 0;
      if (share >= min_share) {
        priority = kNearBit | (share >> 1);
      } else if (near_on) {
        const std::uint64_t near = near_boundary_share(a, b, sight, kShareMask);
        if (near > 0 && near >= near_min_share) priority = std::max<std::uint64_t>(1, near >> 1);
      }
      if (priority != 0) pairs_[candidates++] = pairs_[k] | priority;
    }
    if (candidates == 0) break;
    std::sort(pairs_, pairs_ + candidates, [&](std::uint64_t x, std::uint64_t y) {
      return (x & kShareMask) != (y & kShareMask) ? (x & kShareMask) > (y & kShareMask) : x < y;
    });
    for (std::size_t k = 0; k < rooms; ++k) room_parent_[k] = static_cast<std::uint32_t>(k);
    std::fill(room_count_, room_count_ + rooms, 0u);  // per room: merged this round
    std::size_t merged = 0;
    for (std::size_t k = 0; k < candidates; ++k) {
      const std::uint32_t a = lo_of(pairs_[k]), b = hi_of(pairs_[k]);
      if (room_count_[a] != 0 || room_count_[b] != 0) continue;
      room_count_[a] = room_count_[b] = 1;
      room_parent_[b] = a;  // the lower slot stays
      ++merged;
      if ((pairs_[k] & kNearBit) == 0) ++near_merged;
    }
    merged_total += merged;
    rooms = renumber_merged_rooms(rooms);
  }
  r->visible_merges += merged_total;
  r->visible_near_merges += near_merged;
  return rooms;
}

// Layout of near_list_ (2 x places): [0, places) holds the boundary ends, b's from the front and a's from the back;
// [places, 2 places) the places near them, a's from the front and b's from the back. Marks are cleared on the way
// out, so the cost is the edges once plus each room's places times the other's ends.
std::uint64_t RoomFinder::near_boundary_share(std::uint32_t a, std::uint32_t b, const WallSight& sight,
                                              std::uint64_t share_scale) {
  const std::size_t cap = capacities_.places;
  std::uint32_t* ends = near_list_;
  std::uint32_t* near = near_list_ + cap;
  std::size_t ends_b = 0, ends_a = 0;
  const auto add_ends = [&](std::uint32_t u, std::uint32_t v) {
    const std::int32_t ru = room_of_[u], rv = room_of_[v];
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
  for (std::size_t e = 0; e < num_edges_; ++e) add_ends(edges_[e].a, edges_[e].b);
  for (std::size_t k = 0; k < num_touching_pairs_; ++k)
    add_ends(static_cast<std::uint32_t>(touching_pairs_[k] >> 32),
             static_cast<std::uint32_t>(touching_pairs_[k] & 0xffffffffu));
  for (std::size_t k = 0; k < ends_b; ++k) near_mark_[ends[k]] = 0;
  for (std::size_t k = 0; k < ends_a; ++k) near_mark_[ends[cap - 1 - k]] = 0;
  const double r2 = config_.visible_local_radius_m * config_.visible_local_radius_m;
  const auto close_to = [&](std::uint32_t i, const std::uint32_t* list, std::size_t n, bool backwards) {
    for (std::size_t k = 0; k < n; ++k) {
      const std::uint32_t j = backwards ? list[cap - 1 - k] : list[k];
      const double dx = position_[3 * i] - position_[3 * j], dy = position_[3 * i + 1] - position_[3 * j + 1];
      if (dx * dx + dy * dy <= r2) return true;
    }
    return false;
  };
  std::size_t near_a = 0, near_b = 0;
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    if (room_of_[i] == static_cast<std::int32_t>(a) && close_to(i, ends, ends_b, false)) near[near_a++] = i;
    if (room_of_[i] == static_cast<std::int32_t>(b) && close_to(i, ends, ends_a, true)) near[cap - 1 - near_b++] = i;
  }
  const std::size_t min_places = config_.visible_local_min_places;
  if (near_a < min_places || near_b < min_places) return 0;
  // The same even spread as the whole rooms' samples.
  const std::uint64_t m = config_.visible_samples;
  const std::size_t ma = std::min<std::size_t>(near_a, m), mb = std::min<std::size_t>(near_b, m);
  std::uint64_t clear = 0;
  for (std::size_t x = 0; x < ma; ++x)
    for (std::size_t y = 0; y < mb; ++y)
      clear += sight.sees(place_position(near[sample_rank(near_a, m, x)]),
                          place_position(near[cap - 1 - sample_rank(near_b, m, y)]))
                   ? 1
                   : 0;
  return clear * share_scale / (static_cast<std::uint64_t>(ma) * mb);
}

// Places are keyed by their plan cell (twice the largest clearance a side, so touching spheres lie in neighbouring
// cells) and sorted (in pairs_, free until merge_visible's rounds); each place then looks through the 3 x 3 cells round its own for places of other rooms (a
// higher index: each pair once) whose sphere touches its own and that it sees. The cost is the places' sort, the
// distances to the places in those cells, and a sight line per touching pair of different rooms.
void RoomFinder::find_touching_pairs(const WallSight& sight, UpdateResult* r) {
  num_touching_pairs_ = 0;
  if (!config_.visible_touching || num_places_ == 0) return;
  const auto usable = [&](std::uint32_t i) {
    return room_of_[i] >= 0 && clearance_[i] > 0.0 && std::isfinite(position_[3 * i]) &&
           std::isfinite(position_[3 * i + 1]) && std::isfinite(position_[3 * i + 2]);
  };
  const auto radius = [&](std::uint32_t i) { return std::min(clearance_[i], config_.visible_touch_max_clearance_m); };
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0, cell = 0.0;
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    if (!usable(i)) continue;
    cell = std::max(cell, 2.0 * radius(i));
    x0 = std::min(x0, position_[3 * i]);
    x1 = std::max(x1, position_[3 * i]);
    y0 = std::min(y0, position_[3 * i + 1]);
    y1 = std::max(y1, position_[3 * i + 1]);
  }
  if (!(x1 >= x0)) return;  // no usable place
  const double cols_d = std::floor((x1 - x0) / cell) + 1.0, rows_d = std::floor((y1 - y0) / cell) + 1.0;
  if (!(cols_d * rows_d < 4.0e9)) {  // the cell key is 32 bits: a map this large in cells is not looked through
    ++r->visible_touching_dropped;
    return;
  }
  const std::uint64_t cols = static_cast<std::uint64_t>(cols_d), rows = static_cast<std::uint64_t>(rows_d);
  std::uint64_t* const cell_keys = pairs_;
  std::size_t n = 0;
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    if (!usable(i)) continue;
    const std::uint64_t c = std::min(cols - 1, static_cast<std::uint64_t>((position_[3 * i] - x0) / cell));
    const std::uint64_t w = std::min(rows - 1, static_cast<std::uint64_t>((position_[3 * i + 1] - y0) / cell));
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
        if (j <= i || room_of_[j] == room_of_[i]) continue;
        const double touch = radius(i) + radius(j);
        if ((place_position(i) - place_position(j)).squaredNorm() >= touch * touch ||
            !sight.sees(place_position(i), place_position(j)))
          continue;
        if (num_touching_pairs_ == capacities_.places) {
          ++r->visible_touching_dropped;
          continue;
        }
        touching_pairs_[num_touching_pairs_++] = (static_cast<std::uint64_t>(i) << 32) | j;
      }
    }
  }
  r->visible_touching_pairs += num_touching_pairs_;
}

// A new room takes the id of the previous room it shares most places with (each id once, largest overlaps
// first); the others get fresh ids.
void RoomFinder::assign_ids(const sg::SceneGraph& graph, std::size_t num_rooms, UpdateResult* r) {
  std::fill(room_ids_, room_ids_ + num_rooms, sg::kNoNode);
  std::fill(previous_taken_, previous_taken_ + num_previous_, std::uint8_t{0});
  std::size_t n = 0;
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    if (room_of_[i] < 0) continue;
    const std::uint32_t* prev = previous_.find(place_ids_[i]);
    if (prev == nullptr || *prev >= num_previous_ || previous_ids_[*prev] == sg::kNoNode) continue;
    pairs_[n++] = (static_cast<std::uint64_t>(room_of_[i]) << 32) | *prev;
  }
  std::sort(pairs_, pairs_ + n);
  std::size_t num_matches = 0;
  for (std::size_t k = 0; k < n;) {
    std::size_t j = k;
    while (j < n && pairs_[j] == pairs_[k]) ++j;
    matches_[num_matches++] = Match{static_cast<std::uint32_t>(j - k), static_cast<std::uint32_t>(pairs_[k] >> 32),
                                    static_cast<std::uint32_t>(pairs_[k] & 0xffffffffu)};
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
  remove_previous(graph, /*keep_taken=*/true, r);
  // Kept rooms are removed and re-added under the same id with their labels: remove_node() drops a node's edges
  // newest first in O(degree), where removing them one by one would scan the room's adjacency for each.
  for (std::size_t s = 0; s < num_rooms; ++s) {
    saved_valid_[s] = 0;
    if (const sg::RoomAttributes* existing = graph->room(room_ids_[s])) {
      saved_[s] = *existing;
      saved_valid_[s] = 1;
      graph->remove_node(room_ids_[s]);
    }
  }
  free_chunks_ = 0;
  graph->for_each_resource([&](const memory::ResourceStats& st) {
    if (std::strcmp(st.name, "scene_graph.adjacency_chunks") == 0) free_chunks_ = st.capacity - st.in_use;
  });

  // Centroid, bounds and activity of every room.
  for (std::size_t s = 0; s < num_rooms; ++s) {
    RoomAccumulator& a = room_acc_[s];
    for (int d = 0; d < 3; ++d) {
      a.sum[d] = 0.0;
      a.min[d] = std::numeric_limits<double>::max();
      a.max[d] = std::numeric_limits<double>::lowest();
    }
    a.count = 0;
    a.active = false;
  }
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    if (room_of_[i] < 0) continue;
    RoomAccumulator& a = room_acc_[room_of_[i]];
    // The box holds each place's free-space sphere (radius: its clearance), so it spans the room's free space
    // rather than only the GVD inside it (which stays a clearance away from every wall, floor and ceiling).
    const double radius = config_.box_from_free_space ? std::max(0.0, clearance_[i]) : 0.0;
    for (int d = 0; d < 3; ++d) {
      const double v = position_[3 * i + d];
      a.sum[d] += v;
      a.min[d] = std::min(a.min[d], v - radius);
      a.max[d] = std::max(a.max[d], v + radius);
    }
    ++a.count;
    a.active = a.active || active_[i] != 0;
  }

  // Room nodes: attributes replaced, labels of kept rooms preserved for the classifier.
  const sg::Capacities& gc = graph->capacities();
  Eigen::Vector3d building_sum = Eigen::Vector3d::Zero();
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
    if (graph->num_nodes(sg::NodeKind::kRoom) >= gc.room_nodes || graph->num_nodes() >= gc.nodes() ||
               graph->add_room(room_ids_[s], attrs) != sg::Status::kOk) {
      if (graph->num_nodes(sg::NodeKind::kRoom) >= gc.room_nodes || graph->num_nodes() >= gc.nodes())
        graph->count_refused_node(sg::NodeKind::kRoom);  // shown under the store's own name
      ++r->refused;
      room_ids_[s] = sg::kNoNode;
      continue;
    }
    building_sum += attrs.position_m;
    ++written;
  }

  // The building at the mean of the room centroids.
  bool have_building = false;
  if (written > 0) {
    sg::BuildingAttributes b;
    b.position_m = building_sum / static_cast<double>(written);
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

  // Room -> place (the room becomes the place's parent), room - room where places touch, building -> room.
  for (std::uint32_t i = 0; i < num_places_; ++i) {
    const std::int32_t s = room_of_[i];
    if (s < 0 || room_ids_[s] == sg::kNoNode) {
      ++r->places_unassigned;
      continue;
    }
    if (graph->parent(place_ids_[i]) != sg::kNoNode) {  // another writer's room owns it
      ++r->places_unassigned;
      continue;
    }
    if (add_edge(graph, room_ids_[s], place_ids_[i], r)) ++r->places_assigned;
    else ++r->places_unassigned;
  }
  std::size_t n = 0;
  for (std::size_t e = 0; e < num_edges_; ++e) {
    const std::int32_t a = room_of_[edges_[e].a], b = room_of_[edges_[e].b];
    if (a < 0 || b < 0 || a == b) continue;
    const std::uint64_t lo = static_cast<std::uint64_t>(std::min(a, b)), hi = static_cast<std::uint64_t>(std::max(a, b));
    pairs_[n++] = (lo << 32) | hi;
  }
  std::sort(pairs_, pairs_ + n);
  n = static_cast<std::size_t>(std::unique(pairs_, pairs_ + n) - pairs_);
  for (std::size_t k = 0; k < n; ++k) {
    const sg::NodeId a = room_ids_[pairs_[k] >> 32], b = room_ids_[pairs_[k] & 0xffffffffu];
    if (a == sg::kNoNode || b == sg::kNoNode) continue;
    if (add_edge(graph, a, b, r)) ++r->room_edges;
  }
  if (have_building)
    for (std::size_t s = 0; s < num_rooms; ++s)
      if (room_ids_[s] != sg::kNoNode) add_edge(graph, building_id_, room_ids_[s], r);

  // Remember this update's rooms for the next one's ids.
  previous_.clear();
  for (std::uint32_t i = 0; i < num_places_; ++i)
    if (room_of_[i] >= 0 && room_ids_[room_of_[i]] != sg::kNoNode)
      previous_.insert(place_ids_[i], static_cast<std::uint32_t>(room_of_[i]));
  std::copy(room_ids_, room_ids_ + num_rooms, previous_ids_);
  num_previous_ = num_rooms;
  num_rooms_ = 0;
  for (std::size_t s = 0; s < num_rooms; ++s)
    if (room_ids_[s] != sg::kNoNode) room_ids_[num_rooms_++] = room_ids_[s];
  r->rooms = num_rooms_;
}

}  // namespace qsg::rooms
