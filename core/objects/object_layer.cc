// Layer 2 objects: incremental per-label Euclidean clustering of mesh vertices into objects, in fixed memory.
// The layer's stores and their plan, the cells of the tracked-vertex grid, objects (create, merge, delete, mesh
// keys), tracked vertices, the update's input (blocks and vertices) and the sync into the scene graph. The
// clustering is in object_clustering.cc, the configuration in object_config.cc.
#include "core/objects/object_layer_internal.h"

namespace qsg::objects {

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
  archive_after_ns_ = static_cast<std::uint64_t>(std::llround(config.archive_after_s * 1e9));
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
  v.first_update_ns = o.first_update_ns;
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

void ObjectLayer::mark_changed(std::uint32_t h, bool observed) {
  Object& o = objects_[h];
  if (observed) o.last_update_ns = time_ns_;
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
  o.first_update_ns = time_ns_;
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
  a.first_update_ns = std::min(a.first_update_ns, b.first_update_ns);
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
    else
      mark_changed(h, false);  // left the active window: not an observation, its time stays
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
  const double share = config_.archive_below_use;
  archive_full_ = static_cast<double>(objects_.size()) >= share * static_cast<double>(objects_.capacity()) ||
                  static_cast<double>(key_chunks_.size()) >= share * static_cast<double>(key_chunks_.capacity());
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
