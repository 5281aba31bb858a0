// Layer 1 of the scene graph: a semantic TSDF in a bounded active window around the robot, meshed by marching
// cubes over dirty blocks, with far blocks archived into a compressed global mesh. Every store is carved from
// one arena sized by the board's budget table; after init() integration, meshing and archiving never allocate.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "core/memory/arena.h"
#include "core/memory/fixed_hash_map.h"
#include "core/memory/fixed_vector.h"
#include "core/memory/pool.h"
#include "core/semantics/labels.h"
#include "core/messages/sensor_types.h"

namespace qsg::reconstruction {

// 8 voxels per block side (voxblox/nvblox use the same): a block holds 8^3 = 512 voxels (8 KB at 16 bytes a
// voxel), 0.8 m at 0.1 m voxels — larger than the truncation band (0.3 m), so a depth sample touches at most a
// few blocks; small enough that a block is mostly surface, the marching-cubes +1 layer (9^3 corners) stays in
// cache and the hash of a 8 m window holds only a few thousand entries.
inline constexpr int kBlockSide = 8;
inline constexpr int kBlockVoxels = kBlockSide * kBlockSide * kBlockSide;
inline constexpr int kLabelPairs = 2;

// Per-voxel semantics: two (label, weight) pairs — a bounded "heavy hitters" summary of the label histogram.
// An observation of label l with weight w adds w to l's pair if present, fills an empty pair otherwise, and
// otherwise decrements the weakest pair by w, replacing it by (l, leftover) when its weight reaches zero
// (Misra-Gries). The stored winner is the label of maximum accumulated evidence (the MAP label of the
// count-based Dirichlet posterior) whenever it carries more than a third of the evidence; never a histogram.
struct LabelVote {
  semantics::Label label = semantics::kVoid;
  std::uint16_t weight_q = 0;  // weight * kWeightScale
};

// 16 bytes: quantised distance (fraction of the truncation distance), weight, colour and two label pairs.
struct Voxel {
  std::int16_t sdf_q = 0;      // distance / truncation * 32767
  std::uint16_t weight_q = 0;  // weight * kWeightScale; 0 = unobserved
  std::uint8_t rgb[3] = {0, 0, 0};
  std::uint8_t pad = 0;
  LabelVote votes[kLabelPairs];
};
static_assert(sizeof(Voxel) == 16, "keep the voxel at 16 bytes");
inline constexpr float kWeightScale = 256.0f;

// One mesh vertex: position, colour, label (the most likely label of the voxel nearer to the surface).
struct MeshVertex {
  float x = 0, y = 0, z = 0;
  std::uint8_t r = 0, g = 0, b = 0;
  semantics::Label label = semantics::kVoid;
};
struct MeshTriangle {
  std::uint32_t v[3] = {0, 0, 0};
};
// An indexed mesh for export and tests (heap-backed: extraction is not on the per-frame path).
struct Mesh {
  std::vector<MeshVertex> vertices;
  std::vector<MeshTriangle> triangles;
  // When each vertex's surface was seen (data time, ns): the mean time of the frames integrated into its block.
  // Filled by SemanticTsdf's extract_* calls, kept in step by clean_mesh; empty when not known (a mesh read from
  // a file). The deformation moves a vertex with the nodes of its own visit (BackendStage::correct_mesh).
  std::vector<std::uint64_t> vertex_time_ns;
  bool has_vertex_times() const { return !vertices.empty() && vertex_time_ns.size() == vertices.size(); }
};

struct Config {
  double voxel_size_m = 0.1;
  double truncation_voxels = 3.0;
  double min_range_m = 0.1;
  double max_range_m = 4.5;
  double window_radius_m = 8.0;     // blocks whose centre is farther from the robot are archived
  double max_weight = 100.0;        // voxel weights saturate here, so the map can still follow changes
  double archive_resolution_m = 0.05;  // vertices of the archive closer than this (same cell) are merged
  // When the archive fills it first drops unreferenced vertices, then doubles its merge cell up to this size
  // (coarser but complete), and only then refuses triangles (counted).
  double archive_max_resolution_m = 0.4;
  int integration_threads = 1;        // 1 = on the caller's thread; 2..8 = the caller plus long-lived workers
  bool integrate_labels = true;
  std::string check() const;  // empty when usable, else the bad field and why
  void print(std::FILE* out) const;
};

// Sizes of the layer's stores: the budget table's "reconstruction" arena (capacities_from_budget()), or a test's own.
struct Capacities {
  std::size_t max_blocks = 0;
  std::size_t mesh_vertices = 0;       // active-window mesh, all blocks together
  std::size_t mesh_triangles = 0;
  std::size_t archive_vertices = 0;
  std::size_t archive_triangles = 0;
};
Capacities capacities_from_budget();

struct Counters {
  std::uint64_t frames = 0;
  std::uint64_t pixels_valid = 0;
  std::uint64_t pixels_invalid = 0;        // depth 0, NaN, inf, below min or beyond max range: not integrated
  std::uint64_t blocks_allocated = 0;
  std::uint64_t blocks_archived = 0;       // left the window
  std::uint64_t blocks_evicted = 0;        // pool full: farthest block archived early
  std::uint64_t blocks_refused = 0;        // pool full and nothing evictable
  std::uint64_t blocks_meshed = 0;
  std::uint64_t mesh_overflow = 0;         // vertices/triangles dropped because the active mesh pools were full
  std::uint64_t archive_overflow = 0;      // vertices/triangles dropped because the archive was full
  std::uint64_t archive_replaced = 0;      // archived triangles replaced by a revisit's re-observation
  std::uint64_t archive_compactions = 0;   // archive full: unreferenced vertices dropped
  std::uint64_t archive_coarsenings = 0;   // archive full: merge cell doubled
  std::uint64_t label_frames = 0;          // integrate_label_votes() passes (late labels of an integrated frame)
  std::uint64_t label_samples_missed = 0;  // their block samples whose block was not active (left the window)
  void print(std::FILE* out) const;
};

class SemanticTsdf {
 public:
  SemanticTsdf();
  SemanticTsdf(const SemanticTsdf&) = delete;
  SemanticTsdf& operator=(const SemanticTsdf&) = delete;
  ~SemanticTsdf();

  static memory::ArenaPlan plan(const Capacities& capacities);
  // Checks the config and carves every store from one arena of at most budget_bytes. Start-up only.
  bool init(const Config& config, const Capacities& capacities, std::size_t budget_bytes, std::string* error);

  // Integrates one frame seen from world_T_camera (optical frame: x right, y down, z forward). Labels are used
  // when frame.has_labels. Marks the touched blocks dirty. False (nothing integrated) for a bad frame.
  bool integrate(const messages::RgbdFrame& frame, const Eigen::Isometry3d& world_T_camera);
  // The label votes alone of a frame whose depth was integrated earlier (its segmentation came later): the same
  // voxels and weights integrate() would have voted with, from the frame's own depth and pose, into active blocks
  // only; never allocates a block. Blocks where a voxel's most likely label changed are marked dirty, so
  // update_mesh() gives their vertices the new labels. False (nothing done) without labels or for a bad frame.
  bool integrate_label_votes(const messages::RgbdFrame& frame, const Eigen::Isometry3d& world_T_camera);
  // Re-runs marching cubes over the blocks changed since the last call (and the neighbours that read them).
  void update_mesh();
  // Archives (mesh into the global mesh) and frees every block farther than the window radius from robot_m.
  void update_window(const Eigen::Vector3d& robot_m);
  // integrate + update_mesh + update_window around the camera: the per-frame call.
  bool process(const messages::RgbdFrame& frame, const Eigen::Isometry3d& world_T_camera);

  // The active window's mesh, welded across blocks (one vertex per voxel edge), only referenced vertices.
  void extract_active_mesh(Mesh* out);
  // The archive (global mesh of everything that left the window).
  void extract_archive(Mesh* out) const;
  // Archive + active window: archived triangles an active block has re-observed are left out, and the active
  // mesh goes through the archive's vertex merge (a copy, not in place), so archived and active parts share
  // their border vertices.
  void extract_full_mesh(Mesh* out);

  // Voxel at a world point (nullptr when its block is not allocated). Distances in metres via sdf_m().
  const Voxel* voxel_at(const Eigen::Vector3d& p_m) const;
  float sdf_m(const Voxel& v) const { return static_cast<float>(v.sdf_q) * sdf_scale_; }
  static semantics::Label best_label(const Voxel& v);

  // Read access for the frontend (places, objects). A view is valid until the next integrate(), update_mesh()
  // or update_window(); none of these calls allocate.
  struct BlockView {
    memory::Index3 index;                 // voxel (x, y, z) of the block is global voxel index * kBlockSide + (x, y, z)
    std::uint32_t integrated_stamp = 0;   // frame_stamp() of the last frame integrated into the block
    std::uint32_t meshed_stamp = 0;       // mesh_stamp() of the block's last marching-cubes run
    const Voxel* voxels = nullptr;        // kBlockVoxels; voxel (x, y, z) at x + kBlockSide * (y + kBlockSide * z)
    std::uint32_t num_vertices = 0;
  };
  using Vertex = MeshVertex;  // what next_block_vertex() yields (for generic readers: rooms::WallMap::repaint)
  struct VertexCursor {
    std::uint32_t chunk = memory::kInvalidHandle;
    std::uint32_t index = 0;
  };
  std::uint32_t block_slots() const { return static_cast<std::uint32_t>(blocks_.capacity()); }  // handles < this
  bool block_view(std::uint32_t handle, BlockView* out) const;  // false for a free slot
  std::uint32_t find_block(const memory::Index3& index) const;  // handle, or kInvalidHandle when not active
  template <typename Fn>
  void for_each_block(Fn&& fn) const {  // fn(std::uint32_t handle, const BlockView&)
    BlockView view;
    for (std::uint32_t h = 0; h < block_slots(); ++h)
      if (block_view(h, &view)) fn(h, view);
  }
  // The block's mesh vertices one by one (start with a default cursor); false at the end. key is the vertex's
  // global voxel-edge key: a vertex on a block border appears in both blocks with the same key, and keeps it
  // while the surface is re-meshed.
  bool next_block_vertex(std::uint32_t handle, VertexCursor* cursor, MeshVertex* vertex, std::uint64_t* key) const;
  // The middle of the voxel edge a vertex key names: the vertex lies on that edge, within half a voxel of it. Keys
  // pack the edge's lower voxel (20 bits per axis, offset by 2^19) and its axis; voxel centres sit at index + 0.5.
  Eigen::Vector3d vertex_key_edge_middle_m(std::uint64_t key) const {
    const auto unpack = [](std::uint64_t v) { return static_cast<double>(static_cast<std::int32_t>(v & 0xFFFFF) - (1 << 19)) + 0.5; };
    Eigen::Vector3d g(unpack(key >> 42), unpack(key >> 22), unpack(key >> 2));
    g[static_cast<int>(key & 3)] += 0.5;
    return g * config_.voxel_size_m;
  }
  std::uint32_t frame_stamp() const { return frame_stamp_; }
  std::uint32_t mesh_stamp() const { return mesh_stamp_; }
  double block_size_m() const { return config_.voxel_size_m * kBlockSide; }

  const Config& config() const { return config_; }
  const Capacities& capacities() const { return capacities_; }
  const Counters& counters() const { return counters_; }
  std::size_t active_blocks() const { return blocks_.size(); }
  std::size_t archive_vertices() const { return archive_vertices_.size(); }
  std::size_t archive_triangles() const { return archive_triangle_count_; }
  std::size_t archive_blocks() const { return archive_blocks_.size(); }
  double archive_resolution_m() const { return archive_resolution_m_; }  // grows when the archive fills
  // Bytes the archive's stores hold for what it keeps (vertices + triangle chunks in use).
  std::size_t archive_bytes() const;
  // Bytes of the active window's voxel storage (TSDF + semantics), fixed at init.
  std::size_t window_bytes() const { return capacities_.max_blocks * sizeof(Voxel) * kBlockVoxels; }
  std::size_t arena_bytes() const { return arena_.capacity_bytes(); }

  struct Block;
  struct VertexChunk;
  struct TriangleChunk;
  struct Scratch;
  struct ArchiveChunk;
  struct ArchiveEntry {
    std::uint32_t head = memory::kInvalidHandle;  // chunk chain of the block's archived triangles
    std::uint32_t tail = memory::kInvalidHandle;
    std::uint32_t count = 0;
    // When its last visit saw the block (mean data time of the frames integrated into it, ns). A revisit keeps
    // the earlier triangles it did not observe again under the newer time.
    std::uint64_t time_ns = 0;
  };
  class Workers;

 private:
  std::uint32_t allocate_block(const memory::Index3& index, const Eigen::Vector3d& robot_m);
  bool evict_farthest(const Eigen::Vector3d& robot_m);
  bool vote_block(Block& block, const messages::RgbdFrame& frame, const Eigen::Isometry3d& camera_T_world);
  void integrate_block(Block& block, const messages::RgbdFrame& frame, const Eigen::Isometry3d& camera_T_world);
  void mesh_block(std::uint32_t handle);
  void release_mesh(Block& block);
  void archive_block(std::uint32_t handle);
  bool append_archive_triangle(ArchiveEntry& entry, const MeshTriangle& tri);
  template <typename Keep>
  void filter_archive(ArchiveEntry& entry, Keep&& keep);
  bool make_archive_room(bool need_chunk);
  void compact_archive(double resolution_m);
  bool covered_by_block(const Block& block, const MeshVertex* const* corners) const;
  void integrate_range(const messages::RgbdFrame& frame, const Eigen::Isometry3d& camera_T_world,
                       std::uint32_t begin, std::uint32_t end);
  template <typename Fn>
  void for_each_block_triangle(const Block& block, Fn&& fn) const;
  std::uint32_t archive_vertex(const MeshVertex& v);
  memory::Index3 archive_cell(const MeshVertex& v) const;
  Eigen::Vector3d block_center(const memory::Index3& index) const;

  Config config_;
  Capacities capacities_;
  Counters counters_;
  memory::Arena arena_;
  memory::Pool<Block> blocks_;
  memory::SpatialHash<std::uint32_t> block_index_;
  memory::Pool<VertexChunk> vertex_chunks_;
  memory::Pool<TriangleChunk> triangle_chunks_;
  memory::ArenaVector<std::uint32_t> touched_;   // blocks integrated this frame
  memory::ArenaVector<std::uint32_t> remesh_;    // blocks to mesh this update
  memory::FixedHashMap<std::uint64_t, std::uint32_t, memory::U64Hash> weld_;  // voxel edge -> output vertex
  memory::ArenaVector<MeshVertex> archive_vertices_;
  memory::Pool<ArchiveChunk> archive_chunks_;
  memory::SpatialHash<ArchiveEntry> archive_blocks_;  // block index -> its archived triangles
  memory::SpatialHash<std::uint32_t> archive_index_;  // quantised position -> archive vertex
  memory::ArenaVector<std::uint32_t> archive_remap_;  // compaction's old -> new vertex ids
  std::size_t archive_triangle_count_ = 0;
  double archive_resolution_m_ = 0.0;
  Workers* workers_ = nullptr;  // integration threads beyond the caller's (created by init)
  Scratch* scratch_ = nullptr;  // marching-cubes working set of one block (carved, reused)
  float sdf_scale_ = 0.0f;   // metres per sdf_q unit
  std::uint32_t frame_stamp_ = 0;
  std::uint32_t label_stamp_ = 0;  // integrate_label_votes() passes (Block::label_stamp)
  std::uint32_t mesh_stamp_ = 0;
  bool logged_eviction_ = false;
  bool ready_ = false;
  Eigen::Vector3d robot_m_ = Eigen::Vector3d::Zero();
};

}  // namespace qsg::reconstruction
