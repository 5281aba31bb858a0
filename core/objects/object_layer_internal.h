// Private to core/objects: the object, block and candidate types behind ObjectLayer, and the cell packing and box
// helpers its .cc files share (the layer's stores and tracked vertices, the clustering, the configuration).
// Included by core/objects/*.cc only.
#pragma once

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstring>
#include <limits>

#include "core/objects/object_layer.h"
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
  std::uint64_t first_update_ns = 0;  // the update that created it (the earliest of merged objects)
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

using U64Map = memory::FixedHashMap<std::uint64_t, std::uint32_t, memory::U64Hash>;

}  // namespace qsg::objects
