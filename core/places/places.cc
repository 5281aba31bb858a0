// Incremental ESDF + GVD over the active window (raise and lower waves with per-parent dependent lists), the
// theta-SMA test, places sparsification into connected spatial-hash clusters, and the scene-graph mirror.
#include "core/places/places.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iterator>

#include "budgets/budget_table.h"

namespace qsg::places {

namespace {
constexpr std::uint32_t kNoRef = 0xFFFFFFFFu;
constexpr std::uint32_t kNoCluster = 0xFFFFFFFFu;
constexpr std::uint32_t kSplitPending = 0xFFFFFFFEu;  // member of a cluster being split, not yet reassigned
constexpr float kUnreached = std::numeric_limits<float>::max();
constexpr float kEps = 1e-4f;
constexpr int kMaxBasis = 8;
constexpr int kRim = -1;  // evaluate_gvd: the voxel touches the window's rim

// Voxel states, from the TSDF: seeds are fixed (their distance is the TSDF's), free voxels take their distance
// from wavefronts, occupied (behind a surface) and unobserved voxels stop them. The TSDF only allocates blocks
// around surfaces, so free space far from surfaces is known here through carving: rays from the robot to the
// surfaces it has just seen mark the voxels they cross (kCarved), which are free unless the TSDF says otherwise.
enum : std::uint8_t { kFree = 0, kSeed = 1, kOccupied = 2, kUnobserved = 3 };
enum : std::uint8_t {
  kInLower = 1,
  kInRaise = 2,
  kAffected = 4,
  kEval = 8,
  kGvd = 16,
  kGvdChanged = 32,
  kVisited = 64,
  kCarved = 128,
};
// Voxel::aux: the voxel kept its distance when its parent's block left the window; it is its own parent until a
// real wavefront reaches it (Config::keep_distances_at_rim).
enum : std::uint8_t { kOrphan = 1 };
enum : std::uint8_t { kLive = 0, kRemoved = 1, kLeft = 2 };  // cluster states; the last two await sync()
enum Phase : int { kIdle = 0, kSeedPhase, kRaisePhase, kLowerPhase, kGvdExpand, kGvdEval, kSparsify, kFinalize, kBridge };
enum : std::uint8_t { kEdgeGvd = 0, kEdgeFree = 1, kEdgeBridge = 2 };  // Cluster::edge_free values
enum ListId : int { kDirtyList = 0, kRaiseList = 1, kAffectedList = 2, kEvalList = 3, kChangedList = 4, kNumLists };

struct Offset {
  int dx, dy, dz;
  int block_slot;  // index in Block::nbr of the neighbour block in this direction (13 = self)
};
// The 26 neighbours in a fixed order (determinism: every wave visits them in this order).
struct Offsets {
  Offset o[26];
  Offsets() {
    int n = 0;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if (dx != 0 || dy != 0 || dz != 0) o[n++] = {dx, dy, dz, (dx + 1) + 3 * (dy + 1) + 9 * (dz + 1)};
  }
};
const Offsets kOffsets;

inline std::int32_t floor_div(std::int32_t a, std::int32_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
inline memory::Index3 add(const memory::Index3& a, int dx, int dy, int dz) { return {a.x + dx, a.y + dy, a.z + dz}; }
inline float dist_vox(const memory::Index3& a, const memory::Index3& b) {
  const float x = static_cast<float>(a.x - b.x), y = static_cast<float>(a.y - b.y), z = static_cast<float>(a.z - b.z);
  return std::sqrt(x * x + y * y + z * z);
}
inline int chebyshev(const memory::Index3& a, const memory::Index3& b) {
  return std::max(std::abs(a.x - b.x), std::max(std::abs(a.y - b.y), std::abs(a.z - b.z)));
}
inline std::uint32_t make_ref(std::uint32_t handle, int local) { return handle * kBlockVoxels + static_cast<std::uint32_t>(local); }
// The neighbour limit's order of edges (kMaxClusterEdges): a GVD edge before a free-space edge before a bridge
// (kEdgeGvd < kEdgeFree < kEdgeBridge), then the nearer place (squared distance between the places).
inline bool edge_better(std::uint8_t kind_a, double d2_a, std::uint8_t kind_b, double d2_b) {
  return kind_a < kind_b || (kind_a == kind_b && d2_a < d2_b);
}
}  // namespace

struct Places::Voxel {
  float distance_m = kUnreached;
  std::uint32_t parent = kNoRef;        // the seed this distance comes from (a seed is its own parent)
  std::uint32_t prev = kNoRef;          // doubly linked list of the voxels sharing a parent, headed by the seed
  std::uint32_t next = kNoRef;
  std::uint32_t cluster = kNoCluster;   // place cluster of a GVD voxel
  std::uint32_t cluster_next = kNoRef;  // next member of the cluster
  std::uint8_t state = kUnobserved;
  std::uint8_t flags = 0;
  std::uint8_t num_basis = 0;
  std::uint8_t aux = 0;  // kOrphan
};

struct Places::Block {
  memory::Index3 index;
  std::uint32_t nbr[27];  // handles of the 26 neighbour blocks (cached so waves rarely touch the hash)
  std::uint32_t tsdf_stamp[kMaxVoxelFactor * kMaxVoxelFactor * kMaxVoxelFactor];
  std::uint8_t tsdf_seen[kMaxVoxelFactor * kMaxVoxelFactor * kMaxVoxelFactor];
  std::uint8_t dying = 0;
  Voxel voxels[kBlockVoxels];
};

struct Places::Cluster {
  memory::Index3 cell;
  scene_graph::NodeId node = scene_graph::kNoNode;
  std::uint32_t head = kNoRef;
  std::uint32_t count = 0;
  std::uint32_t rep = kNoRef;
  std::uint8_t state = kLive;
  std::uint8_t dirty = 0;       // needs finalize (split check, representative, edges)
  std::uint8_t sync_dirty = 0;  // the scene graph's copy is out of date
  std::uint8_t synced = 0;      // the node exists in the scene graph
  std::uint8_t num_basis = 0;
  std::uint8_t num_edges = 0;
  std::uint8_t bridge_check = 0;  // its edges changed: is it (still) a small fragment to bridge?
  std::uint8_t held = 0;          // an enclosed pocket (see Config::enclosed_max_voxels): kept out of the graph
  std::uint8_t revived = 0;       // its node is the cell's inactive node, brought back: checked at the next sync
  std::uint8_t merge_check = 0;   // published by this sync: look for revisited inactive places near it
  float clearance_m = 0.0f;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  std::uint32_t cell_next = kNoCluster;  // next live cluster of the same hash cell
  std::uint32_t edge_to[kMaxClusterEdges];
  float edge_weight[kMaxClusterEdges];
  std::uint8_t edge_free[kMaxClusterEdges];  // kEdgeGvd, kEdgeFree (overlapping spheres) or kEdgeBridge
  memory::BoundedArray<scene_graph::PlaceMeshConnection, scene_graph::kMaxPlaceConnections> connections;
};

// An edge of a removed place to an inactive place, waiting for the live place that replaces the removed one.
struct Places::Relink {
  scene_graph::NodeId inactive = scene_graph::kNoNode;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // the removed place's sphere
  float clearance_m = 0.0f;
  float weight_m = 0.0f;  // the removed edge's weight
  memory::Index3 cell;
};

// One inactive place in the index (Places::inactive_): chained per hash cell, or on the free list.
struct Places::InactiveEntry {
  scene_graph::NodeId node = scene_graph::kNoNode;
  std::uint32_t next = kNoRef;
};

// A fixed list of voxel refs (or dirty-block entries) with a usage counter.
struct Places::List {
  std::uint32_t* data = nullptr;
  std::size_t size = 0;
  std::size_t capacity = 0;
  std::size_t high_water = 0;
  std::uint64_t failed = 0;
  const char* name = "";
  bool push(std::uint32_t v) {
    if (size == capacity) {
      ++failed;
      return false;
    }
    data[size++] = v;
    if (size > high_water) high_water = size;
    return true;
  }
  void clear() { size = 0; }
};

// ---------------------------------------------------------------------------------------------------------
std::string Config::check() const {
  if (voxel_factor < 1 || voxel_factor > kMaxVoxelFactor) return "voxel_factor must be 1 or 2";
  if (!(max_distance_m > 0.0 && max_distance_m <= 20.0)) return "max_distance_m must be in (0, 20] m";
  if (!(min_clearance_m >= 0.0 && min_clearance_m < max_distance_m))
    return "min_clearance_m must be in [0, max_distance_m)";
  if (!(min_basis_angle_rad > 0.0 && min_basis_angle_rad <= 3.14159266)) return "min_basis_angle_rad must be in (0, pi]";
  if (min_basis_points < 2 || min_basis_points > kMaxBasis) return "min_basis_points must be in [2, 8]";
  if (!(place_resolution_m > 0.0 && place_resolution_m <= 20.0)) return "place_resolution_m must be in (0, 20] m";
  if (!(window_radius_m > 0.0 && window_radius_m <= 100.0)) return "window_radius_m must be in (0, 100] m";
  if (!(slab_below_m >= 0.0 && slab_above_m >= 0.0 && slab_below_m + slab_above_m > 0.0))
    return "slab_below_m and slab_above_m must be >= 0 and not both 0";
  if (!(min_tsdf_weight >= 0.0)) return "min_tsdf_weight must be >= 0";
  if (bridge_max_fragment_places < 1 || bridge_max_fragment_places > kMaxBridgeFragment)
    return "bridge_max_fragment_places must be in [1, " + std::to_string(kMaxBridgeFragment) + "]";
  if (!(bridge_max_length_m > 0.0 && bridge_max_length_m <= 10.0)) return "bridge_max_length_m must be in (0, 10] m";
  if (!(bridge_min_clearance_m > 0.0)) return "bridge_min_clearance_m must be positive";
  if (enclosed_max_voxels < 0) return "enclosed_max_voxels must be >= 0";
  if (contract_search_places < 1 || contract_search_places > kMaxContractSearch)
    return "contract_search_places must be in [1, " + std::to_string(kMaxContractSearch) + "]";
  if (!(keep_edges_at_rim_m >= 0.0 && keep_edges_at_rim_m < window_radius_m))
    return "keep_edges_at_rim_m must be in [0, window_radius_m) (at or beyond the radius, no edge would ever go)";
  if (!(merge_revisited_within_m >= 0.0 && merge_revisited_within_m <= place_resolution_m))
    return "merge_revisited_within_m must be in [0, place_resolution_m] (the merge searches the neighbouring cells)";
  return {};
}

void Config::print(std::FILE* out) const {
  std::fprintf(out,
               "places: voxel_factor=%d max_distance_m=%.2f min_clearance_m=%.2f min_basis_angle_deg=%.1f "
               "min_basis_points=%d place_resolution_m=%.2f window_radius_m=%.1f slab_m=[-%.1f, +%.1f] "
               "min_tsdf_weight=%.2f free_space_edges=%d relink_inactive=%d bridge_fragments=%d "
               "bridge_max_fragment_places=%d bridge_max_length_m=%.2f bridge_min_clearance_m=%.2f "
               "enclosed_max_voxels=%d contract_removed=%d contract_search_places=%d unobserved_is_obstacle=%d "
               "unobserved_obstacle_above_m=%.2f rim_guard=%d signed_surface_seeds=%d correct_projective_distance=%d "
               "hold_distant_fragments=%d bridge_path_search=%d keep_distances_at_rim=%d "
               "revive_in_same_free_space=%d keep_edges_at_rim_m=%.2f relink_in_same_free_space=%d "
               "merge_revisited_within_m=%.2f\n",
               voxel_factor, max_distance_m, min_clearance_m, min_basis_angle_rad * 180.0 / 3.14159265358979,
               min_basis_points, place_resolution_m, window_radius_m, slab_below_m, slab_above_m, min_tsdf_weight,
               free_space_edges ? 1 : 0, relink_inactive ? 1 : 0, bridge_fragments ? 1 : 0,
               bridge_max_fragment_places, bridge_max_length_m, bridge_min_clearance_m, enclosed_max_voxels,
               contract_removed ? 1 : 0,
               contract_search_places, unobserved_is_obstacle ? 1 : 0,
               unobserved_obstacle_above_m, rim_guard ? 1 : 0, signed_surface_seeds ? 1 : 0,
               correct_projective_distance ? 1 : 0, hold_distant_fragments ? 1 : 0,
               bridge_path_search ? 1 : 0, keep_distances_at_rim ? 1 : 0, revive_in_same_free_space ? 1 : 0,
               keep_edges_at_rim_m, relink_in_same_free_space ? 1 : 0, merge_revisited_within_m);
}

void Capacities::print(std::FILE* out) const {
  std::fprintf(out,
               "places capacities: max_blocks=%zu place_nodes=%zu inactive_cells=%zu observed_blocks=%zu "
               "pending_relinks=%zu\n",
               max_blocks, place_nodes, inactive_cells, observed_blocks, pending_relinks);
}

void Counters::print(std::FILE* out) const {
  std::fprintf(out,
               "places: updates=%llu cycles=%llu tsdf_blocks_read=%llu voxels updated=%llu raised=%llu orphaned=%llu "
               "frontier_seeds=%llu "
               "occupied_seeds=%llu blocks "
               "allocated=%llu freed=%llu refused=%llu gvd_voxels=%llu places=%llu merged=%llu split=%llu "
               "refused clusters=%llu edges=%llu graph=%llu free_space_edges=%llu relinked=%llu "
               "relinks_dropped=%llu relinks_refused=%llu views=%llu views_merged=%llu observed_refused=%llu "
               "rays=%llu bridges=%llu bridges_added=%llu bridge_paths=%llu bridge_searches_cut=%llu bridges_missing=%llu "
               "contracted=%llu enclosed_held=%llu reactivated=%llu revivals_refused=%llu edges_kept_at_rim=%llu "
               "relinks_apart=%llu edges_pruned=%llu\n",
               (unsigned long long)updates, (unsigned long long)cycles, (unsigned long long)tsdf_blocks_read,
               (unsigned long long)voxels_updated, (unsigned long long)voxels_raised,
               (unsigned long long)voxels_orphaned, (unsigned long long)frontier_seeds, (unsigned long long)occupied_seeds,
               (unsigned long long)blocks_allocated, (unsigned long long)blocks_freed,
               (unsigned long long)blocks_refused, (unsigned long long)gvd_voxels, (unsigned long long)places,
               (unsigned long long)clusters_merged, (unsigned long long)clusters_split,
               (unsigned long long)clusters_refused, (unsigned long long)edges_refused,
               (unsigned long long)graph_refused, (unsigned long long)free_space_edges,
               (unsigned long long)relinked, (unsigned long long)relinks_dropped, (unsigned long long)relinks_refused,
               (unsigned long long)views_observed, (unsigned long long)views_merged,
               (unsigned long long)observed_refused, (unsigned long long)rays_carved, (unsigned long long)bridges,
               (unsigned long long)bridges_added, (unsigned long long)bridge_paths,
               (unsigned long long)bridge_searches_cut, (unsigned long long)bridges_missing,
               (unsigned long long)contracted, (unsigned long long)enclosed_held, (unsigned long long)reactivated,
               (unsigned long long)revivals_refused, (unsigned long long)edges_kept_at_rim,
               (unsigned long long)relinks_apart, (unsigned long long)edges_pruned);
}

void MemoryUse::print(std::FILE* out) const {
  constexpr double kMiB = 1024.0 * 1024.0;
  std::fprintf(out,
               "places memory: ESDF+GVD blocks %zu of %zu x %zu bytes = %.2f MiB (planned %.2f MiB); work lists "
               "%.2f MiB (planned %.2f MiB); window total %.2f MiB; place bookkeeping %.2f MiB (planned %.2f MiB); "
               "arena %.2f MiB\n",
               blocks_high_water, blocks_capacity, block_bytes, esdf_used_bytes / kMiB, esdf_planned_bytes / kMiB,
               work_lists_used_bytes / kMiB, work_lists_planned_bytes / kMiB, window_used_bytes() / kMiB,
               places_used_bytes / kMiB, places_planned_bytes / kMiB, arena_planned_bytes / kMiB);
}

Capacities capacities_from_budget() {
  Capacities c;
  c.max_blocks = budgets::active::places::kMaxBlocks;
  c.place_nodes = budgets::active::places::kPlaceNodes;
  c.inactive_cells = budgets::active::places::kInactiveCells;
  c.observed_blocks = budgets::active::places::kObservedBlocks;
  c.pending_relinks = budgets::active::places::kPendingRelinks;
  return c;
}
std::size_t arena_bytes_from_budget() { return budgets::active::places::kArenaBytes; }

// ---------------------------------------------------------------------------------------------------------
Places::Places()
    : blocks_("places.blocks", memory::OverflowPolicy::kRefuse),
      block_index_("places.block_index", memory::OverflowPolicy::kRefuse),
      clusters_("places.clusters", memory::OverflowPolicy::kRefuse),
      inactive_("places.inactive_cells", memory::OverflowPolicy::kRefuse),
      cells_("places.cell_index", memory::OverflowPolicy::kRefuse),
      observed_{memory::SpatialHash<std::uint32_t>("places.observed_blocks_a", memory::OverflowPolicy::kRefuse),
                memory::SpatialHash<std::uint32_t>("places.observed_blocks_b", memory::OverflowPolicy::kRefuse)} {}

Places::~Places() {
  if (ready_) {
    blocks_.clear();
    clusters_.clear();
  }
}

namespace {
std::size_t list_capacity(const Capacities& c, int which) {
  return which == kDirtyList ? c.max_blocks * kMaxVoxelFactor * kMaxVoxelFactor * kMaxVoxelFactor
                             : c.max_blocks * kBlockVoxels;
}
}  // namespace

memory::ArenaPlan Places::plan(const Capacities& c) {
  memory::ArenaPlan plan;
  memory::Pool<Block>::plan(plan, c.max_blocks);
  memory::SpatialHash<std::uint32_t>::plan(plan, memory::SpatialHash<std::uint32_t>::slots_for(c.max_blocks));
  memory::Pool<Cluster>::plan(plan, c.place_nodes);
  memory::SpatialHash<std::uint32_t>::plan(plan, memory::SpatialHash<std::uint32_t>::slots_for(c.inactive_cells));
  plan.add_array<InactiveEntry>(c.inactive_cells);
  memory::SpatialHash<std::uint32_t>::plan(plan, memory::SpatialHash<std::uint32_t>::slots_for(c.place_nodes));
  for (int i = 0; i < 2; ++i)
    memory::SpatialHash<std::uint32_t>::plan(plan, memory::SpatialHash<std::uint32_t>::slots_for(c.observed_blocks));
  plan.add_array<Relink>(c.pending_relinks);
  plan.add_array<List>(kNumLists);
  for (int i = 0; i < kNumLists; ++i) plan.add_array<std::uint32_t>(list_capacity(c, i));
  plan.add_array<std::uint32_t>(c.max_blocks * kBlockVoxels);  // lower-wave ring
  return plan;
}

bool Places::init(const Config& config, const Capacities& c, std::size_t budget_bytes, std::string* error) {
  const auto fail = [error](const std::string& why) {
    if (error != nullptr) *error = "places: " + why;
    return false;
  };
  if (ready_) return fail("init() called twice");
  const std::string bad = config.check();
  if (!bad.empty()) return fail("config: " + bad);
  if (c.max_blocks == 0 || c.place_nodes == 0 || c.inactive_cells == 0 || c.observed_blocks == 0 ||
      c.pending_relinks == 0)
    return fail("capacities: max_blocks, place_nodes, inactive_cells, observed_blocks and pending_relinks must be "
                "positive");
  if (c.max_blocks > (kNoRef / kBlockVoxels) - 1) return fail("capacities: max_blocks too large for 32-bit voxel refs");
  config_ = config;
  capacities_ = c;
  if (!arena_.create("places", plan(c), budget_bytes, error)) return false;
  bool ok = blocks_.carve(arena_, c.max_blocks) &&
            block_index_.carve(arena_, memory::SpatialHash<std::uint32_t>::slots_for(c.max_blocks), c.max_blocks) &&
            clusters_.carve(arena_, c.place_nodes) &&
            inactive_.carve(arena_, memory::SpatialHash<std::uint32_t>::slots_for(c.inactive_cells),
                            c.inactive_cells) &&
            cells_.carve(arena_, memory::SpatialHash<std::uint32_t>::slots_for(c.place_nodes), c.place_nodes) &&
            observed_[0].carve(arena_, memory::SpatialHash<std::uint32_t>::slots_for(c.observed_blocks),
                               c.observed_blocks) &&
            observed_[1].carve(arena_, memory::SpatialHash<std::uint32_t>::slots_for(c.observed_blocks),
                               c.observed_blocks);
  inactive_entries_ = ok ? arena_.carve_array<InactiveEntry>(c.inactive_cells) : nullptr;
  ok = ok && inactive_entries_ != nullptr;
  for (std::size_t i = 0; ok && i < c.inactive_cells; ++i)
    inactive_entries_[i].next = i + 1 < c.inactive_cells ? static_cast<std::uint32_t>(i + 1) : kNoRef;
  inactive_free_ = 0;
  relinks_ = ok ? arena_.carve_array<Relink>(c.pending_relinks) : nullptr;
  ok = ok && relinks_ != nullptr;
  lists_ = ok ? arena_.carve_array<List>(kNumLists) : nullptr;
  ok = ok && lists_ != nullptr;
  static const char* const kNames[kNumLists] = {"places.dirty_tsdf_blocks", "places.raise_list",
                                                "places.affected_list", "places.gvd_eval_list",
                                                "places.gvd_changed_list"};
  for (int i = 0; ok && i < kNumLists; ++i) {
    lists_[i].capacity = list_capacity(c, i);
    lists_[i].name = kNames[i];
    lists_[i].data = arena_.carve_array<std::uint32_t>(lists_[i].capacity);
    ok = lists_[i].data != nullptr;
  }
  lower_capacity_ = c.max_blocks * kBlockVoxels;
  lower_ring_ = ok ? arena_.carve_array<std::uint32_t>(lower_capacity_) : nullptr;
  if (!ok || lower_ring_ == nullptr || !arena_.seal()) return fail("the arena carve did not match its plan");
  cos_theta_ = static_cast<float>(std::cos(config_.min_basis_angle_rad));
  ready_ = true;
  return true;
}

memory::ResourceStats Places::lower_queue_stats() const {
  memory::ResourceStats s;
  s.name = "places.lower_queue";
  s.unit = "voxels";
  s.capacity = lower_capacity_;
  s.in_use = lower_size_;
  s.high_water = lower_high_water_;
  return s;
}

memory::ResourceStats Places::relink_stats() const {
  memory::ResourceStats s;
  s.name = "places.pending_relinks";
  s.unit = "edges";
  s.capacity = capacities_.pending_relinks;
  s.in_use = num_relinks_;
  s.high_water = relinks_high_water_;
  s.failed = counters_.relinks_refused;
  return s;
}

memory::ResourceStats Places::inactive_entry_stats() const {
  return {"places.inactive_places", "places", capacities_.inactive_cells, inactive_used_, inactive_high_water_,
          counters_.inactive_forgotten};
}

memory::ResourceStats Places::list_stats(int which) const {
  memory::ResourceStats s;
  if (lists_ == nullptr) return s;
  const List& l = lists_[which];
  s.name = l.name;
  s.unit = which == kDirtyList ? "blocks" : "voxels";
  s.capacity = l.capacity;
  s.in_use = l.size;
  s.high_water = l.high_water;
  s.failed = l.failed;
  return s;
}

// ---------------------------------------------------------------------------------------------------------
// Geometry

Places::Voxel& Places::vox(std::uint32_t ref) { return blocks_[ref / kBlockVoxels].voxels[ref % kBlockVoxels]; }
const Places::Voxel& Places::vox(std::uint32_t ref) const {
  return blocks_[ref / kBlockVoxels].voxels[ref % kBlockVoxels];
}

// A voxel whose distance spreads to its neighbours: a reached free voxel, a surface seed, or a seed made in
// lower_step from an unobserved voxel (a frontier) or an occupied one beside free space (its own parent).
bool Places::is_source(std::uint32_t ref) const {
  const Voxel& v = vox(ref);
  if (v.parent == kNoRef) return false;
  return v.state == kFree || v.state == kSeed || ((v.state == kUnobserved || v.state == kOccupied) && v.parent == ref);
}

memory::Index3 Places::coords(std::uint32_t ref) const {
  const memory::Index3& b = blocks_[ref / kBlockVoxels].index;
  const int i = static_cast<int>(ref % kBlockVoxels);
  return {b.x * kBlockSide + (i & 7), b.y * kBlockSide + ((i >> 3) & 7), b.z * kBlockSide + (i >> 6)};
}

std::uint32_t Places::neighbor(std::uint32_t ref, int dx, int dy, int dz) const {
  const std::uint32_t h = ref / kBlockVoxels;
  const int i = static_cast<int>(ref % kBlockVoxels);
  const int x = (i & 7) + dx, y = ((i >> 3) & 7) + dy, z = (i >> 6) + dz;
  const int bx = x < 0 ? -1 : (x >= kBlockSide ? 1 : 0);
  const int by = y < 0 ? -1 : (y >= kBlockSide ? 1 : 0);
  const int bz = z < 0 ? -1 : (z >= kBlockSide ? 1 : 0);
  const std::uint32_t nb = (bx | by | bz) == 0 ? h : blocks_[h].nbr[(bx + 1) + 3 * (by + 1) + 9 * (bz + 1)];
  if (nb == memory::kInvalidHandle) return kNoRef;
  return make_ref(nb, (x & 7) + kBlockSide * ((y & 7) + kBlockSide * (z & 7)));
}

std::uint32_t Places::find_voxel(const memory::Index3& g) const {
  const memory::Index3 b{floor_div(g.x, kBlockSide), floor_div(g.y, kBlockSide), floor_div(g.z, kBlockSide)};
  const std::uint32_t* h = block_index_.find(b);
  if (h == nullptr) return kNoRef;
  return make_ref(*h, (g.x - b.x * kBlockSide) + kBlockSide * ((g.y - b.y * kBlockSide) + kBlockSide * (g.z - b.z * kBlockSide)));
}

Eigen::Vector3d Places::center_m(const memory::Index3& g) const {
  return Eigen::Vector3d((g.x + 0.5) * voxel_m_, (g.y + 0.5) * voxel_m_, (g.z + 0.5) * voxel_m_);
}

bool Places::block_in_window(const memory::Index3& b) const {
  const double side = voxel_m_ * kBlockSide;
  const Eigen::Vector3d c((b.x + 0.5) * side, (b.y + 0.5) * side, (b.z + 0.5) * side);
  if ((c - cycle_robot_m_).squaredNorm() > config_.window_radius_m * config_.window_radius_m) return false;
  const double z0 = b.z * side, z1 = z0 + side;
  return z1 > cycle_robot_m_.z() - config_.slab_below_m && z0 < cycle_robot_m_.z() + config_.slab_above_m;
}

// Config::keep_edges_at_rim_m: whether a point lies within that distance of the window's sphere around the
// cycle's robot position.
bool Places::at_window_rim(const Eigen::Vector3d& p) const {
  const double margin = config_.keep_edges_at_rim_m;
  if (!(margin > 0.0)) return false;
  return config_.window_radius_m - (p - cycle_robot_m_).norm() < margin;
}

memory::Index3 Places::cell_of(std::uint32_t ref) const {
  const Eigen::Vector3d p = center_m(coords(ref)) / config_.place_resolution_m;
  return {static_cast<std::int32_t>(std::floor(p.x())), static_cast<std::int32_t>(std::floor(p.y())),
          static_cast<std::int32_t>(std::floor(p.z()))};
}

// ---------------------------------------------------------------------------------------------------------
// Worklists

void Places::push_lower(std::uint32_t ref) {
  Voxel& v = vox(ref);
  if ((v.flags & kInLower) != 0 || blocks_[ref / kBlockVoxels].dying) return;
  // Each voxel is queued at most once (flag), so the ring holding one slot per voxel never overflows.
  v.flags |= kInLower;
  lower_ring_[(lower_head_ + lower_size_) % lower_capacity_] = ref;
  ++lower_size_;
  if (lower_size_ > lower_high_water_) lower_high_water_ = lower_size_;
}

void Places::push_raise(std::uint32_t ref) {
  Voxel& v = vox(ref);
  if ((v.flags & kInRaise) != 0 || blocks_[ref / kBlockVoxels].dying) return;
  v.flags |= kInRaise;
  lists_[kRaiseList].push(ref);
}

void Places::mark_affected(std::uint32_t ref) {
  Voxel& v = vox(ref);
  if ((v.flags & kAffected) != 0 || blocks_[ref / kBlockVoxels].dying) return;
  v.flags |= kAffected;
  lists_[kAffectedList].push(ref);
}

// ---------------------------------------------------------------------------------------------------------
// Parent lists

void Places::set_parent(std::uint32_t ref, std::uint32_t parent, float distance_m) {
  Voxel& v = vox(ref);
  if (v.parent != parent || (v.aux & kOrphan) != 0) {
    clear_parent(ref);
    if (parent != ref) {
      Voxel& p = vox(parent);
      v.prev = parent;
      v.next = p.next;
      if (p.next != kNoRef) vox(p.next).prev = ref;
      p.next = ref;
    }
    v.parent = parent;
  }
  v.distance_m = distance_m;
}

void Places::clear_parent(std::uint32_t ref) {
  Voxel& v = vox(ref);
  v.aux &= static_cast<std::uint8_t>(~kOrphan);
  if (v.parent == kNoRef) return;
  if (v.parent != ref) {
    if (v.prev != kNoRef) vox(v.prev).next = v.next;
    if (v.next != kNoRef) vox(v.next).prev = v.prev;
    v.prev = kNoRef;
    v.next = kNoRef;
  }
  v.parent = kNoRef;
  v.distance_m = kUnreached;
}

// Unlinks every voxel whose distance came from parent_ref (its list of dependents) and hands each to fn(ref, voxel).
template <typename Fn>
void Places::detach_dependents(std::uint32_t parent_ref, Fn&& fn) {
  Voxel& s = vox(parent_ref);
  std::uint32_t d = s.next;
  while (d != kNoRef) {
    Voxel& dv = vox(d);
    const std::uint32_t next = dv.next;
    dv.prev = kNoRef;
    dv.next = kNoRef;
    fn(d, dv);
    d = next;
  }
  s.next = kNoRef;
}

// Every voxel whose distance came from this seed is reset and queued for the raise wave, which hands the hole
// back to the neighbours that still have valid parents (FIESTA-style: exact, no stale distances remain).
void Places::raise_dependents(std::uint32_t seed_ref, bool include_seed) {
  detach_dependents(seed_ref, [&](std::uint32_t d, Voxel& dv) {
    dv.parent = kNoRef;
    dv.distance_m = kUnreached;
    push_raise(d);
    mark_affected(d);
    ++counters_.voxels_raised;
  });
  if (include_seed) {
    Voxel& s = vox(seed_ref);
    s.parent = kNoRef;
    s.distance_m = kUnreached;
    s.aux &= static_cast<std::uint8_t>(~kOrphan);
  }
}

// The dependents of a voxel whose block is leaving the window: those in blocks that stay keep their distance and
// become their own parents (orphans, see Config::keep_distances_at_rim); those in dying blocks are just unlinked.
void Places::orphan_dependents(std::uint32_t parent_ref) {
  detach_dependents(parent_ref, [&](std::uint32_t d, Voxel& dv) {
    if (blocks_[d / kBlockVoxels].dying) {
      dv.parent = kNoRef;
      dv.distance_m = kUnreached;
    } else {
      dv.parent = d;
      dv.aux |= kOrphan;
      ++counters_.voxels_orphaned;
    }
  });
  Voxel& s = vox(parent_ref);
  s.parent = kNoRef;
  s.distance_m = kUnreached;
  s.aux &= static_cast<std::uint8_t>(~kOrphan);
}

void Places::apply_state(std::uint32_t ref, std::uint8_t state, float seed_m) {
  Voxel& v = vox(ref);
  const std::uint8_t old = v.state;
  if (state == kSeed) {
    if (old == kSeed) {
      if (std::fabs(seed_m - v.distance_m) < kEps) return;
      // Reset and refill the dependents: exact whichever way the seed moved (a dependent reached through a
      // voxel that has since taken another parent would otherwise keep a stale distance).
      raise_dependents(ref, false);
      v.distance_m = seed_m;
    } else {
      if (v.parent == ref) raise_dependents(ref, true);  // a frontier or occupied seed: its dependents go with it
      else clear_parent(ref);
      v.state = kSeed;
      set_parent(ref, ref, seed_m);
    }
    push_lower(ref);
    mark_affected(ref);
    ++counters_.voxels_updated;
    return;
  }
  if (state == old) return;
  // A seed, or a frontier or occupied seed (its own parent, see lower_step), hands its dependents back.
  if (old == kSeed || v.parent == ref) raise_dependents(ref, true);
  else clear_parent(ref);
  v.state = state;
  v.distance_m = kUnreached;
  mark_affected(ref);
  ++counters_.voxels_updated;
  if (state == kFree) push_raise(ref);  // refilled from its neighbours
}

// ---------------------------------------------------------------------------------------------------------
// Blocks

// Distance from the centre of the ESDF voxel whose first TSDF voxel is (x0, y0, z0) of TSDF block `tb` to the
// surface, from the TSDF's zero crossings: along each axis, each of the factor^2 TSDF columns through the voxel is
// searched outwards from the centre (up to two TSDF voxels beyond the ESDF voxel) for the nearest sign change,
// interpolated linearly; d_a is the mean crossing distance of the columns that have one. A plane at distance d
// with normal n crosses axis a at d / |n_a|, so d = 1 / sqrt(sum 1 / d_a^2) over the axes with a crossing
// (exact for a plane; nearer for corners). Interpolation uses ratios of TSDF values, so the projective
// overestimate cancels. False when no column crosses.
bool Places::crossing_distance(const reconstruction::SemanticTsdf& tsdf, const memory::Index3& tb, int x0, int y0,
                               int z0, float* distance_m) const {
  const int f = config_.voxel_factor;
  constexpr int kSide = reconstruction::kBlockSide;
  const std::uint16_t min_w = static_cast<std::uint16_t>(
      std::min(65535.0, std::floor(config_.min_tsdf_weight * reconstruction::kWeightScale)));
  // TSDF blocks around tb, looked up once each on first use.
  bool looked[27] = {};
  const reconstruction::Voxel* voxels[27] = {};
  const auto sample = [&](int x, int y, int z, float* value) {
    const int bx = x < 0 ? -1 : (x >= kSide ? 1 : 0), by = y < 0 ? -1 : (y >= kSide ? 1 : 0),
              bz = z < 0 ? -1 : (z >= kSide ? 1 : 0);
    const int slot = (bx + 1) + 3 * ((by + 1) + 3 * (bz + 1));
    if (!looked[slot]) {
      looked[slot] = true;
      const std::uint32_t handle = tsdf.find_block({tb.x + bx, tb.y + by, tb.z + bz});
      reconstruction::SemanticTsdf::BlockView view;
      if (handle != memory::kInvalidHandle && tsdf.block_view(handle, &view)) voxels[slot] = view.voxels;
    }
    if (voxels[slot] == nullptr) return false;
    const reconstruction::Voxel& v =
        voxels[slot][(x - bx * kSide) + kSide * ((y - by * kSide) + kSide * (z - bz * kSide))];
    if (v.weight_q <= min_w) return false;
    *value = tsdf.sdf_m(v);
    return true;
  };
  const float tv = static_cast<float>(tsdf_voxel_m_);
  const float centre = 0.5f * static_cast<float>(f);  // the ESDF voxel's centre, in TSDF voxels from (x0, y0, z0)
  float inv_sq = 0.0f;
  for (int axis = 0; axis < 3; ++axis) {
    float sum = 0.0f;
    int count = 0;
    for (int u = 0; u < f; ++u)
      for (int w = 0; w < f; ++w) {
        // Samples along the column at TSDF offsets k = -2 .. f + 1 (centres at k + 0.5).
        float best = std::numeric_limits<float>::infinity();
        float prev = 0.0f;
        bool have_prev = false;
        for (int k = -2; k <= f + 1; ++k) {
          int c[3];
          c[axis] = k;
          c[(axis + 1) % 3] = u;
          c[(axis + 2) % 3] = w;
          float value = 0.0f;
          if (!sample(x0 + c[0], y0 + c[1], z0 + c[2], &value)) {
            have_prev = false;
            continue;
          }
          if (have_prev && (prev > 0.0f) != (value > 0.0f)) {
            const float at = static_cast<float>(k) - 0.5f + prev / (prev - value);  // crossing, in TSDF voxels
            best = std::min(best, std::fabs(at - centre));
          }
          prev = value;
          have_prev = true;
        }
        if (best < std::numeric_limits<float>::infinity()) {
          sum += best;
          ++count;
        }
      }
    if (count > 0) {
      const float d = std::max(1e-3f, sum / static_cast<float>(count) * tv);
      inv_sq += 1.0f / (d * d);
    }
  }
  if (inv_sq <= 0.0f) return false;
  *distance_m = 1.0f / std::sqrt(inv_sq);
  return true;
}

// Classifies the ESDF voxels covered by one TSDF block (sub-block `sub` of the ESDF block). An ESDF voxel
// averages its factor^3 TSDF voxels (its centre is their common corner, where the mean is the TSDF's trilinear
// value): unobserved when none is observed (free if carved), free at the truncation distance, a seed inside the
// band (and on a zero crossing), occupied behind the surface.
void Places::seed_sub_block(const reconstruction::SemanticTsdf& tsdf, std::uint32_t handle, int sub, bool carve) {
  const int f = config_.voxel_factor;
  Block& b = blocks_[handle];
  const int sx = sub % f, sy = (sub / f) % f, sz = sub / (f * f);
  const memory::Index3 tb{b.index.x * f + sx, b.index.y * f + sy, b.index.z * f + sz};
  const std::uint32_t th = tsdf.find_block(tb);
  reconstruction::SemanticTsdf::BlockView view;
  if (th == memory::kInvalidHandle || !tsdf.block_view(th, &view)) return;  // archived or never seen: keep
  b.tsdf_stamp[sub] = view.integrated_stamp;
  b.tsdf_seen[sub] = 1;
  // The views that saw this block: those observe() recorded for the cycle, else (no observe() calls) the latest
  // frame from the robot's position when the block was part of it.
  const int cycle_set = 1 - pending_;
  std::uint32_t seen_by = 0;
  if (carve && num_views_[cycle_set] > 0) {
    const std::uint32_t* mask = observed_[cycle_set].find(tb);
    seen_by = mask != nullptr ? *mask : 0u;
  }
  const bool legacy = carve && !observing_ && view.integrated_stamp == tsdf.frame_stamp();
  carve = seen_by != 0 || legacy;
  ++counters_.tsdf_blocks_read;
  const int n = kBlockSide / f;  // ESDF voxels per side of the TSDF block
  const std::uint16_t min_w = static_cast<std::uint16_t>(
      std::min(65535.0, std::floor(config_.min_tsdf_weight * reconstruction::kWeightScale)));
  const float clamp_m = tsdf_trunc_m_ * 0.999f;
  for (int ez = 0; ez < n; ++ez)
    for (int ey = 0; ey < n; ++ey)
      for (int ex = 0; ex < n; ++ex) {
        int observed = 0, positive = 0;
        float sum = 0.0f;
        for (int kz = 0; kz < f; ++kz)
          for (int ky = 0; ky < f; ++ky)
            for (int kx = 0; kx < f; ++kx) {
              const int tx = ex * f + kx, ty = ey * f + ky, tz = ez * f + kz;
              const reconstruction::Voxel& tv =
                  view.voxels[tx + reconstruction::kBlockSide * (ty + reconstruction::kBlockSide * tz)];
              if (tv.weight_q <= min_w) continue;
              const float s = tsdf.sdf_m(tv);
              sum += s;
              ++observed;
              positive += s > 0.0f ? 1 : 0;
            }
        const int local = (sx * n + ex) + kBlockSide * ((sy * n + ey) + kBlockSide * (sz * n + ez));
        const std::uint32_t ref = make_ref(handle, local);
        std::uint8_t state = (vox(ref).flags & kCarved) != 0 ? kFree : kUnobserved;
        float seed = 0.0f;
        if (observed > 0) {
          float mean = sum / static_cast<float>(observed);
          // The TSDF's projective distances (along camera rays) overestimate the distance to a surface seen at a
          // grazing angle by 1/sin(angle): a floor seen 2 m ahead from 0.5 m, x4, up to the truncation. Seeds
          // that far off put every voxel near a floor or a ceiling farther from it than it is, and raise GVD
          // sheets between patches of the same floor. Where the zero crossing is found near the voxel, its
          // position (interpolated, so the projective scale cancels) gives the Euclidean distance instead.
          if (config_.correct_projective_distance && mean < clamp_m) {
            float d = 0.0f;
            if (crossing_distance(tsdf, tb, ex * f, ey * f, ez * f, &d)) mean = std::copysign(d, mean);
          }
          if (mean >= clamp_m) {
            state = kFree;
          } else if (mean > 0.0f) {
            state = kSeed;
            seed = mean;
          } else if (positive > 0) {
            // A zero crossing inside the voxel: the surface itself, a seed (the TSDF's projective distances
            // overestimate at grazing angles, so the band alone can miss a surface seen obliquely), at the signed
            // distance of its centre behind the surface (<= 0; 0 when signed_surface_seeds is off).
            state = kSeed;
            if (config_.signed_surface_seeds) seed = std::max(mean, -0.5f * static_cast<float>(voxel_m_));
          } else {
            state = kOccupied;
          }
        }
        apply_state(ref, state, seed);
        // Seen from the camera: the space between holds nothing.
        if (carve && (state == kSeed || (state == kFree && observed > 0))) {
          if (legacy) carve_ray(tsdf, cycle_robot_m_, ref);
          for (int k = 0; k < num_views_[cycle_set]; ++k)
            if ((seen_by >> k) & 1u) carve_ray(tsdf, views_m_[cycle_set][k], ref);
        }
      }
}

// Marks the voxels between the robot and a voxel it has just observed as free (stops at anything the TSDF
// knows as occupied). Samples the segment every half voxel; allocates blocks on the way inside the window.
void Places::carve_ray(const reconstruction::SemanticTsdf& tsdf, const Eigen::Vector3d& origin_m,
                       std::uint32_t target) {
  ++counters_.rays_carved;
  const memory::Index3 goal = coords(target);
  const Eigen::Vector3d b = center_m(goal);
  const Eigen::Vector3d a = origin_m;
  const double len = (b - a).norm();
  const int steps = static_cast<int>(std::ceil(len / (0.5 * voxel_m_)));
  memory::Index3 last{std::numeric_limits<std::int32_t>::min(), 0, 0};
  for (int i = 0; i < steps; ++i) {
    const Eigen::Vector3d p = (a + (b - a) * (static_cast<double>(i) / steps)) / voxel_m_;
    const memory::Index3 g{static_cast<std::int32_t>(std::floor(p.x())), static_cast<std::int32_t>(std::floor(p.y())),
                           static_cast<std::int32_t>(std::floor(p.z()))};
    if (g == last) continue;
    last = g;
    if (g == goal) break;
    ++units_;
    std::uint32_t ref = find_voxel(g);
    if (ref == kNoRef) {
      const memory::Index3 blk{floor_div(g.x, kBlockSide), floor_div(g.y, kBlockSide), floor_div(g.z, kBlockSide)};
      if (allocate_block(tsdf, blk, true) == memory::kInvalidHandle) continue;
      ref = find_voxel(g);
      if (ref == kNoRef) continue;
    }
    Voxel& v = vox(ref);
    if (v.state == kOccupied) break;
    if ((v.flags & kCarved) != 0) continue;
    v.flags |= kCarved;
    if (v.state == kUnobserved) apply_state(ref, kFree, 0.0f);
  }
}

std::uint32_t Places::allocate_block(const reconstruction::SemanticTsdf& tsdf, const memory::Index3& index,
                                     bool read_tsdf) {
  if (const std::uint32_t* h = block_index_.find(index)) return *h;
  if (!block_in_window(index)) return memory::kInvalidHandle;
  const std::uint32_t h = blocks_.acquire();
  if (h == memory::kInvalidHandle) {
    ++counters_.blocks_refused;
    return h;
  }
  if (block_index_.insert(index, h) == nullptr) {
    blocks_.release(h);
    ++counters_.blocks_refused;
    return memory::kInvalidHandle;
  }
  Block& b = blocks_[h];
  b.index = index;
  for (int k = 0; k < 27; ++k) b.nbr[k] = memory::kInvalidHandle;
  b.nbr[13] = h;
  std::fill(std::begin(b.tsdf_stamp), std::end(b.tsdf_stamp), 0u);
  std::fill(std::begin(b.tsdf_seen), std::end(b.tsdf_seen), std::uint8_t{0});
  b.dying = 0;
  for (const Offset& o : kOffsets.o) {
    const std::uint32_t* n = block_index_.find(add(index, o.dx, o.dy, o.dz));
    if (n == nullptr) continue;
    b.nbr[o.block_slot] = *n;
    blocks_[*n].nbr[26 - o.block_slot] = h;
  }
  ++counters_.blocks_allocated;
  const int f = config_.voxel_factor;
  if (read_tsdf)
    for (int sub = 0; sub < f * f * f; ++sub) seed_sub_block(tsdf, h, sub, false);
  // Wavefronts of the neighbours flow into the new block: queue their valid voxels along its faces.
  for (int local = 0; local < kBlockVoxels; ++local) {
    const int x = local & 7, y = (local >> 3) & 7, z = local >> 6;
    if (x != 0 && x != 7 && y != 0 && y != 7 && z != 0 && z != 7) continue;
    const std::uint32_t ref = make_ref(h, local);
    for (const Offset& o : kOffsets.o) {
      const std::uint32_t n = neighbor(ref, o.dx, o.dy, o.dz);
      if (n == kNoRef || n / kBlockVoxels == h) continue;
      if (is_source(n)) push_lower(n);
    }
  }
  return h;
}

// Called for every dying block before any is released: detaches its voxels from lists, parents and clusters.
void Places::evict_block_voxels(std::uint32_t handle) {
  for (int local = 0; local < kBlockVoxels; ++local) {
    const std::uint32_t ref = make_ref(handle, local);
    Voxel& v = vox(ref);
    if (v.cluster != kNoCluster) {
      const std::uint32_t c = v.cluster;
      cluster_remove_voxel(c, ref);
      if (clusters_[c].count == 0) retire_cluster(c, kLeft);
      else clusters_[c].dirty = 1;
    }
    if ((v.flags & kGvd) != 0 && counters_.gvd_voxels > 0) --counters_.gvd_voxels;
    if (v.state == kSeed || v.parent == ref) {
      // Dependents outside the dying blocks lose their parent (frontier, occupied and orphan parents too). The
      // obstacle is still there, only outside the window: they keep their distance as orphans. Off, they are
      // raised like the dependents of a vanished seed (push_raise is a no-op for the dying blocks' own voxels).
      if (config_.keep_distances_at_rim) orphan_dependents(ref);
      else raise_dependents(ref, /*include_seed=*/true);
    } else {
      clear_parent(ref);
    }
    v.flags = 0;
    v.aux = 0;
  }
}

void Places::release_block(std::uint32_t handle) {
  Block& b = blocks_[handle];
  for (const Offset& o : kOffsets.o) {
    const std::uint32_t n = b.nbr[o.block_slot];
    if (n != memory::kInvalidHandle) blocks_[n].nbr[26 - o.block_slot] = memory::kInvalidHandle;
  }
  block_index_.erase(b.index);
  blocks_.release(handle);
  ++counters_.blocks_freed;
}

void Places::begin_cycle(const reconstruction::SemanticTsdf& tsdf, const Eigen::Vector3d& robot_m) {
  cycle_robot_m_ = robot_m;
  voxel_m_ = tsdf.config().voxel_size_m * config_.voxel_factor;
  tsdf_voxel_m_ = tsdf.config().voxel_size_m;
  tsdf_trunc_m_ = static_cast<float>(tsdf.config().voxel_size_m * tsdf.config().truncation_voxels);
  // Blocks that left the window: detach all of them first (parents may sit in another dying block), then free.
  bool any = false;
  blocks_.for_each([&](std::uint32_t, Block& b) {
    b.dying = block_in_window(b.index) ? 0 : 1;
    any = any || b.dying;
  });
  if (any) {
    for (std::uint32_t h = 0; h < blocks_.capacity(); ++h)
      if (blocks_.live(h) && blocks_[h].dying) evict_block_voxels(h);
    for (std::uint32_t h = 0; h < blocks_.capacity(); ++h)
      if (blocks_.live(h) && blocks_[h].dying) release_block(h);
  }
  // The views observed since the last cycle become this cycle's; observe() fills the other set meanwhile.
  pending_ = 1 - pending_;
  observed_[pending_].clear();
  num_views_[pending_] = 0;
  const int cycle_set = 1 - pending_;
  // TSDF blocks integrated since they were last read, and those a view of this cycle saw (already read when a
  // cycle that started before their frame read them after it).
  List& dirty = lists_[kDirtyList];
  dirty.clear();
  const int f = config_.voxel_factor;
  tsdf.for_each_block([&](std::uint32_t, const reconstruction::SemanticTsdf::BlockView& view) {
    ++units_;
    const bool viewed = num_views_[cycle_set] > 0 && observed_[cycle_set].find(view.index) != nullptr;
    const memory::Index3 e{floor_div(view.index.x, f), floor_div(view.index.y, f), floor_div(view.index.z, f)};
    if (!block_in_window(e)) return;
    std::uint32_t h = memory::kInvalidHandle;
    if (const std::uint32_t* found = block_index_.find(e)) h = *found;
    else h = allocate_block(tsdf, e, false);  // its TSDF blocks are read (and carved to) in the seed phase
    if (h == memory::kInvalidHandle) return;
    const int sub = (view.index.x - e.x * f) + f * ((view.index.y - e.y * f) + f * (view.index.z - e.z * f));
    const Block& b = blocks_[h];
    if (!b.tsdf_seen[sub] || b.tsdf_stamp[sub] != view.integrated_stamp || viewed)
      dirty.push(h * static_cast<std::uint32_t>(kMaxVoxelFactor * kMaxVoxelFactor * kMaxVoxelFactor) +
                 static_cast<std::uint32_t>(sub));
  });
}

bool Places::observe(const reconstruction::SemanticTsdf& tsdf, const Eigen::Isometry3d& world_T_camera) {
  if (!ready_) return false;
  ++counters_.views_observed;
  observing_ = true;
  const std::uint32_t stamp = tsdf.frame_stamp();
  int& n = num_views_[pending_];
  int k = n;
  if (n > 0 && view_stamp_[pending_][n - 1] == stamp) {
    k = n - 1;  // the same frame again
  } else if (n == kMaxViews) {
    k = kMaxViews - 1;  // every slot used: the newest view takes the last slot (its blocks keep their bit)
    ++counters_.views_merged;
  } else {
    ++n;
  }
  views_m_[pending_][k] = world_T_camera.translation();
  view_stamp_[pending_][k] = stamp;
  const std::uint32_t bit = 1u << k;
  memory::SpatialHash<std::uint32_t>& set = observed_[pending_];
  tsdf.for_each_block([&](std::uint32_t, const reconstruction::SemanticTsdf::BlockView& view) {
    if (view.integrated_stamp != stamp) return;
    bool inserted = false;
    std::uint32_t* mask = set.find_or_insert(view.index, bit, &inserted);
    if (mask == nullptr) ++counters_.observed_refused;
    else if (!inserted) *mask |= bit;
  });
  return true;
}

// ---------------------------------------------------------------------------------------------------------
// Waves

void Places::raise_step(std::uint32_t ref) {
  Voxel& v = vox(ref);
  v.flags &= static_cast<std::uint8_t>(~kInRaise);
  if (is_source(ref)) push_lower(ref);
  for (const Offset& o : kOffsets.o) {
    const std::uint32_t n = neighbor(ref, o.dx, o.dy, o.dz);
    if (n == kNoRef) continue;
    if (is_source(n)) push_lower(n);
  }
}

void Places::lower_step(const reconstruction::SemanticTsdf& tsdf, std::uint32_t ref) {
  Voxel& v = vox(ref);
  v.flags &= static_cast<std::uint8_t>(~kInLower);
  if (!is_source(ref)) return;
  const std::uint32_t parent = v.parent;
  const memory::Index3 pc = coords(parent);
  const float pd = vox(parent).distance_m;
  const memory::Index3 g = coords(ref);
  const float max_d = static_cast<float>(config_.max_distance_m);
  const float s = static_cast<float>(voxel_m_);
  for (const Offset& o : kOffsets.o) {
    const memory::Index3 gn = add(g, o.dx, o.dy, o.dz);
    const float cand = pd + dist_vox(gn, pc) * s;
    if (cand > max_d) continue;
    std::uint32_t n = neighbor(ref, o.dx, o.dy, o.dz);
    if (n == kNoRef) {
      // The wavefront reaches space no ESDF block holds yet: allocate it inside the window.
      const memory::Index3 nb{floor_div(gn.x, kBlockSide), floor_div(gn.y, kBlockSide), floor_div(gn.z, kBlockSide)};
      if (allocate_block(tsdf, nb, true) == memory::kInvalidHandle) continue;
      n = neighbor(ref, o.dx, o.dy, o.dz);
      if (n == kNoRef) continue;
    }
    Voxel& nv = vox(n);
    if (v.state == kFree && nv.parent == kNoRef && !blocks_[n / kBlockVoxels].dying &&
        ((nv.state == kUnobserved && config_.unobserved_is_obstacle &&
          (gn.z + 1) * voxel_m_ <= cycle_robot_m_.z() + config_.unobserved_obstacle_above_m) ||
         nv.state == kOccupied)) {
      // Free space meets space no sensor has seen: a surface may lie right there. The unobserved voxel becomes a
      // frontier seed at distance 0, so distances here are bounded by it (unknown space counts as an obstacle);
      // the GVD ignores frontier basis points (evaluate_gvd), so no sheet forms between a surface and the unknown.
      // Free space right beside space behind a surface (a floor seen only at a grazing angle leaves no band voxel
      // between them) has the surface within a voxel: the occupied voxel is a seed at distance 0, a real one.
      set_parent(n, n, 0.0f);
      push_lower(n);
      ++(nv.state == kOccupied ? counters_.occupied_seeds : counters_.frontier_seeds);
      continue;
    }
    if (nv.state != kFree) continue;
    // An orphan takes a real parent again when the wave offers about its distance (within half a voxel: the same
    // obstacle, re-read, or one as near); its own dependents are refilled first (their lists hang off it).
    const bool adopt = (nv.aux & kOrphan) != 0 && cand <= nv.distance_m + 0.5f * s;
    if (cand + kEps < nv.distance_m || adopt) {
      if ((nv.aux & kOrphan) != 0) raise_dependents(n, false);
      set_parent(n, parent, cand);
      push_lower(n);
      mark_affected(n);
      ++counters_.voxels_updated;
    }
  }
}

// ---------------------------------------------------------------------------------------------------------
// GVD

// The number of basis points of a voxel (0 when it cannot be on the GVD). Following the brushfire GVD of Lau et
// al., a voxel is where wavefronts meet when a neighbour's parent is a different obstacle (not adjacent to this
// voxel's parent) and this voxel is at least as close to being equidistant from both parents as the neighbour
// is (so the GVD is one voxel thick, both voxels only on exact ties). The theta-SMA keeps a basis point only when
// it makes an angle >= theta with every other basis point seen from the voxel.
int Places::evaluate_gvd(std::uint32_t ref, std::uint32_t* basis_parents, int max_parents) const {
  const Voxel& v = vox(ref);
  if (v.state != kFree || v.parent == kNoRef || v.distance_m < static_cast<float>(config_.min_clearance_m)) return 0;
  // Nearer unknown space than any surface: the true clearance and the true GVD are not known here.
  if (vox(v.parent).state == kUnobserved) return 0;
  // Beside an orphan (its obstacle left the window) the basis points are not known: keep the state, as at the rim.
  if ((v.aux & kOrphan) != 0 || (vox(v.parent).aux & kOrphan) != 0) return kRim;
  const memory::Index3 g = coords(ref);
  const memory::Index3 pv = coords(v.parent);
  const float pv_d = vox(v.parent).distance_m;
  const float s = static_cast<float>(voxel_m_);
  const Eigen::Vector3f a(static_cast<float>(pv.x - g.x), static_cast<float>(pv.y - g.y), static_cast<float>(pv.z - g.z));
  const float la = a.norm();
  if (la <= 0.0f) return 0;
  Eigen::Vector3f dirs[kMaxBasis];
  std::uint32_t parents[kMaxBasis];
  int count = 1;
  dirs[0] = a / la;
  parents[0] = v.parent;
  for (const Offset& o : kOffsets.o) {
    const std::uint32_t n = neighbor(ref, o.dx, o.dy, o.dz);
    // At the window's vertical rim (the block above or below left the window, or never fit in it) the floor or
    // ceiling beyond is not known here: the distance is an upper bound (kRim: gvd_step adds no GVD voxel here and
    // keeps the ones it has, whose places leave the window as they were). See Config::rim_guard.
    if (n == kNoRef) {
      if (config_.rim_guard && o.dz != 0) return kRim;
      continue;
    }
    const Voxel& nv = vox(n);
    if ((nv.state != kFree && nv.state != kSeed) || nv.parent == kNoRef || nv.parent == v.parent) continue;
    if ((nv.aux & kOrphan) != 0 || (vox(nv.parent).aux & kOrphan) != 0) return kRim;
    if (vox(nv.parent).state == kUnobserved) continue;  // a frontier is not a basis point
    const memory::Index3 pn = coords(nv.parent);
    // The same obstacle: adjacent seeds, or a band seed (distance > 0, one voxel off its surface) and a surface
    // seed two voxels away: a flat ceiling's band layer and its surface layer, seen from just beneath, would
    // otherwise look like two obstacles 45-50 degrees apart and raise a sheet under every ceiling.
    const int same_reach = 1 + ((pv_d > 0.0f) != (vox(nv.parent).distance_m > 0.0f) ? 1 : 0);
    if (chebyshev(pn, pv) <= same_reach) continue;
    const Eigen::Vector3f b(static_cast<float>(pn.x - g.x), static_cast<float>(pn.y - g.y), static_cast<float>(pn.z - g.z));
    const float lb = b.norm();
    if (lb <= 0.0f || a.dot(b) > la * lb * cos_theta_) continue;
    if (nv.state == kFree) {
      const float s_vn = vox(nv.parent).distance_m + lb * s - v.distance_m;
      const float s_nv = pv_d + dist_vox(add(g, o.dx, o.dy, o.dz), pv) * s - nv.distance_m;
      if (s_vn > s_nv + 1e-5f) continue;  // the neighbour is nearer the bisector: it is the GVD voxel
    }
    const Eigen::Vector3f u = b / lb;
    bool distinct = true;
    for (int k = 0; k < count && distinct; ++k) distinct = u.dot(dirs[k]) <= cos_theta_;
    if (distinct && count < kMaxBasis) {
      dirs[count] = u;
      parents[count] = nv.parent;
      ++count;
    }
  }
  for (int k = 0; k < count && k < max_parents; ++k) basis_parents[k] = parents[k];
  return count;
}

void Places::gvd_step(std::uint32_t ref) {
  Voxel& v = vox(ref);
  v.flags &= static_cast<std::uint8_t>(~kEval);
  const int nb = evaluate_gvd(ref, nullptr, 0);
  if (nb == kRim && (v.flags & kGvd) != 0) return;  // keeps its state until its block leaves the window
  const bool is = nb >= config_.min_basis_points;
  const bool was = (v.flags & kGvd) != 0;
  const std::uint8_t basis = static_cast<std::uint8_t>(is ? nb : 0);
  if (is == was && basis == v.num_basis) return;
  if (is && !was) {
    v.flags |= kGvd;
    ++counters_.gvd_voxels;
  } else if (!is && was) {
    v.flags &= static_cast<std::uint8_t>(~kGvd);
    if (counters_.gvd_voxels > 0) --counters_.gvd_voxels;
  }
  v.num_basis = basis;
  if ((v.flags & kGvdChanged) == 0) {
    v.flags |= kGvdChanged;
    lists_[kChangedList].push(ref);
  }
}

// ---------------------------------------------------------------------------------------------------------
// Places sparsification

std::uint32_t Places::new_cluster(const memory::Index3& cell) {
  const std::uint32_t h = clusters_.acquire();
  if (h == memory::kInvalidHandle) return h;
  Cluster& c = clusters_[h];
  c.cell = cell;
  // Back in a cell a place left when it went out of the window: the inactive node comes back to life.
  c.revived = 0;
  c.merge_check = 0;
  if (const scene_graph::NodeId old = take_inactive(cell); old != scene_graph::kNoNode) {
    c.node = old;
    c.synced = 1;
    c.revived = 1;
    ++counters_.reactivated;
  } else {
    c.node = scene_graph::make_node_id(scene_graph::kPlacePrefix, next_node_index_++);
  }
  link_cell(h);
  ++clusters_live_;
  counters_.places = clusters_live_;
  return h;
}

// Live clusters per hash cell (an intrusive list headed in cells_): the neighbourhood queries of free-space edges
// and relinks visit 27 cells instead of every cluster.
void Places::link_cell(std::uint32_t cluster) {
  Cluster& c = clusters_[cluster];
  std::uint32_t* head = cells_.find(c.cell);
  c.cell_next = head != nullptr ? *head : kNoCluster;
  if (cells_.insert(c.cell, cluster) == nullptr) c.cell_next = kNoCluster;  // full: counted by the map
}

void Places::unlink_cell(std::uint32_t cluster) {
  Cluster& c = clusters_[cluster];
  std::uint32_t* head = cells_.find(c.cell);
  if (head == nullptr) return;
  if (*head == cluster) {
    if (c.cell_next == kNoCluster) cells_.erase(c.cell);
    else *head = c.cell_next;
  } else {
    for (std::uint32_t h = *head; h != kNoCluster; h = clusters_[h].cell_next)
      if (clusters_[h].cell_next == cluster) {
        clusters_[h].cell_next = c.cell_next;
        break;
      }
  }
  c.cell_next = kNoCluster;
}

void Places::cluster_add_voxel(std::uint32_t cluster, std::uint32_t ref) {
  Voxel& v = vox(ref);
  Cluster& c = clusters_[cluster];
  v.cluster = cluster;
  v.cluster_next = c.head;
  c.head = ref;
  ++c.count;
}

void Places::cluster_remove_voxel(std::uint32_t cluster, std::uint32_t ref) {
  Cluster& c = clusters_[cluster];
  std::uint32_t* link = &c.head;
  while (*link != kNoRef && *link != ref) link = &vox(*link).cluster_next;
  if (*link == ref) {
    *link = vox(ref).cluster_next;
    --c.count;
  }
  Voxel& v = vox(ref);
  v.cluster = kNoCluster;
  v.cluster_next = kNoRef;
  if (c.rep == ref) c.rep = kNoRef;
}

void Places::drop_edge(std::uint32_t cluster, std::uint32_t other) {
  Cluster& c = clusters_[cluster];
  for (int k = 0; k < c.num_edges; ++k) {
    if (c.edge_to[k] != other) continue;
    --c.num_edges;
    c.edge_to[k] = c.edge_to[c.num_edges];
    c.edge_weight[k] = c.edge_weight[c.num_edges];
    c.edge_free[k] = c.edge_free[c.num_edges];
    c.sync_dirty = 1;
    c.bridge_check = 1;
    return;
  }
}

// A cluster without voxels: its node is removed (kRemoved) or kept inactive (kLeft, left the window) by the next
// sync(); the slot waits for that sync unless the node never reached the graph.
void Places::retire_cluster(std::uint32_t cluster, std::uint8_t state) {
  Cluster& c = clusters_[cluster];
  if (c.revived) {
    // It brought its cell's inactive node back but goes before the sync that would check and publish it: the node
    // was never touched, so it returns to its cell as it was. (Removing it would delete a place that another
    // free space, e.g. the floor below, still holds.) A place that leaves the window re-parks it below.
    c.revived = 0;
    if (counters_.reactivated > 0) --counters_.reactivated;
    if (state == kRemoved) {
      park_inactive(c.cell, c.node);
      c.node = scene_graph::kNoNode;
      c.synced = 0;
    }
  }
  for (int k = 0; k < c.num_edges; ++k) drop_edge(c.edge_to[k], cluster);
  c.num_edges = 0;
  unlink_cell(cluster);
  // Members (a merge moves them first) are detached by the caller; clear what is left.
  for (std::uint32_t r = c.head; r != kNoRef;) {
    Voxel& v = vox(r);
    const std::uint32_t next = v.cluster_next;
    v.cluster = kNoCluster;
    v.cluster_next = kNoRef;
    r = next;
  }
  c.head = kNoRef;
  c.count = 0;
  c.rep = kNoRef;
  c.dirty = 0;
  c.state = state;
  if (clusters_live_ > 0) --clusters_live_;
  counters_.places = clusters_live_;
  if (state == kLeft && c.synced) park_inactive(c.cell, c.node);  // refused (counted) when full
  if (!c.synced) clusters_.release(cluster);
}

void Places::merge_clusters(std::uint32_t into, std::uint32_t from) {
  Cluster& a = clusters_[into];
  Cluster& b = clusters_[from];
  std::uint32_t tail = kNoRef;
  for (std::uint32_t r = b.head; r != kNoRef; r = vox(r).cluster_next) {
    vox(r).cluster = into;
    tail = r;
  }
  if (tail != kNoRef) {
    vox(tail).cluster_next = a.head;
    a.head = b.head;
    a.count += b.count;
  }
  b.head = kNoRef;
  b.count = 0;
  if (b.revived && !a.synced) {
    // The merged place takes over the revival (both lie in one hash cell): the next sync checks it from the
    // merged place's position, instead of a fresh node beside the inactive one.
    a.node = b.node;
    a.synced = 1;
    a.revived = 1;
    b.node = scene_graph::kNoNode;
    b.synced = 0;
    b.revived = 0;
  }
  retire_cluster(from, kRemoved);
  a.dirty = 1;
  ++counters_.clusters_merged;
}

// One updated GVD voxel through the paper's Algorithm "Places Sparsification": join a cluster of the same
// hash cell that it touches, or start one; merge the other clusters of the same cell it touches. Edges between
// clusters of different cells are rebuilt from the GVD adjacency when the touched clusters are finalized.
void Places::sparsify_step(std::uint32_t ref) {
  Voxel& v = vox(ref);
  v.flags &= static_cast<std::uint8_t>(~kGvdChanged);
  const bool gvd = (v.flags & kGvd) != 0;
  if (gvd && v.cluster == kNoCluster) {
    const memory::Index3 cell = cell_of(ref);
    std::uint32_t c = kNoCluster;
    for (const Offset& o : kOffsets.o) {
      const std::uint32_t n = neighbor(ref, o.dx, o.dy, o.dz);
      if (n == kNoRef) continue;
      const Voxel& nv = vox(n);
      if ((nv.flags & kGvd) == 0 || nv.cluster >= kSplitPending) continue;
      if (clusters_[nv.cluster].cell == cell) {
        c = nv.cluster;
        break;
      }
    }
    if (c == kNoCluster) {
      c = new_cluster(cell);
      if (c == memory::kInvalidHandle) {
        ++counters_.clusters_refused;
        return;
      }
    }
    cluster_add_voxel(c, ref);
    for (const Offset& o : kOffsets.o) {
      const std::uint32_t n = neighbor(ref, o.dx, o.dy, o.dz);
      if (n == kNoRef) continue;
      const Voxel& nv = vox(n);
      if ((nv.flags & kGvd) == 0 || nv.cluster >= kSplitPending || nv.cluster == c) continue;
      if (clusters_[nv.cluster].cell == cell) merge_clusters(c, nv.cluster);
    }
    clusters_[c].dirty = 1;
  } else if (gvd) {
    if (v.cluster < kSplitPending) clusters_[v.cluster].dirty = 1;
  } else if (v.cluster < kSplitPending) {
    const std::uint32_t c = v.cluster;
    cluster_remove_voxel(c, ref);
    if (clusters_[c].count == 0) retire_cluster(c, kRemoved);
    else clusters_[c].dirty = 1;
  }
}

// A cluster that lost voxels may have fallen apart: its first voxel's component keeps the node, every other
// connected component becomes a new cluster (so each place is one connected piece of the GVD graph).
void Places::split_cluster(const reconstruction::SemanticTsdf& tsdf, std::uint32_t cluster) {
  Cluster& c = clusters_[cluster];
  if (c.count <= 1) return;
  List& stack = lists_[kAffectedList];  // empty in this phase: used as scratch
  List& pending = lists_[kEvalList];
  stack.clear();
  pending.clear();
  std::uint32_t visited = 1;
  vox(c.head).flags |= kVisited;
  stack.push(c.head);
  while (stack.size > 0) {
    const std::uint32_t r = stack.data[--stack.size];
    for (const Offset& o : kOffsets.o) {
      const std::uint32_t n = neighbor(r, o.dx, o.dy, o.dz);
      if (n == kNoRef) continue;
      Voxel& nv = vox(n);
      if (nv.cluster != cluster || (nv.flags & kVisited) != 0) continue;
      nv.flags |= kVisited;
      ++visited;
      stack.push(n);
    }
  }
  if (visited == c.count) {
    for (std::uint32_t r = c.head; r != kNoRef; r = vox(r).cluster_next)
      vox(r).flags &= static_cast<std::uint8_t>(~kVisited);
    return;
  }
  // Keep the visited component; park the rest.
  std::uint32_t* link = &c.head;
  while (*link != kNoRef) {
    Voxel& v = vox(*link);
    if ((v.flags & kVisited) != 0) {
      v.flags &= static_cast<std::uint8_t>(~kVisited);
      link = &v.cluster_next;
    } else {
      const std::uint32_t r = *link;
      *link = v.cluster_next;
      v.cluster = kSplitPending;
      v.cluster_next = kNoRef;
      --c.count;
      pending.push(r);
    }
  }
  if (c.rep != kNoRef && vox(c.rep).cluster != cluster) c.rep = kNoRef;
  for (std::size_t i = 0; i < pending.size; ++i) {
    const std::uint32_t start = pending.data[i];
    if (vox(start).cluster != kSplitPending) continue;
    const std::uint32_t nc = new_cluster(c.cell);
    if (nc == memory::kInvalidHandle) {
      ++counters_.clusters_refused;
      for (std::size_t k = i; k < pending.size; ++k)
        if (vox(pending.data[k]).cluster == kSplitPending) vox(pending.data[k]).cluster = kNoCluster;
      break;
    }
    ++counters_.clusters_split;
    stack.clear();
    cluster_add_voxel(nc, start);
    stack.push(start);
    while (stack.size > 0) {
      const std::uint32_t r = stack.data[--stack.size];
      for (const Offset& o : kOffsets.o) {
        const std::uint32_t n = neighbor(r, o.dx, o.dy, o.dz);
        if (n == kNoRef || vox(n).cluster != kSplitPending) continue;
        cluster_add_voxel(nc, n);
        stack.push(n);
      }
    }
    finalize_cluster(tsdf, nc, false);
  }
  stack.clear();
  pending.clear();
}

void Places::pick_representative(std::uint32_t cluster) {
  Cluster& c = clusters_[cluster];
  std::uint32_t best = kNoRef;
  for (std::uint32_t r = c.head; r != kNoRef; r = vox(r).cluster_next) {
    if (best == kNoRef) {
      best = r;
      continue;
    }
    const Voxel& v = vox(r);
    const Voxel& b = vox(best);
    if (v.num_basis > b.num_basis || (v.num_basis == b.num_basis && (v.distance_m > b.distance_m ||
                                                                     (v.distance_m == b.distance_m && r < best))))
      best = r;
  }
  c.rep = best;
  if (best == kNoRef) return;
  c.position_m = center_m(coords(best));
  c.clearance_m = vox(best).distance_m;
  c.num_basis = vox(best).num_basis;
}

// Each basis point of the representative voxel connects to the nearest mesh vertex of the TSDF block holding the
// surface point behind it (the seed continued by its own distance, away from the place), else of the seed's block.
void Places::compute_mesh_connections(const reconstruction::SemanticTsdf& tsdf, std::uint32_t cluster) {
  Cluster& c = clusters_[cluster];
  c.connections.clear();
  if (c.rep == kNoRef) return;
  std::uint32_t parents[scene_graph::kMaxPlaceConnections];
  const int n = std::min<int>(
      std::max(0, evaluate_gvd(c.rep, parents, static_cast<int>(scene_graph::kMaxPlaceConnections))),
      static_cast<int>(scene_graph::kMaxPlaceConnections));
  const double block_m = tsdf.block_size_m();
  const Eigen::Vector3d place = center_m(coords(c.rep));
  const auto block_of = [block_m](const Eigen::Vector3d& p) {
    return memory::Index3{static_cast<std::int32_t>(std::floor(p.x() / block_m)),
                          static_cast<std::int32_t>(std::floor(p.y() / block_m)),
                          static_cast<std::int32_t>(std::floor(p.z() / block_m))};
  };
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d seed = center_m(coords(parents[k]));
    const Eigen::Vector3d dir = (seed - place).normalized();
    const Eigen::Vector3d surface = seed + dir * static_cast<double>(vox(parents[k]).distance_m);
    // The block holding the surface point, else the seed's, else any neighbour of the surface's block (the
    // surface may sit in a block without vertices of its own when it lies on a block border).
    const memory::Index3 sb = block_of(surface);
    memory::Index3 candidates[29];
    int num = 0;
    candidates[num++] = sb;
    candidates[num++] = block_of(seed);
    for (const Offset& o : kOffsets.o) candidates[num++] = add(sb, o.dx, o.dy, o.dz);
    bool connected = false;
    for (int ci = 0; ci < num && !connected; ++ci) {
      const memory::Index3& tb = candidates[ci];
      const std::uint32_t th = tsdf.find_block(tb);
      if (th == memory::kInvalidHandle) continue;
      reconstruction::SemanticTsdf::VertexCursor cursor;
      reconstruction::MeshVertex mv;
      double best_d2 = std::numeric_limits<double>::max();
      std::uint32_t best = 0, index = 0;
      bool found = false;
      while (tsdf.next_block_vertex(th, &cursor, &mv, nullptr)) {
        const double d2 = (Eigen::Vector3d(mv.x, mv.y, mv.z) - surface).squaredNorm();
        if (d2 < best_d2) {
          best_d2 = d2;
          best = index;
          found = true;
        }
        ++index;
      }
      if (!found) continue;
      scene_graph::PlaceMeshConnection pc;
      pc.block = tb;
      pc.vertex = best;
      pc.voxel_pos_m = seed;
      c.connections.push_back(pc);
      connected = true;
    }
  }
}

// Config::revive_in_same_free_space: whether a place at `pb` with clearance `rb` lies in the same free space as the
// inactive place at `pa` with clearance `ra`: their spheres of free space overlap (the union of two overlapping free
// balls is connected free space, and no surface passes between them however thin), or the ESDF certifies the
// segment between them (every voxel on it free).
bool Places::same_free_space(const Eigen::Vector3d& pa, double ra, const Eigen::Vector3d& pb, double rb) const {
  if ((pb - pa).norm() < ra + rb) return true;
  float w = 0.0f;
  return segment_clearance(pa, pb, &w) && w > 0.0f;
}

// The smallest ESDF distance along the segment between two points (sampled every half voxel, both ends
// included, from the lexicographically smaller end so both clusters of an edge compute the same value); false
// when the segment crosses a voxel that holds a surface (distance 0), is occupied, unobserved or outside the
// window.
bool Places::segment_clearance(Eigen::Vector3d pa, Eigen::Vector3d pb, float* min_distance_m) const {
  if (std::lexicographical_compare(pb.data(), pb.data() + 3, pa.data(), pa.data() + 3)) std::swap(pa, pb);
  const int steps = std::max(1, static_cast<int>(std::ceil((pb - pa).norm() / (0.5 * voxel_m_))));
  float best = kUnreached;
  memory::Index3 last{std::numeric_limits<std::int32_t>::min(), 0, 0};
  for (int i = 0; i <= steps; ++i) {
    const Eigen::Vector3d p = (pa + (pb - pa) * (static_cast<double>(i) / steps)) / voxel_m_;
    const memory::Index3 g{static_cast<std::int32_t>(std::floor(p.x())), static_cast<std::int32_t>(std::floor(p.y())),
                           static_cast<std::int32_t>(std::floor(p.z()))};
    if (g == last) continue;
    last = g;
    const std::uint32_t ref = find_voxel(g);
    if (ref == kNoRef) return false;
    const Voxel& v = vox(ref);
    if ((v.state != kFree && v.state != kSeed) || v.parent == kNoRef || !(v.distance_m > 0.0f)) return false;
    best = std::min(best, v.distance_m);
  }
  *min_distance_m = best;
  return true;
}

// Whether the free space of two clusters is joined: a voxel of one, whose sphere overlaps the other's
// representative sphere (each cluster is a connected piece of GVD, so its voxels and their spheres connect to its
// representative), with the segment between them certified by the ESDF. The pair tested is chosen the same way
// from both ends (the smaller of the two tests' voxel refs), so both clusters agree on the edge and its weight.
bool Places::spheres_meet(std::uint32_t a, std::uint32_t b, float* weight_m) const {
  if (b < a) std::swap(a, b);
  const auto best_voxel = [this](std::uint32_t from, std::uint32_t to_cluster, std::uint32_t* out) {
    const Cluster& t = clusters_[to_cluster];
    const Eigen::Vector3d pt = center_m(coords(t.rep));
    double best = std::numeric_limits<double>::max();
    *out = kNoRef;
    for (std::uint32_t r = clusters_[from].head; r != kNoRef; r = vox(r).cluster_next) {
      const double reach = static_cast<double>(vox(r).distance_m) + static_cast<double>(t.clearance_m);
      // The deepest overlap (least distance minus reach) wins; ties by the smaller ref.
      const double slack = (center_m(coords(r)) - pt).norm() - reach;
      if (slack < 0.0 && (slack < best || (slack == best && r < *out))) {
        best = slack;
        *out = r;
      }
    }
    return best;
  };
  std::uint32_t va = kNoRef, vb = kNoRef;
  const double sa = best_voxel(a, b, &va), sb = best_voxel(b, a, &vb);
  if (va == kNoRef && vb == kNoRef) return false;
  const bool use_a = vb == kNoRef || (va != kNoRef && sa <= sb);
  return use_a ? segment_clearance(center_m(coords(va)), clusters_[b].position_m, weight_m)
               : segment_clearance(center_m(coords(vb)), clusters_[a].position_m, weight_m);
}

// Edges from the GVD adjacency: cluster A joins cluster B when a voxel of A touches a voxel of B; the weight is
// the smallest clearance among the voxels through which the GVD passes from A to B (the touching pairs).
void Places::recompute_edges(std::uint32_t cluster) {
  Cluster& c = clusters_[cluster];
  std::uint32_t to[kMaxClusterEdges];
  float weight[kMaxClusterEdges];
  std::uint8_t free_edge[kMaxClusterEdges];
  int n = 0;
  // The neighbour limit: a candidate past kMaxClusterEdges replaces the worst one held if it is better (edge_better),
  // else it is pruned; either way one candidate is not kept (Counters::edges_pruned).
  const auto offer = [&](std::uint32_t x, float w, std::uint8_t kind) {
    const double d2 = (clusters_[x].position_m - c.position_m).squaredNorm();
    if (n < kMaxClusterEdges) {
      to[n] = x;
      weight[n] = w;
      free_edge[n] = kind;
      ++n;
      return;
    }
    ++counters_.edges_pruned;
    int worst = 0;
    double worst_d2 = (clusters_[to[0]].position_m - c.position_m).squaredNorm();
    for (int k = 1; k < n; ++k) {
      const double dk = (clusters_[to[k]].position_m - c.position_m).squaredNorm();
      if (edge_better(free_edge[worst], worst_d2, free_edge[k], dk)) {
        worst = k;
        worst_d2 = dk;
      }
    }
    if (!edge_better(kind, d2, free_edge[worst], worst_d2)) return;
    to[worst] = x;
    weight[worst] = w;
    free_edge[worst] = kind;
  };
  for (std::uint32_t r = c.head; r != kNoRef; r = vox(r).cluster_next) {
    const Voxel& v = vox(r);
    for (const Offset& o : kOffsets.o) {
      const std::uint32_t nr = neighbor(r, o.dx, o.dy, o.dz);
      if (nr == kNoRef) continue;
      const Voxel& nv = vox(nr);
      if ((nv.flags & kGvd) == 0 || nv.cluster >= kSplitPending || nv.cluster == cluster) continue;
      const float w = std::min(v.distance_m, nv.distance_m);
      int k = 0;
      while (k < n && to[k] != nv.cluster) ++k;
      if (k < n) {
        weight[k] = std::min(weight[k], w);
      } else {
        offer(nv.cluster, w, kEdgeGvd);
      }
    }
  }
  // Free-space edges (after the GVD's, which keep priority for the slots): places of the 27 cells around this
  // one whose spheres of free space overlap, certified by the ESDF along the segment between them.
  if (config_.free_space_edges && c.rep != kNoRef) {
    for (int oi = 0; oi <= 26; ++oi) {  // the 26 neighbour cells, then the cell itself
      const memory::Index3 cell = oi < 26 ? add(c.cell, kOffsets.o[oi].dx, kOffsets.o[oi].dy, kOffsets.o[oi].dz) : c.cell;
      const std::uint32_t* head = cells_.find(cell);
      for (std::uint32_t x = head != nullptr ? *head : kNoCluster; x != kNoCluster; x = clusters_[x].cell_next) {
        const Cluster& xc = clusters_[x];
        if (x == cluster || xc.state != kLive || xc.rep == kNoRef) continue;
        int k = 0;
        while (k < n && to[k] != x) ++k;
        if (k < n) continue;
        // Already two GVD hops away (through a GVD neighbour of this cluster): the GVD joins them.
        bool near = false;
        for (int j = 0; j < n && !near; ++j) {
          if (free_edge[j]) continue;
          const Cluster& g = clusters_[to[j]];
          for (int e = 0; e < g.num_edges && !near; ++e) near = g.edge_to[e] == x && !g.edge_free[e];
        }
        if (near) continue;
        float w = 0.0f;
        if (!spheres_meet(cluster, x, &w)) continue;
        offer(x, w, kEdgeFree);
      }
    }
  }
  // Bridges stay while their segment is still certified free (the bridge pass adds them; a fragment that has
  // since joined the rest keeps its bridge as one more free-space edge).
  if (config_.bridge_fragments && c.rep != kNoRef) {
    for (int k = 0; k < c.num_edges; ++k) {
      if (c.edge_free[k] != kEdgeBridge) continue;
      const std::uint32_t x = c.edge_to[k];
      int j = 0;
      while (j < n && to[j] != x) ++j;
      if (j < n || n == kMaxClusterEdges) continue;
      const Cluster& xc = clusters_[x];
      float w = 0.0f;
      if (xc.state != kLive || xc.rep == kNoRef ||
          (xc.position_m - c.position_m).norm() > config_.bridge_max_length_m ||
          !segment_clearance(c.position_m, xc.position_m, &w) ||
          static_cast<double>(w) < config_.bridge_min_clearance_m)
        continue;
      to[n] = x;
      weight[n] = w;
      free_edge[n] = kEdgeBridge;
      ++n;
    }
  }
  // Drop the edges that are gone (from both ends), then write the others into both ends.
  for (int k = c.num_edges - 1; k >= 0; --k) {
    const std::uint32_t other = c.edge_to[k];
    bool kept = false;
    for (int j = 0; j < n && !kept; ++j) kept = to[j] == other;
    if (!kept) drop_edge(other, cluster);
  }
  int kept = 0;
  for (int j = 0; j < n; ++j) {
    Cluster& o = clusters_[to[j]];
    int k = 0;
    while (k < o.num_edges && o.edge_to[k] != cluster) ++k;
    if (k == o.num_edges) {
      if (o.num_edges == kMaxClusterEdges &&
          !make_room(to[j], free_edge[j], (o.position_m - c.position_m).squaredNorm())) {
        ++counters_.edges_pruned;
        continue;  // the other end holds better edges: not kept at either end (the lists stay symmetric)
      }
      k = o.num_edges;
      o.edge_to[k] = cluster;
      ++o.num_edges;
      o.bridge_check = 1;
      o.edge_weight[k] = weight[j];
      o.edge_free[k] = free_edge[j];
      o.sync_dirty = 1;
    } else if (o.edge_weight[k] != weight[j] || o.edge_free[k] != free_edge[j]) {
      o.edge_weight[k] = weight[j];
      o.edge_free[k] = free_edge[j];
      o.sync_dirty = 1;
    }
    c.edge_to[kept] = to[j];
    c.edge_weight[kept] = weight[j];
    c.edge_free[kept] = free_edge[j];
    ++kept;
  }
  c.num_edges = static_cast<std::uint8_t>(kept);
}

// The other end of a new edge is at the neighbour limit: its worst edge gives way (dropped at both of its ends) if
// the new one is better; false when every edge it holds is at least as good.
bool Places::make_room(std::uint32_t cluster, std::uint8_t kind, double d2) {
  Cluster& c = clusters_[cluster];
  int worst = -1;
  double worst_d2 = 0.0;
  for (int k = 0; k < c.num_edges; ++k) {
    const double dk = (clusters_[c.edge_to[k]].position_m - c.position_m).squaredNorm();
    if (worst < 0 || edge_better(c.edge_free[worst], worst_d2, c.edge_free[k], dk)) {
      worst = k;
      worst_d2 = dk;
    }
  }
  if (worst < 0 || !edge_better(kind, d2, c.edge_free[worst], worst_d2)) return false;
  const std::uint32_t other = c.edge_to[worst];
  drop_edge(cluster, other);
  drop_edge(other, cluster);
  ++counters_.edges_pruned;
  return true;
}

void Places::finalize_cluster(const reconstruction::SemanticTsdf& tsdf, std::uint32_t cluster, bool split_check) {
  clusters_[cluster].dirty = 0;
  if (split_check) split_cluster(tsdf, cluster);
  pick_representative(cluster);
  compute_mesh_connections(tsdf, cluster);
  recompute_edges(cluster);
  clusters_[cluster].sync_dirty = 1;
  clusters_[cluster].bridge_check = 1;
}

bool Places::add_cluster_edge(std::uint32_t a, std::uint32_t b, float weight_m, std::uint8_t kind) {
  Cluster& ca = clusters_[a];
  Cluster& cb = clusters_[b];
  for (int k = 0; k < ca.num_edges; ++k)
    if (ca.edge_to[k] == b) return false;
  if (ca.num_edges == kMaxClusterEdges || cb.num_edges == kMaxClusterEdges) {
    ++counters_.edges_refused;
    return false;
  }
  ca.edge_to[ca.num_edges] = b;
  ca.edge_weight[ca.num_edges] = weight_m;
  ca.edge_free[ca.num_edges] = kind;
  ++ca.num_edges;
  cb.edge_to[cb.num_edges] = a;
  cb.edge_weight[cb.num_edges] = weight_m;
  cb.edge_free[cb.num_edges] = kind;
  ++cb.num_edges;
  ca.sync_dirty = 1;
  cb.sync_dirty = 1;
  ca.bridge_check = 1;
  cb.bridge_check = 1;
  return true;
}

// A live place whose component of live places is small (GVD pieces under furniture, or cut off by the theta-SMA
// and clearance filters) is joined to the nearest live place outside it whose straight segment stays in observed
// free space. Without it such pieces stay separate components of one free-space region. False-free: the segment
// must be certified by the ESDF voxel by voxel, so no bridge crosses a wall or unobserved space.
void Places::bridge_fragment(std::uint32_t cluster) {
  std::uint32_t members[kMaxBridgeFragment];
  int num = 0;
  members[num++] = cluster;
  const int limit = config_.bridge_max_fragment_places;
  for (int i = 0; i < num; ++i) {
    const Cluster& m = clusters_[members[i]];
    for (int k = 0; k < m.num_edges; ++k) {
      const std::uint32_t o = m.edge_to[k];
      bool seen = false;
      for (int j = 0; j < num && !seen; ++j) seen = members[j] == o;
      if (seen) continue;
      if (num == limit) {
        set_held(cluster, false);  // part of a larger component: nothing to do
        clusters_[cluster].bridge_check = 0;
        return;
      }
      members[num++] = o;
    }
  }
  const double max_len = config_.bridge_max_length_m;
  const int reach = static_cast<int>(std::ceil(max_len / config_.place_resolution_m));
  std::uint32_t best_from = kNoCluster, best_to = kNoCluster;
  double best_d2 = max_len * max_len;
  float best_w = 0.0f;
  bool candidates = false;  // some place outside the fragment is within reach (certified or not)
  for (int i = 0; i < num; ++i) {
    const Cluster& m = clusters_[members[i]];
    if (m.rep == kNoRef || m.num_edges == kMaxClusterEdges) continue;
    for (int dz = -reach; dz <= reach; ++dz)
      for (int dy = -reach; dy <= reach; ++dy)
        for (int dx = -reach; dx <= reach; ++dx) {
          const std::uint32_t* head = cells_.find(add(m.cell, dx, dy, dz));
          for (std::uint32_t x = head != nullptr ? *head : kNoCluster; x != kNoCluster; x = clusters_[x].cell_next) {
            const Cluster& xc = clusters_[x];
            if (xc.state != kLive || xc.rep == kNoRef || xc.num_edges == kMaxClusterEdges) continue;
            const double d2 = (xc.position_m - m.position_m).squaredNorm();
            if (d2 > best_d2 || (d2 == best_d2 && best_to != kNoCluster)) continue;
            bool inside = false;
            for (int j = 0; j < num && !inside; ++j) inside = members[j] == x;
            candidates = candidates || !inside;
            float w = 0.0f;
            if (inside || !segment_clearance(m.position_m, xc.position_m, &w) ||
                static_cast<double>(w) < config_.bridge_min_clearance_m)
              continue;
            best_from = members[i];
            best_to = x;
            best_d2 = d2;
            best_w = w;
          }
        }
  }
  if (best_to == kNoCluster && config_.bridge_path_search) {
    bool interrupted = false;
    best_w = bridge_by_path(members, num, &best_from, &best_to, &interrupted);
    if (interrupted) {
      ++counters_.bridge_searches_cut;  // out of time: bridge_check stays set and the held states as they were
      return;
    }
  }
  if (best_to == kNoCluster) {
    ++counters_.bridges_missing;  // stays flagged: retried next cycle, when more of the map is known
    // Places around, none reachable through free space, and only a few GVD voxels: a pocket enclosed by surfaces.
    std::uint32_t voxels = 0;
    for (int i = 0; i < num; ++i) voxels += clusters_[members[i]].count;
    const bool enclosed = candidates && static_cast<int>(voxels) <= config_.enclosed_max_voxels;
    bool distant = config_.hold_distant_fragments;
    for (int i = 0; i < num && distant; ++i)
      distant = (clusters_[members[i]].position_m - cycle_robot_m_).squaredNorm() > max_len * max_len;
    // Distance holds back only places not yet published: one in the graph stays there when the robot walks away.
    for (int i = 0; i < num; ++i) set_held(members[i], enclosed || (distant && !clusters_[members[i]].synced));
    return;
  }
  clusters_[cluster].bridge_check = 0;
  for (int i = 0; i < num; ++i) set_held(members[i], false);
  if (add_cluster_edge(best_from, best_to, best_w, kEdgeBridge)) ++counters_.bridges_added;
}

// No straight segment certified: a breadth-first search through the ESDF from the fragment's representative
// voxels, over free voxels whose distance is at least bridge_min_clearance_m, at most bridge_max_length_m / voxel
// steps, to the first GVD voxel of a live place outside the fragment (around furniture, past a pillar). Returns
// the bridge's weight (the search's clearance bound, a lower bound of the path's smallest distance) and sets
// from/to; to stays kNoCluster when nothing is reached. Scratch: the affected list (empty in this phase) and the
// kVisited flags, cleared before returning. One search can visit tens of thousands of voxels, so it checks the
// deadline's clock as the cycle's loops do and gives up when it has expired (*interrupted; the fragment is tried
// again next cycle). The work-unit cap is not checked here: lockstep runs stay identical however they are sliced.
float Places::bridge_by_path(const std::uint32_t* members, int num, std::uint32_t* from, std::uint32_t* to,
                             bool* interrupted) {
  *interrupted = false;
  const Deadline* deadline = deadline_;
  const std::uint32_t every =
      deadline == nullptr || deadline->check_every == 0 ? 1 : deadline->check_every;
  List& queue = lists_[kAffectedList];
  queue.clear();
  const float min_d = static_cast<float>(config_.bridge_min_clearance_m);
  const int max_steps = static_cast<int>(std::ceil(config_.bridge_max_length_m / voxel_m_));
  const auto member = [&](std::uint32_t c) {
    for (int j = 0; j < num; ++j)
      if (members[j] == c) return true;
    return false;
  };
  for (int i = 0; i < num; ++i) {
    const std::uint32_t r = clusters_[members[i]].rep;
    if (r == kNoRef || (vox(r).flags & kVisited) != 0 || !queue.push(r)) continue;
    vox(r).flags |= kVisited;  // only voxels in the queue carry the flag, so all of it is cleared below
  }
  std::uint32_t found = kNoCluster;
  std::size_t head = 0;
  for (int step = 0; step < max_steps && found == kNoCluster && !*interrupted && head < queue.size; ++step) {
    const std::size_t layer_end = queue.size;
    for (; head < layer_end && found == kNoCluster && !*interrupted; ++head) {
      const std::uint32_t r = queue.data[head];
      ++units_;
      if (deadline != nullptr && deadline->expired != nullptr && units_ % every == 0 &&
          deadline->expired(deadline->context)) {
        *interrupted = true;
        break;
      }
      for (const Offset& o : kOffsets.o) {
        const std::uint32_t n = neighbor(r, o.dx, o.dy, o.dz);
        if (n == kNoRef) continue;
        Voxel& nv = vox(n);
        if ((nv.flags & kVisited) != 0) continue;
        if ((nv.state != kFree && nv.state != kSeed) || nv.parent == kNoRef || nv.distance_m < min_d) continue;
        const std::uint32_t c = nv.cluster;
        if (c < clusters_.capacity() && clusters_.live(c) && !member(c)) {
          const Cluster& xc = clusters_[c];
          if (xc.state == kLive && xc.rep != kNoRef && xc.num_edges < kMaxClusterEdges) {
            found = c;
            break;
          }
        }
        if (!queue.push(n)) break;  // full (counted by the list): this voxel's neighbours stay unexplored
        nv.flags |= kVisited;
      }
    }
  }
  for (std::size_t k = 0; k < queue.size; ++k) vox(queue.data[k]).flags &= static_cast<std::uint8_t>(~kVisited);
  queue.clear();
  if (*interrupted || found == kNoCluster) return 0.0f;
  // The fragment's place nearest the one reached (with room for one more edge) takes the bridge.
  double best = std::numeric_limits<double>::max();
  for (int i = 0; i < num; ++i) {
    const Cluster& m = clusters_[members[i]];
    if (m.num_edges == kMaxClusterEdges) continue;
    const double d2 = (m.position_m - clusters_[found].position_m).squaredNorm();
    if (d2 < best) {
      best = d2;
      *from = members[i];
    }
  }
  if (best == std::numeric_limits<double>::max()) return 0.0f;
  *to = found;
  ++counters_.bridge_paths;
  return min_d;
}

// Holding a place back (or releasing it) changes what sync() publishes; a released place's held neighbours are
// re-checked, since the component they share is no longer a fragment.
void Places::set_held(std::uint32_t cluster, bool held) {
  Cluster& c = clusters_[cluster];
  if ((c.held != 0) == held) return;
  c.held = held ? 1 : 0;
  c.sync_dirty = 1;
  if (held) return;
  for (int k = 0; k < c.num_edges; ++k)
    if (clusters_[c.edge_to[k]].held) clusters_[c.edge_to[k]].bridge_check = 1;
}

// ---------------------------------------------------------------------------------------------------------
// The anytime cycle

UpdateResult Places::update(const reconstruction::SemanticTsdf& tsdf, const Eigen::Vector3d& robot_m,
                            const Deadline& deadline) {
  UpdateResult result;
  if (!ready_) return result;
  ++counters_.updates;
  units_ = 0;
  // The path search reads the deadline too; the pointer lives exactly as long as this call.
  struct DeadlineScope {
    const Deadline** slot;
    ~DeadlineScope() { *slot = nullptr; }
  } scope{&deadline_};
  deadline_ = &deadline;
  const std::uint32_t every = deadline.check_every == 0 ? 1 : deadline.check_every;
  // At least one unit of work per call, so repeated calls always finish a cycle.
  const auto expired = [&]() {
    if (units_ == 0) return false;
    if (units_ >= deadline.max_work_units) return true;
    return deadline.expired != nullptr && units_ % every == 0 && deadline.expired(deadline.context);
  };
  const auto run_list = [&](int which, auto&& step) {
    List& l = lists_[which];
    while (cursor_ < l.size) {
      if (expired()) return false;
      step(l.data[cursor_++]);
      ++units_;
    }
    l.clear();
    cursor_ = 0;
    return true;
  };
  for (;;) {
    switch (phase_) {
      case kIdle:
        begin_cycle(tsdf, robot_m);
        ++units_;
        cursor_ = 0;
        phase_ = kSeedPhase;
        break;
      case kSeedPhase:
        if (!run_list(kDirtyList, [&](std::uint32_t e) {
              constexpr std::uint32_t kSubs = kMaxVoxelFactor * kMaxVoxelFactor * kMaxVoxelFactor;
              seed_sub_block(tsdf, e / kSubs, static_cast<int>(e % kSubs), true);
            }))
          return {false, units_};
        phase_ = kRaisePhase;
        break;
      case kRaisePhase:
        if (!run_list(kRaiseList, [&](std::uint32_t r) { raise_step(r); })) return {false, units_};
        phase_ = kLowerPhase;
        break;
      case kLowerPhase:
        while (lower_size_ > 0) {
          if (expired()) return {false, units_};
          const std::uint32_t r = lower_ring_[lower_head_];
          lower_head_ = (lower_head_ + 1) % lower_capacity_;
          --lower_size_;
          lower_step(tsdf, r);
          ++units_;
        }
        lower_head_ = 0;
        phase_ = kGvdExpand;
        break;
      case kGvdExpand:
        if (!run_list(kAffectedList, [&](std::uint32_t r) {
              Voxel& v = vox(r);
              v.flags &= static_cast<std::uint8_t>(~kAffected);
              // A GVD voxel whose distance moved changes its place's clearance or an edge weight.
              if ((v.flags & (kGvd | kGvdChanged)) == kGvd) {
                v.flags |= kGvdChanged;
                lists_[kChangedList].push(r);
              }
              if ((v.flags & kEval) == 0) {
                v.flags |= kEval;
                lists_[kEvalList].push(r);
              }
              for (const Offset& o : kOffsets.o) {
                const std::uint32_t n = neighbor(r, o.dx, o.dy, o.dz);
                if (n == kNoRef || (vox(n).flags & kEval) != 0) continue;
                vox(n).flags |= kEval;
                lists_[kEvalList].push(n);
              }
            }))
          return {false, units_};
        phase_ = kGvdEval;
        break;
      case kGvdEval:
        if (!run_list(kEvalList, [&](std::uint32_t r) { gvd_step(r); })) return {false, units_};
        phase_ = kSparsify;
        break;
      case kSparsify:
        if (!run_list(kChangedList, [&](std::uint32_t r) { sparsify_step(r); })) return {false, units_};
        phase_ = kFinalize;
        break;
      case kFinalize:
        while (cursor_ < clusters_.capacity()) {
          if (expired()) return {false, units_};
          const std::uint32_t h = static_cast<std::uint32_t>(cursor_++);
          if (clusters_.live(h) && clusters_[h].state == kLive && clusters_[h].dirty) {
            finalize_cluster(tsdf, h, true);
            ++units_;
          } else if ((h & 63) == 0) {
            ++units_;  // scanning slots costs too, a little
          }
        }
        cursor_ = 0;
        counters_.bridges_missing = 0;
        phase_ = kBridge;
        break;
      case kBridge:
        while (config_.bridge_fragments && cursor_ < clusters_.capacity()) {
          if (expired()) return {false, units_};
          const std::uint32_t h = static_cast<std::uint32_t>(cursor_++);
          if (clusters_.live(h) && clusters_[h].state == kLive && clusters_[h].bridge_check &&
              clusters_[h].rep != kNoRef) {
            bridge_fragment(h);
            ++units_;
          } else if ((h & 63) == 0) {
            ++units_;
          }
        }
        cursor_ = 0;
        phase_ = kIdle;
        ++counters_.cycles;
        counters_.free_space_edges = 0;
        counters_.bridges = 0;
        counters_.enclosed_held = 0;
        clusters_.for_each([&](std::uint32_t, const Cluster& c) {
          if (c.state != kLive) return;
          counters_.enclosed_held += c.held;
          for (int k = 0; k < c.num_edges; ++k) {
            counters_.free_space_edges += c.edge_free[k] == kEdgeFree ? 1 : 0;
            counters_.bridges += c.edge_free[k] == kEdgeBridge ? 1 : 0;
          }
        });
        counters_.free_space_edges /= 2;
        counters_.bridges /= 2;
        result.complete = true;
        result.work_units = units_;
        return result;
      default:
        phase_ = kIdle;
        break;
    }
  }
}

// ---------------------------------------------------------------------------------------------------------
// Scene graph mirror

namespace {
// A graph write refused for another reason than a full store: counted in graph_errors, logged 1st, 2nd, 4th, ...
void log_graph_error(const char* what, scene_graph::Status status, std::uint64_t n) {
  if ((n & (n - 1)) == 0)
    std::fprintf(stderr, "places: the scene graph refused %s (%s), not for want of room; %llu so far\n", what,
                 scene_graph::to_string(status), static_cast<unsigned long long>(n));
}
}  // namespace

SyncResult Places::sync(scene_graph::SceneGraph* graph) {
  SyncResult r;
  if (!ready_ || graph == nullptr || !graph->initialized()) {
    r.status = scene_graph::Status::kMissingNode;
    return r;
  }
  const scene_graph::Capacities& gc = graph->capacities();
  const auto refuse = [&](const char* what) {
    ++r.refused;
    ++counters_.graph_refused;
    r.status = scene_graph::Status::kFull;
    const std::uint64_t n = counters_.graph_refused;
    if ((n & (n - 1)) == 0)  // 1, 2, 4, ...: bounded logging
      std::fprintf(stderr, "places: scene graph %s store full; refused %llu so far (retried on the next sync)\n",
                   what, static_cast<unsigned long long>(n));
  };
  // Retired clusters: places that left the window stay, inactive; removed places leave the graph. The first go
  // inactive before any removal, and the nodes this sync removes are listed (sorted), so the contraction counts
  // neither as a place that anchors an inactive one in the active graph.
  scene_graph::NodeId removing[kMaxRemovingPerSync];
  std::size_t num_removing = 0;
  for (std::uint32_t h = 0; h < clusters_.capacity(); ++h) {
    if (!clusters_.live(h)) continue;
    Cluster& c = clusters_[h];
    if (c.state == kLeft) {
      if (scene_graph::PlaceAttributes* p = graph->place(c.node)) {
        p->is_active = false;
        ++r.nodes_deactivated;
      }
      clusters_.release(h);
    } else if (c.state == kRemoved && c.synced && num_removing < kMaxRemovingPerSync) {
      removing[num_removing++] = c.node;  // beyond the array: still removed, only counted as a possible anchor
    }
  }
  std::sort(removing, removing + num_removing);
  for (std::uint32_t h = 0; h < clusters_.capacity(); ++h) {
    if (!clusters_.live(h)) continue;
    Cluster& c = clusters_[h];
    if (c.state == kRemoved) {
      if (config_.relink_inactive && c.synced) {
        // Its edges to inactive places would vanish with it: park them for the place that replaces it.
        graph->for_each_neighbor(c.node, [&](scene_graph::NodeId m, const scene_graph::EdgeRecord& e) {
          if (scene_graph::node_prefix(m) != scene_graph::kPlacePrefix) return;
          const scene_graph::PlaceAttributes* pm = graph->place(m);
          if (pm == nullptr || pm->is_active) return;
          if (num_relinks_ == capacities_.pending_relinks) {
            ++counters_.relinks_refused;
            return;
          }
          Relink& l = relinks_[num_relinks_++];
          relinks_high_water_ = std::max(relinks_high_water_, num_relinks_);
          l.inactive = m;
          l.position_m = c.position_m;
          l.clearance_m = c.clearance_m;
          l.weight_m = e.info.weighted ? static_cast<float>(e.info.weight) : c.clearance_m;
          l.cell = c.cell;
        });
      }
      if (config_.contract_removed && c.synced) contract_around(graph, c.node, removing, num_removing, &r);
      if (graph->remove_node(c.node)) ++r.nodes_removed;
      clusters_.release(h);
    }
  }
  // Nodes first (so every edge finds both ends), then edges.
  for (std::uint32_t h = 0; h < clusters_.capacity(); ++h) {
    if (!clusters_.live(h)) continue;
    Cluster& c = clusters_[h];
    if (c.state != kLive || !c.sync_dirty || c.rep == kNoRef) continue;
    if (c.revived) {
      // Config::revive_in_same_free_space: the inactive node came back only if it left from the same free space.
      c.revived = 0;
      const scene_graph::PlaceAttributes* old = graph->place(c.node);
      if (config_.revive_in_same_free_space && old != nullptr && !old->is_active &&
          !same_free_space(old->position_m, old->distance_m, c.position_m, c.clearance_m)) {
        park_inactive(c.cell, c.node);  // stays inactive where it was; a later place of the cell may revive it
        c.node = scene_graph::make_node_id(scene_graph::kPlacePrefix, next_node_index_++);
        c.synced = 0;
        --counters_.reactivated;
        ++counters_.revivals_refused;
      }
    }
    if (c.held) {
      // An enclosed pocket: not published; withdrawn if it was (unless inactive places hang on it).
      if (c.synced) {
        bool linked = false;
        graph->for_each_neighbor(c.node, [&](scene_graph::NodeId m, const scene_graph::EdgeRecord&) {
          const scene_graph::PlaceAttributes* pm =
              scene_graph::node_prefix(m) == scene_graph::kPlacePrefix ? graph->place(m) : nullptr;
          linked = linked || (pm != nullptr && !pm->is_active);
        });
        if (linked) {
          c.sync_dirty = 0;
          continue;
        }
        if (graph->remove_node(c.node)) ++r.nodes_removed;
        c.synced = 0;
      }
      c.sync_dirty = 0;
      continue;
    }
    scene_graph::PlaceAttributes attrs;
    attrs.position_m = c.position_m;
    attrs.is_active = true;
    attrs.distance_m = c.clearance_m;
    attrs.num_basis_points = c.num_basis;
    attrs.mesh_connections = c.connections;
    if (scene_graph::PlaceAttributes* p = graph->place(c.node)) {
      attrs.last_update_time_ns = p->last_update_time_ns;
      *p = attrs;
      ++r.nodes_updated;
      c.synced = 1;
      c.merge_check = 1;
      continue;
    }
    // Checked here so a full graph is a counted refusal in every build (the store's own policy may abort).
    if (graph->num_nodes(scene_graph::NodeKind::kPlace) >= gc.place_nodes || graph->num_nodes() >= gc.nodes()) {
      graph->count_refused_node(scene_graph::NodeKind::kPlace);  // shown under the store's own name
      refuse("place node");
      continue;
    }
    const scene_graph::Status st = graph->add_place(c.node, attrs);
    if (st == scene_graph::Status::kOk) {
      ++r.nodes_added;
      c.synced = 1;
      c.merge_check = 1;
    } else if (st == scene_graph::Status::kFull) {
      refuse("place node");
    } else {
      log_graph_error("a place node", st, ++counters_.graph_errors);
    }
  }
  for (std::uint32_t h = 0; h < clusters_.capacity(); ++h) {
    if (!clusters_.live(h)) continue;
    Cluster& c = clusters_[h];
    if (c.state != kLive || !c.sync_dirty || !c.synced) continue;
    bool complete = true;
    // Remove graph edges to active places that are no longer neighbours (edges to inactive places stay, and so do
    // edges with an end at the window's rim: Config::keep_edges_at_rim_m).
    const bool c_at_rim = at_window_rim(c.position_m);
    for (;;) {
      scene_graph::NodeId stale[32];
      int num_stale = 0;
      graph->for_each_neighbor(c.node, [&](scene_graph::NodeId m, const scene_graph::EdgeRecord&) {
        if (num_stale == 32 || scene_graph::node_prefix(m) != scene_graph::kPlacePrefix) return;
        const scene_graph::PlaceAttributes* pm = graph->place(m);
        if (pm == nullptr || !pm->is_active) return;
        for (int k = 0; k < c.num_edges; ++k)
          if (clusters_[c.edge_to[k]].node == m) return;
        if (c_at_rim || at_window_rim(pm->position_m)) {
          ++counters_.edges_kept_at_rim;
          return;
        }
        stale[num_stale++] = m;
      });
      for (int k = 0; k < num_stale; ++k)
        if (graph->remove_edge(c.node, stale[k])) ++r.edges_removed;
      if (num_stale < 32) break;
    }
    for (int k = 0; k < c.num_edges; ++k) {
      const Cluster& o = clusters_[c.edge_to[k]];
      if (!o.synced) {
        complete = false;
        continue;
      }
      const double w = c.edge_weight[k];
      if (scene_graph::EdgeAttributes* info = graph->edge_info(c.node, o.node)) {
        if (info->weight != w || !info->weighted) {
          info->weight = w;
          info->weighted = true;
          ++r.edges_updated;
        }
        continue;
      }
      if (graph->num_edges() >= gc.edges) {
        graph->count_refused_edge();
        refuse("edge");
        complete = false;
        continue;
      }
      scene_graph::EdgeAttributes info;
      info.weight = w;
      info.weighted = true;
      const scene_graph::Status st = graph->add_edge(c.node, o.node, info);
      if (st == scene_graph::Status::kOk) {
        ++r.edges_added;
      } else {
        if (st == scene_graph::Status::kFull) refuse("edge");  // the full store counted it itself
        else log_graph_error("a place edge", st, ++counters_.graph_errors);
        complete = false;
      }
    }
    if (complete) c.sync_dirty = 0;
  }
  if (config_.merge_revisited_within_m > 0.0) {
    for (std::uint32_t h = 0; h < clusters_.capacity(); ++h) {
      if (!clusters_.live(h)) continue;
      Cluster& c = clusters_[h];
      if (c.state == kLive && c.merge_check && c.synced) merge_revisited(graph, h, &r);
      c.merge_check = 0;
    }
  }
  resolve_relinks(graph, &r);
  return r;
}

// ---------------------------------------------------------------------------------------------------------
// Inactive places: the index of revisits

void Places::park_inactive(const memory::Index3& cell, scene_graph::NodeId node) {
  if (inactive_free_ == kNoRef) {
    ++counters_.inactive_forgotten;
    return;
  }
  std::uint32_t* head = inactive_.find_or_insert(cell, kNoRef);
  if (head == nullptr) {  // the cell map is full (counted by the map)
    ++counters_.inactive_forgotten;
    return;
  }
  const std::uint32_t e = inactive_free_;
  inactive_free_ = inactive_entries_[e].next;
  inactive_entries_[e].node = node;
  inactive_entries_[e].next = *head;
  *head = e;
  inactive_high_water_ = std::max(inactive_high_water_, ++inactive_used_);
}

scene_graph::NodeId Places::take_inactive(const memory::Index3& cell) {
  std::uint32_t* head = inactive_.find(cell);
  if (head == nullptr) return scene_graph::kNoNode;
  const std::uint32_t e = *head;
  const scene_graph::NodeId node = inactive_entries_[e].node;
  *head = inactive_entries_[e].next;
  if (*head == kNoRef) inactive_.erase(cell);
  inactive_entries_[e].next = inactive_free_;
  inactive_free_ = e;
  --inactive_used_;
  return node;
}

// Config::merge_revisited_within_m: the inactive places of the 27 cells around a live place that lie within the
// distance and in its free space are merged into it. Index entries of nodes gone from the graph are dropped on
// the way; those of places still active (parked as they left, deactivated by this sync's start) are skipped.
void Places::merge_revisited(scene_graph::SceneGraph* graph, std::uint32_t cluster, SyncResult* r) {
  const Cluster& c = clusters_[cluster];
  const double radius = config_.merge_revisited_within_m;
  const Eigen::Vector3d& p = c.position_m;
  const memory::Index3 home{static_cast<std::int32_t>(std::floor(p.x() / config_.place_resolution_m)),
                            static_cast<std::int32_t>(std::floor(p.y() / config_.place_resolution_m)),
                            static_cast<std::int32_t>(std::floor(p.z() / config_.place_resolution_m))};
  for (int oi = 0; oi <= 26; ++oi) {
    const memory::Index3 cell = oi < 26 ? add(home, kOffsets.o[oi].dx, kOffsets.o[oi].dy, kOffsets.o[oi].dz) : home;
    std::uint32_t* head = inactive_.find(cell);
    if (head == nullptr) continue;
    std::uint32_t* link = head;
    while (*link != kNoRef) {
      const std::uint32_t e = *link;
      const scene_graph::NodeId m = inactive_entries_[e].node;
      const scene_graph::PlaceAttributes* pm = m != c.node ? graph->place(m) : nullptr;
      bool drop = pm == nullptr;  // gone from the graph (or the live node itself): forget it
      if (pm != nullptr && !pm->is_active && (pm->position_m - p).norm() <= radius &&
          same_free_space(pm->position_m, pm->distance_m, p, c.clearance_m)) {
        const scene_graph::SceneGraph::MergeResult mr = graph->merge_into(c.node, m);
        if (mr.status == scene_graph::Status::kOk) {
          ++counters_.revisits_merged;
          counters_.merge_edges_moved += mr.moved;
          ++r->nodes_removed;
          r->edges_removed += mr.dropped + mr.refused;
          if (mr.refused > 0) {
            ++r->refused;
            counters_.graph_refused += mr.refused;
            r->status = scene_graph::Status::kFull;
          }
          drop = true;
        }
      }
      if (!drop) {
        link = &inactive_entries_[e].next;
        continue;
      }
      *link = inactive_entries_[e].next;
      inactive_entries_[e].next = inactive_free_;
      inactive_free_ = e;
      --inactive_used_;
    }
    if (*head == kNoRef) inactive_.erase(cell);
  }
}

// The live, synced place of the cell or a neighbouring cell nearest to a removed place, among those whose
// sphere of free space overlaps the removed place's (so the two spheres' union joins them through free space).
std::uint32_t Places::replacement_for(const Eigen::Vector3d& position_m, double clearance_m,
                                      const memory::Index3& cell) const {
  std::uint32_t best = kNoCluster;
  double best_d2 = std::numeric_limits<double>::max();
  for (int oi = 0; oi <= 26; ++oi) {
    const memory::Index3 nc = oi < 26 ? add(cell, kOffsets.o[oi].dx, kOffsets.o[oi].dy, kOffsets.o[oi].dz) : cell;
    const std::uint32_t* head = cells_.find(nc);
    for (std::uint32_t x = head != nullptr ? *head : kNoCluster; x != kNoCluster; x = clusters_[x].cell_next) {
      const Cluster& xc = clusters_[x];
      if (xc.state != kLive || !xc.synced || xc.rep == kNoRef) continue;
      const double reach = clearance_m + static_cast<double>(xc.clearance_m);
      const double d2 = (xc.position_m - position_m).squaredNorm();
      float w = 0.0f;
      if (d2 >= reach * reach || d2 >= best_d2 || !segment_clearance(position_m, xc.position_m, &w)) continue;
      best = x;
      best_d2 = d2;
    }
  }
  return best;
}

// Moves the parked edges of removed places to their replacements; an edge waits while the removed place's
// position is inside the window (its replacement may appear in a later cycle) and is dropped after.
void Places::resolve_relinks(scene_graph::SceneGraph* graph, SyncResult* r) {
  std::size_t kept = 0;
  for (std::size_t i = 0; i < num_relinks_; ++i) {
    const Relink l = relinks_[i];
    const scene_graph::PlaceAttributes* pi = graph->place(l.inactive);
    if (pi == nullptr || pi->is_active) continue;  // gone, or back in the window with edges of its own
    std::uint32_t x = replacement_for(l.position_m, l.clearance_m, l.cell);
    if (x != kNoCluster && config_.relink_in_same_free_space &&
        !same_free_space(pi->position_m, pi->distance_m, clusters_[x].position_m, clusters_[x].clearance_m)) {
      ++counters_.relinks_apart;  // waits for another replacement, or is dropped as below
      x = kNoCluster;
    }
    if (x != kNoCluster && clusters_[x].node == l.inactive) {
      ++counters_.relinked;  // the place is its own replacement (it came back as the cluster): nothing to join
      continue;
    }
    if (x != kNoCluster) {
      const Cluster& xc = clusters_[x];
      if (graph->edge_info(l.inactive, xc.node) == nullptr) {
        scene_graph::EdgeAttributes info;
        info.weighted = true;
        info.weight = std::min({static_cast<double>(l.weight_m), static_cast<double>(l.clearance_m),
                                static_cast<double>(xc.clearance_m)});
        const bool full = graph->num_edges() >= graph->capacities().edges;
        const scene_graph::Status st = full ? scene_graph::Status::kFull : graph->add_edge(l.inactive, xc.node, info);
        if (st != scene_graph::Status::kOk) {
          if (st == scene_graph::Status::kFull) {
            if (full) graph->count_refused_edge();  // else the store counted it itself
            ++r->refused;
            ++counters_.graph_refused;
            r->status = scene_graph::Status::kFull;
          } else {
            log_graph_error("a relink edge", st, ++counters_.graph_errors);
          }
          relinks_[kept++] = l;  // retried on the next sync
          continue;
        }
        ++r->edges_added;
      }
      ++counters_.relinked;
      continue;
    }
    const memory::Index3 g{static_cast<std::int32_t>(std::floor(l.position_m.x() / voxel_m_)),
                           static_cast<std::int32_t>(std::floor(l.position_m.y() / voxel_m_)),
                           static_cast<std::int32_t>(std::floor(l.position_m.z() / voxel_m_))};
    if (find_voxel(g) != kNoRef) relinks_[kept++] = l;
    else ++counters_.relinks_dropped;
  }
  num_relinks_ = kept;
}

// Whether an inactive place still reaches an active place (other than `removed`) within contract_search_places
// graph nodes. Bounded breadth-first search on a fixed array: no allocation.
bool Places::anchored(const scene_graph::SceneGraph& graph, scene_graph::NodeId start, scene_graph::NodeId removed,
                      const scene_graph::NodeId* removing, std::size_t num_removing) const {
  scene_graph::NodeId queue[kMaxContractSearch];
  const int limit = config_.contract_search_places;
  int num = 0;
  queue[num++] = start;
  bool found = false, overflow = false;
  for (int i = 0; i < num && !found && !overflow; ++i) {
    graph.for_each_neighbor(queue[i], [&](scene_graph::NodeId m, const scene_graph::EdgeRecord&) {
      if (found || overflow || m == removed || scene_graph::node_prefix(m) != scene_graph::kPlacePrefix) return;
      const scene_graph::PlaceAttributes* pm = graph.place(m);
      if (pm == nullptr || std::binary_search(removing, removing + num_removing, m)) return;  // going: no anchor
      if (pm->is_active) {
        found = true;
        return;
      }
      for (int j = 0; j < num; ++j)
        if (queue[j] == m) return;
      if (num == limit) {
        overflow = true;  // undecided: contract (one edge too many is cheaper than a cut graph)
        return;
      }
      queue[num++] = m;
    });
  }
  return found;
}

// Before a place node is removed: each inactive neighbour that only reached the active graph through it is joined
// to the removed place's nearest other neighbour (preferring active ones), with the weaker of the two edge weights.
void Places::contract_around(scene_graph::SceneGraph* graph, scene_graph::NodeId removed,
                             const scene_graph::NodeId* removing, std::size_t num_removing, SyncResult* r) {
  constexpr int kMaxNeighbours = 32;
  scene_graph::NodeId nbr[kMaxNeighbours];
  Eigen::Vector3d pos[kMaxNeighbours];
  double weight[kMaxNeighbours];
  bool active[kMaxNeighbours];
  std::uint8_t rank[kMaxNeighbours];  // as a target: 0 active, 1 inactive, 2 removed later in this sync
  int n = 0;
  graph->for_each_neighbor(removed, [&](scene_graph::NodeId m, const scene_graph::EdgeRecord& e) {
    if (n == kMaxNeighbours || scene_graph::node_prefix(m) != scene_graph::kPlacePrefix) return;
    const scene_graph::PlaceAttributes* pm = graph->place(m);
    if (pm == nullptr) return;
    nbr[n] = m;
    pos[n] = pm->position_m;
    weight[n] = e.info.weighted ? e.info.weight : pm->distance_m;
    active[n] = pm->is_active;
    // A place removed later in this sync is the last resort: its own removal then contracts again.
    rank[n] = std::binary_search(removing, removing + num_removing, m) ? 2 : (pm->is_active ? 0 : 1);
    ++n;
  });
  for (int i = 0; i < n; ++i) {
    if (active[i] || anchored(*graph, nbr[i], removed, removing, num_removing)) continue;
    int best = -1;
    double best_d2 = std::numeric_limits<double>::max();
    for (int pass = 0; pass < 3 && best < 0; ++pass)
      for (int j = 0; j < n; ++j) {
        if (j == i || rank[j] != pass) continue;
        const double d2 = (pos[j] - pos[i]).squaredNorm();
        if (d2 < best_d2) {
          best = j;
          best_d2 = d2;
        }
      }
    if (best < 0 || graph->edge_info(nbr[i], nbr[best]) != nullptr) continue;
    scene_graph::EdgeAttributes info;
    info.weighted = true;
    info.weight = std::min(weight[i], weight[best]);
    const bool full = graph->num_edges() >= graph->capacities().edges;
    const scene_graph::Status st = full ? scene_graph::Status::kFull : graph->add_edge(nbr[i], nbr[best], info);
    if (st != scene_graph::Status::kOk) {
      if (st == scene_graph::Status::kFull) {
        if (full) graph->count_refused_edge();  // else the store counted it itself
        ++r->refused;
        ++counters_.graph_refused;
        r->status = scene_graph::Status::kFull;
      } else {
        log_graph_error("a contraction edge", st, ++counters_.graph_errors);
      }
      continue;
    }
    ++r->edges_added;
    ++counters_.contracted;
  }
}

MemoryUse Places::memory_use() const {
  MemoryUse m;
  m.block_bytes = sizeof(Block);
  const memory::ResourceStats bs = blocks_.stats();
  m.blocks_high_water = bs.high_water;
  m.blocks_capacity = capacities_.max_blocks;
  m.esdf_used_bytes = bs.high_water * sizeof(Block);
  {
    memory::ArenaPlan p;
    memory::Pool<Block>::plan(p, capacities_.max_blocks);
    memory::SpatialHash<std::uint32_t>::plan(p, memory::SpatialHash<std::uint32_t>::slots_for(capacities_.max_blocks));
    m.esdf_planned_bytes = p.total_bytes();
  }
  for (int i = 0; lists_ != nullptr && i < kNumLists; ++i) {
    m.work_lists_used_bytes += lists_[i].high_water * sizeof(std::uint32_t);
    m.work_lists_planned_bytes += lists_[i].capacity * sizeof(std::uint32_t);
  }
  m.work_lists_used_bytes += lower_high_water_ * sizeof(std::uint32_t);
  m.work_lists_planned_bytes += lower_capacity_ * sizeof(std::uint32_t);
  {
    const memory::ResourceStats cs = clusters_.stats(), cells = cells_.stats(), in = inactive_.stats();
    memory::ArenaPlan p;
    memory::Pool<Cluster>::plan(p, capacities_.place_nodes);
    memory::SpatialHash<std::uint32_t>::plan(p, memory::SpatialHash<std::uint32_t>::slots_for(capacities_.inactive_cells));
    p.add_array<InactiveEntry>(capacities_.inactive_cells);
    memory::SpatialHash<std::uint32_t>::plan(p, memory::SpatialHash<std::uint32_t>::slots_for(capacities_.place_nodes));
    p.add_array<Relink>(capacities_.pending_relinks);
    m.places_planned_bytes = p.total_bytes();
    // Used: slots at their high water, each at its planned share of the store.
    const auto share = [](std::size_t planned, std::size_t used, std::size_t capacity) {
      return capacity == 0 ? 0 : planned * used / capacity;
    };
    memory::ArenaPlan pc, pi, ph;
    memory::Pool<Cluster>::plan(pc, capacities_.place_nodes);
    memory::SpatialHash<std::uint32_t>::plan(pi, memory::SpatialHash<std::uint32_t>::slots_for(capacities_.inactive_cells));
    memory::SpatialHash<std::uint32_t>::plan(ph, memory::SpatialHash<std::uint32_t>::slots_for(capacities_.place_nodes));
    m.places_used_bytes = share(pc.total_bytes(), cs.high_water, cs.capacity) +
                          share(pi.total_bytes(), in.high_water, in.capacity) +
                          inactive_high_water_ * sizeof(InactiveEntry) +
                          share(ph.total_bytes(), cells.high_water, cells.capacity) +
                          relinks_high_water_ * sizeof(Relink);
  }
  m.arena_planned_bytes = plan(capacities_).total_bytes();
  return m;
}

// ---------------------------------------------------------------------------------------------------------
// Queries

std::uint32_t Places::voxel_at(const Eigen::Vector3d& p_m) const {
  if (!ready_) return kNoRef;
  return find_voxel({static_cast<std::int32_t>(std::floor(p_m.x() / voxel_m_)),
                     static_cast<std::int32_t>(std::floor(p_m.y() / voxel_m_)),
                     static_cast<std::int32_t>(std::floor(p_m.z() / voxel_m_))});
}

bool Places::distance_at(const Eigen::Vector3d& p_m, float* distance_m) const {
  const std::uint32_t ref = voxel_at(p_m);
  if (ref == kNoRef) return false;
  const Voxel& v = vox(ref);
  if ((v.state != kFree && v.state != kSeed) || v.parent == kNoRef) return false;
  *distance_m = v.distance_m;
  return true;
}

bool Places::probe(const Eigen::Vector3d& p_m, VoxelProbe* out) const {
  const std::uint32_t ref = voxel_at(p_m);
  if (ref == kNoRef) return false;
  static constexpr const char* kStates[] = {"free", "seed", "occupied", "unobserved"};
  const Voxel& v = vox(ref);
  *out = VoxelProbe{};
  out->position_m = center_m(coords(ref));
  out->state = kStates[v.state & 3];
  out->carved = (v.flags & kCarved) != 0;
  out->gvd = (v.flags & kGvd) != 0;
  out->distance_m = v.distance_m;
  out->num_basis_points = v.num_basis;
  if (v.parent != kNoRef) {
    const Voxel& pv = vox(v.parent);
    out->has_parent = true;
    out->parent_m = center_m(coords(v.parent));
    out->parent_state = kStates[pv.state & 3];
    out->parent_distance_m = pv.distance_m;
  }
  return true;
}

void Places::gvd_voxels(std::vector<GvdVoxelInfo>* out) const {
  out->clear();
  if (!ready_) return;
  blocks_.for_each([&](std::uint32_t h, const Block&) {
    for (int local = 0; local < kBlockVoxels; ++local) {
      const std::uint32_t ref = make_ref(h, local);
      const Voxel& v = vox(ref);
      if ((v.flags & kGvd) == 0) continue;
      GvdVoxelInfo info;
      info.position_m = center_m(coords(ref));
      info.clearance_m = v.distance_m;
      info.num_basis_points = v.num_basis;
      std::uint32_t parents[kMaxBasis];
      const int n = std::min(std::max(0, evaluate_gvd(ref, parents, kMaxBasis)), kMaxBasis);
      for (int k = 0; k < n; ++k) info.basis_m.push_back(center_m(coords(parents[k])));
      out->push_back(info);
    }
  });
}

void Places::places(std::vector<PlaceInfo>* out) const {
  out->clear();
  if (!ready_) return;
  clusters_.for_each([&](std::uint32_t, const Cluster& c) {
    if (c.state != kLive) return;
    PlaceInfo p;
    p.id = c.node;
    p.position_m = c.position_m;
    p.clearance_m = c.clearance_m;
    p.num_basis_points = c.num_basis;
    p.num_voxels = c.count;
    for (int k = 0; k < c.num_edges; ++k)
      (c.edge_free[k] == kEdgeBridge ? p.bridge_edges : c.edge_free[k] == kEdgeFree ? p.free_space_edges : p.edges)
          .emplace_back(clusters_[c.edge_to[k]].node, c.edge_weight[k]);
    for (std::uint32_t r = c.head; r != kNoRef; r = vox(r).cluster_next) {
      p.voxel_positions_m.push_back(center_m(coords(r)));
      p.voxel_clearances_m.push_back(vox(r).distance_m);
      p.voxel_basis_points.push_back(vox(r).num_basis);
    }
    out->push_back(std::move(p));
  });
}

std::size_t Places::num_place_edges() const {
  std::size_t n = 0;
  clusters_.for_each([&](std::uint32_t, const Cluster& c) {
    if (c.state == kLive) n += c.num_edges;
  });
  return n / 2;
}

}  // namespace qsg::places
