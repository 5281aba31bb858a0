// Layer 4-5 geometry: rooms found by persistent homology over the places graph (the paper's "Room Clustering via
// Persistent Homology"), flood fill of the remaining places, room and building nodes written into the scene graph.
//
// One update reads every place node (clearance distance_m) and place-place edge (weight = clearance along the
// edge; 0 or less: a passage a door stage closed, see Config::seed_closed_regions) from the graph, computes the
// Betti-0 curve of the clearance filtration over [d-, d+] in one union-find pass, picks the dilation by the paper's
// alpha plateau rule, seeds rooms with the components at that dilation, assigns the other places by a flood fill
// that expands the edge of largest clearance first, and replaces the rooms of the previous update (ids kept where a
// new room overlaps an old one most). Works on the 3D graph: no floor slicing. Places and edges are read in the
// order of their ids, so the rooms depend on the graph's content only (a graph saved and read back gives the same
// rooms). Every store is carved once from one arena at init(); update() never allocates.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>

#include "core/memory/arena.h"
#include "core/memory/fixed_hash_map.h"
#include "core/memory/resource_stats.h"
#include "core/rooms/door_detector.h"
#include "core/rooms/wall_sight.h"
#include "core/scene_graph/node_id.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::rooms {

// How seed components are chosen from the clearance filtration.
enum class Seeding : std::uint8_t {
  // The paper: one dilation delta* for the whole graph by the alpha plateau rule on the Betti-0 curve; the
  // components alive at delta* (of at least min_component_size places) are the seeds.
  kPlateau,
  // Per component, on the filtration's merge tree: sweeping the dilation down from d+, when two components meet
  // and each is at least min_component_size places and has persisted at least min_persistence_m (its largest
  // clearance minus the clearance where they meet), both become seeds with the places they hold at that moment.
  // Each room is cut at its own door's clearance, so a small room need not share delta* with a large hall.
  kPersistence,
};
const char* to_string(Seeding seeding);

// Defaults: persistence seeding with 8 places and 0.4 m, chosen on the IPA floor plans and generated buildings
// (bench/rooms/rooms_eval; the paper's setting is kPlateau with 15 places, see paper()).
struct Config {
  Seeding seeding = Seeding::kPersistence;
  double min_persistence_m = 0.4;  // kPersistence: smallest (birth - merge) clearance gap of a seed component
  // kPersistence: components meeting through a wider passage (clearance above this, i.e. an opening wider than
  // twice it) are one room whatever their persistence. Infinity: no limit.
  double max_door_clearance_m = std::numeric_limits<double>::infinity();
  double min_dilation_m = 0.5;   // d-: smallest dilation (clearance) of the filtration
  double max_dilation_m = 1.2;   // d+: largest dilation
  double dilation_step_m = 0.01; // the Betti curve is sampled every step over [d-, d+]
  // Places; smaller components are not counted (and seed no room). The paper uses 15 with its sparser places;
  // ours are denser, about 3.3-3.9 per m^2 of floor (up to three 1 m cells between floor and ceiling). 6 since the
  // places' seeds come from zero crossings (fewer spurious sheets near floors): 8 then lost small rooms
  // (bench/results/rooms.md, "min_component_size").
  std::uint32_t min_component_size = 6;
  // The paper's alpha: only flat intervals longer than alpha x the longest one are candidates; among them the one
  // with the most components wins. 0 over-segments, 1 picks the most persistent interval.
  double plateau_alpha = 0.5;
  // Extent split: the places' clearance is capped near half the storey height by floor and ceiling, so every
  // space wider than about 2.5 m looks alike to the filtration above, and a room that meets a corridor through a
  // wide opening (no constriction) merges with it. After the flood fill, each place whose clearance is at least
  // extent_saturation_m (bounded by floor and ceiling rather than walls) gets an extended clearance: its clearance
  // plus its horizontal graph distance to the nearest place below that clearance, a horizontal distance to the
  // walls inside the saturated sheet. Each room is then seeded again on the extended clearance over
  // [split_min_extent_m, split_max_extent_m] with the persistence rule (split_min_persistence_m,
  // split_min_component_size) through its own edges only; a room with two or more seeds is split and its other
  // places flood-filled among them, again through its own edges. Rooms are never merged by it. On by default: it
  // trades recall (long corridors of varying width are cut too) for far fewer rooms merged with their corridor, and
  // a merged room is the costlier error downstream (one label for two rooms); bench/results/rooms.md.
  bool split_by_extent = true;
  // Closed passages: a place-place edge of weight 0 or less is a passage a door stage closed (rooms::cut_place_edges,
  // doors found on the robot's surface). The filtration never crosses it (its clearance is 0, below d-), and with
  // this on, every piece of the places graph that the closed edges cut off and that holds no seed (at least
  // min_component_size places) is a room of its own: a corridor narrower than d- whose doors were all found, say,
  // which the flood fill would otherwise hand to the rooms on its doors. Without closed edges it does nothing.
  bool seed_closed_regions = true;
  // Corridor merge, after the split: a corridor is the space that connects many rooms, and the seeding cuts it
  // into pieces wherever it widens or narrows, a loss of recall that no door cue recovers (it has no door there).
  // Two adjacent rooms that both touch at least corridor_min_neighbours other rooms (through any place edge, open
  // or closed by a door stage) and meet through at least corridor_min_open_edges open place edges (a wide
  // opening, not a door) are one room; pairs are merged most open edges first, the neighbour counts taken again
  // after each merge. A room off a corridor touches one or two rooms, so it is left alone. It raises the IPA
  // plans' recall at the same precision; the settings were chosen there (bench/results/rooms.md).
  bool merge_corridors = true;
  std::uint32_t corridor_min_neighbours = 3;
  std::uint32_t corridor_min_open_edges = 20;
  // With sight lines, a place edge that crosses a long wall (WallSight::crosses_structure) is read as closed, as a
  // door's is: an edge the places layer left through a wall is no passage. The final door stage also writes weight
  // 0 on such edges (DoorConfig::sight_cut_edges, for the saved graph); during a run the room finder reads them
  // through the online door window's sight lines (OnlineDoors::sight), as it reads the online doors.
  bool close_edges_through_walls = true;
  // Visibility merge, last, when the update is given sight lines (a WallSight: the final door stage's slices, or
  // during a run the online door window's; furniture left out): two adjacent rooms (any place edge between them,
  // open or closed) whose places see each other past every structural wall are one room that furniture or a false
  // door cut in two. Up to visible_samples places of each room (spread evenly over its places in id order) are
  // paired with as many of the other's; the pair is merged when at least visible_min_share of those sight lines are
  // clear. Pairs merge clearest first, each room once a round, for at most visible_max_rounds rounds (rooms and
  // their samples taken again each round). A door between two rooms is in a wall, so few of their sight lines are
  // clear. Together with the closing of edges through walls (DoorConfig::sight_cut_edges) it raises recall on the
  // furnished plans without losing precision; either alone does not (bench/results/rooms.md, "merge_visible").
  bool merge_visible = true;
  // ... also with a window's sight lines (the online door window's, during a run). Off: during a run the merge
  // lowered precision (bench/results/rooms.md); edges through walls are still closed there.
  bool merge_visible_in_window = false;
  double visible_min_share = 0.8;
  std::uint32_t visible_samples = 12;  // at most kMaxVisibleSamples
  std::uint32_t visible_max_rounds = 32;
  static constexpr std::uint32_t kMaxVisibleSamples = 32;
  // ... or, when the whole rooms' sight lines fall short (an L-shaped room, a bend, a cabinet row that joins a
  // wall and hides one end from the other), by their sight lines near the boundary: each room's places within
  // visible_local_radius_m (in plan) of the other room's ends of the place edges between them, sampled as above;
  // at least visible_local_min_places on each side, and at least visible_local_min_share of those lines clear.
  // Such pairs merge after the pairs that qualify as whole rooms. 0: off. 2.25 m raises the furnished plans'
  // recall most while their precision stays above 0.95 (bench/results/rooms.md, "visible_local_radius_m").
  double visible_local_radius_m = 2.25;
  double visible_local_min_share = 0.8;
  std::uint32_t visible_local_min_places = 3;
  // Rooms are adjacent for the merge also where the free-space spheres of a place of each touch (the distance
  // between them below the sum of their clearances) and the two see each other (one slice, no structure between),
  // with no place edge between them: the places graph follows the free space's skeleton, so two pieces of one room
  // on either side of a desk, or round a cabinet, can share open floor with no edge. Such pairs are found once per
  // update (at most Capacities::places of them; more are counted in UpdateResult::visible_touching_dropped) and
  // count as the boundary's ends for the test near it too. A small gain on the IPA plans, none lost elsewhere; a
  // fixed plan radius instead was not monotonic in the radius, the sphere test has no such parameter
  // (bench/results/rooms.md, "visible_touching").
  bool visible_touching = true;
  // ... a sphere counting at most this radius there (it sizes the search's cells: one huge clearance must not make
  // the search quadratic in the places). 1.5 to 8 m give the same rooms on the benchmark's graphs.
  double visible_touch_max_clearance_m = 4.0;
  double extent_saturation_m = 1.0;
  double split_min_extent_m = 1.0;
  double split_max_extent_m = 2.5;
  double split_min_persistence_m = 0.5;
  std::uint32_t split_min_component_size = 6;
  // A room's bounding box spans its places' free-space spheres (position +- clearance), i.e. the room's free
  // space, as the room boxes the room classifier was trained on do; off, only the place positions (the GVD, a
  // clearance inside the walls).
  bool box_from_free_space = true;
  std::uint64_t building_index = 0;  // the building node is make_node_id('B', building_index)

  static Config paper();              // the paper's method and numbers: kPlateau, 15 places, alpha 0.5, no split
  std::size_t curve_samples() const;  // samples of the Betti curve (d-, d- + step, ..., d+)
  std::string check() const;          // empty when usable, else the bad field and why
  void print(std::FILE* out) const;
};

// Fixed sizes of the finder's stores: the scene graph's capacities (from_scene_graph), or a test's own.
struct Capacities {
  std::size_t places = 0;       // place nodes read per update (more are ignored and counted)
  std::size_t place_edges = 0;  // place-place edges read per update (more are ignored and counted)
  std::size_t rooms = 0;        // rooms per update (more seeds are dropped, smallest first, and counted)
  static Capacities from_scene_graph(const scene_graph::Capacities& graph);
  std::string check() const;
  void print(std::FILE* out) const;
};

// What one update did; outcome says whether rooms were written.
enum class Outcome : std::uint8_t {
  kOk,
  kNotInitialized,  // init() has not succeeded
  kNoGraph,         // null or uninitialized scene graph
  kNoPlaces,        // the graph holds no place node: previous rooms and the building are removed
  kNoRooms,         // no component reached the minimum size at any dilation: previous rooms are removed
};
const char* to_string(Outcome outcome);

struct UpdateResult {
  Outcome outcome = Outcome::kNotInitialized;
  std::size_t places = 0;            // read
  std::size_t place_edges = 0;       // read
  std::size_t rooms = 0;             // written
  std::size_t seeds = 0;             // seed components found (kPersistence: emitted from the merge tree)
  std::size_t room_edges = 0;        // room-room edges written
  std::size_t places_assigned = 0;   // places that got a room parent
  std::size_t places_unassigned = 0; // in a component of the places graph without a seed, or refused
  std::size_t seeded_places = 0;     // places in the seed components
  std::size_t rooms_kept = 0;        // rooms that kept the id of a previous room
  std::size_t rooms_removed = 0;     // previous rooms that no new room took over
  double dilation_m = 0.0;           // the chosen delta*
  std::uint32_t betti_at_dilation = 0;
  std::size_t truncated = 0;         // places or edges beyond the finder's capacities (ignored)
  std::size_t refused = 0;           // nodes or edges the scene graph had no room for
  std::size_t seeds_dropped = 0;     // seed components beyond the room capacity
  std::size_t rooms_split = 0;       // split_by_extent: rooms split in two or more
  std::size_t split_rooms_added = 0; // split_by_extent: rooms those splits added (beyond capacity: not added)
  std::size_t closed_edges = 0;      // place edges read as closed (weight <= 0, or a DoorSet door)
  std::size_t closed_region_rooms = 0;  // seed_closed_regions: rooms seeded by a closed-off region
  std::size_t corridor_merges = 0;   // merge_corridors: rooms merged into an adjacent corridor piece
  std::size_t visible_merges = 0;    // merge_visible: rooms merged into an adjacent room they see
  std::size_t visible_pairs = 0;     // merge_visible: adjacent room pairs whose sight lines were tested (all rounds)
  std::size_t visible_near_merges = 0;  // merge_visible: of visible_merges, those by the lines near the boundary
  std::size_t visible_touching_pairs = 0;    // merge_visible: place pairs in two rooms, touching and in sight
  std::size_t visible_touching_dropped = 0;  // ... beyond the finder's room for them (Capacities::places); 1 when
                                             // the map was too large in cells to look through (none found)
  std::size_t edges_through_walls = 0;  // close_edges_through_walls: open edges read as closed (in closed_edges too)
};

struct Counters {
  std::uint64_t updates = 0;
  std::uint64_t no_places = 0;
  std::uint64_t no_rooms = 0;
  std::uint64_t truncated = 0;      // places or edges ignored for capacity, all updates together
  std::uint64_t graph_refused = 0;  // scene-graph nodes or edges refused, all updates together
  std::uint64_t seeds_dropped = 0;
  std::uint64_t rooms_created = 0;  // fresh room ids
  std::uint64_t rooms_removed = 0;
  void print(std::FILE* out) const;
};

// The paper's plateau rule on a sampled Betti curve (betti[i] at d- + i x step, ascending): flat runs of equal
// values of non-zero count are the intervals; among those longer than alpha x the longest (all when alpha is 0,
// only the longest when it is 1), the one with the most components wins (ties: the longer, then the
// smaller dilation). Returns the index of the run's first sample (its d_min), or -1 when every sample is 0.
int choose_plateau(const std::uint32_t* betti, std::size_t samples, double alpha);

class RoomFinder {
 public:
  RoomFinder();
  RoomFinder(const RoomFinder&) = delete;
  RoomFinder& operator=(const RoomFinder&) = delete;
  ~RoomFinder();

  static memory::ArenaPlan plan(const Config& config, const Capacities& capacities);
  // Checks config and capacities and carves every store from one arena of at most budget_bytes (0: exactly the
  // plan). Start-up only; false with the bad field in *error.
  bool init(const Config& config, const Capacities& capacities, std::size_t budget_bytes, std::string* error);
  bool initialized() const { return ready_; }

  // Recomputes the rooms and the building from the graph's places. A place edge that one of `doors` closes
  // (door_closes_edge) is read as closed, as an edge of weight <= 0 is (the online door stage's doors; the final
  // stage writes weights instead). With `sight` (the final door stage's WallSight, or the online door window's), a
  // place edge through a long wall is read as closed too (Config::close_edges_through_walls) and rooms that see each
  // other are merged last (Config::merge_visible). Never allocates.
  UpdateResult update(scene_graph::SceneGraph* graph, std::uint64_t time_ns = 0, const DoorSet* doors = nullptr,
                      const WallSight* sight = nullptr);

  // The Betti curve of the last update: value i at dilation_at(i) (ascending), curve_size() samples.
  std::size_t curve_size() const { return curve_size_; }
  double dilation_at(std::size_t i) const { return config_.min_dilation_m + static_cast<double>(i) * config_.dilation_step_m; }
  std::uint32_t betti_at(std::size_t i) const { return curve_[i]; }
  const std::uint32_t* betti_curve() const { return curve_; }

  // The rooms of the last update (ids in the scene graph) and the building (kNoNode when there is none).
  std::size_t num_rooms() const { return num_rooms_; }
  scene_graph::NodeId room_id(std::size_t i) const { return room_ids_[i]; }
  scene_graph::NodeId building_id() const { return building_written_ ? building_id_ : scene_graph::kNoNode; }

  const Config& config() const { return config_; }
  const Capacities& capacities() const { return capacities_; }
  const Counters& counters() const { return counters_; }
  template <typename Fn>
  void for_each_resource(Fn&& fn) const {  // fn(const memory::ResourceStats&)
    fn(arena_.stats());
    fn(index_.stats());
    fn(previous_.stats());
  }

  struct Edge;
  struct HeapEntry;
  struct Match;
  struct RoomAccumulator;

 private:
  bool read_places(const scene_graph::SceneGraph& graph, const DoorSet* doors, const WallSight* sight,
                   UpdateResult* r);
  void compute_curve();
  std::size_t seed_rooms(double dilation_m, UpdateResult* r);
  std::size_t seed_by_persistence(UpdateResult* r);
  std::size_t seed_closed_regions(std::size_t seeds, UpdateResult* r);
  void emit_seed(std::uint32_t root, std::size_t* seeds, UpdateResult* r);
  void join(std::uint32_t ra, std::uint32_t rb, std::uint8_t split);
  template <typename Fn>
  void for_each_place_edge(std::uint32_t i, Fn&& fn) const;
  template <typename Value, typename MayEnter>
  void fill(Value value, MayEnter may_enter);
  void flood_fill();
  void compute_extent();
  std::size_t split_by_extent(std::size_t num_rooms, UpdateResult* r);
  std::size_t merge_corridors(std::size_t num_rooms, UpdateResult* r);
  std::size_t merge_visible(std::size_t num_rooms, const WallSight& sight, UpdateResult* r);
  // merge_visible's test near the boundary of rooms a and b: the share of clear sight lines (0..share_scale), or 0
  // with too few places near it.
  std::uint64_t near_boundary_share(std::uint32_t a, std::uint32_t b, const WallSight& sight,
                                    std::uint64_t share_scale);
  // merge_visible's pairs of places in different rooms whose spheres touch and that see each other
  // (touching_pairs_), found once before its rounds (Config::visible_touching).
  void find_touching_pairs(const WallSight& sight, UpdateResult* r);
  std::size_t renumber_merged_rooms(std::size_t num_rooms);
  Eigen::Vector3d place_position(std::uint32_t i) const {
    return Eigen::Vector3d(position_[3 * i], position_[3 * i + 1], position_[3 * i + 2]);
  }
  std::uint32_t find_room(std::uint32_t slot);
  void assign_ids(const scene_graph::SceneGraph& graph, std::size_t num_rooms, UpdateResult* r);
  void write_rooms(scene_graph::SceneGraph* graph, std::size_t num_rooms, std::uint64_t time_ns, UpdateResult* r);
  void remove_previous(scene_graph::SceneGraph* graph, bool keep_taken, UpdateResult* r);
  bool edge_fits(scene_graph::SceneGraph* graph, scene_graph::NodeId a, scene_graph::NodeId b);
  bool add_edge(scene_graph::SceneGraph* graph, scene_graph::NodeId a, scene_graph::NodeId b, UpdateResult* r);
  std::uint32_t find(std::uint32_t i);
  void heap_push(const HeapEntry& e);
  HeapEntry heap_pop();

  Config config_;
  Capacities capacities_;
  Counters counters_;
  memory::Arena arena_;
  memory::FixedHashMap<scene_graph::NodeId, std::uint32_t, memory::U64Hash> index_{"rooms.place_index"};
  // Place -> slot of its room in the previous update (for stable room ids).
  memory::FixedHashMap<scene_graph::NodeId, std::uint32_t, memory::U64Hash> previous_{"rooms.previous_rooms"};

  // Places of this update (local index i < num_places_).
  scene_graph::NodeId* place_ids_ = nullptr;
  double* clearance_ = nullptr;
  double* position_ = nullptr;  // x, y, z per place
  std::uint8_t* active_ = nullptr;
  std::size_t num_places_ = 0;
  Edge* edges_ = nullptr;
  std::size_t num_edges_ = 0;
  std::uint32_t* adjacency_offset_ = nullptr;  // CSR: place i's edges are adjacency_[offset[i], offset[i + 1])
  std::uint32_t* adjacency_ = nullptr;         // edge indices
  std::uint32_t* order_ = nullptr;             // scratch: sort orders
  std::uint32_t* parent_ = nullptr;            // union-find
  std::uint32_t* size_ = nullptr;
  std::int32_t* room_of_ = nullptr;            // per place: room slot of this update, or -1
  HeapEntry* heap_ = nullptr;
  std::size_t heap_size_ = 0;
  std::size_t heap_capacity_ = 0;
  std::uint64_t* pairs_ = nullptr;             // scratch: (a, b) keys for matching and room-room edges
  Match* matches_ = nullptr;
  std::uint32_t* curve_ = nullptr;
  std::size_t curve_size_ = 0;
  // kPersistence merge tree, per union-find root: largest clearance, member list (next / tail), holds seeds.
  double* birth_ = nullptr;
  std::uint32_t* member_next_ = nullptr;
  std::uint32_t* member_tail_ = nullptr;
  std::uint8_t* split_ = nullptr;
  double* extent_ = nullptr;                   // split_by_extent: extended clearance per place
  std::uint32_t* sub_seeds_ = nullptr;         // split_by_extent: per seed, its room, then its slot
  std::uint32_t* room_seeds_ = nullptr;        // split_by_extent: per room slot, its seeds and flags
  std::uint32_t* room_parent_ = nullptr;       // merge_corridors: union-find over room slots
  std::uint32_t* room_neighbours_ = nullptr;   // merge_corridors: rooms each room touches; then the new slots
  std::uint32_t* sight_samples_ = nullptr;     // merge_visible: per room slot, kMaxVisibleSamples place indices
  std::uint32_t* room_count_ = nullptr;        // merge_visible: per room slot, its places; then sampled so far
  std::uint32_t* near_list_ = nullptr;         // merge_visible: 2 x places: a pair's boundary ends, then near places
  std::uint8_t* near_mark_ = nullptr;          // merge_visible: per place, a boundary end already listed
  std::uint64_t* touching_pairs_ = nullptr;    // find_touching_pairs: (a << 32) | b place indices, a < b
  std::size_t num_touching_pairs_ = 0;

  // Rooms: this update's (slot -> id, accumulated places) and the previous update's ids.
  scene_graph::NodeId* room_ids_ = nullptr;
  RoomAccumulator* room_acc_ = nullptr;
  std::uint32_t* root_room_ = nullptr;         // per place root: seed slot, or kNone
  scene_graph::NodeId* previous_ids_ = nullptr;
  std::uint8_t* previous_taken_ = nullptr;
  scene_graph::RoomAttributes* saved_ = nullptr;  // attributes of kept rooms while they are re-added
  std::uint8_t* saved_valid_ = nullptr;
  std::size_t num_rooms_ = 0;
  std::size_t num_previous_ = 0;
  std::uint64_t next_room_index_ = 0;
  scene_graph::NodeId building_id_ = scene_graph::kNoNode;
  std::size_t free_chunks_ = 0;                // the graph's free adjacency chunks while writing
  bool building_written_ = false;
  bool ready_ = false;
};

}  // namespace qsg::rooms
