// ObjectLayer's clustering (the paper's Euclidean clustering of mesh vertices per label, made incremental): the
// candidates sorted into clustering cells, cells joined by union-find, the clusters numbered, the existing objects
// each cluster touches, the merge rules, the object index, and each cluster turned into an object.
#include "core/objects/object_layer_internal.h"

namespace qsg::objects {

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
MergeRule merge_rule(const Config& config, semantics::Label label, const float* lo, const float* hi, const float* olo,
                     const float* ohi, bool new_cluster) {
  float c[3], oc[3];
  box_centre(lo, hi, c);
  box_centre(olo, ohi, oc);
  if (config.merge_overlapping && (inside(c, olo, ohi) || inside(oc, lo, hi))) return MergeRule::kCentreInBox;
  bool intersect = true;
  for (int i = 0; i < 3; ++i) intersect = intersect && lo[i] <= ohi[i] && olo[i] <= hi[i];
  if (config.merge_intersecting && intersect) return MergeRule::kIntersect;
  const LabelParams& p = config.labels[label];
  if (new_cluster || !config.merge_by_size_prior || !(p.max_size_m > 0.0)) return MergeRule::kNone;
  const float tol = static_cast<float>(p.tolerance_m);
  const float size = static_cast<float>(p.max_size_m);
  if (lo[2] > ohi[2] + tol || olo[2] > hi[2] + tol) return MergeRule::kNone;
  for (int i = 0; i < 2; ++i)
    if (std::max(hi[i], ohi[i]) - std::min(lo[i], olo[i]) > size) return MergeRule::kNone;
  return MergeRule::kSizePrior;
}

// Every vertex left the active window, and no vertex changed it for more than Config::archive_after_s: a visit of
// the past, which the frontend no longer merges into.
bool ObjectLayer::archived(std::uint32_t h) const {
  const Object& o = objects_[h];
  return archive_after_ns_ > 0 && o.num_tracked == 0 && time_ns_ > o.last_update_ns &&
         time_ns_ - o.last_update_ns > archive_after_ns_;
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
    *rule = merge_rule(config_, label, lo, hi, objects_[g].lo, objects_[g].hi, new_cluster);
    if (*rule != MergeRule::kNone && archived(g)) {
      if (archive_full_) {
        ++counters_.archived_merged_full;
      } else {
        ++counters_.archived_kept_apart;
        *rule = MergeRule::kNone;
      }
    }
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

}  // namespace qsg::objects
