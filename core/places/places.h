// Layer 3 of the scene graph: an incremental ESDF and GVD (theta-simplified medial axis) over the active window,
// seeded from the Layer-1 TSDF, sparsified into a graph of places (the paper's Algorithm "Places Sparsification")
// and mirrored into the scene graph. Anytime: update() works through a worklist until its deadline and resumes.
// Every store is carved from one arena sized by the board's budget table; after init() nothing allocates.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "core/memory/arena.h"
#include "core/memory/fixed_hash_map.h"
#include "core/memory/pool.h"
#include "core/memory/resource_stats.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/scene_graph/attributes.h"
#include "core/scene_graph/node_id.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::places {

// 8 voxels per ESDF block side, as the TSDF: at the default 0.2 m GVD voxel a block is 1.6 m and covers 2 x 2 x 2
// TSDF blocks, so one dirty TSDF block maps to exactly one ESDF block.
inline constexpr int kBlockSide = 8;
inline constexpr int kBlockVoxels = kBlockSide * kBlockSide * kBlockSide;
inline constexpr int kMaxVoxelFactor = 2;
inline constexpr int kMaxClusterEdges = 24;  // place edges kept per place (neighbouring cells of a 3D hash)
inline constexpr int kMaxViews = 32;         // observe() calls remembered between two cycles (one bit each)
inline constexpr int kMaxBridgeFragment = 16;  // largest bridge_max_fragment_places (a fixed search array)
inline constexpr int kMaxContractSearch = 256;  // largest contract_search_places (a fixed search array)
inline constexpr int kMaxRemovingPerSync = 256;  // removed nodes sync() keeps out of the contraction's anchors

struct Config {
  // GVD voxel = voxel_factor x TSDF voxel (1 or 2). 2 (0.2 m at 0.1 m TSDF voxels) by default: 8x fewer voxels
  // to propagate and store, while node positions stay well inside the 0.15 m accuracy target (a GVD sheet is
  // located to half a voxel, 0.1 m), and a 0.8 m door is still 4 voxels wide.
  int voxel_factor = 2;
  double max_distance_m = 3.0;       // wavefronts stop here (bounds work in large open or unobserved space)
  double min_clearance_m = 0.2;      // GVD voxels closer to an obstacle are dropped (unstable near surfaces)
  double min_basis_angle_rad = 0.785398163;  // theta of the theta-SMA: smallest angle between two basis points
  int min_basis_points = 2;          // n_b: GVD voxels with fewer basis points are not places
  double place_resolution_m = 1.0;   // delta_p: side of the spatial-hash cells that cluster GVD voxels
  double window_radius_m = 7.0;      // ESDF blocks whose centre is farther from the robot are freed; keep it
                                     // below the TSDF window minus one ESDF block so every read block exists
  // The ESDF covers a vertical slab around the robot: free space is what the TSDF observed or what camera rays
  // carved, and the slab bounds the blocks a wavefront may allocate above and below.
  double slab_below_m = 2.0;
  double slab_above_m = 3.0;
  double min_tsdf_weight = 0.0;      // TSDF voxels with more weight than this count as observed
  // A GVD voxel that holds the surface (a zero crossing among its TSDF voxels) seeds the wavefront with the TSDF's
  // signed distance at its centre (down to -half a voxel behind the surface) rather than 0, so distances in free
  // space count from the surface, not from the centre of the coarse voxel that holds it (which is up to half a
  // GVD voxel, 0.1 m, off either way). Off: such seeds start at 0.
  bool signed_surface_seeds = true;
  // Seeds take their distance from the TSDF's zero crossings near them, interpolated along the three axes, rather
  // than from the TSDF's value: projective distances at grazing angles overestimate by 1/sin(angle) (a floor seen
  // from a 0.5 m camera: up to 4x, to the truncation); see crossing_distance. Off: the TSDF's value.
  bool correct_projective_distance = true;
  // Unobserved space beside free space may hold a surface (a floor under the camera's view, a ceiling above it):
  // it bounds ESDF distances like an obstacle (a frontier seed at distance 0), and a voxel nearer to it than to
  // any surface, or a frontier basis point, makes no GVD. Off, distances come from observed surfaces only and
  // places form on sheets between a wall and a floor the camera never saw.
  bool unobserved_is_obstacle = true;
  // ... up to this height above the robot (the camera). A quadruped's camera sees the floor around it but rarely
  // the ceiling above it: bounding by the unseen space above keeps places off the sheets that the unseen ceiling
  // would end, but it also removes every place in a room's middle, whose clearance the rooms layer needs
  // (bench/results/places.md). Hence 0 by default (the floor side only); a large value bounds everywhere.
  double unobserved_obstacle_above_m = 0.0;
  // A voxel at the window's vertical rim (the block above or below it is outside the window: the spherical window
  // drops the floor's and the ceiling's blocks before those at the robot's height) takes its distance from the
  // walls alone: it becomes no new GVD voxel there, and a GVD voxel already there keeps its state until it leaves.
  // Off, such voxels grow sheets that are not in the world, which become inactive places when the robot moves on.
  bool rim_guard = true;
  // An obstacle whose ESDF block leaves the window (the window's horizontal rim) is still there: the free voxels
  // left inside that took their distance from it keep that distance (each becomes its own parent, an "orphan",
  // counted in Counters::voxels_orphaned) and the GVD around them keeps its state, as at the vertical rim, until
  // a real wavefront reaches them again (the robot comes back) or their block leaves too. Off (the FIESTA rule for
  // a vanished obstacle), they are raised and refilled from the obstacles still inside, e.g. the floor alone
  // beside a wall that just left: corridor places went inactive with far more clearance than the walls beside
  // them allowed, which merged rooms through their doors (bench/results/places.md).
  bool keep_distances_at_rim = true;
  // The paper: each GVD voxel's distance "defines a sphere of free-space"; the union of the spheres is the free
  // space and carries its connectivity. Places of neighbouring hash cells whose spheres overlap are joined by a
  // free-space edge (weight: the smallest ESDF distance along the segment), which reconnects GVD pieces that the
  // theta-SMA and clearance filters cut off from the rest of the same free-space region.
  bool free_space_edges = true;
  // A removed place's edges to inactive places (which cannot re-derive their edges: their voxels are gone) move
  // to the live place of the same or a neighbouring cell whose sphere overlaps the removed one's.
  bool relink_inactive = true;
  // ... and only when the live place is in the same free space as the inactive one (their spheres overlap, or the
  // ESDF certifies the segment between them), as for a revival: the removed place's sphere may overlap the new
  // one's while the inactive place lies on the other side of a floor slab whose underside the camera never saw
  // (the new place's clearance then reaches through it). A refused relink waits for another replacement and is
  // dropped with the others when the removed place leaves the window. Off: more edges join free spaces apart
  // (bench/results/places.md).
  bool relink_in_same_free_space = true;
  // A place that left the window stays in the graph, inactive, and a new place in the same hash cell later brings
  // that node back to life with its edges to other inactive places (a revisit). A 1 m cell can also hold free space
  // on the other side of a wall or a floor slab (a two-floor building's cell from 2 to 3 m holds the top of the
  // ground floor and the bottom of the upper one), where those edges would cross the wall or the slab. On, the node
  // is brought back only if the new place is in the same free space as where the node left: their spheres of free
  // space (position, clearance) overlap, or the ESDF certifies the segment between them; otherwise the new place
  // gets a node of its own and the old one stays where it was. Off: any new place of the cell revives it, and
  // place edges run through the slab of two-floor buildings (bench/results/places.md). The cost: a revisit the
  // ESDF cannot certify (space near an unseen ceiling, not carved again) is refused too, and an inactive region
  // that hung on that node alone stays apart (until keep_edges_at_rim_m kept the edges it had lost at the rim).
  // Refusing only on known obstacles (occupied, surface, frontier seed) avoided that but let more through the slab.
  bool revive_in_same_free_space = true;
  // Within this distance of the window's sphere (window_radius_m around the robot), a place's GVD piece is cut
  // short as the ESDF blocks beyond the rim leave, so two places there stop touching although the free space
  // between them is as it was: the edge between them, certified while both were inside, is kept until both are
  // farther in again (or for good once one leaves). Without it, a region whose last edges to the rest went this
  // way left the window as a component of its own (bench/results/places.md). The slab's top and bottom are not
  // counted: there a kept edge often ran from one floor to the next. 0: edges follow the GVD up to the rim; must be
  // below window_radius_m.
  double keep_edges_at_rim_m = 0.5;
  // The paper's reconciliation of revisited places ("we merge nodes within a distance threshold, 0.4 m"): after
  // each sync, an inactive place within this distance of a live place, and in the same free space (as for a
  // revival), is merged into it: its edges move to the live node (SceneGraph::merge_into) and its node goes. A
  // revisit re-derives the GVD from new views, and its places seldom come back in the hash cell they left (a 1 m
  // cell's revival), so without this every tour of a building leaves a new set of places beside the old ones
  // (bench/results/odometry.md, 8-hour mission). 0 turns it off; at most place_resolution_m.
  double merge_revisited_within_m = 0.4;
  // Bridges (as Hydra joins its disconnected components): a live place whose component of live places holds at
  // most bridge_max_fragment_places places (e.g. a 1-2 place GVD piece under a table or a bed, in the same free
  // space as the room around it) is joined to the nearest live place outside that component, at most
  // bridge_max_length_m away, whose straight segment keeps an ESDF distance of at least bridge_min_clearance_m
  // (one TSDF voxel by default: every GVD voxel it crosses is observed free space, none holds a surface; a whole
  // GVD voxel would refuse the 0.4 m gaps between furniture where such fragments sit).
  bool bridge_fragments = true;
  int bridge_max_fragment_places = 16;  // 4 left two groups of a furnished plan apart (bench/results/places.md)
  double bridge_max_length_m = 3.0;
  double bridge_min_clearance_m = 0.1;
  // When no straight segment is certified, a breadth-first search through free ESDF voxels (distance >=
  // bridge_min_clearance_m, at most bridge_max_length_m of steps) looks for a path around what is in the way.
  bool bridge_path_search = true;
  // A fragment that no bridge can join although places lie within reach, and that holds at most this many GVD
  // voxels, is a pocket enclosed by surfaces (the averaged TSDF opens small cavities inside furniture), not free
  // space the robot can reach: it is kept out of the scene graph while so. 0 publishes every place.
  int enclosed_max_voxels = 8;
  // A fragment that no bridge can join and that lies wholly farther than bridge_max_length_m from the robot is
  // free space seen from afar (through a door, past furniture) that no observed free space joins to the robot's
  // yet: its places not yet in the scene graph are kept out until a bridge joins them or the robot comes near,
  // and dropped if they leave the window first (seen again when the robot comes back). Places already published
  // stay. Off, such islands stay separate components of the graph.
  bool hold_distant_fragments = true;
  // When a removed place was the only link between an inactive place and the active graph (no active place within
  // contract_search_places graph nodes of the inactive one without it), the inactive place is joined to the removed
  // place's nearest other neighbour: an edge contraction, so removing a node never cuts the graph.
  bool contract_removed = true;
  int contract_search_places = 64;
  std::string check() const;         // empty when usable, else the bad field and why
  void print(std::FILE* out) const;
};

// Sizes of the layer's stores: the budget table's "places" arena (capacities_from_budget()), or a test's own. No
// defaults: a number lives only in budgets/<board>.json.
struct Capacities {
  std::size_t max_blocks = 0;        // ESDF blocks of kBlockVoxels voxels (the window's free space and surfaces)
  std::size_t place_nodes = 0;       // clusters = place nodes alive in the window, plus those awaiting sync()
  // Inactive places remembered by hash cell for revisits (revival and merging): cells, and places over all cells.
  std::size_t inactive_cells = 0;
  // TSDF blocks whose free space observe() remembers until the next cycle (each cycle holds one such set while
  // observe() fills the other); a frame touches a few hundred blocks, a cycle of 5 keyframes ~1000.
  std::size_t observed_blocks = 0;
  std::size_t pending_relinks = 0;     // inactive-place edges waiting for a live place to move to
  void print(std::FILE* out) const;
};
Capacities capacities_from_budget();
std::size_t arena_bytes_from_budget();

// When to stop: after max_work_units (deterministic, for tests and lockstep runs) or when expired(context) says
// so (checked every check_every units; e.g. a clock comparison supplied by the scheduler). Never allocates.
struct Deadline {
  using Fn = bool (*)(const void* context);
  std::uint64_t max_work_units = std::numeric_limits<std::uint64_t>::max();
  Fn expired = nullptr;
  const void* context = nullptr;
  std::uint32_t check_every = 64;
  static Deadline unlimited() { return Deadline{}; }
  static Deadline work_units(std::uint64_t units) {
    Deadline d;
    d.max_work_units = units;
    return d;
  }
};

struct UpdateResult {
  bool complete = false;          // the cycle finished: the GVD and places reflect the TSDF of the cycle's start
  std::uint64_t work_units = 0;   // done in this call
};

struct Counters {
  std::uint64_t updates = 0;           // update() calls
  std::uint64_t cycles = 0;            // completed cycles
  std::uint64_t tsdf_blocks_read = 0;  // dirty TSDF blocks re-seeded
  std::uint64_t voxels_updated = 0;    // ESDF voxels whose distance or parent changed (lower wave and seeds)
  std::uint64_t voxels_raised = 0;     // ESDF voxels reset by raise waves
  std::uint64_t voxels_orphaned = 0;   // kept their distance when its obstacle's block left (keep_distances_at_rim)
  std::uint64_t frontier_seeds = 0;    // unobserved voxels made frontier seeds (see Config::unobserved_is_obstacle)
  std::uint64_t occupied_seeds = 0;    // occupied voxels beside free ones (no band voxel between) made seeds
  std::uint64_t blocks_allocated = 0;
  std::uint64_t blocks_freed = 0;      // left the window
  std::uint64_t blocks_refused = 0;    // block pool full: the wavefront stopped there
  std::uint64_t gvd_voxels = 0;        // current
  std::uint64_t places = 0;            // current live clusters (active place nodes)
  std::uint64_t clusters_merged = 0;
  std::uint64_t clusters_split = 0;
  std::uint64_t clusters_refused = 0;  // cluster pool full: a GVD voxel stayed without a place
  std::uint64_t edges_refused = 0;     // a bridge found no free slot at one of its ends (kMaxClusterEdges)
  // Edge candidates not kept under the neighbour limit (kMaxClusterEdges): a place keeps its best edges, GVD before
  // free-space before bridge, nearer before farther; a better candidate replaces its worst, a worse one is pruned.
  // Policy, not a fault: it grows with every edge recomputation among crowded places (traffic).
  std::uint64_t edges_pruned = 0;
  std::uint64_t graph_refused = 0;     // sync(): the scene graph's place or edge store was full
  std::uint64_t graph_errors = 0;      // sync(): the graph refused a request for another reason (a node not in it
                                       // yet, or gone): not a full store; relinks retry on the next sync
  std::uint64_t reactivated = 0;       // places re-created in a cell an inactive node had left: the node is reused
  std::uint64_t revivals_refused = 0;  // ... not reused: not the same free space (Config::revive_in_same_free_space)
  std::uint64_t revisits_merged = 0;   // inactive places merged into a live one (Config::merge_revisited_within_m)
  std::uint64_t merge_edges_moved = 0;  // ... their edges moved to the live node
  std::uint64_t inactive_forgotten = 0;  // inactive places the index could not hold (never revived or merged)
  std::uint64_t edges_kept_at_rim = 0;  // syncs that kept an edge the GVD no longer gives (Config::keep_edges_at_rim_m)
  std::uint64_t free_space_edges = 0;  // current free-space edges (sphere overlap, not GVD adjacency)
  std::uint64_t relinked = 0;          // edges of removed places moved from an inactive place to a live one
  std::uint64_t relinks_dropped = 0;   // no live place replaced the removed one before it left the window
  std::uint64_t relinks_refused = 0;   // pending relink store full
  std::uint64_t relinks_apart = 0;     // attempts whose replacement was not in the inactive place's free space
  std::uint64_t views_observed = 0;    // observe() calls
  std::uint64_t views_merged = 0;      // observe() found every view slot used: the newest slot was overwritten
  std::uint64_t observed_refused = 0;  // observe(): the observed-block set was full (that block is not carved)
  std::uint64_t rays_carved = 0;
  std::uint64_t bridges = 0;           // current bridge edges (joining a small fragment to the nearest live place)
  std::uint64_t bridges_added = 0;
  std::uint64_t bridges_missing = 0;   // last cycle: fragment checks that found no place reachable through free space
  std::uint64_t bridge_paths = 0;      // bridges found by the path search (no straight segment was certified)
  std::uint64_t bridge_searches_cut = 0;  // path searches stopped by the deadline's clock: retried next cycle
  std::uint64_t contracted = 0;        // edges added by contraction around a removed place (see Config)
  std::uint64_t enclosed_held = 0;     // current live places held out of the graph (enclosed pockets, distant islands)
  void print(std::FILE* out) const;
};

// Bytes held for the ESDF and GVD (the dense window data) and, separately, for the place bookkeeping; "used"
// figures are high-water marks since init(), "planned" ones what the arena carved for them.
struct MemoryUse {
  std::size_t block_bytes = 0;                 // sizeof one ESDF block (kBlockVoxels voxels and its header)
  std::size_t blocks_high_water = 0;
  std::size_t blocks_capacity = 0;
  std::size_t esdf_used_bytes = 0;             // blocks_high_water x block_bytes
  std::size_t esdf_planned_bytes = 0;          // the block pool and its index
  std::size_t work_lists_used_bytes = 0;       // voxel-ref work lists and the lower-wave ring, at their high water
  std::size_t work_lists_planned_bytes = 0;
  std::size_t places_used_bytes = 0;           // clusters, cell index, inactive cells, relinks at their high water
  std::size_t places_planned_bytes = 0;
  std::size_t arena_planned_bytes = 0;         // everything, as carved
  std::size_t window_used_bytes() const { return esdf_used_bytes + work_lists_used_bytes; }
  void print(std::FILE* out) const;
};

// What sync() changed in the scene graph.
struct SyncResult {
  scene_graph::Status status = scene_graph::Status::kOk;  // kFull when a node or edge did not fit (retried later)
  std::size_t nodes_added = 0;
  std::size_t nodes_updated = 0;
  std::size_t nodes_removed = 0;
  std::size_t nodes_deactivated = 0;  // left the window: kept, is_active = false
  std::size_t edges_added = 0;
  std::size_t edges_updated = 0;
  std::size_t edges_removed = 0;
  std::size_t refused = 0;
};

// Read-only views for tests and evaluation (heap-backed outputs: not for the real-time path).
struct GvdVoxelInfo {
  Eigen::Vector3d position_m;
  float clearance_m = 0.0f;
  std::uint8_t num_basis_points = 0;
  std::vector<Eigen::Vector3d> basis_m;  // the basis points' voxel centres (surface seeds)
};
// One ESDF voxel as the places see it (diagnosis: places_eval --trace).
struct VoxelProbe {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // voxel centre
  const char* state = "";      // free, seed, occupied, unobserved
  bool carved = false, gvd = false;
  float distance_m = 0.0f;
  int num_basis_points = 0;
  bool has_parent = false;
  Eigen::Vector3d parent_m = Eigen::Vector3d::Zero();
  const char* parent_state = "";
  float parent_distance_m = 0.0f;
};
struct PlaceInfo {
  scene_graph::NodeId id = scene_graph::kNoNode;
  Eigen::Vector3d position_m;
  double clearance_m = 0.0;
  std::uint32_t num_basis_points = 0;
  std::uint32_t num_voxels = 0;
  std::vector<std::pair<scene_graph::NodeId, double>> edges;  // GVD adjacency: neighbour, weight (min clearance)
  std::vector<std::pair<scene_graph::NodeId, double>> free_space_edges;  // overlapping spheres: neighbour, weight
  std::vector<std::pair<scene_graph::NodeId, double>> bridge_edges;  // fragment joined through free space
  std::vector<Eigen::Vector3d> voxel_positions_m;  // the cluster's GVD voxels
  std::vector<double> voxel_clearances_m;
  std::vector<std::uint32_t> voxel_basis_points;
};

class Places {
 public:
  Places();
  Places(const Places&) = delete;
  Places& operator=(const Places&) = delete;
  ~Places();

  static memory::ArenaPlan plan(const Capacities& capacities);
  // Checks the config and carves every store from one arena of at most budget_bytes. Start-up only.
  bool init(const Config& config, const Capacities& capacities, std::size_t budget_bytes, std::string* error);

  // Per keyframe, right after the frame was integrated (cheap: one pass over the TSDF's block table, no voxel
  // reads): remembers the camera position and the TSDF blocks this frame touched, so the next cycle carves the
  // free space between them, whatever the number of keyframes between two update() calls. Without observe()
  // calls, a cycle carves from robot_m to the blocks of the latest frame only. False when not initialised.
  bool observe(const reconstruction::SemanticTsdf& tsdf, const Eigen::Isometry3d& world_T_camera);

  // One step of the cycle: scan the TSDF for blocks integrated since their last read (and free ESDF blocks that
  // left the window around robot_m), re-seed them, run raise and lower waves, re-test the GVD where parents
  // changed, and sparsify the changed GVD voxels into places. Stops when the deadline says so and continues from
  // there on the next call; robot_m is taken at the start of a cycle. Never allocates.
  UpdateResult update(const reconstruction::SemanticTsdf& tsdf, const Eigen::Vector3d& robot_m,
                      const Deadline& deadline);
  // Adds, updates, deactivates and removes only the place nodes and edges that changed since the last sync.
  SyncResult sync(scene_graph::SceneGraph* graph);

  // ESDF value at a point: false when the voxel is not allocated, not free or not reached by a wavefront. Up to
  // half a voxel negative in a surface voxel whose centre lies behind the surface (signed_surface_seeds).
  bool distance_at(const Eigen::Vector3d& p_m, float* distance_m) const;
  void gvd_voxels(std::vector<GvdVoxelInfo>* out) const;
  bool probe(const Eigen::Vector3d& p_m, VoxelProbe* out) const;  // false when no block holds p
  void places(std::vector<PlaceInfo>* out) const;
  bool cycle_in_progress() const { return phase_ != 0; }
  double voxel_size_m() const { return voxel_m_; }
  std::size_t num_places() const { return clusters_live_; }  // live places, with those held as enclosed pockets
  // The live places whose node is in the scene graph (the active window's, held pockets included): fn(context,
  // node, position) for each, in cluster order. Bounded by the window's cluster store, not the building.
  void for_each_published(void (*fn)(void* context, scene_graph::NodeId node, const Eigen::Vector3d& position_m),
                          void* context) const;
  std::size_t num_place_edges() const;
  MemoryUse memory_use() const;

  const Config& config() const { return config_; }
  const Capacities& capacities() const { return capacities_; }
  const Counters& counters() const { return counters_; }
  // Usage of every store: fn(const memory::ResourceStats&).
  template <typename Fn>
  void for_each_resource(Fn&& fn) const {
    fn(arena_.stats());
    fn(blocks_.stats());
    fn(block_index_.stats());
    fn(clusters_.stats());
    fn(inactive_.stats());
    fn(inactive_entry_stats());
    fn(cells_.stats());
    fn(observed_[0].stats());
    fn(observed_[1].stats());
    fn(relink_stats());
    fn(lower_queue_stats());
    fn(list_stats(0));
    fn(list_stats(1));
    fn(list_stats(2));
    fn(list_stats(3));
    fn(list_stats(4));
  }

  struct Voxel;
  struct Block;
  struct Cluster;
  struct List;
  struct EdgeCandidates;

 private:
  memory::ResourceStats lower_queue_stats() const;
  memory::ResourceStats relink_stats() const;
  memory::ResourceStats inactive_entry_stats() const;
  memory::ResourceStats list_stats(int which) const;

  // Geometry helpers.
  Voxel& vox(std::uint32_t ref);
  const Voxel& vox(std::uint32_t ref) const;
  bool is_source(std::uint32_t ref) const;
  memory::Index3 coords(std::uint32_t ref) const;
  std::uint32_t neighbor(std::uint32_t ref, int dx, int dy, int dz) const;
  std::uint32_t find_voxel(const memory::Index3& g) const;
  Eigen::Vector3d center_m(const memory::Index3& g) const;
  bool block_in_window(const memory::Index3& block) const;
  bool at_window_rim(const Eigen::Vector3d& p) const;
  memory::Index3 cell_of(std::uint32_t ref) const;

  // ESDF.
  void begin_cycle(const reconstruction::SemanticTsdf& tsdf, const Eigen::Vector3d& robot_m);
  void finish_cycle();
  std::uint32_t allocate_block(const reconstruction::SemanticTsdf& tsdf, const memory::Index3& index, bool read_tsdf);
  void evict_block_voxels(std::uint32_t handle);
  void release_block(std::uint32_t handle);
  void seed_sub_block(const reconstruction::SemanticTsdf& tsdf, std::uint32_t handle, int sub, bool carve);
  std::uint32_t voxel_at(const Eigen::Vector3d& p_m) const;  // kNoRef when no block holds p (or not ready)
  bool crossing_distance(const reconstruction::SemanticTsdf& tsdf, const memory::Index3& tb, int x0, int y0, int z0,
                         float* distance_m) const;
  void carve_ray(const reconstruction::SemanticTsdf& tsdf, const Eigen::Vector3d& origin_m, std::uint32_t target);
  void apply_state(std::uint32_t ref, std::uint8_t state, float seed_m);
  void raise_dependents(std::uint32_t seed_ref, bool include_seed);
  void orphan_dependents(std::uint32_t parent_ref);
  template <typename Fn>
  void detach_dependents(std::uint32_t parent_ref, Fn&& fn);
  void set_parent(std::uint32_t ref, std::uint32_t parent, float distance_m);
  void clear_parent(std::uint32_t ref);
  void push_lower(std::uint32_t ref);
  void push_raise(std::uint32_t ref);
  void mark_affected(std::uint32_t ref);
  void lower_step(const reconstruction::SemanticTsdf& tsdf, std::uint32_t ref);
  void raise_step(std::uint32_t ref);

  // GVD.
  int evaluate_gvd(std::uint32_t ref, std::uint32_t* basis_parents, int max_parents) const;
  void gvd_step(std::uint32_t ref);
  void expand_affected(std::uint32_t ref);

  // Places.
  void sparsify_step(std::uint32_t ref);
  std::uint32_t new_cluster(const memory::Index3& cell);
  void cluster_add_voxel(std::uint32_t cluster, std::uint32_t ref);
  void cluster_remove_voxel(std::uint32_t cluster, std::uint32_t ref);
  void merge_clusters(std::uint32_t into, std::uint32_t from);
  void retire_cluster(std::uint32_t cluster, std::uint8_t state);
  void drop_edge(std::uint32_t cluster, std::uint32_t other);
  void finalize_cluster(const reconstruction::SemanticTsdf& tsdf, std::uint32_t cluster, bool split_check);
  void split_cluster(const reconstruction::SemanticTsdf& tsdf, std::uint32_t cluster);
  void pick_representative(std::uint32_t cluster);
  void recompute_edges(std::uint32_t cluster);
  void offer_edge(const Cluster& c, EdgeCandidates* e, std::uint32_t x, float w, std::uint8_t kind);
  void gvd_edge_candidates(std::uint32_t cluster, EdgeCandidates* e);
  void free_space_edge_candidates(std::uint32_t cluster, EdgeCandidates* e);  // pass_free_space_edges.cc
  void kept_bridge_candidates(std::uint32_t cluster, EdgeCandidates* e);      // pass_bridges.cc
  void write_edges(std::uint32_t cluster, const EdgeCandidates& candidates);
  bool make_room(std::uint32_t cluster, std::uint8_t kind, double d2);
  void compute_mesh_connections(const reconstruction::SemanticTsdf& tsdf, std::uint32_t cluster);
  bool same_free_space(const Eigen::Vector3d& pa, double ra, const Eigen::Vector3d& pb, double rb) const;
  bool segment_clearance(Eigen::Vector3d a_m, Eigen::Vector3d b_m, float* min_distance_m) const;
  bool spheres_meet(std::uint32_t a, std::uint32_t b, float* weight_m) const;
  void link_cell(std::uint32_t cluster);
  void unlink_cell(std::uint32_t cluster);
  std::uint32_t replacement_for(const Eigen::Vector3d& position_m, double clearance_m,
                                const memory::Index3& cell) const;
  void resolve_relinks(scene_graph::SceneGraph* graph, SyncResult* r);
  void park_relinks(scene_graph::SceneGraph* graph, const Cluster& removed);
  // sync(), in order.
  void sync_retired(scene_graph::SceneGraph* graph, SyncResult* r);
  void sync_nodes(scene_graph::SceneGraph* graph, SyncResult* r);
  void sync_edges(scene_graph::SceneGraph* graph, SyncResult* r);
  void refuse_graph_write(SyncResult* r, const char* what);
  bool add_repair_edge(scene_graph::SceneGraph* graph, scene_graph::NodeId a, scene_graph::NodeId b, double weight_m,
                       const char* what, SyncResult* r);
  // The inactive-place index: nodes parked by hash cell (a cell holds any number, chained in a fixed array).
  void park_inactive(const memory::Index3& cell, scene_graph::NodeId node);
  scene_graph::NodeId take_inactive(const memory::Index3& cell);
  void merge_revisited(scene_graph::SceneGraph* graph, std::uint32_t cluster, SyncResult* r);
  void bridge_fragment(std::uint32_t cluster);
  // interrupted: the deadline's clock expired during the search (to stays kNoCluster; nothing else changed).
  float bridge_by_path(const std::uint32_t* members, int num, std::uint32_t* from, std::uint32_t* to,
                       bool* interrupted);
  void set_held(std::uint32_t cluster, bool held);
  bool add_cluster_edge(std::uint32_t a, std::uint32_t b, float weight_m, std::uint8_t kind);
  bool anchored(const scene_graph::SceneGraph& graph, scene_graph::NodeId start, scene_graph::NodeId removed,
                const scene_graph::NodeId* removing, std::size_t num_removing) const;
  void contract_around(scene_graph::SceneGraph* graph, scene_graph::NodeId removed,
                       const scene_graph::NodeId* removing, std::size_t num_removing, SyncResult* r);

  Config config_;
  Capacities capacities_;
  Counters counters_;
  memory::Arena arena_;
  memory::Pool<Block> blocks_;
  memory::SpatialHash<std::uint32_t> block_index_;
  memory::Pool<Cluster> clusters_;
  memory::SpatialHash<std::uint32_t> inactive_;  // hash cell -> its first inactive entry (list via next)
  struct InactiveEntry;
  InactiveEntry* inactive_entries_ = nullptr;   // capacities_.inactive_cells entries
  std::uint32_t inactive_free_ = 0;             // head of the free list
  std::size_t inactive_used_ = 0, inactive_high_water_ = 0;
  memory::SpatialHash<std::uint32_t> cells_;           // hash cell -> first live cluster (list via cell_next)
  // observe(): TSDF block -> bit k set when view k saw it; [pending_] fills, the other belongs to the cycle.
  memory::SpatialHash<std::uint32_t> observed_[2];
  Eigen::Vector3d views_m_[2][kMaxViews];
  std::uint32_t view_stamp_[2][kMaxViews] = {};
  int num_views_[2] = {0, 0};
  int pending_ = 0;
  bool observing_ = false;  // observe() was called: cycles carve from the observed views only
  struct Relink;
  Relink* relinks_ = nullptr;
  std::size_t num_relinks_ = 0, relinks_high_water_ = 0;
  List* lists_ = nullptr;  // [0] dirty TSDF sub-blocks, [1] raise, [2] affected, [3] GVD evaluation, [4] GVD changed
  std::uint32_t* lower_ring_ = nullptr;
  std::size_t lower_capacity_ = 0, lower_head_ = 0, lower_size_ = 0, lower_high_water_ = 0;

  // Cycle state (resumable).
  int phase_ = 0;
  std::size_t cursor_ = 0;
  Eigen::Vector3d cycle_robot_m_ = Eigen::Vector3d::Zero();
  std::uint64_t units_ = 0;
  const Deadline* deadline_ = nullptr;  // the running update()'s deadline (the path search checks its clock)

  double voxel_m_ = 0.2;
  double tsdf_voxel_m_ = 0.1;
  float tsdf_trunc_m_ = 0.3f;
  float cos_theta_ = 0.7071f;
  std::uint64_t next_node_index_ = 0;
  std::size_t clusters_live_ = 0;
  bool ready_ = false;
};

}  // namespace qsg::places
