// Semantic TSDF integration, marching cubes over dirty blocks, the active window and the mesh archive.
// Integration is in tsdf_integration.cc.
#include "core/reconstruction/semantic_tsdf_internal.h"

#include "budgets/budget_table.h"
#include "core/reconstruction/marching_cubes.h"
#include "core/reconstruction/reconstruction_params.h"

namespace qsg::reconstruction {

// ---------------------------------------------------------------------------------------------------------
std::string Config::check() const {
  // Each field within its declared range (reconstruction_params.cc), then the rules between fields.
  if (std::string why = params::check(params_table(), *this); !why.empty()) return why;
  if (!(max_range_m > min_range_m)) return "max_range_m must exceed min_range_m";
  if (!(window_radius_m > max_range_m)) return "window_radius_m must exceed max_range_m";
  if (!(archive_max_resolution_m >= archive_resolution_m))
    return "archive_max_resolution_m must be at least archive_resolution_m";
  return {};
}

void Config::print(std::FILE* out) const {
  params::print(params::sections_of("reconstruction", params_table()), this, out);  // every field, from the table
}

void Counters::print(std::FILE* out) const {
  std::fprintf(out,
               "reconstruction: frames=%llu pixels valid=%llu invalid=%llu blocks allocated=%llu archived=%llu "
               "evicted=%llu refused=%llu meshed=%llu mesh_overflow=%llu archive_overflow=%llu archive_replaced=%llu "
               "archive_compactions=%llu archive_coarsenings=%llu label_frames=%llu label_samples_missed=%llu\n",
               (unsigned long long)frames, (unsigned long long)pixels_valid, (unsigned long long)pixels_invalid,
               (unsigned long long)blocks_allocated, (unsigned long long)blocks_archived,
               (unsigned long long)blocks_evicted, (unsigned long long)blocks_refused,
               (unsigned long long)blocks_meshed, (unsigned long long)mesh_overflow,
               (unsigned long long)archive_overflow, (unsigned long long)archive_replaced,
               (unsigned long long)archive_compactions, (unsigned long long)archive_coarsenings,
               (unsigned long long)label_frames, (unsigned long long)label_samples_missed);
}

Capacities capacities_from_budget() {
  Capacities c;
  c.max_blocks = budgets::active::reconstruction::kMaxBlocks;
  c.mesh_vertices = budgets::active::reconstruction::kMeshVertices;
  c.mesh_triangles = budgets::active::reconstruction::kMeshTriangles;
  c.archive_vertices = budgets::active::reconstruction::kArchiveVertices;
  c.archive_triangles = budgets::active::reconstruction::kArchiveTriangles;
  return c;
}

// ---------------------------------------------------------------------------------------------------------
SemanticTsdf::SemanticTsdf()
    : blocks_("reconstruction.blocks", memory::OverflowPolicy::kRefuse),
      block_index_("reconstruction.block_index", memory::OverflowPolicy::kRefuse),
      vertex_chunks_("reconstruction.vertex_chunks", memory::OverflowPolicy::kRefuse),
      triangle_chunks_("reconstruction.triangle_chunks", memory::OverflowPolicy::kRefuse),
      touched_("reconstruction.touched", memory::OverflowPolicy::kRefuse),
      remesh_("reconstruction.remesh", memory::OverflowPolicy::kRefuse),
      weld_("reconstruction.weld", memory::OverflowPolicy::kRefuse),
      archive_vertices_("reconstruction.archive_vertices", memory::OverflowPolicy::kRefuse),
      archive_chunks_("reconstruction.archive_chunks", memory::OverflowPolicy::kRefuse),
      archive_blocks_("reconstruction.archive_blocks", memory::OverflowPolicy::kRefuse),
      archive_index_("reconstruction.archive_index", memory::OverflowPolicy::kRefuse),
      archive_remap_("reconstruction.archive_remap", memory::OverflowPolicy::kRefuse) {}

SemanticTsdf::~SemanticTsdf() {
  // The pools hold their objects in the arena: destroy them before the arena goes.
  delete workers_;
  if (ready_) {
    blocks_.clear();
    vertex_chunks_.clear();
    triangle_chunks_.clear();
    archive_chunks_.clear();
  }
}

namespace {
std::size_t archive_chunk_count(const Capacities& c) { return c.archive_triangles / kArchiveChunk; }
// A block's triangles need at least one chunk, so there are never more archived blocks than chunks.
std::size_t archive_block_count(const Capacities& c) { return archive_chunk_count(c); }
}  // namespace

memory::ArenaPlan SemanticTsdf::plan(const Capacities& c) {
  memory::ArenaPlan plan;
  memory::Pool<Block>::plan(plan, c.max_blocks);
  memory::SpatialHash<std::uint32_t>::plan(plan, memory::SpatialHash<std::uint32_t>::slots_for(c.max_blocks));
  memory::Pool<VertexChunk>::plan(plan, c.mesh_vertices / kChunkSize);
  memory::Pool<TriangleChunk>::plan(plan, c.mesh_triangles / kChunkSize);
  memory::ArenaVector<std::uint32_t>::plan(plan, c.max_blocks);
  memory::ArenaVector<std::uint32_t>::plan(plan, c.max_blocks);
  using Weld = memory::FixedHashMap<std::uint64_t, std::uint32_t, memory::U64Hash>;
  Weld::plan(plan, Weld::slots_for(c.mesh_vertices));
  memory::ArenaVector<MeshVertex>::plan(plan, c.archive_vertices);
  memory::Pool<ArchiveChunk>::plan(plan, archive_chunk_count(c));
  memory::SpatialHash<ArchiveEntry>::plan(plan, memory::SpatialHash<ArchiveEntry>::slots_for(archive_block_count(c)));
  memory::SpatialHash<std::uint32_t>::plan(plan, memory::SpatialHash<std::uint32_t>::slots_for(c.archive_vertices));
  memory::ArenaVector<std::uint32_t>::plan(plan, c.archive_vertices);
  plan.add_array<Scratch>(1);
  return plan;
}

bool SemanticTsdf::init(const Config& config, const Capacities& c, std::size_t budget_bytes, std::string* error) {
  const auto fail = [error](const std::string& why) {
    if (error != nullptr) *error = "reconstruction: " + why;
    return false;
  };
  if (ready_) return fail("init() called twice");
  const std::string bad = config.check();
  if (!bad.empty()) return fail("config: " + bad);
  if (c.max_blocks == 0 || c.mesh_vertices < kChunkSize || c.mesh_triangles < kChunkSize ||
      c.archive_triangles < kArchiveChunk || c.archive_vertices == 0)
    return fail("capacities: max_blocks, mesh_vertices, mesh_triangles (>= 64), archive_vertices and "
                "archive_triangles (>= 32) must be positive");
  config_ = config;
  capacities_ = c;
  if (!arena_.create("reconstruction", plan(c), budget_bytes, error)) return false;
  using Weld = memory::FixedHashMap<std::uint64_t, std::uint32_t, memory::U64Hash>;
  const bool ok =
      blocks_.carve(arena_, c.max_blocks) &&
      block_index_.carve(arena_, memory::SpatialHash<std::uint32_t>::slots_for(c.max_blocks), c.max_blocks) &&
      vertex_chunks_.carve(arena_, c.mesh_vertices / kChunkSize) &&
      triangle_chunks_.carve(arena_, c.mesh_triangles / kChunkSize) && touched_.carve(arena_, c.max_blocks) &&
      remesh_.carve(arena_, c.max_blocks) && weld_.carve(arena_, Weld::slots_for(c.mesh_vertices), c.mesh_vertices) &&
      archive_vertices_.carve(arena_, c.archive_vertices) &&
      archive_chunks_.carve(arena_, archive_chunk_count(c)) &&
      archive_blocks_.carve(arena_, memory::SpatialHash<ArchiveEntry>::slots_for(archive_block_count(c)),
                            archive_block_count(c)) &&
      archive_index_.carve(arena_, memory::SpatialHash<std::uint32_t>::slots_for(c.archive_vertices),
                           c.archive_vertices) &&
      archive_remap_.carve(arena_, c.archive_vertices);
  scratch_ = ok ? arena_.carve_array<Scratch>(1) : nullptr;
  if (!ok || scratch_ == nullptr || !arena_.seal()) return fail("the arena carve did not match its plan");
  sdf_scale_ = static_cast<float>(config_.voxel_size_m * config_.truncation_voxels) / kSdfQuant;
  archive_resolution_m_ = config_.archive_resolution_m;
  if (config_.integration_threads > 1) workers_ = new Workers(config_.integration_threads - 1);
  ready_ = true;
  return true;
}

Eigen::Vector3d SemanticTsdf::block_center(const memory::Index3& i) const {
  const double b = config_.voxel_size_m * kBlockSide;
  return Eigen::Vector3d((i.x + 0.5) * b, (i.y + 0.5) * b, (i.z + 0.5) * b);
}

semantics::Label SemanticTsdf::best_label(const Voxel& v) {
  const LabelVote& a = v.votes[0];
  const LabelVote& b = v.votes[1];
  if (a.weight_q == 0 && b.weight_q == 0) return semantics::kVoid;
  return a.weight_q >= b.weight_q ? a.label : b.label;
}

const Voxel* SemanticTsdf::voxel_at(const Eigen::Vector3d& p_m) const {
  if (!ready_) return nullptr;
  const double s = config_.voxel_size_m;
  const std::int32_t gx = static_cast<std::int32_t>(std::floor(p_m.x() / s));
  const std::int32_t gy = static_cast<std::int32_t>(std::floor(p_m.y() / s));
  const std::int32_t gz = static_cast<std::int32_t>(std::floor(p_m.z() / s));
  const auto blk = [](std::int32_t g) { return g >= 0 ? g / kBlockSide : (g - kBlockSide + 1) / kBlockSide; };
  const memory::Index3 bi{blk(gx), blk(gy), blk(gz)};
  const std::uint32_t* h = block_index_.find(bi);
  if (h == nullptr) return nullptr;
  const int lx = gx - bi.x * kBlockSide, ly = gy - bi.y * kBlockSide, lz = gz - bi.z * kBlockSide;
  return &blocks_[*h].voxels[lx + kBlockSide * (ly + kBlockSide * lz)];
}

bool SemanticTsdf::block_view(std::uint32_t handle, BlockView* out) const {
  if (!ready_ || handle >= blocks_.capacity() || !blocks_.live(handle)) return false;
  const Block& b = blocks_[handle];
  out->index = b.index;
  out->integrated_stamp = b.frame_stamp;
  out->meshed_stamp = b.mesh_stamp;
  out->voxels = b.voxels;
  out->num_vertices = b.num_vertices;
  return true;
}

std::uint32_t SemanticTsdf::find_block(const memory::Index3& index) const {
  if (!ready_) return memory::kInvalidHandle;
  const std::uint32_t* h = block_index_.find(index);
  return h == nullptr ? memory::kInvalidHandle : *h;
}

bool SemanticTsdf::next_block_vertex(std::uint32_t handle, VertexCursor* cursor, MeshVertex* vertex,
                                     std::uint64_t* key) const {
  if (!ready_ || handle >= blocks_.capacity() || !blocks_.live(handle)) return false;
  const Block& b = blocks_[handle];
  if (cursor->index >= b.num_vertices) return false;
  if (cursor->index == 0) cursor->chunk = b.vertex_head;
  else if (cursor->index % kChunkSize == 0) cursor->chunk = vertex_chunks_[cursor->chunk].next;
  if (cursor->chunk == memory::kInvalidHandle) return false;
  const VertexChunk& chunk = vertex_chunks_[cursor->chunk];
  const int slot = static_cast<int>(cursor->index % kChunkSize);
  *vertex = chunk.vertices[slot];
  if (key != nullptr) *key = edge_key(b.index, chunk.codes[slot]);
  ++cursor->index;
  return true;
}

// ---------------------------------------------------------------------------------------------------------
// Meshing

void SemanticTsdf::release_mesh(Block& block) {
  for (std::uint32_t c = block.vertex_head; c != memory::kInvalidHandle;) {
    const std::uint32_t next = vertex_chunks_[c].next;
    vertex_chunks_.release(c);
    c = next;
  }
  for (std::uint32_t c = block.triangle_head; c != memory::kInvalidHandle;) {
    const std::uint32_t next = triangle_chunks_[c].next;
    triangle_chunks_.release(c);
    c = next;
  }
  block.vertex_head = block.triangle_head = memory::kInvalidHandle;
  block.num_vertices = block.num_triangles = 0;
}

void SemanticTsdf::update_mesh() {
  if (!ready_) return;
  ++mesh_stamp_;
  remesh_.clear();
  // A changed block re-meshes itself and the seven lower neighbours whose cubes read its voxels as their +1 layer.
  for (std::uint32_t h = 0; h < blocks_.capacity(); ++h) {
    if (!blocks_.live(h) || !blocks_[h].dirty) continue;
    const memory::Index3 bi = blocks_[h].index;
    for (int o = 0; o < 8; ++o) {
      const memory::Index3 ni{bi.x - (o & 1), bi.y - ((o >> 1) & 1), bi.z - ((o >> 2) & 1)};
      const std::uint32_t* nh = o == 0 ? &h : block_index_.find(ni);
      if (nh == nullptr || blocks_[*nh].mesh_stamp == mesh_stamp_) continue;
      blocks_[*nh].mesh_stamp = mesh_stamp_;
      remesh_.push_back(*nh);
    }
    blocks_[h].dirty = false;
  }
  for (std::uint32_t h : remesh_) mesh_block(h);
}

void SemanticTsdf::mesh_block(std::uint32_t handle) {
  Block& block = blocks_[handle];
  release_mesh(block);
  ++counters_.blocks_meshed;
  const Block* nb[8];
  for (int o = 0; o < 8; ++o) {
    const memory::Index3 ni{block.index.x + (o & 1), block.index.y + ((o >> 1) & 1), block.index.z + ((o >> 2) & 1)};
    const std::uint32_t* nh = o == 0 ? &handle : block_index_.find(ni);
    nb[o] = nh == nullptr ? nullptr : &blocks_[*nh];
  }
  Scratch& s = *scratch_;
  for (int x = 0; x < kCorners; ++x)
    for (int y = 0; y < kCorners; ++y)
      for (int z = 0; z < kCorners; ++z) {
        Scratch::Corner& c = s.corners[(x * kCorners + y) * kCorners + z];
        const Block* b = nb[(x >> 3) | ((y >> 3) << 1) | ((z >> 3) << 2)];
        const Voxel* v = b == nullptr ? nullptr : &b->voxels[(x & 7) + kBlockSide * ((y & 7) + kBlockSide * (z & 7))];
        c.observed = v != nullptr && v->weight_q > 0;
        if (!c.observed) continue;
        c.d = sdf_m(*v);
        std::memcpy(c.rgb, v->rgb, 3);
        c.label = best_label(*v);
      }
  std::fill(std::begin(s.code_to_vertex), std::end(s.code_to_vertex), static_cast<std::int16_t>(-1));

  const MarchingCubesTables& mc = marching_cubes_tables();
  const double voxel = config_.voxel_size_m;
  std::uint32_t vertex_tail = memory::kInvalidHandle, triangle_tail = memory::kInvalidHandle;
  bool overflow = false;
  const auto corner_at = [&s](int x, int y, int z) -> const Scratch::Corner& {
    return s.corners[(x * kCorners + y) * kCorners + z];
  };
  // The vertex on edge (lower corner, axis), created on first use; -1 when the chunk pool is full.
  const auto vertex_of = [&](int x, int y, int z, int axis) -> int {
    const int code = edge_code(x, y, z, axis);
    if (s.code_to_vertex[code] >= 0) return s.code_to_vertex[code];
    const Scratch::Corner& a = corner_at(x, y, z);
    const Scratch::Corner& b = corner_at(x + (axis == 0), y + (axis == 1), z + (axis == 2));
    if (block.num_vertices % kChunkSize == 0) {
      const std::uint32_t c = vertex_chunks_.acquire();
      if (c == memory::kInvalidHandle) return -1;
      if (vertex_tail == memory::kInvalidHandle) block.vertex_head = c;
      else vertex_chunks_[vertex_tail].next = c;
      vertex_tail = c;
    }
    VertexChunk& chunk = vertex_chunks_[vertex_tail];
    const int slot = block.num_vertices % kChunkSize;
    // Computed from global voxel coordinates only, so a neighbour block meshing the same edge gets the same bits.
    const double t = static_cast<double>(a.d) / (static_cast<double>(a.d) - static_cast<double>(b.d));
    const double g[3] = {static_cast<double>(block.index.x * kBlockSide + x) + 0.5 + (axis == 0 ? t : 0.0),
                         static_cast<double>(block.index.y * kBlockSide + y) + 0.5 + (axis == 1 ? t : 0.0),
                         static_cast<double>(block.index.z * kBlockSide + z) + 0.5 + (axis == 2 ? t : 0.0)};
    MeshVertex& mv = chunk.vertices[slot];
    mv.x = static_cast<float>(g[0] * voxel);
    mv.y = static_cast<float>(g[1] * voxel);
    mv.z = static_cast<float>(g[2] * voxel);
    mv.r = static_cast<std::uint8_t>(std::lround(a.rgb[0] + t * (b.rgb[0] - a.rgb[0])));
    mv.g = static_cast<std::uint8_t>(std::lround(a.rgb[1] + t * (b.rgb[1] - a.rgb[1])));
    mv.b = static_cast<std::uint8_t>(std::lround(a.rgb[2] + t * (b.rgb[2] - a.rgb[2])));
    mv.label = std::fabs(a.d) <= std::fabs(b.d) ? a.label : b.label;
    chunk.codes[slot] = static_cast<std::uint16_t>(code);
    s.code_to_vertex[code] = static_cast<std::int16_t>(block.num_vertices);
    ++block.num_vertices;
    return s.code_to_vertex[code];
  };

  for (int x = 0; x < kBlockSide && !overflow; ++x)
    for (int y = 0; y < kBlockSide && !overflow; ++y)
      for (int z = 0; z < kBlockSide && !overflow; ++z) {
        int cube = 0;
        bool complete = true;
        for (int c = 0; c < 8 && complete; ++c) {
          const Scratch::Corner& k = corner_at(x + (c & 1), y + ((c >> 1) & 1), z + ((c >> 2) & 1));
          complete = k.observed != 0;
          if (complete && k.d < 0.0f) cube |= 1 << c;
        }
        if (!complete || mc.edge_mask[static_cast<std::size_t>(cube)] == 0) continue;
        const auto& tris = mc.triangles[static_cast<std::size_t>(cube)];
        for (int t = 0; t < mc.num_triangles[static_cast<std::size_t>(cube)] && !overflow; ++t) {
          int idx[3];
          for (int k = 0; k < 3; ++k) {
            const int e = tris[static_cast<std::size_t>(3 * t + k)];
            const int low = mc.edge_corners[static_cast<std::size_t>(e)][0];
            idx[k] = vertex_of(x + (low & 1), y + ((low >> 1) & 1), z + ((low >> 2) & 1), e / 4);
            if (idx[k] < 0) overflow = true;
          }
          if (overflow) break;
          if (block.num_triangles % kChunkSize == 0) {
            const std::uint32_t c = triangle_chunks_.acquire();
            if (c == memory::kInvalidHandle) {
              overflow = true;
              break;
            }
            if (triangle_tail == memory::kInvalidHandle) block.triangle_head = c;
            else triangle_chunks_[triangle_tail].next = c;
            triangle_tail = c;
          }
          std::uint16_t* dst = triangle_chunks_[triangle_tail].indices[block.num_triangles % kChunkSize];
          for (int k = 0; k < 3; ++k) dst[k] = static_cast<std::uint16_t>(idx[k]);
          ++block.num_triangles;
        }
      }
  if (overflow) ++counters_.mesh_overflow;
}

template <typename Fn>
void SemanticTsdf::for_each_block_triangle(const Block& block, Fn&& fn) const {
  // fn(const MeshVertex* v[3], const std::uint16_t codes[3])
  Scratch& s = *scratch_;
  int n = 0;
  for (std::uint32_t c = block.vertex_head; c != memory::kInvalidHandle && n <= kMaxChunksPerBlock;
       c = vertex_chunks_[c].next)
    s.chain[n++] = &vertex_chunks_[c];
  int t = 0;
  for (std::uint32_t c = block.triangle_head; c != memory::kInvalidHandle; c = triangle_chunks_[c].next) {
    const TriangleChunk& chunk = triangle_chunks_[c];
    for (int k = 0; k < kChunkSize && t < block.num_triangles; ++k, ++t) {
      const MeshVertex* v[3];
      std::uint16_t codes[3];
      for (int j = 0; j < 3; ++j) {
        const int i = chunk.indices[k][j];
        v[j] = &s.chain[i / kChunkSize]->vertices[i % kChunkSize];
        codes[j] = s.chain[i / kChunkSize]->codes[i % kChunkSize];
      }
      fn(v, codes);
    }
  }
}

void SemanticTsdf::extract_active_mesh(Mesh* out) {
  out->vertices.clear();
  out->triangles.clear();
  out->vertex_time_ns.clear();
  if (!ready_) return;
  weld_.clear();
  for (std::uint32_t h = 0; h < blocks_.capacity(); ++h) {
    if (!blocks_.live(h)) continue;
    const Block& block = blocks_[h];
    const std::uint64_t time_ns = block.mean_time_ns();
    for_each_block_triangle(block, [&](const MeshVertex* const* v, const std::uint16_t* codes) {
      MeshTriangle tri;
      for (int j = 0; j < 3; ++j) {
        bool inserted = false;
        const std::uint32_t next = static_cast<std::uint32_t>(out->vertices.size());
        const std::uint32_t* id = weld_.find_or_insert(edge_key(block.index, codes[j]), next, &inserted);
        if (id == nullptr) return;  // the weld table is as large as the mesh pools: cannot fill first
        if (inserted) {
          out->vertices.push_back(*v[j]);
          out->vertex_time_ns.push_back(time_ns);
        }
        tri.v[j] = *id;
      }
      out->triangles.push_back(tri);
    });
  }
}

// ---------------------------------------------------------------------------------------------------------
// Window and archive

memory::Index3 SemanticTsdf::archive_cell(const MeshVertex& v) const {
  const double r = archive_resolution_m_;
  return {static_cast<std::int32_t>(std::floor(v.x / r)), static_cast<std::int32_t>(std::floor(v.y / r)),
          static_cast<std::int32_t>(std::floor(v.z / r))};
}

std::uint32_t SemanticTsdf::archive_vertex(const MeshVertex& v) {
  const memory::Index3 key = archive_cell(v);
  if (const std::uint32_t* id = archive_index_.find(key)) return *id;
  if (archive_vertices_.full()) return memory::kInvalidHandle;
  const std::uint32_t id = static_cast<std::uint32_t>(archive_vertices_.size());
  if (archive_index_.insert(key, id) == nullptr) return memory::kInvalidHandle;
  archive_vertices_.push_back(v);
  return id;
}

std::size_t SemanticTsdf::archive_bytes() const {
  return archive_vertices_.size() * sizeof(MeshVertex) + archive_chunks_.size() * sizeof(ArchiveChunk);
}

bool SemanticTsdf::append_archive_triangle(ArchiveEntry& entry, const MeshTriangle& tri) {
  if (entry.head == memory::kInvalidHandle || archive_chunks_[entry.tail].count == kArchiveChunk) {
    const std::uint32_t c = archive_chunks_.acquire();
    if (c == memory::kInvalidHandle) return false;
    if (entry.head == memory::kInvalidHandle) entry.head = c;
    else archive_chunks_[entry.tail].next = c;
    entry.tail = c;
  }
  ArchiveChunk& chunk = archive_chunks_[entry.tail];
  chunk.triangles[chunk.count++] = tri;
  ++entry.count;
  ++archive_triangle_count_;
  return true;
}

// Keeps the triangles of one archived block for which keep(MeshTriangle&) is true (keep may rewrite them),
// compacting the chain in place and releasing the chunks it no longer needs. Every chunk but the tail is full,
// so the writer never overtakes the reader.
template <typename Keep>
void SemanticTsdf::filter_archive(ArchiveEntry& entry, Keep&& keep) {
  std::uint32_t write_chunk = entry.head, write_slot = 0, kept = 0;
  for (std::uint32_t c = entry.head; c != memory::kInvalidHandle; c = archive_chunks_[c].next) {
    const std::uint32_t count = archive_chunks_[c].count;
    for (std::uint32_t i = 0; i < count; ++i) {
      MeshTriangle t = archive_chunks_[c].triangles[i];
      if (!keep(t)) continue;
      if (write_slot == kArchiveChunk) {
        write_chunk = archive_chunks_[write_chunk].next;
        write_slot = 0;
      }
      archive_chunks_[write_chunk].triangles[write_slot++] = t;
      ++kept;
    }
  }
  std::uint32_t free_from = entry.head;
  if (kept == 0) {
    entry.head = entry.tail = memory::kInvalidHandle;
  } else {
    archive_chunks_[write_chunk].count = write_slot;
    free_from = archive_chunks_[write_chunk].next;
    archive_chunks_[write_chunk].next = memory::kInvalidHandle;
    entry.tail = write_chunk;
  }
  while (free_from != memory::kInvalidHandle) {
    const std::uint32_t next = archive_chunks_[free_from].next;
    archive_chunks_.release(free_from);
    free_from = next;
  }
  archive_triangle_count_ -= entry.count - kept;
  entry.count = kept;
}

// Re-merges the archive's vertices on a grid of `resolution_m`, dropping vertices no triangle uses and the
// triangles that collapse. Runs only when the archive is full, in place, in the stores it already has.
void SemanticTsdf::compact_archive(double resolution_m) {
  const std::size_t n = archive_vertices_.size();
  archive_remap_.clear();
  for (std::size_t i = 0; i < n; ++i) archive_remap_.push_back(memory::kInvalidHandle);
  archive_blocks_.for_each([&](const memory::Index3&, ArchiveEntry& e) {
    for (std::uint32_t c = e.head; c != memory::kInvalidHandle; c = archive_chunks_[c].next)
      for (std::uint32_t i = 0; i < archive_chunks_[c].count; ++i)
        for (std::uint32_t v : archive_chunks_[c].triangles[i].v) archive_remap_[v] = 0;
  });
  archive_index_.clear();
  archive_resolution_m_ = resolution_m;
  std::uint32_t next = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (archive_remap_[i] == memory::kInvalidHandle) continue;
    bool inserted = false;
    const std::uint32_t* id = archive_index_.find_or_insert(archive_cell(archive_vertices_[i]), next, &inserted);
    if (inserted) archive_vertices_[next++] = archive_vertices_[i];  // next <= i: in place
    archive_remap_[i] = *id;
  }
  while (archive_vertices_.size() > next) archive_vertices_.pop_back();
  archive_blocks_.for_each([&](const memory::Index3&, ArchiveEntry& e) {
    filter_archive(e, [&](MeshTriangle& t) {
      for (std::uint32_t& v : t.v) v = archive_remap_[v];
      return t.v[0] != t.v[1] && t.v[1] != t.v[2] && t.v[0] != t.v[2];
    });
  });
}

bool SemanticTsdf::make_archive_room(bool need_chunk) {
  // First the free option: vertices no triangle uses any more (revisits replace triangles, not vertices).
  const std::size_t vertices_before = archive_vertices_.size();
  compact_archive(archive_resolution_m_);
  ++counters_.archive_compactions;
  const bool vertices_ok = archive_vertices_.size() + archive_vertices_.capacity() / 8 <= archive_vertices_.capacity();
  if (!need_chunk && vertices_ok) return true;
  // Then a coarser archive: the mesh stays complete, its detail halves.
  const double coarser = archive_resolution_m_ * 2.0;
  if (coarser > config_.archive_max_resolution_m + 1e-9) {
    if (counters_.archive_overflow == 0)
      std::fprintf(stderr,
                   "reconstruction: archive full at its coarsest resolution (%.3f m, %zu of %zu vertices, %zu "
                   "triangles); refusing new archived triangles (see counters().archive_overflow)\n",
                   archive_resolution_m_, archive_vertices_.size(), archive_vertices_.capacity(),
                   archive_triangle_count_);
    return archive_vertices_.size() < vertices_before;
  }
  const std::size_t triangles_before = archive_triangle_count_;
  compact_archive(coarser);
  ++counters_.archive_coarsenings;
  std::fprintf(stderr,
               "reconstruction: archive full; merge cell %.3f -> %.3f m: %zu -> %zu vertices, %zu -> %zu triangles\n",
               coarser / 2.0, coarser, vertices_before, archive_vertices_.size(), triangles_before,
               archive_triangle_count_);
  return true;
}

bool SemanticTsdf::covered_by_block(const Block& block, const MeshVertex* const* corners) const {
  // The voxel holding the triangle's centroid is one of its cube's corners: when this visit observed it, the
  // visit's own mesh describes that cube (a surface, or free space where something was).
  const double inv = 1.0 / config_.voxel_size_m;
  const float c[3] = {(corners[0]->x + corners[1]->x + corners[2]->x) / 3.0f,
                      (corners[0]->y + corners[1]->y + corners[2]->y) / 3.0f,
                      (corners[0]->z + corners[1]->z + corners[2]->z) / 3.0f};
  const std::int32_t base[3] = {block.index.x * kBlockSide, block.index.y * kBlockSide, block.index.z * kBlockSide};
  int local[3];
  for (int k = 0; k < 3; ++k)
    local[k] = std::clamp(static_cast<int>(std::floor(c[k] * inv)) - base[k], 0, kBlockSide - 1);
  return block.voxels[local[0] + kBlockSide * (local[1] + kBlockSide * local[2])].weight_q > 0;
}

void SemanticTsdf::archive_block(std::uint32_t handle) {
  Block& block = blocks_[handle];
  ArchiveEntry* entry = archive_blocks_.find(block.index);
  if (entry != nullptr) {
    // A revisit: what this visit observed replaces what the archive held there; the rest stays.
    const std::size_t before = entry->count;
    filter_archive(*entry, [&](MeshTriangle& t) {
      const MeshVertex* corners[3] = {&archive_vertices_[t.v[0]], &archive_vertices_[t.v[1]],
                                      &archive_vertices_[t.v[2]]};
      return !covered_by_block(block, corners);
    });
    counters_.archive_replaced += before - entry->count;
  } else if (block.num_triangles > 0) {
    entry = archive_blocks_.insert(block.index, ArchiveEntry{});
  }
  if (entry != nullptr && block.num_triangles > 0) entry->time_ns = block.mean_time_ns();
  bool overflow = entry == nullptr && block.num_triangles > 0;
  bool tried_room = false;
  if (entry != nullptr) {
    for_each_block_triangle(block, [&](const MeshVertex* const* v, const std::uint16_t*) {
      for (int attempt = 0; attempt < 2; ++attempt) {
        MeshTriangle tri;
        bool ok = true;
        for (int j = 0; j < 3 && ok; ++j) {
          tri.v[j] = archive_vertex(*v[j]);
          ok = tri.v[j] != memory::kInvalidHandle;
        }
        if (ok) {
          // Compression merged two corners: the triangle collapsed.
          if (tri.v[0] == tri.v[1] || tri.v[1] == tri.v[2] || tri.v[0] == tri.v[2]) return;
          if (append_archive_triangle(*entry, tri)) return;
        }
        // Full: make room once per block (compaction re-numbers vertices, so the triangle is re-mapped).
        if (tried_room || attempt == 1) break;
        tried_room = true;
        if (!make_archive_room(/*need_chunk=*/ok)) break;
      }
      overflow = true;
    });
  }
  if (overflow) ++counters_.archive_overflow;
  release_mesh(block);
  block_index_.erase(block.index);
  blocks_.release(handle);
  ++counters_.blocks_archived;
}

void SemanticTsdf::update_window(const Eigen::Vector3d& robot_m) {
  if (!ready_) return;
  robot_m_ = robot_m;
  const double r2 = config_.window_radius_m * config_.window_radius_m;
  for (std::uint32_t h = 0; h < blocks_.capacity(); ++h)
    if (blocks_.live(h) && (block_center(blocks_[h].index) - robot_m).squaredNorm() > r2) archive_block(h);
}

bool SemanticTsdf::process(const messages::RgbdFrame& frame, const Eigen::Isometry3d& world_T_camera) {
  if (!integrate(frame, world_T_camera)) return false;
  update_mesh();
  update_window(world_T_camera.translation());
  return true;
}

void SemanticTsdf::extract_archive(Mesh* out) const {
  out->vertices.clear();
  out->triangles.clear();
  out->vertex_time_ns.clear();
  if (!ready_) return;
  // Only the vertices some triangle uses (a revisit can leave unused ones until the next compaction). A vertex
  // two blocks share takes the later block's time.
  std::vector<std::uint32_t> remap(archive_vertices_.size(), memory::kInvalidHandle);
  archive_blocks_.for_each([&](const memory::Index3&, const ArchiveEntry& e) {
    for (std::uint32_t c = e.head; c != memory::kInvalidHandle; c = archive_chunks_[c].next)
      for (std::uint32_t i = 0; i < archive_chunks_[c].count; ++i) {
        MeshTriangle t = archive_chunks_[c].triangles[i];
        for (std::uint32_t& v : t.v) {
          if (remap[v] == memory::kInvalidHandle) {
            remap[v] = static_cast<std::uint32_t>(out->vertices.size());
            out->vertices.push_back(archive_vertices_[v]);
            out->vertex_time_ns.push_back(e.time_ns);
          }
          v = remap[v];
          out->vertex_time_ns[v] = std::max(out->vertex_time_ns[v], e.time_ns);
        }
        out->triangles.push_back(t);
      }
  });
}

void SemanticTsdf::extract_full_mesh(Mesh* out) {
  out->vertices.clear();
  out->triangles.clear();
  out->vertex_time_ns.clear();
  if (!ready_) return;
  // The archive, less what an active block has observed again (the active mesh stands for it now)...
  // Each vertex takes the time of the latest visit that holds it (the archive's blocks', the active blocks').
  std::vector<std::uint32_t> remap(archive_vertices_.size(), memory::kInvalidHandle);
  const auto emit_archived = [&](std::uint32_t v, std::uint64_t time_ns) {
    if (remap[v] == memory::kInvalidHandle) {
      remap[v] = static_cast<std::uint32_t>(out->vertices.size());
      out->vertices.push_back(archive_vertices_[v]);
      out->vertex_time_ns.push_back(time_ns);
    }
    std::uint64_t& t = out->vertex_time_ns[remap[v]];
    t = std::max(t, time_ns);
    return remap[v];
  };
  archive_blocks_.for_each([&](const memory::Index3& index, const ArchiveEntry& e) {
    const std::uint32_t* active = block_index_.find(index);
    for (std::uint32_t c = e.head; c != memory::kInvalidHandle; c = archive_chunks_[c].next)
      for (std::uint32_t i = 0; i < archive_chunks_[c].count; ++i) {
        MeshTriangle t = archive_chunks_[c].triangles[i];
        const MeshVertex* corners[3] = {&archive_vertices_[t.v[0]], &archive_vertices_[t.v[1]],
                                        &archive_vertices_[t.v[2]]};
        if (active != nullptr && covered_by_block(blocks_[*active], corners)) continue;
        for (std::uint32_t& v : t.v) v = emit_archived(v, e.time_ns);
        out->triangles.push_back(t);
      }
  });
  // ...then the active mesh through the archive's own vertex merge, so a vertex on the border between an
  // archived and an active block is one vertex: no seam.
  Mesh active;
  extract_active_mesh(&active);
  std::unordered_map<memory::Index3, std::uint32_t, memory::Index3Hash> fresh;
  std::vector<std::uint32_t> active_to_out(active.vertices.size());
  for (std::size_t i = 0; i < active.vertices.size(); ++i) {
    const memory::Index3 cell = archive_cell(active.vertices[i]);
    if (const std::uint32_t* id = archive_index_.find(cell)) {
      active_to_out[i] = emit_archived(*id, active.vertex_time_ns[i]);
      continue;
    }
    const auto it = fresh.emplace(cell, static_cast<std::uint32_t>(out->vertices.size()));
    if (it.second) {
      out->vertices.push_back(active.vertices[i]);
      out->vertex_time_ns.push_back(active.vertex_time_ns[i]);
    }
    active_to_out[i] = it.first->second;
  }
  for (MeshTriangle t : active.triangles) {
    for (std::uint32_t& v : t.v) v = active_to_out[v];
    if (t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2]) continue;
    out->triangles.push_back(t);
  }
}

}  // namespace qsg::reconstruction
