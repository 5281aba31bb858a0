// Private to core/places: the voxel, block, cluster and list types behind Places, and the constants and small
// helpers its .cc files share (the ESDF, the GVD, sparsification, the repair passes and the scene-graph mirror).
// Included by core/places/*.cc only.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <limits>

#include "core/places/places.h"

namespace qsg::places {

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
inline const Offsets kOffsets;

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

// recompute_edges(): a place's candidate edges, in the order offered (GVD, free-space, bridges), at most the limit.
struct Places::EdgeCandidates {
  std::uint32_t to[kMaxClusterEdges];
  float weight[kMaxClusterEdges];
  std::uint8_t kind[kMaxClusterEdges];  // kEdgeGvd, kEdgeFree or kEdgeBridge
  int n = 0;
};

// A graph write refused for another reason than a full store: counted in graph_errors, logged 1st, 2nd, 4th, ...
void log_graph_error(const char* what, scene_graph::Status status, std::uint64_t n);

}  // namespace qsg::places
