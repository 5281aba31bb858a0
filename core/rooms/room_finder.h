// Layers 4-5: rooms by persistent homology over the places graph (the paper's "Room Clustering via Persistent
// Homology"), flood fill of the remaining places, room and building nodes written into the scene graph; our
// refinements run between the flood fill and the writing, in the order core/rooms/refine/refine.h gives them.
//
// One update reads every place node (clearance distance_m) and place-place edge (weight = clearance along the
// edge; 0 or less: a passage a door stage closed, see Config::seed_closed_regions) from the graph, computes the
// Betti-0 curve of the clearance filtration over [d-, d+] in one union-find pass (filtration.cc), seeds rooms
// (the paper's alpha plateau rule, or our persistence rule: seeding.cc), assigns the other places by a flood fill
// that expands the edge of largest clearance first, refines the partition (refine/), and replaces the rooms of the
// previous update (ids kept where a new room overlaps an old one most: room_writer.cc). Works on the 3D graph: no
// floor slicing. Places and edges are read in the order of their ids, so the rooms depend on the graph's content
// only (a graph saved and read back gives the same rooms). Every store is carved once from one arena at init();
// update() never allocates.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

#include "core/memory/arena.h"
#include "core/memory/fixed_hash_map.h"
#include "core/memory/resource_stats.h"
#include "core/rooms/config.h"
#include "core/rooms/door_cues.h"
#include "core/rooms/partition.h"
#include "core/rooms/refine/refine.h"
#include "core/scene_graph/node_id.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::rooms {

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
  std::size_t closed_edges = 0;      // place edges read as closed (weight <= 0, or closed by `doors`)
  std::size_t closed_region_rooms = 0;  // seed_closed_regions: rooms seeded by a closed-off region
  std::size_t corridor_merges = 0;   // merge_corridors: rooms merged into an adjacent corridor piece
  std::size_t visible_merges = 0;    // merge_visible: rooms merged into an adjacent room they see
  std::size_t visible_pairs = 0;     // merge_visible: adjacent room pairs whose sight lines were tested (all rounds)
  std::size_t visible_near_merges = 0;  // merge_visible: of visible_merges, those by the lines near the boundary
  std::size_t visible_touching_pairs = 0;    // merge_visible: place pairs in two rooms, touching and in sight
  std::size_t visible_touching_dropped = 0;  // ... beyond the finder's room for them (Capacities::places); 1 when
                                             // the map was too large in cells to look through (none found)
  std::size_t edges_through_walls = 0;  // close_edges_through_walls: open edges read as closed (in closed_edges too)
  bool window = false;                  // read the window only (Config::window_updates)
  std::size_t rooms_open = 0;           // window: rooms holding an active place (replaced by this update)
  std::size_t boundary_edges = 0;       // window: place edges from the window to a kept room's places
  std::size_t rooms_partial = 0;        // window: open rooms read only near the window (Config::window_room_margin_m)
  std::size_t places_kept = 0;          // ... their places not read (they keep their room)
  std::size_t places_visited = 0;       // window: place records looked at to choose the window (the open places,
                                        // the closed places in the grid cells near them): the window's size
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

  // Recomputes the rooms and the building from the graph's places. A place edge that `doors` closes is read as
  // closed, as an edge of weight <= 0 is (the online door stage's doors; the final stage writes weights instead).
  // With `sight` (the final door stage's sight lines, or the online door window's), a place edge through a long
  // wall is read as closed too (Config::close_edges_through_walls), and with whole-map sight lines rooms that see
  // each other are merged last (Config::merge_visible). Never allocates.
  // window (with Config::window_updates): reads and replaces only the window's rooms (core/rooms/window.cc).
  UpdateResult update(scene_graph::SceneGraph* graph, std::uint64_t time_ns = 0, const ClosedPassages* doors = nullptr,
                      const SightLines* sight = nullptr, bool window = false);

  // The Betti curve of the last update: value i at dilation_at(i) (ascending), curve_size() samples.
  std::size_t curve_size() const { return curve_size_; }
  double dilation_at(std::size_t i) const {
    return config_.min_dilation_m + static_cast<double>(i) * config_.dilation_step_m;
  }
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
    fn(room_slot_.stats());
  }

  struct Match {  // a new room's places in a previous room
    std::uint32_t count;
    std::uint32_t room;      // slot of this update
    std::uint32_t previous;  // slot of the previous update
  };
  struct RoomAccumulator {
    double sum[3];
    double min[3];
    double max[3];
    std::uint32_t count;
    bool active;
    void reset();
    void add(const double* position, double radius);  // a place and its free-space sphere
    void add(const RoomAccumulator& other);           // another part of the same room
  };

 private:
  // room_finder.cc: reading the places graph.
  void read_places(scene_graph::SceneGraph* graph, const ClosedPassages* doors, const SightLines* sight,
                   UpdateResult* r);
  // window.cc: the window's places and open rooms; rooms matched by the graph's room-place edges.
  void collect_window(scene_graph::SceneGraph* graph, UpdateResult* r);
  void collect_all_rooms(const scene_graph::SceneGraph& graph);
  void note_boundary(const scene_graph::SceneGraph& g, std::uint32_t place, scene_graph::NodeId other, UpdateResult* r);
  bool previous_room_of(const scene_graph::SceneGraph& graph, std::uint32_t place, std::uint32_t* previous) const;
  void finish_window(scene_graph::SceneGraph* graph, std::uint64_t time_ns, UpdateResult* r);
  bool partial_slot(scene_graph::NodeId room, std::uint32_t* slot) const;
  void detach_partial(scene_graph::SceneGraph* graph);
  void keep_far_part(scene_graph::SceneGraph* graph, std::uint32_t slot);
  UpdateResult window_without_rooms(scene_graph::SceneGraph* graph, std::uint64_t time_ns, UpdateResult r);
  void build_adjacency();
  // filtration.cc: the paper's filtration, Betti curve and plateau seeds.
  void compute_curve();
  std::size_t seed_rooms(double dilation_m, UpdateResult* r);
  // seeding.cc: our seeds (persistence, closed-off regions).
  std::size_t seed_by_persistence(UpdateResult* r);
  std::size_t seed_closed_regions(std::size_t seeds, UpdateResult* r);
  void emit_seed(std::uint32_t root, std::size_t* seeds, UpdateResult* r);
  // room_writer.cc: room ids, nodes and edges, the building.
  void assign_ids(const scene_graph::SceneGraph& graph, std::size_t num_rooms, UpdateResult* r);
  void write_rooms(scene_graph::SceneGraph* graph, std::size_t num_rooms, std::uint64_t time_ns, UpdateResult* r);
  void accumulate_rooms(std::size_t num_rooms);
  std::size_t write_room_nodes(scene_graph::SceneGraph* graph, std::size_t num_rooms, std::uint64_t time_ns,
                               Eigen::Vector3d* centroid_sum, UpdateResult* r);
  bool write_building(scene_graph::SceneGraph* graph, std::size_t written, const Eigen::Vector3d& centroid_sum,
                      std::uint64_t time_ns, UpdateResult* r);
  void write_edges(scene_graph::SceneGraph* graph, std::size_t num_rooms, bool have_building, UpdateResult* r);
  void remove_previous(scene_graph::SceneGraph* graph, bool keep_taken, UpdateResult* r);
  bool edge_fits(scene_graph::SceneGraph* graph, scene_graph::NodeId a, scene_graph::NodeId b);
  bool add_edge(scene_graph::SceneGraph* graph, scene_graph::NodeId a, scene_graph::NodeId b, UpdateResult* r);
  UpdateResult no_rooms(scene_graph::SceneGraph* graph, Outcome outcome, UpdateResult r);

  Eigen::Vector3d place_position(std::uint32_t i) const {
    return Eigen::Vector3d(position_[3 * i], position_[3 * i + 1], position_[3 * i + 2]);
  }
  PlacesGraph places() const;

  Config config_;
  Capacities capacities_;
  Counters counters_;
  memory::Arena arena_;
  memory::FixedHashMap<scene_graph::NodeId, std::uint32_t, memory::U64Hash> index_{"rooms.place_index"};
  // Place -> slot of its room in the previous update (for stable room ids).
  memory::FixedHashMap<scene_graph::NodeId, std::uint32_t, memory::U64Hash> previous_{"rooms.previous_rooms"};
  // Config::window_updates: room id -> its slot among this update's previous rooms (the open ones, or all).
  memory::FixedHashMap<scene_graph::NodeId, std::uint32_t, memory::U64Hash> room_slot_{"rooms.window_rooms"};
  // A place edge from window place `place` to a place of kept (or partial) room `room`.
  struct Boundary { std::uint32_t place; scene_graph::NodeId room; };
  Boundary* boundary_ = nullptr;  // capacity: capacities_.places
  RoomAccumulator* far_ = nullptr;  // per open room (room_slot_), its places not read (count 0: none); rooms
  std::int64_t* far_units_ = nullptr;  // ... their position sums in the graph's fixed point (3 per room)
  std::size_t num_boundary_ = 0;
  bool window_ = false;  // this update reads the window only

  // Places of this update (local index i < num_places_).
  scene_graph::NodeId* place_ids_ = nullptr;
  double* clearance_ = nullptr;
  double* position_ = nullptr;  // x, y, z per place
  std::uint8_t* active_ = nullptr;
  std::size_t num_places_ = 0;
  PlaceEdge* edges_ = nullptr;
  std::size_t num_edges_ = 0;
  std::uint32_t* adjacency_offset_ = nullptr;  // CSR: place i's edges are adjacency_[offset[i], offset[i + 1])
  std::uint32_t* adjacency_ = nullptr;         // edge indices
  std::int32_t* room_of_ = nullptr;            // per place: room slot of this update, or -1
  Workspace ws_;                               // scratch shared with the refinement passes
  refine::Refinements refine_;
  Match* matches_ = nullptr;
  std::uint32_t* curve_ = nullptr;
  std::size_t curve_size_ = 0;

  // Rooms: this update's (slot -> id, accumulated places) and the previous update's ids.
  scene_graph::NodeId* room_ids_ = nullptr;
  RoomAccumulator* room_acc_ = nullptr;
  scene_graph::NodeId* previous_ids_ = nullptr;
  std::uint8_t* previous_taken_ = nullptr;
  scene_graph::RoomAttributes* saved_ = nullptr;  // attributes of kept rooms while they are re-added
  std::uint8_t* saved_valid_ = nullptr;           // 1: saved_ holds them; 2: ... and the node stays (a partial room)
  std::size_t num_rooms_ = 0;
  std::size_t num_previous_ = 0;
  std::uint64_t next_room_index_ = 0;
  scene_graph::NodeId building_id_ = scene_graph::kNoNode;
  std::size_t free_chunks_ = 0;                // the graph's free adjacency chunks while writing
  bool building_written_ = false;
  bool ready_ = false;
};

}  // namespace qsg::rooms
