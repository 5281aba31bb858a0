// Doors and openings from the robot's own surface: the cue that separates a room from its corridor where the
// places' clearance cannot (a corridor about as wide as its doors, a wide opening under the storey's clearance cap).
//
// One horizontal slice of the reconstructed surface at a given height becomes a wall raster: a cell is wall when
// the surface inside it spans at least min_wall_height_m vertically within the slice's band, so floors and ceilings
// (flat, one layer) do not count and walls, jambs and furniture sides do. The free space is the non-wall cells
// near the places (the space the robot mapped). Its Euclidean distance transform and medial axis (Zhang-Suen
// thinning) give the classical critical points of a free-space Voronoi diagram (Thrun's "critical lines"): a
// medial-axis cell whose clearance is a local minimum along the axis, whose two nearest walls lie on opposite sides
// (the jambs), and from which the clearance rises by at least min_rise_m within rise_reach_m on both sides of the
// jamb-to-jamb line. That line is the door. Place-place edges that cross a door (in plan, and within max_dz_m of the
// slice) are the ones a room should not grow through; cut_place_edges() gives them weight 0, which the room finder
// reads as a closed passage.
//
// Slices: one per storey the robot walked on (the modes of its poses' heights), slice_above_robot_m above the
// robot's height there: with the camera 0.5 m above the floor, 1.2 m above the floor, above most furniture and
// below the lintels. find_doors() reads the places and the robot's poses (agent nodes) from the scene graph and
// runs every slice.
//
// Two ways to run it. Offline (find_doors, detect_doors): heap buffers sized by the slice, on the final surface (the
// app when a run finishes; bench/rooms/rooms_eval once per explored plan). Online (core/doors/online_doors.h): the
// same detection (detect_doors_in_raster) on a fixed window around the robot, in buffers carved at start-up, so a
// backend update can see doors without allocating. A DoorSet holds doors for the room finder, which reads an edge
// that crosses one as closed, exactly as cut_place_edges marks it.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "budgets/budget_table.h"
#include "core/memory/arena.h"
#include "core/memory/resource_stats.h"
#include "core/rooms/door_cues.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::rooms {

class WallSight;  // core/doors/wall_sight.h

struct DoorConfig {
  double cell_m = 0.05;               // raster resolution
  double slice_half_band_m = 0.4;     // surface within +-this of the slice height is read
  double min_wall_height_m = 0.3;     // vertical extent of the surface in a cell (inside the band) to be wall
  double mapped_radius_m = 2.0;       // free cells within this (in plan) of a place are mapped free space
  double place_band_m = 1.5;          // places within +-this of the slice height mark mapped space
  double min_width_m = 0.5;           // door widths (jamb to jamb) considered
  double max_width_m = 2.5;
  double min_rise_m = 0.1;            // clearance rise on both sides of the door line
  double rise_reach_m = 1.0;          // ... within this distance of it
  double max_off_centre = 0.35;       // |d1 - d2| / (d1 + d2) of the jambs' distances from the axis cell
  double suppression_m = 0.4;         // of two critical cells closer than this, the narrower stays
  // The final stage's raster size limit, about 24 bytes a cell while a slice is worked on (the workspace and the
  // surface's height range per cell): 4 Mi cells (a 100 m x 100 m storey at 0.05 m) is about 100 MB. A surface
  // beyond it (or a stray vertex far away) is an error, not an allocation. A capacity: budgets/<board>.json.
  std::size_t max_cells = budgets::active::doors::kFinalMaxCells;
  // Storeys and slices.
  double slice_above_robot_m = 0.7;   // the slice's height above the robot's (camera's) height on a storey
  double storey_bin_m = 0.1;          // robot heights are binned this finely ...
  double storey_min_share = 0.05;     // ... and a bin holding this share of the poses, a local maximum, is a storey
  double storey_separation_m = 2.0;   // of two storeys closer than this, the one with more poses stays
  // Closing edges.
  double cut_extension_m = 0.3;       // door lines lengthened by this at both ends (into the jambs)
  double cut_max_dz_m = 1.5;          // edges whose ends lie within this of the slice's height
  // The online stage's memory (OnlineDoors, DoorSet::update_window): a kept door that a pass over its window does
  // not find again is dropped after this many such passes in a row (1: each pass replaces its window's doors), and
  // a found door whose midpoint lies within online_match_m of a kept door's on the same storey is that door, seen
  // again (its line replaces the kept one).
  int online_misses_to_drop = 2;
  double online_match_m = 0.5;
  // Bypassed doors (drop_bypassed_doors, run by find_doors): a door whose two sides the places graph joins by a
  // path of at most bypass_max_m, none of whose edges crosses the door's line lengthened by bypass_extension_m at
  // both ends, is a gap the robot can walk round inside one space (between a chair and a table, a post and a wall),
  // not a door. A real door's other side is reached only through another door. 0 turns the check off. The path
  // takes place edges no longer than bypass_max_edge_m: a walk round an obstacle in short steps, not a long edge
  // that the places layer left through a wall beside the door.
  double bypass_max_m = 3.0;
  double bypass_extension_m = 0.6;
  double bypass_max_edge_m = 1.2;
  // Places one search may settle; beyond it the door is kept (counted). A capacity: budgets/<board>.json.
  std::size_t bypass_max_places = budgets::active::doors::kBypassMaxPlaces;
  // Sight lines for the room finder's visibility merge (WallSight, built by find_doors from the same slices): the
  // slice's walls are thickened by sight_wall_dilation_m (bridging gaps up to twice it in a wall seen in pieces),
  // and a connected piece whose bounding box spans at least sight_min_wall_m (diagonal) is structure, which blocks
  // a sight line; shorter pieces are furniture, which does not.
  double sight_wall_dilation_m = 0.15;
  double sight_min_wall_m = 3.0;
  // ... unless it is a thick island: a piece spanning less than sight_furniture_max_m whose mean width (its
  // thickened area over its diagonal) exceeds sight_furniture_min_width_m is furniture too (a ring of tables, a row
  // of desks standing free in a hall; a wall, even thickened, is about 0.4-0.6 m wide, and a building's connected
  // walls span far more). 0 for sight_furniture_max_m: off. Measured on the IPA furnished plans with the local
  // sight test (RoomFinder::Config::visible_local_radius_m; bench/results/rooms.md).
  double sight_furniture_max_m = 8.0;
  double sight_furniture_min_width_m = 1.0;
  // ... and the place edges that cross such structure are closed too (cut_edges_through_walls), by the callers of
  // find_doors that build the sight lines (the app's final stage, rooms_eval).
  bool sight_cut_edges = true;
  bool validate(std::string* error) const;
};

struct Door {
  Eigen::Vector2d a = Eigen::Vector2d::Zero();  // jamb to jamb, in plan
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  double z_m = 0.0;                              // the slice's height
  double width_m() const { return (b - a).norm(); }
};

struct DoorStats {
  std::size_t slices = 0;  // find_doors: storeys sliced
  std::size_t cols = 0, rows = 0, wall_cells = 0, free_cells = 0, axis_cells = 0, candidates = 0;  // summed
  std::size_t candidates_dropped = 0;  // beyond the workspace's candidate capacity (counted, not an error)
  std::size_t doors_dropped = 0;       // beyond the output capacity
  std::size_t bypassed = 0;            // find_doors: doors dropped because the places graph goes round them
  std::size_t bypass_searches_cut = 0; // ... doors whose searches stopped short (bypass_max_places or the search
                                       // buffers) without a path: kept
  std::size_t bypass_unchecked = 0;    // ... doors kept unchecked: the bypass graph could not be allocated
};

// A slice raster: cell (c, r) covers [lo + (c, r) x cell_m, lo + (c + 1, r + 1) x cell_m); row-major, cols wide.
struct DoorRaster {
  Eigen::Vector2d lo = Eigen::Vector2d::Zero();
  int cols = 0;
  int rows = 0;
  double cell_m = 0.05;
  std::size_t cells() const { return static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows); }
  bool cell_of(double x, double y, int* c, int* r) const {
    const double fc = std::floor((x - lo.x()) / cell_m), fr = std::floor((y - lo.y()) / cell_m);
    if (!(fc >= 0.0 && fr >= 0.0 && fc < cols && fr < rows)) return false;  // also false for NaN
    *c = static_cast<int>(fc);
    *r = static_cast<int>(fr);
    return true;
  }
  Eigen::Vector2d centre_of(int c, int r) const {
    return Eigen::Vector2d(lo.x() + (c + 0.5) * cell_m, lo.y() + (r + 0.5) * cell_m);
  }
};

// The buffers one slice is worked on in, about 16 bytes a cell plus the candidates: carved from an arena (online)
// or held on the heap (offline). The caller fills wall() (1: wall, before the one-cell dilation) for the raster
// and place_cells() with the places' cells (index r x cols + c), then calls detect_doors_in_raster().
class DoorWorkspace {
 public:
  struct Capacities {
    std::size_t cells = 0;        // raster cells (cols x rows at most this)
    std::size_t max_side = 0;     // cols and rows at most this
    std::size_t places = 0;       // place cells
    std::size_t candidates = 0;   // critical cells that pass every test, before suppression
  };
  DoorWorkspace() = default;
  DoorWorkspace(const DoorWorkspace&) = delete;
  DoorWorkspace& operator=(const DoorWorkspace&) = delete;
  static memory::ArenaPlan plan(const Capacities& capacities);
  bool carve(memory::Arena& arena, const Capacities& capacities);
  bool allocate(const Capacities& capacities, std::string* error);  // its own arena (offline use)
  const Capacities& capacities() const { return capacities_; }
  std::uint8_t* wall() { return wall_; }
  std::uint32_t* place_cells() { return place_cells_; }
  // After a detection: the mapped free space (1) and the clearance (metres) of the last raster, for pictures.
  const std::uint8_t* free_space() const { return free_; }
  const float* clearance() const { return clearance_; }

  struct Candidate {
    Door door;
    double half_width = 0.0;
  };

 private:
  friend bool detect_doors_in_raster(DoorWorkspace*, const DoorRaster&, std::size_t, double, const DoorConfig&,
                                     Door*, std::size_t, std::size_t*, DoorStats*);
  Capacities capacities_;
  memory::Arena own_;                // allocate(): the workspace's own arena (offline use)
  std::uint8_t* wall_ = nullptr;
  std::uint8_t* free_ = nullptr;
  std::uint8_t* axis_ = nullptr;
  std::uint8_t* dilated_ = nullptr;  // the walls dilated by one cell: a jamb must be one
  float* clearance_ = nullptr;
  std::uint32_t* stack_ = nullptr;   // flood fill, then thinning's marks
  std::uint32_t* list_ = nullptr;    // thinning's border list
  std::uint32_t* place_cells_ = nullptr;
  double* line_f_ = nullptr;         // 1D distance transform: samples, output, parabola apexes and bounds
  double* line_d_ = nullptr;
  std::int32_t* line_v_ = nullptr;
  double* line_z_ = nullptr;
  Candidate* candidates_ = nullptr;
};

// The detection on a filled workspace (see DoorWorkspace): dilated walls, the mapped free space the place cells
// reach, its exact Euclidean distance transform and Zhang-Suen medial axis, the critical cells and their door
// lines, narrowest first with suppression. Writes at most out_capacity doors (more are counted in
// stats->doors_dropped) and their number in *num_out. Never allocates. False on a bad config or a raster beyond the
// workspace.
bool detect_doors_in_raster(DoorWorkspace* workspace, const DoorRaster& raster, std::size_t num_place_cells,
                            double slice_z_m, const DoorConfig& config, Door* out, std::size_t out_capacity,
                            std::size_t* num_out, DoorStats* stats);

// Whether the place edge a-b crosses the door in plan (its line lengthened by cut_extension_m at both ends, into
// the jambs, so that no edge squeezes past a jamb's corner) with both ends within cut_max_dz_m of the door's height.
bool door_closes_edge(const Door& door, const DoorConfig& config, const Eigen::Vector3d& a, const Eigen::Vector3d& b);

// Doors for the room finder (RoomFinder::update): a fixed store with a grid index on the doors' midpoints, so an
// edge is tested against the doors near it only. Full: add() refuses and counts.
// The doors handed to the room finder: it reads a place edge that crosses one as closed (ClosedPassages).
class DoorSet : public ClosedPassages {
 public:
  DoorSet() = default;
  DoorSet(const DoorSet&) = delete;
  DoorSet& operator=(const DoorSet&) = delete;
  static memory::ArenaPlan plan(std::size_t max_doors);
  bool carve(memory::Arena& arena, std::size_t max_doors, const DoorConfig& config);
  bool add(const Door& door);
  void clear();
  // One online pass over a window (OnlineDoors::detect). The kept doors in_scope(door) selects (the window's
  // interior on the pass's storey) are matched to the pass's doors: each found door in turn takes the kept door in
  // scope, not yet matched, whose midpoint is nearest its own within match_m; a match takes the found door's line
  // and clears its misses. A found door without a match is added. A door in scope
  // that no found door matches counts a miss and is removed at misses_to_drop misses in a row. Never allocates.
  struct WindowUpdate {
    std::size_t matched = 0;  // kept doors found again
    std::size_t added = 0;    // found doors new to the set
    std::size_t missed = 0;   // doors in scope not found, still kept
    std::size_t removed = 0;  // doors in scope dropped at misses_to_drop misses
    std::size_t refused = 0;  // found doors the full set could not take
  };
  template <typename InScope>
  WindowUpdate update_window(const Door* found, std::size_t num_found, InScope&& in_scope, double match_m,
                             int misses_to_drop);
  // Passes in a row that missed door i (0 for a door just found or added).
  int misses(std::size_t i) const { return misses_[i]; }
  // Removes every door pred(door) is true for; returns how many.
  template <typename Pred>
  std::size_t remove_if(Pred&& pred) {
    return compact([&](std::size_t i) { return pred(doors_[i]); });
  }
  bool closes(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const override;
  std::size_t size() const { return size_; }
  const Door& operator[](std::size_t i) const { return doors_[i]; }
  memory::ResourceStats stats() const { return counter_.stats(); }

 private:
  // Removes every door drop(index) is true for, keeping the others' order and misses, and re-indexes.
  template <typename DropIndex>
  std::size_t compact(DropIndex&& drop) {
    std::size_t kept = 0;
    for (std::size_t i = 0; i < size_; ++i)
      if (!drop(i)) {
        misses_[kept] = misses_[i];
        doors_[kept++] = doors_[i];
      }
    const std::size_t removed = size_ - kept;
    size_ = kept;
    counter_.set_in_use(size_);
    reindex();
    return removed;
  }
  static std::size_t buckets_for(std::size_t max_doors);
  std::size_t bucket_of(long gx, long gy) const;
  void link(std::size_t i);
  void reindex();
  DoorConfig config_;
  double grid_m_ = 2.0;
  Door* doors_ = nullptr;
  std::uint8_t* misses_ = nullptr;   // per door: passes in a row that did not find it (update_window)
  std::uint8_t* flags_ = nullptr;    // per door: update_window's scratch (in scope, matched)
  std::uint32_t* next_ = nullptr;    // per door: the next in its bucket
  std::uint32_t* head_ = nullptr;    // per bucket: the first door
  std::size_t buckets_ = 0;
  std::size_t size_ = 0;
  memory::UsageCounter counter_{"door_set", "doors", 0, memory::OverflowPolicy::kRefuse};
};

template <typename InScope>
DoorSet::WindowUpdate DoorSet::update_window(const Door* found, std::size_t num_found, InScope&& in_scope,
                                             double match_m, int misses_to_drop) {
  constexpr std::uint8_t kInScope = 1, kMatched = 2;
  WindowUpdate u;
  const std::size_t kept_before = size_;
  for (std::size_t i = 0; i < kept_before; ++i) flags_[i] = in_scope(doors_[i]) ? kInScope : 0;
  const double match2 = match_m * match_m;
  for (std::size_t k = 0; k < num_found; ++k) {
    const Door& f = found[k];
    if (!f.a.allFinite() || !f.b.allFinite() || !std::isfinite(f.z_m)) continue;
    const Eigen::Vector2d mid = 0.5 * (f.a + f.b);
    std::size_t best = kept_before;
    double best2 = match2;
    for (std::size_t i = 0; i < kept_before; ++i) {
      if (flags_[i] != kInScope) continue;  // out of scope, or matched already
      const double d2 = (0.5 * (doors_[i].a + doors_[i].b) - mid).squaredNorm();
      if (d2 <= best2) best2 = d2, best = i;
    }
    if (best < kept_before) {
      doors_[best] = f;
      misses_[best] = 0;
      flags_[best] |= kMatched;
      ++u.matched;
    } else if (add(f)) {
      ++u.added;
    } else {
      ++u.refused;
    }
  }
  const int drop_at = std::max(1, misses_to_drop);
  for (std::size_t i = 0; i < kept_before; ++i) {
    if (flags_[i] != kInScope) continue;
    if (misses_[i] < 255) ++misses_[i];
    if (misses_[i] >= drop_at) ++u.removed; else ++u.missed;
  }
  // Drops the doors in scope at drop_at misses and re-indexes (the matched doors' midpoints moved).
  compact([&](std::size_t i) { return i < kept_before && flags_[i] == kInScope && misses_[i] >= drop_at; });
  return u;
}

// The slice heights for the robot's pose heights: one per storey (see DoorConfig), ascending.
std::vector<double> door_slice_heights(const std::vector<double>& robot_z_m, const DoorConfig& config);

// Doors in the slice at slice_z_m of the surface (mesh vertices); place positions mark the mapped space (and the
// raster's extent). False with *error set on a bad config or a raster beyond max_cells; no surface or no places near
// the slice gives no doors.
bool detect_doors(const std::vector<Eigen::Vector3f>& surface, const std::vector<Eigen::Vector3d>& places,
                  double slice_z_m, const DoorConfig& config, std::vector<Door>* doors, DoorStats* stats,
                  std::string* error, WallSight* sight = nullptr);

// Every slice of the robot's storeys (agent nodes' heights), with the graph's places as the mapped space; then the
// doors the places graph goes round are dropped (drop_bypassed_doors, counted in stats->bypassed).
// With sight not null, each slice's walls are also added to it (WallSight::add_slice) for the room finder's
// visibility merge; it is cleared first.
bool find_doors(const std::vector<Eigen::Vector3f>& surface, const scene_graph::SceneGraph& graph,
                const DoorConfig& config, std::vector<Door>* doors, DoorStats* stats, std::string* error,
                WallSight* sight = nullptr);

// The places graph a door's bypass is searched on (DoorConfig::bypass_max_m): place ids and positions and the
// edges between them, in fixed arrays carved from an arena (the online stage) or allocated (offline), with the
// buffers of a bounded Dijkstra search. Fill with add_place and add_edge (by id; an edge whose ends were not both
// added is ignored), then finish(); clear() starts over. Never allocates after carve/allocate.
class BypassGraph {
 public:
  struct Capacities {
    std::size_t places = 0;
    std::size_t edges = 0;
  };
  BypassGraph() = default;
  BypassGraph(const BypassGraph&) = delete;
  BypassGraph& operator=(const BypassGraph&) = delete;
  static memory::ArenaPlan plan(const Capacities& capacities);
  bool carve(memory::Arena& arena, const Capacities& capacities);
  bool allocate(const Capacities& capacities, std::string* error);  // its own arena (offline use)
  void clear();
  // False (and counted in refused()) when full or the position is not finite.
  bool add_place(scene_graph::NodeId id, const Eigen::Vector3d& position_m);
  bool add_edge(scene_graph::NodeId a, scene_graph::NodeId b);
  // Resolves the edges' ids (edges to places not added are dropped) and builds the adjacency.
  void finish();
  std::size_t places() const { return num_places_; }
  std::size_t edges() const { return num_edges_; }
  std::size_t refused() const { return refused_; }

  enum class Bypass : std::uint8_t {
    kNone,   // no edge of the graph crosses the door, or none of its edges' ends are joined round it
    kFound,  // a path round the door joins the two ends of an edge it closes
    kCut,    // no path found, but a search stopped at bypass_max_places or at the search buffers' size
  };
  // For each edge the door closes (door_closes_edge), the shortest path between its ends over edges that do not
  // cross the door's line lengthened by bypass_extension_m and are no longer than bypass_max_edge_m, searched up to
  // bypass_max_m. After finish().
  Bypass goes_round(const Door& door, const DoorConfig& config);

 private:
  struct Edge {
    std::uint32_t a, b;
  };
  struct HeapItem {
    float d;  // metres along the path (a search reaches bypass_max_m, a few metres)
    std::uint32_t node;
  };
  // config: the door's line lengthened by its cut_extension_m (goes_round sets it to bypass_extension_m).
  bool search(const Door& door, const DoorConfig& config, std::uint32_t from, std::uint32_t to, bool* cut);
  static constexpr std::uint32_t kNoPlace = 0xffffffffu;
  std::uint32_t index_of(scene_graph::NodeId id) const;  // kNoPlace when not a place of the graph
  Capacities capacities_;
  memory::Arena own_;
  scene_graph::NodeId* ids_ = nullptr;       // by index, sorted at finish()
  Eigen::Vector3d* position_ = nullptr;
  std::uint32_t* order_ = nullptr;           // finish(): the sort's permutation
  Eigen::Vector3d* scratch_ = nullptr;       // finish(): positions while permuted
  scene_graph::NodeId* edge_ids_ = nullptr;  // 2 per edge, until finish()
  Edge* edges_ = nullptr;
  std::uint32_t* offset_ = nullptr;          // CSR: places + 1
  std::uint32_t* adjacency_ = nullptr;       // CSR: 2 per edge (edge indices)
  float* dist_ = nullptr;                    // per place, metres; +inf between searches
  std::uint32_t* touched_ = nullptr;         // places whose dist_ a search set
  HeapItem* heap_ = nullptr;                 // 1 per edge (a push beyond it is skipped: Bypass::kCut)
  std::size_t num_places_ = 0, num_edges_ = 0, num_edge_ids_ = 0, refused_ = 0;
  bool finished_ = false;
};

// Drops every door the places graph goes round (DoorConfig::bypass_max_m; BypassGraph::goes_round): a path found
// for any place edge the door closes drops it. Each door is judged on the graph as it is, the other doors' edges
// open, so the result does not depend on the doors' order. Returns the number dropped; stats (optional) counts them,
// the searches stopped short, and the doors left unchecked when the graph cannot be allocated (all kept). Allocates
// (offline use, as find_doors).
std::size_t drop_bypassed_doors(std::vector<Door>* doors, const DoorConfig& config,
                                const scene_graph::SceneGraph& graph, DoorStats* stats = nullptr);

// Every place-place edge not closed yet (weight <= 0) for which closes(a, b) holds, a and b its ends' positions,
// gets weight 0: a closed passage for the room finder (Config::seed_closed_regions). Returns the number closed.
// The final stage's closures: cut_place_edges (doors), cut_edges_through_walls (wall_sight.h).
std::size_t close_place_edges(scene_graph::SceneGraph* graph,
                              const std::function<bool(const Eigen::Vector3d&, const Eigen::Vector3d&)>& closes);

// Every place-place edge a door closes (door_closes_edge) gets weight 0 (close_place_edges). Returns the number of
// edges closed.
std::size_t cut_place_edges(const std::vector<Door>& doors, const DoorConfig& config,
                            scene_graph::SceneGraph* graph);

}  // namespace qsg::rooms
