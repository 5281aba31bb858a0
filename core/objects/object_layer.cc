// Layer 2 objects: incremental per-label Euclidean clustering of mesh vertices into objects, in fixed memory.
#include "core/objects/object_layer.h"

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstring>
#include <limits>

#include "budgets/budget_table.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::objects {

using memory::kInvalidHandle;
using scene_graph::NodeId;

struct ObjectLayer::Object {
  NodeId node = scene_graph::kNoNode;
  semantics::Label label = semantics::kVoid;
  bool changed = false;   // waiting in changed_ for the next sync
  std::uint32_t touched = 0;  // stamp of the last update that changed it (the merge step looks at these only)
  bool in_graph = false;  // a node was added for it
  double sum[3] = {0, 0, 0};
  std::uint64_t num_vertices = 0;
  float lo[3] = {0, 0, 0};
  float hi[3] = {0, 0, 0};
  // Box of the vertices released with their blocks (their positions are gone): a recomputed box starts from it.
  float released_lo[3] = {0, 0, 0};
  float released_hi[3] = {0, 0, 0};
  bool box_dirty = false;  // a vertex on the box's boundary went stale or moved: recompute at the end of the update
  std::uint32_t tracked_head = kInvalidHandle;  // doubly linked through TrackedVertex::obj_prev/obj_next
  std::uint32_t num_tracked = 0;
  std::uint32_t key_head = kInvalidHandle;
  std::uint32_t key_tail = kInvalidHandle;
  std::uint32_t num_keys = 0;
  std::uint64_t keys_seen = 0;  // distinct keys ever offered (the reservoir's count)
  std::uint64_t last_update_ns = 0;
  // Entry in the merge index (object_cells_), kept in step with the box by index_object().
  std::uint64_t index_cell = 0;
  std::uint32_t index_next = kInvalidHandle;
  std::uint8_t extent_class = 0;
  bool indexed = false;
  std::uint32_t label_prev = kInvalidHandle;  // all objects of the label (label_head_), doubly linked
  std::uint32_t label_next = kInvalidHandle;
};

struct ObjectLayer::TrackedVertex {
  std::uint64_t key = 0;
  float p[3] = {0, 0, 0};
  semantics::Label label = semantics::kVoid;
  std::uint32_t object = kInvalidHandle;
  std::uint32_t block = kInvalidHandle;
  std::uint32_t obj_prev = kInvalidHandle;
  std::uint32_t obj_next = kInvalidHandle;
  std::uint32_t cell_next = kInvalidHandle;
  std::uint32_t block_next = kInvalidHandle;
  std::uint32_t seen = 0;  // stamp of the last update that presented it
};

struct ObjectLayer::Block {
  memory::Index3 index;
  std::uint32_t head = kInvalidHandle;  // tracked vertices owned by the block (singly linked)
  std::uint32_t count = 0;
  std::uint32_t presented = 0;  // stamp of the last update that re-meshed it
};

struct ObjectLayer::Candidate {
  std::uint64_t key = 0;
  float p[3] = {0, 0, 0};
  memory::Index3 block;
  std::uint32_t cell = kInvalidHandle;  // its clustering cell (cells_); kInvalidHandle if it fits none
  semantics::Label label = semantics::kVoid;
};

// Sorting these puts the candidates of each clustering cell next to each other, the cells in key order.
struct ObjectLayer::SortedCandidate {
  std::uint64_t cell_key;
  std::uint32_t candidate;
};

// An occupied clustering cell.
struct ObjectLayer::CandidateCell {
  std::uint64_t key;
  std::uint32_t begin, end;  // its vertices: sorted_points_[begin, end)
  float lo[3], hi[3];        // box of its vertices (tighter than the cell: more pairs of cells are ruled out)
  std::uint32_t cluster;     // on the root of a set of joined cells: the number of its cluster
  bool searched;             // for objects to join, by its cluster
};

namespace {

constexpr int kCellBits = 19;
constexpr std::int32_t kCellOffset = 1 << (kCellBits - 1);
constexpr std::uint64_t kCellMask = (std::uint64_t{1} << kCellBits) - 1;
constexpr std::uint32_t kMaxLinked = 16;  // existing objects one cluster may join in one update

// Clustering cells: two vertices of one cell are within the tolerance, so a vertex within the tolerance of another
// is at most two cells away on each axis. Their coordinates are counted from the lowest cell of the label's
// candidates in the update, plus this reach, so that every neighbour's coordinates fit the field too.
constexpr std::uint64_t kNeighbourReach = 2;
constexpr double kMaxClusterCell = static_cast<double>(kCellMask - kNeighbourReach);
// Relative margin on squared distances, far above float rounding (~1e-7): a shortcut decided on a box or a cell
// side with this margin agrees with the vertex-to-vertex test dist_sq <= tolerance^2.
constexpr double kRoundingMargin = 1e-5;

// A grid cell of one label: 19 bits per axis and the label on top.
inline std::uint64_t pack_fields(semantics::Label label, std::uint64_t x, std::uint64_t y, std::uint64_t z) {
  return (static_cast<std::uint64_t>(label) << (3 * kCellBits)) | (x << (2 * kCellBits)) | (y << kCellBits) | z;
}

// A cell of the grids keyed by absolute cell coordinates (cells of >= 0.05 m cover +-13 km; farther cells share
// keys, which costs distance tests but never changes a result).
inline std::uint64_t pack_cell(semantics::Label label, std::int32_t x, std::int32_t y, std::int32_t z) {
  const auto p = [](std::int32_t v) { return static_cast<std::uint64_t>(v + kCellOffset) & kCellMask; };
  return pack_fields(label, p(x), p(y), p(z));
}

inline bool inside(const float* p, const float* lo, const float* hi) {
  return p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] && p[1] <= hi[1] && p[2] >= lo[2] && p[2] <= hi[2];
}

inline void box_centre(const float* lo, const float* hi, float* c) {
  for (int i = 0; i < 3; ++i) c[i] = 0.5f * (lo[i] + hi[i]);
}

// Whether p is on the box: removing or moving it may shrink the box (a vertex strictly inside cannot).
inline bool on_boundary(const float* p, const float* lo, const float* hi) {
  for (int i = 0; i < 3; ++i)
    if (p[i] <= lo[i] || p[i] >= hi[i]) return true;
  return false;
}

inline void empty_box(float* lo, float* hi) {
  for (int i = 0; i < 3; ++i) {
    lo[i] = std::numeric_limits<float>::max();
    hi[i] = -std::numeric_limits<float>::max();
  }
}

inline float dist_sq(const float* a, const float* b) {
  const float dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return dx * dx + dy * dy + dz * dz;
}

// Squared distance from p to the box (0 inside).
inline float box_dist_sq(const float* p, const float* lo, const float* hi) {
  float d = 0.0f;
  for (int i = 0; i < 3; ++i) {
    const float g = std::max({0.0f, lo[i] - p[i], p[i] - hi[i]});
    d += g * g;
  }
  return d;
}

bool is_large(semantics::Label l) {
  using namespace semantics;
  switch (l) {
    case kTable: case kCabinet: case kSofa: case kBed: case kChestOfDrawers: case kShower: case kBathtub:
    case kCounter: case kFireplace: case kShelving: case kGymEquipment: case kSeating: case kFurniture:
      return true;
    default:
      return false;
  }
}
bool is_small(semantics::Label l) {
  using namespace semantics;
  switch (l) {
    case kPicture: case kCushion: case kPlant: case kTowel: case kLighting: case kClothes: case kObjects:
    case kMirror: case kTvMonitor: case kBoardPanel:
      return true;
    default:
      return false;
  }
}

}  // namespace

LabelTable default_label_params() {
  LabelTable t{};
  for (semantics::Label l = 0; l < semantics::kNumObjectLabels; ++l) {
    LabelParams& p = t[l];
    p.enabled = !semantics::is_structure(l);
    p.tolerance_m = 0.2;
    p.min_vertices = is_small(l) ? 8 : 20;
    p.max_vertices = is_large(l) ? 200000 : 50000;
  }
  t[semantics::kBed].max_size_m = 2.3;
  t[semantics::kTable].max_size_m = 2.4;
  return t;
}

std::string Config::check() const {
  char buf[160];
  for (semantics::Label l = 0; l < semantics::kNumObjectLabels; ++l) {
    const LabelParams& p = labels[l];
    const char* name = semantics::object_label(l).name;
    if (p.enabled && semantics::is_structure(l)) {
      std::snprintf(buf, sizeof(buf), "labels[%u] (%s): a structure label never becomes an object", l, name);
      return buf;
    }
    if (!(p.tolerance_m >= 0.05 && p.tolerance_m <= 2.0)) {
      std::snprintf(buf, sizeof(buf), "labels[%u] (%s).tolerance_m must be in [0.05, 2] m", l, name);
      return buf;
    }
    if (p.min_vertices < 1 || p.max_vertices < p.min_vertices) {
      std::snprintf(buf, sizeof(buf), "labels[%u] (%s): need 1 <= min_vertices <= max_vertices", l, name);
      return buf;
    }
    if (!(p.max_size_m >= 0.0 && p.max_size_m <= 20.0)) {
      std::snprintf(buf, sizeof(buf), "labels[%u] (%s).max_size_m must be in [0, 20] m (0: no size prior)", l, name);
      return buf;
    }
  }
  if (!(index_cell_m >= 0.25 && index_cell_m <= 50.0)) return "index_cell_m must be in [0.25, 50] m";
  if (max_keys_per_object < 1 || max_keys_per_object > 1000000) return "max_keys_per_object must be in [1, 1000000]";
  return {};
}

void Config::print(std::FILE* out) const {
  std::fprintf(out,
               "objects: merge_overlapping=%d merge_intersecting=%d merge_by_size_prior=%d index_cell_m=%.2f "
               "max_keys_per_object=%u; enabled labels (tolerance_m, min..max vertices[, max_size_m]):",
               merge_overlapping ? 1 : 0, merge_intersecting ? 1 : 0, merge_by_size_prior ? 1 : 0, index_cell_m,
               max_keys_per_object);
  for (semantics::Label l = 0; l < semantics::kNumObjectLabels; ++l) {
    const LabelParams& p = labels[l];
    if (!p.enabled) continue;
    std::fprintf(out, " %s(%.2f,%u..%u", semantics::object_label(l).name, p.tolerance_m, p.min_vertices,
                 p.max_vertices);
    if (p.max_size_m > 0.0) std::fprintf(out, ",%.2f", p.max_size_m);
    std::fprintf(out, ")");
  }
  std::fprintf(out, "\n");
}

std::string Capacities::check() const {
  if (cluster_vertices == 0) return "cluster_vertices must be positive";
  if (tracked_vertices == 0) return "tracked_vertices must be positive";
  if (vertex_keys < ObjectLayer::kKeysPerChunk) return "vertex_keys must be at least 15";
  if (tracked_blocks == 0) return "tracked_blocks must be positive";
  if (objects == 0) return "objects must be positive";
  if (vertex_keys > std::numeric_limits<std::uint32_t>::max() / 2)
    return "vertex_keys too large for 32-bit mesh connections";
  return {};
}

void Capacities::print(std::FILE* out) const {
  std::fprintf(out,
               "objects capacities: cluster_vertices %zu, tracked_vertices %zu, vertex_keys %zu, tracked_blocks %zu, "
               "objects %zu\n",
               cluster_vertices, tracked_vertices, vertex_keys, tracked_blocks, objects);
}

Capacities capacities_from_budget() {
  namespace b = budgets::active::objects;
  Capacities c;
  c.cluster_vertices = b::kClusterVertices;
  c.tracked_vertices = b::kTrackedVertices;
  c.vertex_keys = b::kVertexKeys;
  c.tracked_blocks = b::kTrackedBlocks;
  c.objects = b::kObjects;
  return c;
}

void Counters::print(std::FILE* out) const {
  std::fprintf(out,
               "objects: updates=%" PRIu64 " presented=%" PRIu64 " candidates=%" PRIu64 " clusters=%" PRIu64
               " (too_small=%" PRIu64 " too_large=%" PRIu64 " joined=%" PRIu64 " overlap_merged=%" PRIu64
               ") objects created=%" PRIu64 " merged=%" PRIu64 " (overlap %" PRIu64 " intersect %" PRIu64
               " size %" PRIu64 ") removed=%" PRIu64 " index queries=%" PRIu64 " (scans %" PRIu64
               ", visits %" PRIu64 ") boxes_recomputed=%" PRIu64 " vertices stale=%" PRIu64
               " released=%" PRIu64 " blocks released=%" PRIu64 " keys repeated=%" PRIu64 " capped=%" PRIu64
               " resampled=%" PRIu64
               " overflow: candidate=%" PRIu64 " tracked=%" PRIu64
               " key=%" PRIu64 " block=%" PRIu64 " object=%" PRIu64 " graph_node=%" PRIu64
               " graph_connection=%" PRIu64 "\n",
               updates, vertices_presented, candidates, clusters, clusters_too_small, clusters_too_large,
               clusters_joined, clusters_overlap_merged, objects_created, objects_merged, objects_overlap_merged,
               objects_intersect_merged, objects_size_merged, objects_removed, index_queries, index_scans, index_visits,
               boxes_recomputed, vertices_stale, vertices_released, blocks_released, keys_repeated, keys_capped,
               keys_resampled, candidate_overflow, tracked_overflow, key_overflow, block_overflow, object_overflow, graph_node_failures,
               graph_connection_failures);
}

// -------------------------------------------------------------------------------------------------------------
// Every store refuses (counted, logged) rather than aborting: a full store is a degradation the layer reports.
ObjectLayer::ObjectLayer()
    : objects_("objects.objects", memory::OverflowPolicy::kRefuse),
      tracked_("objects.tracked_vertices", memory::OverflowPolicy::kRefuse),
      tracked_index_("objects.tracked_index", memory::OverflowPolicy::kRefuse),
      tracked_cells_("objects.tracked_cells", memory::OverflowPolicy::kRefuse),
      kept_keys_("objects.kept_keys", memory::OverflowPolicy::kRefuse),
      blocks_("objects.blocks", memory::OverflowPolicy::kRefuse),
      block_index_("objects.block_index", memory::OverflowPolicy::kRefuse),
      key_chunks_("objects.key_chunks", memory::OverflowPolicy::kRefuse),
      candidates_("objects.candidates", memory::OverflowPolicy::kRefuse),
      candidate_index_("objects.candidate_index", memory::OverflowPolicy::kRefuse),
      sorted_candidates_("objects.sorted_candidates", memory::OverflowPolicy::kRefuse),
      sorted_points_("objects.sorted_points", memory::OverflowPolicy::kRefuse),
      cells_("objects.cluster_cells", memory::OverflowPolicy::kRefuse),
      cell_parent_("objects.cell_parents", memory::OverflowPolicy::kRefuse),
      cluster_begin_("objects.cluster_begin", memory::OverflowPolicy::kRefuse),
      new_tracked_("objects.new_tracked", memory::OverflowPolicy::kRefuse),
      object_cells_("objects.object_cells", memory::OverflowPolicy::kRefuse),
      order_("objects.order", memory::OverflowPolicy::kRefuse),
      presented_blocks_("objects.presented_blocks", memory::OverflowPolicy::kRefuse),
      changed_("objects.changed", memory::OverflowPolicy::kRefuse),
      removed_nodes_("objects.removed_nodes", memory::OverflowPolicy::kRefuse),
      synced_("objects.synced", memory::OverflowPolicy::kRefuse) {}

ObjectLayer::~ObjectLayer() = default;

namespace {
using U64Map = memory::FixedHashMap<std::uint64_t, std::uint32_t, memory::U64Hash>;
std::size_t key_chunk_count(const Capacities& c) { return (c.vertex_keys + 14) / 15; }
}  // namespace

memory::ArenaPlan ObjectLayer::plan(const Capacities& c) {
  memory::ArenaPlan p;
  memory::Pool<Object>::plan(p, c.objects);
  memory::Pool<TrackedVertex>::plan(p, c.tracked_vertices);
  U64Map::plan(p, U64Map::slots_for(c.tracked_vertices));
  U64Map::plan(p, U64Map::slots_for(c.tracked_vertices));
  memory::Pool<Block>::plan(p, c.tracked_blocks);
  memory::SpatialHash<std::uint32_t>::plan(p, memory::SpatialHash<std::uint32_t>::slots_for(c.tracked_blocks));
  memory::Pool<KeyChunk>::plan(p, key_chunk_count(c));
  U64Map::plan(p, U64Map::slots_for(c.vertex_keys));
  memory::ArenaVector<Candidate>::plan(p, c.cluster_vertices);
  U64Map::plan(p, U64Map::slots_for(c.cluster_vertices));
  memory::ArenaVector<SortedCandidate>::plan(p, c.cluster_vertices);
  memory::ArenaVector<Point>::plan(p, c.cluster_vertices);
  memory::ArenaVector<CandidateCell>::plan(p, c.cluster_vertices);
  memory::ArenaVector<std::uint32_t>::plan(p, c.cluster_vertices);
  memory::ArenaVector<std::uint32_t>::plan(p, c.cluster_vertices + 1);
  memory::ArenaVector<std::uint32_t>::plan(p, c.cluster_vertices);
  memory::ArenaVector<std::uint32_t>::plan(p, c.cluster_vertices);
  memory::ArenaVector<std::uint32_t>::plan(p, c.tracked_blocks);
  memory::ArenaVector<std::uint32_t>::plan(p, c.objects);
  memory::ArenaVector<NodeId>::plan(p, c.objects);
  memory::ArenaVector<NodeId>::plan(p, c.objects);
  U64Map::plan(p, U64Map::slots_for(c.objects));
  return p;
}

bool ObjectLayer::init(const Config& config, const Capacities& c, std::size_t budget_bytes, std::string* error) {
  std::string why = config.check();
  if (!why.empty()) {
    if (error != nullptr) *error = "objects config: " + why;
    return false;
  }
  why = c.check();
  if (!why.empty()) {
    if (error != nullptr) *error = "objects capacities: " + why;
    return false;
  }
  if (ready_) {
    if (error != nullptr) *error = "objects: init() called twice";
    return false;
  }
  if (!arena_.create("objects", plan(c), budget_bytes, error)) return false;
  config_ = config;
  capacities_ = c;
  for (semantics::Label l = 0; l < semantics::kNumObjectLabels; ++l) {
    const double tol = config.labels[l].tolerance_m;
    inv_tolerance_[l] = static_cast<float>(1.0 / tol);
    tolerance_sq_[l] = static_cast<float>(tol * tol);
    tolerance_sq_above_[l] = static_cast<float>(tol * tol * (1.0 + kRoundingMargin));
    tolerance_sq_below_[l] = static_cast<float>(tol * tol * (1.0 - kRoundingMargin));
    // Cell side tol * sqrt((1 - margin) / 3): the cell's diagonal is within the tolerance, with the margin.
    inv_cluster_cell_[l] = std::sqrt(3.0 / (1.0 - kRoundingMargin)) / tol;
  }
  inv_index_cell_ = static_cast<float>(1.0 / config.index_cell_m);
  label_head_.fill(kInvalidHandle);
  const std::size_t tracked_slots = U64Map::slots_for(c.tracked_vertices);
  const std::size_t candidate_slots = U64Map::slots_for(c.cluster_vertices);
  const bool ok = objects_.carve(arena_, c.objects) && tracked_.carve(arena_, c.tracked_vertices) &&
                  tracked_index_.carve(arena_, tracked_slots, c.tracked_vertices) &&
                  tracked_cells_.carve(arena_, tracked_slots, c.tracked_vertices) &&
                  blocks_.carve(arena_, c.tracked_blocks) &&
                  block_index_.carve(arena_, memory::SpatialHash<std::uint32_t>::slots_for(c.tracked_blocks),
                                     c.tracked_blocks) &&
                  key_chunks_.carve(arena_, key_chunk_count(c)) &&
                  kept_keys_.carve(arena_, U64Map::slots_for(c.vertex_keys), c.vertex_keys) &&
                  candidates_.carve(arena_, c.cluster_vertices) &&
                  candidate_index_.carve(arena_, candidate_slots, c.cluster_vertices) &&
                  sorted_candidates_.carve(arena_, c.cluster_vertices) &&
                  sorted_points_.carve(arena_, c.cluster_vertices) && cells_.carve(arena_, c.cluster_vertices) &&
                  cell_parent_.carve(arena_, c.cluster_vertices) &&
                  cluster_begin_.carve(arena_, c.cluster_vertices + 1) &&
                  new_tracked_.carve(arena_, c.cluster_vertices) &&
                  order_.carve(arena_, c.cluster_vertices) && presented_blocks_.carve(arena_, c.tracked_blocks) &&
                  changed_.carve(arena_, c.objects) && removed_nodes_.carve(arena_, c.objects) &&
                  synced_.carve(arena_, c.objects) &&
                  object_cells_.carve(arena_, U64Map::slots_for(c.objects), c.objects);
  if (!ok || !arena_.seal()) {
    if (error != nullptr) *error = "objects: the arena carve did not match its plan";
    return false;
  }
  ready_ = true;
  return true;
}

// ------------------------------------------------------------------------------------------------ cells
void ObjectLayer::cell_of(semantics::Label label, const float* p, std::int32_t* c) const {
  const float inv = inv_tolerance_[label];
  for (int i = 0; i < 3; ++i) c[i] = static_cast<std::int32_t>(std::floor(p[i] * inv));
}

std::uint64_t ObjectLayer::cell_key(semantics::Label label, const float* p) const {
  std::int32_t c[3];
  cell_of(label, p, c);
  return pack_cell(label, c[0], c[1], c[2]);
}

void ObjectLayer::cell_insert(U64Map& cells, std::uint64_t cell, std::uint32_t item, std::uint32_t* next_field) {
  bool inserted = false;
  std::uint32_t* head = cells.find_or_insert(cell, item, &inserted);
  if (head == nullptr) {  // cannot happen: the cell map holds one entry per item
    *next_field = kInvalidHandle;
    return;
  }
  *next_field = inserted ? kInvalidHandle : *head;
  *head = item;
}

void ObjectLayer::tracked_cell_remove(std::uint32_t slot) {
  const TrackedVertex& t = tracked_[slot];
  const std::uint64_t cell = cell_key(t.label, t.p);
  std::uint32_t* head = tracked_cells_.find(cell);
  if (head == nullptr) return;
  if (*head == slot) {
    if (t.cell_next == kInvalidHandle) tracked_cells_.erase(cell);
    else *head = t.cell_next;
    return;
  }
  for (std::uint32_t s = *head; s != kInvalidHandle; s = tracked_[s].cell_next) {
    if (tracked_[s].cell_next == slot) {
      tracked_[s].cell_next = t.cell_next;
      return;
    }
  }
}

// ------------------------------------------------------------------------------------------------ objects
ObjectView ObjectLayer::view(std::uint32_t h) const {
  const Object& o = objects_[h];
  ObjectView v;
  v.node = o.node;
  v.label = o.label;
  if (o.num_vertices > 0) {
    const double n = static_cast<double>(o.num_vertices);
    v.vertex_mean_m = Eigen::Vector3d(o.sum[0] / n, o.sum[1] / n, o.sum[2] / n);
    v.min_m = Eigen::Vector3d(o.lo[0], o.lo[1], o.lo[2]);
    v.max_m = Eigen::Vector3d(o.hi[0], o.hi[1], o.hi[2]);
    v.position_m = 0.5 * (v.min_m + v.max_m);
  }
  v.num_vertices = o.num_vertices;
  v.num_tracked = o.num_tracked;
  v.num_keys = o.num_keys;
  v.last_update_ns = o.last_update_ns;
  return v;
}

bool ObjectLayer::visible(std::uint32_t h) const {
  const Object& o = objects_[h];
  return o.num_vertices >= config_.labels[o.label].min_vertices;
}

std::size_t ObjectLayer::num_objects() const {
  std::size_t n = 0;
  for (std::uint32_t h = 0; h < objects_.capacity(); ++h) n += objects_.live(h) && visible(h) ? 1 : 0;
  return n;
}

std::uint32_t ObjectLayer::find_handle(NodeId node) const {
  for (std::uint32_t h = 0; h < objects_.capacity(); ++h)
    if (objects_.live(h) && visible(h) && objects_[h].node == node) return h;
  return kInvalidHandle;
}

std::uint32_t ObjectLayer::object_key_head(std::uint32_t h) const { return objects_[h].key_head; }

bool ObjectLayer::find_object(NodeId node, ObjectView* out) const {
  const std::uint32_t h = find_handle(node);
  if (h == kInvalidHandle) return false;
  *out = view(h);
  return true;
}

bool ObjectLayer::mesh_vertex_key(std::uint32_t connection, std::uint64_t* key) const {
  const std::uint32_t chunk = connection / kKeysPerChunk;
  const std::uint32_t i = connection % kKeysPerChunk;
  if (!key_chunks_.live(chunk) || i >= key_chunks_[chunk].count) return false;
  *key = key_chunks_[chunk].keys[i];
  return true;
}

void ObjectLayer::mark_changed(std::uint32_t h) {
  Object& o = objects_[h];
  o.last_update_ns = time_ns_;
  o.touched = stamp_;
  if (o.changed) return;
  // changed_ holds at most one entry per live object, plus stale handles of released ones: compact when full.
  if (changed_.full()) {
    std::size_t k = 0;
    for (std::size_t i = 0; i < changed_.size(); ++i) {
      const std::uint32_t c = changed_[i];
      if (objects_.live(c) && objects_[c].changed) changed_[k++] = c;
    }
    while (changed_.size() > k) changed_.pop_back();
  }
  if (changed_.push_back(h)) o.changed = true;
}

std::uint32_t ObjectLayer::create_object(semantics::Label label) {
  const std::uint32_t h = objects_.acquire();
  if (h == kInvalidHandle) return h;
  Object& o = objects_[h];
  o.node = scene_graph::make_node_id(scene_graph::kObjectPrefix, next_object_index_++);
  o.label = label;
  empty_box(o.lo, o.hi);
  empty_box(o.released_lo, o.released_hi);
  o.box_dirty = false;
  o.keys_seen = 0;
  o.indexed = false;
  o.label_prev = kInvalidHandle;
  o.label_next = label_head_[label];
  if (o.label_next != kInvalidHandle) objects_[o.label_next].label_prev = h;
  label_head_[label] = h;
  ++counters_.objects_created;
  ++result_.objects_created;
  mark_changed(h);
  return h;
}

void ObjectLayer::release_keys(std::uint32_t h) {
  Object& o = objects_[h];
  for (std::uint32_t c = o.key_head; c != kInvalidHandle;) {
    const std::uint32_t next = key_chunks_[c].next;
    for (std::uint32_t i = 0; i < key_chunks_[c].count; ++i) kept_keys_.erase(key_chunks_[c].keys[i]);
    key_chunks_.release(c);
    c = next;
  }
  o.key_head = o.key_tail = kInvalidHandle;
  o.num_keys = 0;
  o.keys_seen = 0;
}

// Takes an object out of the merge index and its label's list, and frees its slot.
void ObjectLayer::release_object(std::uint32_t h) {
  unindex_object(h);
  Object& o = objects_[h];
  if (o.label_prev != kInvalidHandle) objects_[o.label_prev].label_next = o.label_next;
  else label_head_[o.label] = o.label_next;
  if (o.label_next != kInvalidHandle) objects_[o.label_next].label_prev = o.label_prev;
  objects_.release(h);
}

void ObjectLayer::delete_object(std::uint32_t h) {
  release_keys(h);
  Object& o = objects_[h];
  if (o.in_graph && !removed_nodes_.push_back(o.node)) ++counters_.graph_node_failures;
  release_object(h);
  ++counters_.objects_removed;
}

void ObjectLayer::merge_objects(std::uint32_t into, std::uint32_t from) {
  Object& a = objects_[into];
  Object& b = objects_[from];
  std::uint32_t last = kInvalidHandle;
  for (std::uint32_t s = b.tracked_head; s != kInvalidHandle; s = tracked_[s].obj_next) {
    tracked_[s].object = into;
    last = s;
  }
  if (last != kInvalidHandle) {
    tracked_[last].obj_next = a.tracked_head;
    if (a.tracked_head != kInvalidHandle) tracked_[a.tracked_head].obj_prev = last;
    a.tracked_head = b.tracked_head;
  }
  a.num_tracked += b.num_tracked;
  for (int i = 0; i < 3; ++i) {
    a.sum[i] += b.sum[i];
    a.lo[i] = std::min(a.lo[i], b.lo[i]);
    a.hi[i] = std::max(a.hi[i], b.hi[i]);
    a.released_lo[i] = std::min(a.released_lo[i], b.released_lo[i]);
    a.released_hi[i] = std::max(a.released_hi[i], b.released_hi[i]);
  }
  a.box_dirty = a.box_dirty || b.box_dirty;
  a.num_vertices += b.num_vertices;
  // b's keys are offered to a one by one: a's sample stays within Config::max_keys_per_object (a concatenation would
  // let every merge exceed it, and drift merges a new cluster into its object every pass), and chunks stay full.
  for (std::uint32_t c = b.key_head; c != kInvalidHandle;) {
    const std::uint32_t next = key_chunks_[c].next;
    for (std::uint32_t i = 0; i < key_chunks_[c].count; ++i) {
      const std::uint64_t key = key_chunks_[c].keys[i];
      kept_keys_.erase(key);
      append_key(into, key);
    }
    key_chunks_.release(c);
    c = next;
  }
  b.key_head = b.key_tail = kInvalidHandle;
  b.num_keys = 0;
  if (b.in_graph && !removed_nodes_.push_back(b.node)) ++counters_.graph_node_failures;
  release_object(from);
  index_object(into);
  ++counters_.objects_merged;
  mark_changed(into);
}

// Keeps `key` as one of object h's mesh connections: once per key (a block that left the window and came back
// presents its vertices again), and up to Config::max_keys_per_object per object.
bool ObjectLayer::append_key(std::uint32_t h, std::uint64_t key) {
  Object& o = objects_[h];
  if (kept_keys_.find(key) != nullptr) {
    ++counters_.keys_repeated;
    return true;
  }
  ++o.keys_seen;
  if (o.num_keys >= config_.max_keys_per_object) {
    // Reservoir sampling (Vitter's algorithm R): the n-th key replaces a random kept one with probability cap / n,
    // so the kept keys stay a uniform sample of every key the object was given. A hash of the key and the count
    // stands in for the random draw: deterministic, and nothing to seed.
    std::uint64_t z = key ^ (o.keys_seen * 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    std::uint64_t slot = z % o.keys_seen;
    if (slot >= config_.max_keys_per_object) {
      ++counters_.keys_capped;
      return true;
    }
    for (std::uint32_t c = o.key_head; c != kInvalidHandle; c = key_chunks_[c].next) {
      KeyChunk& chunk = key_chunks_[c];
      if (slot >= chunk.count) {
        slot -= chunk.count;
        continue;
      }
      kept_keys_.erase(chunk.keys[slot]);
      if (kept_keys_.insert(key, h) == nullptr) {  // cannot fail: one erased just before
        ++counters_.key_overflow;
        return false;
      }
      chunk.keys[slot] = key;
      ++counters_.keys_resampled;
      return true;
    }
    ++counters_.keys_capped;  // (merged lists always hold num_keys >= cap keys; not reached)
    return true;
  }
  if (o.key_tail == kInvalidHandle || key_chunks_[o.key_tail].count == kKeysPerChunk) {
    const std::uint32_t c = key_chunks_.acquire();
    if (c == kInvalidHandle) {
      ++counters_.key_overflow;
      return false;
    }
    key_chunks_[c].next = kInvalidHandle;
    key_chunks_[c].count = 0;
    if (o.key_tail == kInvalidHandle) o.key_head = c;
    else key_chunks_[o.key_tail].next = c;
    o.key_tail = c;
  }
  if (kept_keys_.insert(key, h) == nullptr) {  // sized as the chunks: full only with them
    ++counters_.key_overflow;
    return false;
  }
  KeyChunk& chunk = key_chunks_[o.key_tail];
  chunk.keys[chunk.count++] = key;
  ++o.num_keys;
  return true;
}

void ObjectLayer::add_to_box(std::uint32_t h, const float* p) {
  Object& o = objects_[h];
  for (int i = 0; i < 3; ++i) {
    o.lo[i] = std::min(o.lo[i], p[i]);
    o.hi[i] = std::max(o.hi[i], p[i]);
  }
}

// ------------------------------------------------------------------------------------------------ tracked
void ObjectLayer::detach_tracked(std::uint32_t slot, bool subtract_from_object) {
  TrackedVertex& t = tracked_[slot];
  tracked_index_.erase(t.key);
  tracked_cell_remove(slot);
  const std::uint32_t h = t.object;
  if (h == kInvalidHandle || !objects_.live(h)) return;
  Object& o = objects_[h];
  if (t.obj_prev != kInvalidHandle) tracked_[t.obj_prev].obj_next = t.obj_next;
  else o.tracked_head = t.obj_next;
  if (t.obj_next != kInvalidHandle) tracked_[t.obj_next].obj_prev = t.obj_prev;
  --o.num_tracked;
  if (subtract_from_object) {
    for (int i = 0; i < 3; ++i) o.sum[i] -= t.p[i];
    --o.num_vertices;
    if (on_boundary(t.p, o.lo, o.hi)) o.box_dirty = true;
    mark_changed(h);
    if (o.num_vertices == 0) delete_object(h);
    return;
  }
  for (int i = 0; i < 3; ++i) {  // released with its block: its position still bounds the object
    o.released_lo[i] = std::min(o.released_lo[i], t.p[i]);
    o.released_hi[i] = std::max(o.released_hi[i], t.p[i]);
  }
  if (o.num_tracked == 0) {
    if (!visible(h)) delete_object(h);  // a tentative object that never grew: noise
    else mark_changed(h);               // left the active window
  }
}

void ObjectLayer::unlink_from_block(std::uint32_t slot) {
  const std::uint32_t b = tracked_[slot].block;
  if (b == kInvalidHandle || !blocks_.live(b)) return;
  Block& block = blocks_[b];
  if (block.head == slot) {
    block.head = tracked_[slot].block_next;
  } else {
    for (std::uint32_t s = block.head; s != kInvalidHandle; s = tracked_[s].block_next) {
      if (tracked_[s].block_next == slot) {
        tracked_[s].block_next = tracked_[slot].block_next;
        break;
      }
    }
  }
  --block.count;
}

void ObjectLayer::move_tracked(std::uint32_t slot, const InputVertex& v) {
  TrackedVertex& t = tracked_[slot];
  const float p[3] = {v.x, v.y, v.z};
  if (p[0] == t.p[0] && p[1] == t.p[1] && p[2] == t.p[2]) return;
  const std::uint64_t old_cell = cell_key(t.label, t.p);
  const std::uint64_t new_cell = cell_key(t.label, p);
  if (old_cell != new_cell) tracked_cell_remove(slot);
  Object& o = objects_[t.object];
  if (on_boundary(t.p, o.lo, o.hi)) o.box_dirty = true;
  for (int i = 0; i < 3; ++i) {
    o.sum[i] += static_cast<double>(p[i]) - static_cast<double>(t.p[i]);
    t.p[i] = p[i];
  }
  add_to_box(t.object, p);
  index_object(t.object);
  if (old_cell != new_cell) cell_insert(tracked_cells_, new_cell, slot, &t.cell_next);
  mark_changed(t.object);
}

void ObjectLayer::sweep_block(std::uint32_t b) {
  Block& block = blocks_[b];
  std::uint32_t prev = kInvalidHandle;
  for (std::uint32_t s = block.head; s != kInvalidHandle;) {
    const std::uint32_t next = tracked_[s].block_next;
    if (tracked_[s].seen != stamp_) {
      if (prev == kInvalidHandle) block.head = next;
      else tracked_[prev].block_next = next;
      --block.count;
      detach_tracked(s, true);
      tracked_.release(s);
      ++counters_.vertices_stale;
    } else {
      prev = s;
    }
    s = next;
  }
  if (block.count == 0) {
    block_index_.erase(block.index);
    blocks_.release(b);
  }
}

bool ObjectLayer::register_vertex(std::uint32_t h, const Candidate& c) {
  std::uint32_t b = kInvalidHandle;
  if (const std::uint32_t* bh = block_index_.find(c.block)) {
    b = *bh;
  } else {
    b = blocks_.acquire();
    if (b == kInvalidHandle) {
      ++counters_.block_overflow;
      return false;
    }
    if (block_index_.insert(c.block, b) == nullptr) {
      blocks_.release(b);
      ++counters_.block_overflow;
      return false;
    }
    blocks_[b].index = c.block;
    blocks_[b].head = kInvalidHandle;
    blocks_[b].count = 0;
    blocks_[b].presented = stamp_;
  }
  const std::uint32_t slot = tracked_.acquire();
  if (slot == kInvalidHandle) {
    ++counters_.tracked_overflow;
    return false;
  }
  if (tracked_index_.insert(c.key, slot) == nullptr) {
    tracked_.release(slot);
    ++counters_.tracked_overflow;
    return false;
  }
  TrackedVertex& t = tracked_[slot];
  t.key = c.key;
  std::memcpy(t.p, c.p, sizeof(t.p));
  t.label = c.label;
  t.object = h;
  t.block = b;
  t.seen = stamp_;
  t.cell_next = kInvalidHandle;
  new_tracked_.push_back(slot);  // cannot be refused: one entry per candidate; into tracked_cells_ at the end
  Block& block = blocks_[b];
  t.block_next = block.head;
  block.head = slot;
  ++block.count;
  Object& o = objects_[h];
  t.obj_prev = kInvalidHandle;
  t.obj_next = o.tracked_head;
  if (o.tracked_head != kInvalidHandle) tracked_[o.tracked_head].obj_prev = slot;
  o.tracked_head = slot;
  ++o.num_tracked;
  for (int i = 0; i < 3; ++i) o.sum[i] += c.p[i];
  ++o.num_vertices;
  add_to_box(h, c.p);
  append_key(h, c.key);
  return true;
}

// ------------------------------------------------------------------------------------------------ update
void ObjectLayer::begin_update(std::uint64_t time_ns) {
  in_update_ = true;
  in_block_ = false;
  if (++stamp_ == 0) stamp_ = 1;
  time_ns_ = time_ns;
  result_ = UpdateResult{};
  candidates_.clear();
  presented_blocks_.clear();
}

void ObjectLayer::begin_block(const memory::Index3& block) {
  if (!ready_ || !in_update_) return;
  in_block_ = true;
  current_index_ = block;
  ++result_.blocks;
  current_block_ = kInvalidHandle;
  if (const std::uint32_t* h = block_index_.find(block)) {
    current_block_ = *h;
    if (blocks_[*h].presented != stamp_) {
      blocks_[*h].presented = stamp_;
      presented_blocks_.push_back(*h);  // cannot overflow: one entry per block record
    }
  }
}

void ObjectLayer::add_vertex(const InputVertex& v) {
  if (!in_block_) return;
  if (v.label >= semantics::kNumObjectLabels || !config_.labels[v.label].enabled) return;
  if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) return;
  ++result_.vertices;
  ++counters_.vertices_presented;
  if (const std::uint32_t* s = tracked_index_.find(v.key)) {
    const std::uint32_t slot = *s;
    if (tracked_[slot].label == v.label) {
      if (tracked_[slot].seen != stamp_) {
        tracked_[slot].seen = stamp_;
        move_tracked(slot, v);
      }
      return;
    }
    // The vertex changed label: it leaves its object and is clustered again.
    unlink_from_block(slot);
    detach_tracked(slot, true);
    tracked_.release(slot);
    ++counters_.vertices_stale;
  }
  bool inserted = false;
  const std::uint32_t next = static_cast<std::uint32_t>(candidates_.size());
  if (candidate_index_.find_or_insert(v.key, next, &inserted) == nullptr) {
    ++counters_.candidate_overflow;
    return;
  }
  if (!inserted) return;  // a border duplicate already presented by the neighbouring block
  Candidate* c = candidates_.emplace_back();
  if (c == nullptr) {
    candidate_index_.erase(v.key);
    ++counters_.candidate_overflow;
    return;
  }
  c->key = v.key;
  c->p[0] = v.x;
  c->p[1] = v.y;
  c->p[2] = v.z;
  c->label = v.label;
  c->cell = kInvalidHandle;
  c->block = current_index_;
}

void ObjectLayer::release_block(const memory::Index3& index) {
  if (!ready_) return;
  const std::uint32_t* bh = block_index_.find(index);
  if (bh == nullptr) return;
  const std::uint32_t b = *bh;
  for (std::uint32_t s = blocks_[b].head; s != kInvalidHandle;) {
    const std::uint32_t next = tracked_[s].block_next;
    detach_tracked(s, false);
    tracked_.release(s);
    ++counters_.vertices_released;
    s = next;
  }
  block_index_.erase(index);
  blocks_.release(b);
  ++counters_.blocks_released;
}

// ------------------------------------------------------------------------------------------------ clustering
// Sorts the candidates into clustering cells (by label, then cell coordinates) and lists the occupied cells with
// the boxes of their vertices. Cell coordinates count from the lowest cell of the label's candidates, so positions
// far from the origin cluster as well as near ones; only the candidates of one label in one update must span less
// than 2^19 cells (15 km at the smallest tolerance, against a mesh window of tens of metres). A candidate beyond
// that is not clustered and counted as a candidate overflow.
void ObjectLayer::sort_candidates_into_cells() {
  sorted_candidates_.clear();
  sorted_points_.clear();
  cells_.clear();
  cell_parent_.clear();
  std::array<std::array<float, 3>, semantics::kNumObjectLabels> lowest;
  for (auto& l : lowest) l.fill(std::numeric_limits<float>::max());
  for (const Candidate& c : candidates_)
    for (int i = 0; i < 3; ++i) lowest[c.label][i] = std::min(lowest[c.label][i], c.p[i]);
  std::array<std::array<double, 3>, semantics::kNumObjectLabels> origin;
  for (semantics::Label l = 0; l < semantics::kNumObjectLabels; ++l)
    for (int i = 0; i < 3; ++i)
      origin[l][i] = std::floor(static_cast<double>(lowest[l][i]) * inv_cluster_cell_[l]) - kNeighbourReach;
  // Double precision: the cell of a vertex is exact to far below the rounding margin, wherever it is.
  for (std::uint32_t k = 0; k < candidates_.size(); ++k) {
    Candidate& c = candidates_[k];
    const double inv = inv_cluster_cell_[c.label];
    std::uint64_t field[3];
    bool fits = true;
    for (int i = 0; i < 3; ++i) {
      const double cell = std::floor(static_cast<double>(c.p[i]) * inv) - origin[c.label][i];
      fits = fits && cell <= kMaxClusterCell;
      field[i] = fits ? static_cast<std::uint64_t>(cell) : 0;
    }
    if (!fits) {
      ++counters_.candidate_overflow;
      continue;
    }
    sorted_candidates_.push_back(SortedCandidate{pack_fields(c.label, field[0], field[1], field[2]), k});
  }
  std::sort(sorted_candidates_.begin(), sorted_candidates_.end(),
            [](const SortedCandidate& a, const SortedCandidate& b) { return a.cell_key < b.cell_key; });
  for (std::uint32_t k = 0; k < sorted_candidates_.size(); ++k) {
    const SortedCandidate& s = sorted_candidates_[k];
    if (cells_.empty() || cells_.back().key != s.cell_key) {
      CandidateCell* cell = cells_.emplace_back();
      cell->key = s.cell_key;
      cell->begin = k;
      empty_box(cell->lo, cell->hi);
      cell_parent_.push_back(static_cast<std::uint32_t>(cells_.size() - 1));
    }
    CandidateCell& cell = cells_.back();
    Candidate& c = candidates_[s.candidate];
    cell.end = k + 1;
    for (int i = 0; i < 3; ++i) {
      cell.lo[i] = std::min(cell.lo[i], c.p[i]);
      cell.hi[i] = std::max(cell.hi[i], c.p[i]);
    }
    sorted_points_.push_back(Point{{c.p[0], c.p[1], c.p[2]}});
    c.cell = static_cast<std::uint32_t>(cells_.size() - 1);
  }
}

std::uint32_t ObjectLayer::find_root(std::uint32_t cell) {
  while (cell_parent_[cell] != cell) {
    cell_parent_[cell] = cell_parent_[cell_parent_[cell]];  // path halving
    cell = cell_parent_[cell];
  }
  return cell;
}

// Whether the boxes of the vertices of two cells of `label` are too far apart for any pair to be within the
// tolerance (most pairs of cells of a sparse set).
bool ObjectLayer::cells_apart(const CandidateCell& a, const CandidateCell& b, semantics::Label label) const {
  float d = 0.0f;
  for (int i = 0; i < 3; ++i) {
    const float gap = std::max({0.0f, b.lo[i] - a.hi[i], a.lo[i] - b.hi[i]});
    d += gap * gap;
  }
  return d > tolerance_sq_above_[label];
}

// Whether two cells of `label` that are not apart hold a pair of vertices within the tolerance: every pair is
// when their joint box is small enough; otherwise vertices of `a` near the box of `b` are tested against those of
// `b` until the first close pair.
bool ObjectLayer::cells_connected(const CandidateCell& a, const CandidateCell& b, semantics::Label label) const {
  float d = 0.0f;
  for (int i = 0; i < 3; ++i) {
    const float span = std::max(a.hi[i], b.hi[i]) - std::min(a.lo[i], b.lo[i]);
    d += span * span;
  }
  if (d <= tolerance_sq_below_[label]) return true;
  const float tol_sq = tolerance_sq_[label];
  const float above = tolerance_sq_above_[label];
  for (std::uint32_t i = a.begin; i < a.end; ++i) {
    const float* p = sorted_points_[i].p;
    if (box_dist_sq(p, b.lo, b.hi) > above) continue;
    for (std::uint32_t j = b.begin; j < b.end; ++j)
      if (dist_sq(p, sorted_points_[j].p) <= tol_sq) return true;
  }
  return false;
}

// Joins every two cells holding a pair of vertices within the tolerance (union-find; a set's root is its lowest
// cell). Each pair of neighbouring cells is seen once, from the lower key: the next two cells up in the same (x, y)
// column, then 12 columns ahead in (x, y), in each the run of at most five keys from two cells down to two cells
// up. Neighbours' keys grow with the cell's, so each column's run is found by a cursor that only moves forward.
void ObjectLayer::connect_cells() {
  constexpr int kColumns[12][2] = {{0, 1},  {0, 2},  {1, -2}, {1, -1}, {1, 0}, {1, 1},
                                   {1, 2},  {2, -2}, {2, -1}, {2, 0},  {2, 1}, {2, 2}};
  constexpr std::int64_t kX = std::int64_t{1} << (2 * kCellBits);
  constexpr std::int64_t kY = std::int64_t{1} << kCellBits;
  std::uint64_t first_offset[12];  // from a cell's key to the lowest key of the column's run
  for (int j = 0; j < 12; ++j)
    first_offset[j] = static_cast<std::uint64_t>(kColumns[j][0] * kX + kColumns[j][1] * kY -
                                                 static_cast<std::int64_t>(kNeighbourReach));
  std::uint32_t cursor[12] = {};
  const std::uint32_t n = static_cast<std::uint32_t>(cells_.size());
  for (std::uint32_t a = 0; a < n; ++a) {
    const std::uint64_t key = cells_[a].key;
    const auto label = static_cast<semantics::Label>(key >> (3 * kCellBits));
    std::uint32_t root = find_root(a);  // stays a's root: only this loop joins sets while it looks at a
    const auto join = [&](std::uint32_t b) {
      const std::uint32_t other = find_root(b);
      if (other == root || cells_apart(cells_[a], cells_[b], label) || !cells_connected(cells_[a], cells_[b], label))
        return;
      if (root < other) {
        cell_parent_[other] = root;
      } else {
        cell_parent_[root] = other;
        root = other;
      }
    };
    for (std::uint32_t b = a + 1; b < n && cells_[b].key <= key + kNeighbourReach; ++b) join(b);
    for (int j = 0; j < 12; ++j) {
      // Coordinates are at least kNeighbourReach and leave that much room at the top: no field overflows.
      const std::uint64_t first = key + first_offset[j];
      const std::uint64_t last = first + 2 * kNeighbourReach;
      std::uint32_t& b = cursor[j];
      while (b < n && cells_[b].key < first) ++b;
      for (std::uint32_t k = b; k < n && cells_[k].key <= last; ++k) join(k);
    }
  }
  // Every cell straight to its root: a parent is never above its child, so one pass in order.
  for (std::uint32_t c = 0; c < n; ++c) cell_parent_[c] = cell_parent_[cell_parent_[c]];
}

// Numbers the clusters (sets of joined cells) in the order of their first candidate and lists the candidates of
// each together in order_, in the order they were presented: cluster k is order_[cluster_begin_[k], [k + 1]).
// Returns the number of clusters.
std::uint32_t ObjectLayer::group_clusters() {
  for (CandidateCell& cell : cells_) {
    cell.cluster = kInvalidHandle;
    cell.searched = false;
  }
  cluster_begin_.clear();
  cluster_begin_.push_back(0);
  order_.clear();
  for (const Candidate& c : candidates_) {  // count the candidates of each cluster in cluster_begin_[k + 1]
    if (c.cell == kInvalidHandle) continue;
    CandidateCell& root = cells_[cell_parent_[c.cell]];
    if (root.cluster == kInvalidHandle) {
      root.cluster = static_cast<std::uint32_t>(cluster_begin_.size() - 1);
      cluster_begin_.push_back(0);
    }
    ++cluster_begin_[root.cluster + 1];
    order_.push_back(kInvalidHandle);
  }
  const std::uint32_t num_clusters = static_cast<std::uint32_t>(cluster_begin_.size() - 1);
  for (std::uint32_t k = 1; k <= num_clusters; ++k) cluster_begin_[k] += cluster_begin_[k - 1];
  // Each cluster's start serves as its write position, which leaves it at the next cluster's start: shift back.
  for (std::uint32_t i = 0; i < candidates_.size(); ++i) {
    const std::uint32_t cell = candidates_[i].cell;
    if (cell != kInvalidHandle) order_[cluster_begin_[cells_[cell_parent_[cell]].cluster]++] = i;
  }
  for (std::uint32_t k = num_clusters; k > 0; --k) cluster_begin_[k] = cluster_begin_[k - 1];
  cluster_begin_[0] = 0;
  return num_clusters;
}

// The existing objects that the cluster order_[begin, end) touches (a tracked vertex of its label within the
// tolerance of one of its vertices), at most max_linked, in the order found. Each cell of the cluster is searched
// once, over the tracked grid cells next to the box of its vertices.
std::uint32_t ObjectLayer::find_linked_objects(std::uint32_t begin, std::uint32_t end, std::uint32_t* linked,
                                               std::uint32_t max_linked) {
  std::uint32_t num_linked = 0;
  if (tracked_cells_.empty() || begin == end) return 0;
  const semantics::Label label = candidates_[order_[begin]].label;
  const float tol_sq = tolerance_sq_[label];
  const float above = tolerance_sq_above_[label];
  for (std::uint32_t k = begin; k < end; ++k) {
    CandidateCell& cell = cells_[candidates_[order_[k]].cell];
    if (cell.searched) continue;
    cell.searched = true;
    std::int32_t c0[3], c1[3];
    cell_of(label, cell.lo, c0);
    cell_of(label, cell.hi, c1);
    for (std::int32_t x = c0[0] - 1; x <= c1[0] + 1; ++x)
      for (std::int32_t y = c0[1] - 1; y <= c1[1] + 1; ++y)
        for (std::int32_t z = c0[2] - 1; z <= c1[2] + 1; ++z) {
          const std::uint32_t* head = tracked_cells_.find(pack_cell(label, x, y, z));
          if (head == nullptr) continue;
          for (std::uint32_t s = *head; s != kInvalidHandle; s = tracked_[s].cell_next) {
            const TrackedVertex& t = tracked_[s];
            bool known = false;
            for (std::uint32_t i = 0; i < num_linked && !known; ++i) known = linked[i] == t.object;
            if (known || box_dist_sq(t.p, cell.lo, cell.hi) > above) continue;
            for (std::uint32_t i = cell.begin; i < cell.end; ++i) {
              if (dist_sq(t.p, sorted_points_[i].p) > tol_sq) continue;
              linked[num_linked++] = t.object;
              if (num_linked == max_linked) return num_linked;
              break;
            }
          }
        }
  }
  return num_linked;
}

// Which rule, if any, pairs a box of `label` with object `other` (same label). The paper's: one's centre lies in
// the other's box; centres are box centres, the objects' positions (a vertex mean is pulled toward the best-seen
// surface and may leave the box of a part seen apart). Hydra's overlap: the boxes intersect. The size prior: the
// joint box fits one instance and the heights meet. A new cluster is tested with the first two only (the prior
// pairs fragments, which are objects by then).
ObjectLayer::MergeRule ObjectLayer::merge_rule(semantics::Label label, const float* lo, const float* hi,
                                               std::uint32_t other, bool cluster) const {
  const Object& o = objects_[other];
  float c[3], oc[3];
  box_centre(lo, hi, c);
  box_centre(o.lo, o.hi, oc);
  if (config_.merge_overlapping && (inside(c, o.lo, o.hi) || inside(oc, lo, hi))) return MergeRule::kCentreInBox;
  bool intersect = true;
  for (int i = 0; i < 3; ++i) intersect = intersect && lo[i] <= o.hi[i] && o.lo[i] <= hi[i];
  if (config_.merge_intersecting && intersect) return MergeRule::kIntersect;
  const LabelParams& p = config_.labels[label];
  if (cluster || !config_.merge_by_size_prior || !(p.max_size_m > 0.0)) return MergeRule::kNone;
  const float tol = static_cast<float>(p.tolerance_m);
  const float size = static_cast<float>(p.max_size_m);
  if (lo[2] > o.hi[2] + tol || o.lo[2] > hi[2] + tol) return MergeRule::kNone;
  for (int i = 0; i < 2; ++i)
    if (std::max(hi[i], o.hi[i]) - std::min(lo[i], o.lo[i]) > size) return MergeRule::kNone;
  return MergeRule::kSizePrior;
}

// The index cell of an object's box centre and its half-extent class (the largest half side, in cells, rounded up).
std::uint64_t ObjectLayer::object_cell(std::uint32_t h, std::uint8_t* extent_class) const {
  const Object& o = objects_[h];
  const float inv = inv_index_cell_;
  float c[3], half = 0.0f;
  box_centre(o.lo, o.hi, c);
  for (int i = 0; i < 3; ++i) half = std::max(half, 0.5f * (o.hi[i] - o.lo[i]));
  const float k = std::ceil(half * inv);
  *extent_class = static_cast<std::uint8_t>(k < static_cast<float>(kExtentClasses - 1) ? k : kExtentClasses - 1);
  const auto cell = [inv](float v) { return static_cast<std::int32_t>(std::floor(v * inv)); };
  return pack_cell(o.label, cell(c[0]), cell(c[1]), cell(c[2]));
}

// Keeps an object's index entry in step with its box; call after its box changed. Objects without vertices
// (an empty box) are not indexed.
void ObjectLayer::index_object(std::uint32_t h) {
  Object& o = objects_[h];
  if (o.num_vertices == 0) {
    unindex_object(h);
    return;
  }
  std::uint8_t extent_class = 0;
  const std::uint64_t cell = object_cell(h, &extent_class);
  if (o.indexed && o.index_cell == cell && o.extent_class == extent_class) return;
  unindex_object(h);
  // Cannot be refused: the map holds at most one cell per object.
  cell_insert(object_cells_, cell, h, &o.index_next);
  o.index_cell = cell;
  o.extent_class = extent_class;
  o.indexed = true;
  ++extent_count_[o.label][extent_class];
}

void ObjectLayer::unindex_object(std::uint32_t h) {
  Object& o = objects_[h];
  if (!o.indexed) return;
  o.indexed = false;
  --extent_count_[o.label][o.extent_class];
  std::uint32_t* head = object_cells_.find(o.index_cell);
  if (head == nullptr) return;
  if (*head == h) {
    if (o.index_next == kInvalidHandle) object_cells_.erase(o.index_cell);
    else *head = o.index_next;
    return;
  }
  for (std::uint32_t g = *head; g != kInvalidHandle; g = objects_[g].index_next) {
    if (objects_[g].index_next == h) {
      objects_[g].index_next = o.index_next;
      return;
    }
  }
}

// An object of `label` (not `skip`) that a rule pairs with the box, or kInvalidHandle. A new cluster considers
// visible objects only. Every rule pairs boxes whose centres are, per axis, at most the two half sides apart, plus
// the size prior's length horizontally and the tolerance vertically: the search covers those index cells, or
// every object when that reach spans more cells than the index holds objects of the label.
std::uint32_t ObjectLayer::find_mergeable(semantics::Label label, const float* lo, const float* hi,
                                          std::uint32_t skip, bool new_cluster, MergeRule* rule) {
  *rule = MergeRule::kNone;
  std::uint32_t largest = 0, count = 0;
  for (std::uint32_t k = 0; k < kExtentClasses; ++k) {
    const std::uint32_t n = extent_count_[label][k];
    if (n > 0) largest = k;
    count += n;
  }
  if (count == 0 || (count == 1 && skip != kInvalidHandle && objects_[skip].indexed)) return kInvalidHandle;
  ++counters_.index_queries;
  const auto test = [&](std::uint32_t g) {
    if (g == skip || !objects_.live(g) || objects_[g].label != label || objects_[g].num_vertices == 0) return false;
    if (new_cluster && !visible(g)) return false;
    ++counters_.index_visits;
    *rule = merge_rule(label, lo, hi, g, new_cluster);
    return *rule != MergeRule::kNone;
  };
  const LabelParams& p = config_.labels[label];
  const float cell = static_cast<float>(config_.index_cell_m);
  const float other_half = static_cast<float>(largest) * cell;
  const float tol = static_cast<float>(p.tolerance_m);
  const float size = !new_cluster && config_.merge_by_size_prior ? static_cast<float>(p.max_size_m) : 0.0f;
  std::int32_t c0[3], c1[3];
  double cells = 1.0;
  for (int i = 0; i < 3; ++i) {
    const float c = 0.5f * (lo[i] + hi[i]);
    const float reach = std::max(0.5f * (hi[i] - lo[i]) + other_half, i < 2 ? size : 0.0f) + tol;
    c0[i] = static_cast<std::int32_t>(std::floor((c - reach) * inv_index_cell_));
    c1[i] = static_cast<std::int32_t>(std::floor((c + reach) * inv_index_cell_));
    cells *= static_cast<double>(c1[i] - c0[i] + 1);
  }
  if (largest == kExtentClasses - 1 || cells > static_cast<double>(count)) {
    // A box larger than the classes reach, or more cells than objects of the label: look at each of them.
    ++counters_.index_scans;
    for (std::uint32_t g = label_head_[label]; g != kInvalidHandle; g = objects_[g].label_next)
      if (test(g)) return g;
    return kInvalidHandle;
  }
  for (std::int32_t x = c0[0]; x <= c1[0]; ++x)
    for (std::int32_t y = c0[1]; y <= c1[1]; ++y)
      for (std::int32_t z = c0[2]; z <= c1[2]; ++z) {
        const std::uint32_t* head = object_cells_.find(pack_cell(label, x, y, z));
        if (head == nullptr) continue;
        for (std::uint32_t g = *head; g != kInvalidHandle; g = objects_[g].index_next)
          if (test(g)) return g;
      }
  return kInvalidHandle;
}

// Applies the rules between every object changed in this update and the others of its label, repeatedly (a merged
// box is larger and may now pair with another). The larger object survives and keeps its node.
void ObjectLayer::merge_changed_objects() {
  for (std::size_t i = 0; i < changed_.size(); ++i) {
    std::uint32_t h = changed_[i];
    if (!objects_.live(h) || !objects_[h].changed || objects_[h].touched != stamp_ || objects_[h].num_vertices == 0)
      continue;
    for (;;) {
      MergeRule rule = MergeRule::kNone;
      const std::uint32_t g = find_mergeable(objects_[h].label, objects_[h].lo, objects_[h].hi, h, false, &rule);
      if (g == kInvalidHandle) break;
      const bool keep_g = objects_[g].num_vertices > objects_[h].num_vertices;
      const std::uint32_t into = keep_g ? g : h;
      merge_objects(into, keep_g ? h : g);
      if (rule == MergeRule::kCentreInBox) ++counters_.objects_overlap_merged;
      else if (rule == MergeRule::kIntersect) ++counters_.objects_intersect_merged;
      else ++counters_.objects_size_merged;
      h = into;
    }
  }
}

void ObjectLayer::recompute_box(std::uint32_t h) {
  Object& o = objects_[h];
  for (int i = 0; i < 3; ++i) {
    o.lo[i] = o.released_lo[i];
    o.hi[i] = o.released_hi[i];
  }
  for (std::uint32_t s = o.tracked_head; s != kInvalidHandle; s = tracked_[s].obj_next) add_to_box(h, tracked_[s].p);
  o.box_dirty = false;
  index_object(h);
  ++counters_.boxes_recomputed;
}

void ObjectLayer::process_cluster(std::uint32_t begin, std::uint32_t end, const std::uint32_t* linked,
                                  std::uint32_t num_linked) {
  ++counters_.clusters;
  ++result_.clusters;
  std::uint32_t target = kInvalidHandle;
  bool created = false;
  if (num_linked > 0) {
    // The largest survives (keeps its node id; smaller tentative ones have none); of equal ones the oldest, so the
    // choice does not depend on the order the cluster found them in.
    target = linked[0];
    for (std::uint32_t i = 1; i < num_linked; ++i) {
      const Object& o = objects_[linked[i]];
      const Object& t = objects_[target];
      if (o.num_vertices > t.num_vertices ||
          (o.num_vertices == t.num_vertices && scene_graph::node_index(o.node) < scene_graph::node_index(t.node)))
        target = linked[i];
    }
    for (std::uint32_t i = 0; i < num_linked; ++i)
      if (linked[i] != target && objects_.live(linked[i])) merge_objects(target, linked[i]);
    ++counters_.clusters_joined;
  } else {
    const semantics::Label label = candidates_[order_[begin]].label;
    const LabelParams& params = config_.labels[label];
    const std::uint32_t size = end - begin;
    const bool small = size < params.min_vertices;
    if (small) ++counters_.clusters_too_small;  // kept as a tentative object
    if (size > params.max_vertices) {
      ++counters_.clusters_too_large;
      return;
    }
    if ((config_.merge_overlapping || config_.merge_intersecting) && !small) {
      float lo[3], hi[3];
      empty_box(lo, hi);
      for (std::uint32_t k = begin; k < end; ++k) {
        const Candidate& c = candidates_[order_[k]];
        for (int i = 0; i < 3; ++i) {
          lo[i] = std::min(lo[i], c.p[i]);
          hi[i] = std::max(hi[i], c.p[i]);
        }
      }
      MergeRule rule = MergeRule::kNone;
      target = find_mergeable(label, lo, hi, kInvalidHandle, true, &rule);
      if (target != kInvalidHandle) ++counters_.clusters_overlap_merged;
    }
    if (target == kInvalidHandle) {
      target = create_object(label);
      created = true;
      if (target == kInvalidHandle) {
        ++counters_.object_overflow;
        return;
      }
    }
  }
  for (std::uint32_t k = begin; k < end; ++k) register_vertex(target, candidates_[order_[k]]);
  if (created && objects_[target].num_vertices == 0) {  // every vertex was refused
    delete_object(target);
    return;
  }
  index_object(target);
  mark_changed(target);
}

UpdateResult ObjectLayer::end_update() {
  if (!ready_ || !in_update_) return UpdateResult{};
  in_update_ = false;
  in_block_ = false;
  ++counters_.updates;
  // 1. Tracked vertices of re-meshed blocks that were not presented again: the surface moved.
  for (const std::uint32_t b : presented_blocks_)
    if (blocks_.live(b)) sweep_block(b);
  // 2. Connected components of the candidates (and the objects they touch).
  counters_.candidates += candidates_.size();
  result_.candidates = static_cast<std::uint32_t>(candidates_.size());
  new_tracked_.clear();
  sort_candidates_into_cells();
  connect_cells();
  const std::uint32_t num_clusters = group_clusters();
  std::uint32_t linked[kMaxLinked];
  for (std::uint32_t k = 0; k < num_clusters; ++k) {
    const std::uint32_t begin = cluster_begin_[k], end = cluster_begin_[k + 1];
    process_cluster(begin, end, linked, find_linked_objects(begin, end, linked, kMaxLinked));
  }
  for (const std::uint32_t slot : new_tracked_) {
    TrackedVertex& t = tracked_[slot];
    cell_insert(tracked_cells_, cell_key(t.label, t.p), slot, &t.cell_next);
  }
  // 3. Boxes that may have shrunk (stale or moved boundary vertices), then the centre-in-box rule between objects.
  for (const std::uint32_t h : changed_)
    if (objects_.live(h) && objects_[h].box_dirty) recompute_box(h);
  if (config_.merge_overlapping || config_.merge_intersecting || config_.merge_by_size_prior) merge_changed_objects();
  // 4. The candidate map back to empty, in time proportional to what this update used: entry by entry, or by
  // clearing every slot when that is less work (an erase hashes and shifts; clearing a slot is one store).
  if (candidates_.size() * 16 >= candidate_index_.slot_count()) {
    candidate_index_.clear();
  } else {
    for (const Candidate& c : candidates_) candidate_index_.erase(c.key);
  }
  candidates_.clear();
  std::uint32_t changed = 0;
  for (const std::uint32_t h : changed_)
    if (objects_.live(h) && objects_[h].changed) ++changed;
  result_.objects_updated = changed;
  return result_;
}

UpdateResult ObjectLayer::update(const reconstruction::SemanticTsdf& tsdf, std::uint64_t time_ns) {
  if (!ready_) return UpdateResult{};
  begin_update(time_ns);
  // Blocks that left the window: their vertices are released (the objects keep their summaries).
  presented_blocks_.clear();
  block_index_.for_each([&](const memory::Index3& index, std::uint32_t& handle) {
    if (tsdf.find_block(index) == kInvalidHandle) presented_blocks_.push_back(handle);
  });
  for (const std::uint32_t b : presented_blocks_) release_block(blocks_[b].index);
  presented_blocks_.clear();
  const std::uint32_t since = last_mesh_stamp_;
  tsdf.for_each_block([&](std::uint32_t handle, const reconstruction::SemanticTsdf::BlockView& view) {
    if (view.meshed_stamp <= since) return;
    begin_block(view.index);
    reconstruction::SemanticTsdf::VertexCursor cursor;
    reconstruction::MeshVertex v;
    InputVertex in;
    while (tsdf.next_block_vertex(handle, &cursor, &v, &in.key)) {
      in.x = v.x;
      in.y = v.y;
      in.z = v.z;
      in.label = v.label;
      add_vertex(in);
    }
  });
  last_mesh_stamp_ = tsdf.mesh_stamp();
  return end_update();
}

// ------------------------------------------------------------------------------------------------ sync
void ObjectLayer::log_graph_failure(const char* what, std::uint64_t count) const {
  if ((count & (count - 1)) == 0)
    std::fprintf(stderr, "qsg: warning: objects: scene graph %s full; %" PRIu64 " failure(s) so far\n", what, count);
}

namespace {
std::size_t free_mesh_chunks(const scene_graph::SceneGraph& graph) {
  std::size_t free_chunks = 0;
  graph.for_each_resource([&](const memory::ResourceStats& s) {
    if (std::strcmp(s.name, "scene_graph.mesh_chunks") == 0) free_chunks = s.capacity - s.in_use;
  });
  return free_chunks;
}
}  // namespace

bool ObjectLayer::sync(scene_graph::SceneGraph* graph) {
  synced_.clear();
  if (!ready_ || graph == nullptr || !graph->initialized()) return false;
  bool ok = true;
  for (const NodeId id : removed_nodes_) graph->remove_node(id);
  removed_nodes_.clear();
  const scene_graph::Capacities& gc = graph->capacities();
  for (const std::uint32_t h : changed_) {
    if (!objects_.live(h) || !objects_[h].changed) continue;
    Object& o = objects_[h];
    if (!visible(h)) {  // tentative, or shrank below the min count: not (or no longer) in the graph
      if (o.in_graph) graph->remove_node(o.node);
      o.in_graph = false;
      o.changed = false;
      continue;
    }
    const ObjectView v = view(h);
    scene_graph::ObjectAttributes* a = graph->object(o.node);
    scene_graph::ObjectAttributes fresh;
    if (a == nullptr) {
      if (graph->num_nodes(scene_graph::NodeKind::kObject) >= gc.object_nodes || graph->num_nodes() >= gc.nodes()) {
        graph->count_refused_node(scene_graph::NodeKind::kObject);  // shown under the store's own name
        ++counters_.graph_node_failures;
        log_graph_failure("object store", counters_.graph_node_failures);
        ok = false;
        continue;  // stays changed: retried at the next sync
      }
      a = &fresh;
    }
    a->position_m = v.position_m;  // the box centre, consistent with bounding_box (see the header)
    a->last_update_time_ns = o.last_update_ns;
    a->is_active = o.num_tracked > 0;
    char name[32];
    const int n = std::snprintf(name, sizeof(name), "O(%" PRIu64 ")", scene_graph::node_index(o.node));
    a->name.assign(name, static_cast<std::size_t>(std::max(0, std::min(n, 31))));
    a->color = semantics::object_label(o.label).color;
    a->bounding_box = scene_graph::BoundingBox::aabb(v.min_m, v.max_m);
    a->semantic_label = o.label;
    if (a == &fresh) {
      if (graph->add_object(o.node, fresh) != scene_graph::Status::kOk) {
        ++counters_.graph_node_failures;
        log_graph_failure("object store", counters_.graph_node_failures);
        ok = false;
        continue;
      }
    }
    o.in_graph = true;
    graph->clear_mesh_connections(o.node);
    const std::size_t room = free_mesh_chunks(*graph) * scene_graph::kMeshChunkValues;
    std::size_t added = 0;
    for (std::uint32_t c = o.key_head; c != kInvalidHandle && added < room; c = key_chunks_[c].next)
      for (std::uint32_t i = 0; i < key_chunks_[c].count && added < room; ++i, ++added)
        graph->append_mesh_connection(o.node, c * kKeysPerChunk + i);
    if (added < o.num_keys) {
      counters_.graph_connection_failures += o.num_keys - added;
      log_graph_failure("mesh-connection pool", counters_.graph_connection_failures);
      ok = false;
    }
    o.changed = false;
    synced_.push_back(o.node);
  }
  std::size_t k = 0;
  for (std::size_t i = 0; i < changed_.size(); ++i) {
    const std::uint32_t h = changed_[i];
    if (objects_.live(h) && objects_[h].changed) changed_[k++] = h;
  }
  while (changed_.size() > k) changed_.pop_back();
  return ok;
}

}  // namespace qsg::objects
