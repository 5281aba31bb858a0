// Layer 2 objects: per-label Euclidean clustering of the active window's new mesh vertices into objects (label,
// centroid, box, mesh-vertex references), merged across updates, synced into the scene graph; fixed memory.
//
// How an update works (paper sec. "Layers 2: Objects and Agents", plus what makes it incremental):
//   - Only vertices of blocks re-meshed since the last update are presented. A vertex is identified by its global
//     voxel-edge key (border duplicates share it; it survives re-meshing), so a vertex already assigned to an
//     object keeps its object; only vertices with unseen keys ("candidates") are clustered.
//   - Candidates of each label are clustered by connected components under distance <= the label's tolerance.
//     They are sorted into grid cells of side tolerance / sqrt(3), so any two vertices of one cell are connected
//     without a distance check; a union-find over the occupied cells then joins neighbouring cells (up to two
//     cells away) that hold a pair within the tolerance, found by walking the sorted cells, not by hashing.
//     Pairs of cells already joined are skipped, and a pair's search stops at its first close pair, so the cost
//     follows the number of cells rather than the density of the vertices. A cluster that comes within the
//     tolerance of an existing object's tracked vertex of the same label joins that object (and joins objects it
//     connects), so an object seen over several updates is the same connected component a single batch would give.
//   - Any other cluster larger than the label's max vertex count is dropped. One with at least the min count is
//     merged into an existing visible object of the same label when one's centre lies in the other's box (the
//     paper's rule) or their boxes intersect, else it is new. A smaller one becomes a tentative object: tracked
//     and joinable (an object seen a little at a time still forms), but invisible (not listed, not in the scene
//     graph) until it reaches the min count, and deleted when its last vertex leaves the window below it.
//   - At the end of every update, objects (tentative ones included) changed by it are merged with any other object
//     of their label that one of three rules pairs them with: the paper's centre-in-box rule; boxes that intersect
//     (Hydra also merges on overlap); and, for labels with a size prior (LabelParams::max_size_m), fragments whose
//     joint box still fits one instance of the label and whose heights meet. Boxes grow over updates, so parts
//     of one piece of furniture seen apart merge whichever update each came from. The size prior is for labels
//     whose visible parts a low camera sees disconnected: a bed's foot end and the headboard above a mattress at
//     camera height, a table's legs below a top thinner than a voxel. Merged objects keep every vertex, so the box
//     covers the whole object and its centre is the object's.
//   - Candidates for a merge come from a fixed-capacity grid index of object box centres per label (cells of
//     Config::index_cell_m), searched over the reach of the rules: the cost of an update follows the objects near
//     what changed, not the number of objects ever seen.
//   - An object's position is the centre of its axis-aligned box, not the mean of its vertices: surface vertices
//     sample an object non-uniformly (a table's top dominates its legs, the side facing the robot dominates the
//     far side), so their mean is pulled toward the best-seen surface, while the box centre is what a
//     ground-truth box and the scene graph's bounding box describe. The vertex mean stays available.
//   - The box follows the surface: when tracked vertices go stale or move, the box is recomputed (at the end of
//     the update) from the tracked vertices plus the box of the vertices already released with their blocks.
//   - Visits (Config::archive_after_s; Hydra's split between frontend and backend): an object whose vertices all
//     left the active window and that no update's vertices changed for archive_after_s is archived. The rules above
//     no longer merge anything into it, so a revisit made in other drift becomes an object of its own, with its own
//     time, the loop-closure correction moves each visit with its own drift, and objects::merge_revisits() joins
//     the visits at the finish, in the corrected map. (An object whose blocks never leave the window stays one
//     object across visits: its surface is the TSDF's, which fuses every visit.) Each visit kept apart costs an
//     object and a sample of keys, so visits are kept apart only while both stores are below
//     Config::archive_below_use of their capacity; past it revisits merge as mapped, as before.
//   - Tracked vertices whose block was re-meshed without them are stale (the surface moved) and leave their
//     object; tracked vertices of blocks that left the active window are released but stay in the object's
//     summary (centroid sum, count, box) and in its list of vertex keys.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <cstdio>
#include <string>

#include "core/memory/arena.h"
#include "core/memory/fixed_hash_map.h"
#include "core/memory/fixed_vector.h"
#include "core/memory/pool.h"
#include "core/scene_graph/node_id.h"
#include "core/semantics/labels.h"

namespace qsg::reconstruction {
class SemanticTsdf;
}
namespace qsg::scene_graph {
class SceneGraph;
}

namespace qsg::objects {

// Clustering parameters of one label. Structure labels (semantics::is_structure) must stay disabled.
struct LabelParams {
  bool enabled = false;
  double tolerance_m = 0.2;       // two vertices closer than this are in the same cluster
  std::uint32_t min_vertices = 20;  // smaller clusters are noise (not yet an object)
  std::uint32_t max_vertices = 50000;  // larger clusters are not one object (e.g. a mislabelled wall)
  // Size prior (0 = none): two objects of the label whose joint box is at most this long on both horizontal axes,
  // and whose heights meet within the tolerance, are fragments of one instance and merge.
  double max_size_m = 0.0;
};

using LabelTable = std::array<LabelParams, semantics::kNumObjectLabels>;
// Every non-structure mpcat40 label enabled; tolerance 0.2 m (two 0.1 m voxels: marching-cubes vertices of one
// surface are at most ~0.17 m apart). The minimum size is a noise gate, 8 vertices for small labels (a picture
// is only a few) and 20 for all others: noise does not grow with the label's physical size, and a large object
// is often seen only in part (a 0.43 m coffee table below a 0.5 m camera shows one side, ~30 vertices); its
// fragments are merged (connection, centre-in-box, box overlap), not hidden. The maximum vertex count depends on
// the label's size. Size priors for the two labels whose parts a 0.5 m camera sees disconnected: bed 2.3 m (a
// super-king bed with its frame), table 2.4 m (an eight-seat dining table).
LabelTable default_label_params();

struct Config {
  LabelTable labels = default_label_params();
  // The paper's centre-in-box merge: of new clusters not connected to an object, and between changed objects.
  bool merge_overlapping = true;
  // Merge objects of one label whose boxes intersect (Hydra's overlap merge); also for new clusters.
  bool merge_intersecting = true;
  // Apply the labels' size priors (LabelParams::max_size_m) between changed objects and their neighbours.
  bool merge_by_size_prior = true;
  // Cell of the grid that indexes object box centres for the merge search: a performance knob (which objects may
  // merge does not depend on it); about the size of a large object.
  double index_cell_m = 2.0;
  // Mesh-vertex references (mesh connections) an object keeps at most: a uniform sample of its surface (reservoir
  // sampling over every vertex it was given), not all of it. A revisited surface under drifting odometry lands on
  // new vertices every pass, so each object reaches the cap: the key store (the budget's vertex_keys) then holds
  // vertex_keys / max_keys_per_object objects at the cap (an 8-hour mission under drift with 2048 filled it;
  // bench/results/odometry.md). Vertices past the cap still shape the object (centroid, box).
  std::uint32_t max_keys_per_object = 512;
  // Visits kept apart (Hydra's split: the frontend merges into objects of the active window, the backend merges
  // revisits after the correction). An object whose vertices all left the active window more than this long ago is
  // archived: a new cluster or a changed object no longer merges into it by the rules above, so a revisit made in
  // other drift becomes an object of its own, with its own time, and the correction moves each visit with its own
  // drift; merge_revisits() joins them at the finish, in the corrected map. 0: every visit merges as mapped.
  double archive_after_s = 10.0;
  // The policy when the stores fill: every visit kept apart is an object and a sample of keys more, so visits are
  // kept apart only while the object store and the key store are both below this share of their capacity; past it a
  // revisit merges as mapped, and a mission of any length stays within the stores (counted: archived_merged_full).
  double archive_below_use = 0.5;
  // At the finish (merge_revisits), objects that the layer held at the same time (their lives, first to last update,
  // overlap) are never joined: the layer's own rules, wider than the finish's, saw both and kept them apart, and a
  // correction moves them together. Without it a survivor's grown box joins a visit's neighbour of its label.
  bool finish_keeps_concurrent_apart = true;
  std::string check() const;      // empty when usable, else the bad field and why
  void print(std::FILE* out) const;
};

// The merge rules between two boxes of one label (lo/hi: min and max corners), as Config switches them: the paper's
// centre-in-box, intersecting boxes, and (not for a new cluster) the label's size prior.
enum class MergeRule : std::uint8_t { kNone, kCentreInBox, kIntersect, kSizePrior };
MergeRule merge_rule(const Config& config, semantics::Label label, const float* lo, const float* hi,
                     const float* other_lo, const float* other_hi, bool new_cluster);

// Sizes of the layer's stores: the budget table's "objects" arena (capacities_from_budget()), or a test's own.
struct Capacities {
  std::size_t cluster_vertices = 0;  // new (not yet tracked) vertices clustered in one update
  std::size_t tracked_vertices = 0;  // object vertices in the active window
  std::size_t vertex_keys = 0;       // mesh-vertex keys kept by all objects (their mesh connections)
  std::size_t tracked_blocks = 0;    // active-window blocks holding object vertices
  std::size_t objects = 0;
  std::string check() const;
  void print(std::FILE* out) const;
};
Capacities capacities_from_budget();

struct Counters {
  std::uint64_t updates = 0;
  std::uint64_t vertices_presented = 0;    // vertices of enabled labels in re-meshed blocks
  std::uint64_t candidates = 0;            // of which not tracked yet (clustered)
  std::uint64_t clusters = 0;
  std::uint64_t clusters_too_small = 0;     // kept as tentative objects
  std::uint64_t clusters_too_large = 0;
  std::uint64_t clusters_joined = 0;       // connected to existing objects
  std::uint64_t clusters_overlap_merged = 0;  // new clusters merged by the centre-in-box rule
  std::uint64_t objects_overlap_merged = 0;   // objects merged by the centre-in-box rule (also in objects_merged)
  std::uint64_t objects_intersect_merged = 0;  // by intersecting boxes (also in objects_merged)
  std::uint64_t objects_size_merged = 0;       // by the label's size prior (also in objects_merged)
  std::uint64_t archived_kept_apart = 0;       // merges a rule would have made into an archived object, not made
  std::uint64_t archived_merged_full = 0;      // ... made all the same: the stores past Config::archive_below_use
  std::uint64_t index_queries = 0;             // merge searches through the object index
  std::uint64_t index_scans = 0;               // of which walked the label's list (a box larger than the index reaches)
  std::uint64_t index_visits = 0;              // objects those searches tested against a rule
  std::uint64_t boxes_recomputed = 0;         // after vertices went stale or moved
  std::uint64_t objects_created = 0;
  std::uint64_t objects_merged = 0;        // objects absorbed by another object
  std::uint64_t objects_removed = 0;       // every vertex went stale
  std::uint64_t vertices_stale = 0;
  std::uint64_t vertices_released = 0;     // their block left the active window
  std::uint64_t blocks_released = 0;
  // Overflows (each also counted and logged by the store that refused):
  std::uint64_t candidate_overflow = 0;  // also a candidate beyond the clustering grid's reach (not a store)
  std::uint64_t tracked_overflow = 0;
  std::uint64_t key_overflow = 0;
  std::uint64_t keys_repeated = 0;       // a revisited vertex whose key an object already keeps: not stored twice
  std::uint64_t keys_capped = 0;         // not kept: the object holds Config::max_keys_per_object already
  std::uint64_t keys_resampled = 0;      // ... kept in place of a random kept one (the reservoir's uniform sample)
  std::uint64_t block_overflow = 0;
  std::uint64_t object_overflow = 0;
  std::uint64_t graph_node_failures = 0;   // scene graph full: object not added (retried on the next sync)
  std::uint64_t graph_connection_failures = 0;  // scene graph mesh-connection pool full: connections dropped
  void print(std::FILE* out) const;
};

// One presented mesh vertex.
struct InputVertex {
  std::uint64_t key = 0;  // global voxel-edge key (SemanticTsdf::next_block_vertex)
  float x = 0, y = 0, z = 0;
  semantics::Label label = semantics::kVoid;
};

// Read-only summary of one object.
struct ObjectView {
  scene_graph::NodeId node = scene_graph::kNoNode;
  semantics::Label label = semantics::kVoid;
  // The object's position (what the scene graph reports): the centre of its box, see the file comment.
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  // The mean of its vertices: biased toward the best-seen surface, kept for consumers that weigh by surface.
  Eigen::Vector3d vertex_mean_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d min_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_m = Eigen::Vector3d::Zero();
  std::uint64_t num_vertices = 0;  // in the vertex mean (tracked now or released with their block)
  std::uint32_t num_tracked = 0;   // in the active window now
  std::uint32_t num_keys = 0;      // mesh-vertex references kept
  std::uint64_t last_update_ns = 0;  // the last update whose vertices changed it (leaving the window does not)
  std::uint64_t first_update_ns = 0;  // the update that created it (of objects merged into it, the earliest)
};

// What one update did.
struct UpdateResult {
  std::uint32_t blocks = 0;      // re-meshed blocks presented
  std::uint32_t vertices = 0;    // vertices of enabled labels presented
  std::uint32_t candidates = 0;  // new vertices clustered
  std::uint32_t clusters = 0;
  std::uint32_t objects_created = 0;
  std::uint32_t objects_updated = 0;  // objects changed (created, grown, merged, shrunk)
};

class ObjectLayer {
 public:
  ObjectLayer();
  ObjectLayer(const ObjectLayer&) = delete;
  ObjectLayer& operator=(const ObjectLayer&) = delete;
  ~ObjectLayer();

  static memory::ArenaPlan plan(const Capacities& capacities);
  // Checks config and capacities, carves every store from one arena of at most budget_bytes. Start-up only.
  bool init(const Config& config, const Capacities& capacities, std::size_t budget_bytes, std::string* error);
  bool initialized() const { return ready_; }

  // The per-update call: releases blocks that left the TSDF's window, presents the vertices of blocks re-meshed
  // since the last call, clusters, merges. Never allocates.
  UpdateResult update(const reconstruction::SemanticTsdf& tsdf, std::uint64_t time_ns);

  // The same, one step at a time (tests, replay): begin_update(), then for each re-meshed block begin_block()
  // followed by all of its vertices, release_block() for blocks that left the window, then end_update().
  void begin_update(std::uint64_t time_ns);
  void begin_block(const memory::Index3& block);
  void add_vertex(const InputVertex& vertex);
  void release_block(const memory::Index3& block);
  UpdateResult end_update();

  // Adds new objects to the graph (NodeId prefix 'O'), updates changed ones (attributes and mesh connections),
  // removes merged or vanished ones. Full graph stores are counted and logged, never fatal; an object that
  // did not fit is retried on the next sync. False when something did not fit.
  bool sync(scene_graph::SceneGraph* graph);
  // Nodes added or updated by the last sync() (e.g. to connect them to their nearest place).
  const memory::VectorView<scene_graph::NodeId>& synced_nodes() const { return synced_; }

  // The stable mesh-vertex reference behind a scene-graph mesh connection: the vertex's global voxel-edge key
  // (its position is on that voxel edge; it finds the vertex in the mesh archive). False for an unknown value.
  bool mesh_vertex_key(std::uint32_t connection, std::uint64_t* key) const;

  // Visible objects (at least their label's min vertex count).
  template <typename Fn>
  void for_each_object(Fn&& fn) const {  // fn(const ObjectView&)
    for (std::uint32_t h = 0; h < objects_.capacity(); ++h)
      if (objects_.live(h) && visible(h)) fn(view(h));
  }
  bool find_object(scene_graph::NodeId node, ObjectView* out) const;
  // Tentative objects (below their label's min vertex count; diagnostics and tests).
  template <typename Fn>
  void for_each_tentative_object(Fn&& fn) const {  // fn(const ObjectView&)
    for (std::uint32_t h = 0; h < objects_.capacity(); ++h)
      if (objects_.live(h) && !visible(h)) fn(view(h));
  }
  // The mesh-vertex keys of an object: fn(std::uint64_t key).
  template <typename Fn>
  void for_each_vertex_key(scene_graph::NodeId node, Fn&& fn) const;

  std::size_t num_objects() const;                                 // visible ones
  std::size_t num_tentative_objects() const { return objects_.size() - num_objects(); }
  std::size_t num_tracked_vertices() const { return tracked_.size(); }
  const Config& config() const { return config_; }
  const Capacities& capacities() const { return capacities_; }
  const Counters& counters() const { return counters_; }
  std::size_t arena_bytes() const { return arena_.capacity_bytes(); }

  template <typename Fn>
  void for_each_resource(Fn&& fn) const {  // fn(const memory::ResourceStats&)
    fn(arena_.stats());
    fn(objects_.stats());
    fn(tracked_.stats());
    fn(tracked_index_.stats());
    fn(kept_keys_.stats());
    fn(tracked_cells_.stats());
    fn(blocks_.stats());
    fn(block_index_.stats());
    fn(key_chunks_.stats());
    fn(candidates_.stats());
    fn(candidate_index_.stats());
    fn(sorted_candidates_.stats());
    fn(sorted_points_.stats());
    fn(cells_.stats());
    fn(cell_parent_.stats());
    fn(cluster_begin_.stats());
    fn(new_tracked_.stats());
    fn(object_cells_.stats());
  }

  static constexpr std::uint32_t kKeysPerChunk = 15;

  struct Object;
  struct TrackedVertex;
  struct Block;
  struct KeyChunk {
    std::uint64_t keys[kKeysPerChunk];
    std::uint32_t next;
    std::uint32_t count;
  };
  struct Candidate;
  struct SortedCandidate;
  struct CandidateCell;
  struct Point {
    float p[3];
  };

 private:
  ObjectView view(std::uint32_t h) const;
  bool visible(std::uint32_t h) const;
  std::uint32_t find_handle(scene_graph::NodeId node) const;  // linear: objects are few, not on the hot path
  std::uint32_t object_key_head(std::uint32_t h) const;
  void cell_of(semantics::Label label, const float* p, std::int32_t* c) const;
  std::uint64_t cell_key(semantics::Label label, const float* p) const;
  void cell_insert(memory::FixedHashMap<std::uint64_t, std::uint32_t, memory::U64Hash>& cells, std::uint64_t cell,
                   std::uint32_t item, std::uint32_t* next_field);
  void tracked_cell_remove(std::uint32_t slot);
  void detach_tracked(std::uint32_t slot, bool subtract_from_object);
  void unlink_from_block(std::uint32_t slot);
  void move_tracked(std::uint32_t slot, const InputVertex& v);
  void add_to_box(std::uint32_t object, const float* p);
  void sweep_block(std::uint32_t block);
  std::uint32_t create_object(semantics::Label label);
  void merge_objects(std::uint32_t into, std::uint32_t from);
  void delete_object(std::uint32_t h);
  // To be synced. observed: by this update's vertices (its time becomes the update's), not by leaving the window.
  void mark_changed(std::uint32_t h, bool observed = true);
  bool register_vertex(std::uint32_t object, const Candidate& c);
  bool append_key(std::uint32_t object, std::uint64_t key);
  void release_keys(std::uint32_t object);
  void sort_candidates_into_cells();
  std::uint32_t find_root(std::uint32_t cell);
  bool cells_apart(const CandidateCell& a, const CandidateCell& b, semantics::Label label) const;
  bool cells_connected(const CandidateCell& a, const CandidateCell& b, semantics::Label label) const;
  void connect_cells();
  std::uint32_t group_clusters();
  std::uint32_t find_linked_objects(std::uint32_t begin, std::uint32_t end, std::uint32_t* linked,
                                    std::uint32_t max_linked);
  void process_cluster(std::uint32_t begin, std::uint32_t end, const std::uint32_t* linked, std::uint32_t num_linked);
  bool archived(std::uint32_t h) const;
  std::uint32_t find_mergeable(semantics::Label label, const float* lo, const float* hi, std::uint32_t skip,
                               bool new_cluster, MergeRule* rule);
  std::uint64_t object_cell(std::uint32_t h, std::uint8_t* bucket) const;
  void index_object(std::uint32_t h);
  void unindex_object(std::uint32_t h);
  void release_object(std::uint32_t h);
  void merge_changed_objects();
  void recompute_box(std::uint32_t h);
  void log_graph_failure(const char* what, std::uint64_t count) const;

  Config config_;
  Capacities capacities_;
  Counters counters_;
  std::array<float, semantics::kNumObjectLabels> inv_tolerance_{};
  std::array<float, semantics::kNumObjectLabels> tolerance_sq_{};
  // Squared tolerance widened and narrowed by a margin larger than float rounding: a box test against the wider
  // one never rejects a pair the vertex test would accept, one against the narrower never accepts one it would reject.
  std::array<float, semantics::kNumObjectLabels> tolerance_sq_above_{};
  std::array<float, semantics::kNumObjectLabels> tolerance_sq_below_{};
  std::array<double, semantics::kNumObjectLabels> inv_cluster_cell_{};  // 1 / the clustering cell side
  float inv_index_cell_ = 0.5f;

  memory::Arena arena_;
  memory::Pool<Object> objects_;
  memory::Pool<TrackedVertex> tracked_;
  memory::FixedHashMap<std::uint64_t, std::uint32_t, memory::U64Hash> tracked_index_;  // vertex key -> slot
  memory::FixedHashMap<std::uint64_t, std::uint32_t, memory::U64Hash> tracked_cells_;  // (label, cell) -> list
  memory::FixedHashMap<std::uint64_t, std::uint32_t, memory::U64Hash> kept_keys_;  // every key an object keeps
  memory::Pool<Block> blocks_;
  memory::SpatialHash<std::uint32_t> block_index_;
  memory::Pool<KeyChunk> key_chunks_;
  memory::ArenaVector<Candidate> candidates_;
  memory::FixedHashMap<std::uint64_t, std::uint32_t, memory::U64Hash> candidate_index_;  // dedupe in one update
  // Clustering scratch, refilled by every update (see sort_candidates_into_cells()):
  memory::ArenaVector<SortedCandidate> sorted_candidates_;  // candidates by cell key
  memory::ArenaVector<Point> sorted_points_;                // their positions in that order, each cell contiguous
  memory::ArenaVector<CandidateCell> cells_;                // the occupied cells, by key
  memory::ArenaVector<std::uint32_t> cell_parent_;          // union-find forest over cells_
  memory::ArenaVector<std::uint32_t> cluster_begin_;        // cluster k is order_[cluster_begin_[k], [k + 1])
  // Slots registered by this update: entered into tracked_cells_ once every cluster has looked for objects to
  // join (they cannot join another cluster of this update, which would be the same cluster).
  memory::ArenaVector<std::uint32_t> new_tracked_;
  // (label, cell of the box centre) -> objects there, linked through Object::index_next.
  memory::FixedHashMap<std::uint64_t, std::uint32_t, memory::U64Hash> object_cells_;
  // Objects per label per half-extent class (in index cells; the last class is "larger"): how far a search reaches.
  static constexpr std::uint32_t kExtentClasses = 16;
  std::array<std::array<std::uint32_t, kExtentClasses>, semantics::kNumObjectLabels> extent_count_{};
  std::array<std::uint32_t, semantics::kNumObjectLabels> label_head_{};  // objects of each label (Object::label_*)
  memory::ArenaVector<std::uint32_t> order_;            // candidates by cluster, in presentation order in each
  memory::ArenaVector<std::uint32_t> presented_blocks_;  // block records re-meshed this update
  memory::ArenaVector<std::uint32_t> changed_;           // objects changed since the last sync
  memory::ArenaVector<scene_graph::NodeId> removed_nodes_;  // nodes to remove at the next sync
  memory::ArenaVector<scene_graph::NodeId> synced_;

  std::uint32_t stamp_ = 0;           // update counter; a tracked vertex seen this update carries it
  std::uint32_t current_block_ = memory::kInvalidHandle;  // record of the block being presented (may be absent)
  memory::Index3 current_index_;
  bool in_block_ = false;
  bool in_update_ = false;
  std::uint32_t last_mesh_stamp_ = 0;  // of the TSDF, at the previous update()
  std::uint64_t time_ns_ = 0;
  std::uint64_t archive_after_ns_ = 0;  // Config::archive_after_s (0: never archived)
  bool archive_full_ = false;           // the stores past Config::archive_below_use (set by begin_update)
  std::uint64_t next_object_index_ = 0;
  UpdateResult result_;
  bool ready_ = false;
};

template <typename Fn>
void ObjectLayer::for_each_vertex_key(scene_graph::NodeId node, Fn&& fn) const {
  const std::uint32_t h = find_handle(node);
  if (h == memory::kInvalidHandle) return;
  for (std::uint32_t c = object_key_head(h); c != memory::kInvalidHandle; c = key_chunks_[c].next)
    for (std::uint32_t i = 0; i < key_chunks_[c].count; ++i) fn(key_chunks_[c].keys[i]);
}

}  // namespace qsg::objects
