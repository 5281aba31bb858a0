// Private to core/reconstruction: the block, chunk and scratch types behind SemanticTsdf and the constants its .cc
// files share (integration in tsdf_integration.cc; the window, meshing and archive in semantic_tsdf.cc). Included by
// core/reconstruction/*.cc only.
#pragma once

#include "core/reconstruction/semantic_tsdf.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <thread>
#include <unordered_map>

namespace qsg::reconstruction {

constexpr int kChunkSize = 64;
constexpr int kCorners = kBlockSide + 1;                   // the block plus the neighbours' first layer
constexpr int kEdgeCodes = kCorners * kCorners * kCorners * 3;
constexpr int kMaxChunksPerBlock = (kEdgeCodes + kChunkSize - 1) / kChunkSize;
constexpr float kSdfQuant = 32767.0f;
// Archived triangles per chunk: a surface block holds ~50-150 triangles at 0.1 m, so 32 wastes little on
// blocks that only graze a surface.
constexpr int kArchiveChunk = 32;

inline int edge_code(int x, int y, int z, int axis) { return ((x * kCorners + y) * kCorners + z) * 3 + axis; }

// Global key of a voxel edge: lower voxel (20 bits per axis, offset to unsigned) and axis.
inline std::uint64_t edge_key(const memory::Index3& block, int code) {
  const int axis = code % 3;
  int rest = code / 3;
  const int z = rest % kCorners;
  rest /= kCorners;
  const int y = rest % kCorners;
  const int x = rest / kCorners;
  const auto pack = [](std::int32_t v) { return static_cast<std::uint64_t>((v + (1 << 19)) & 0xFFFFF); };
  return (pack(block.x * kBlockSide + x) << 42) | (pack(block.y * kBlockSide + y) << 22) |
         (pack(block.z * kBlockSide + z) << 2) | static_cast<std::uint64_t>(axis);
}

inline bool valid_depth(float d, float min_m, float max_m) { return std::isfinite(d) && d >= min_m && d <= max_m; }

struct SemanticTsdf::Block {
  memory::Index3 index;
  std::uint32_t frame_stamp = 0;
  std::uint32_t mesh_stamp = 0;
  std::uint32_t label_stamp = 0;  // the last label_votes() pass that touched the block
  std::uint32_t vertex_head = memory::kInvalidHandle;
  std::uint32_t triangle_head = memory::kInvalidHandle;
  std::uint16_t num_vertices = 0;
  std::uint16_t num_triangles = 0;
  bool dirty = false;
  std::uint32_t time_frames = 0;  // frames integrated into the block since it was allocated ...
  double time_sum_s = 0.0;        // ... and the sum of their data times (s): the block's time is their mean
  std::uint64_t mean_time_ns() const {
    return time_frames == 0 ? 0 : static_cast<std::uint64_t>(std::max(0.0, time_sum_s / time_frames) * 1e9);
  }
  Voxel voxels[kBlockVoxels];
};

struct SemanticTsdf::VertexChunk {
  MeshVertex vertices[kChunkSize];
  std::uint16_t codes[kChunkSize];
  std::uint32_t next = memory::kInvalidHandle;
};

struct SemanticTsdf::TriangleChunk {
  std::uint16_t indices[kChunkSize][3];
  std::uint32_t next = memory::kInvalidHandle;
};

struct SemanticTsdf::ArchiveChunk {
  MeshTriangle triangles[kArchiveChunk];
  std::uint32_t next = memory::kInvalidHandle;
  std::uint32_t count = 0;
};

// Integration threads: long-lived, started by init(); a job hands out block indices through one atomic counter,
// the caller works too, and run() returns when every index is done. Nothing allocates per job.
class SemanticTsdf::Workers {
 public:
  using Job = void (*)(void* context, std::uint32_t index);
  explicit Workers(int extra_threads) {
    threads_.reserve(static_cast<std::size_t>(extra_threads));
    for (int i = 0; i < extra_threads; ++i) threads_.emplace_back([this] { loop(); });
  }
  ~Workers() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    start_.notify_all();
    for (std::thread& t : threads_) t.join();
  }
  void run(Job job, void* context, std::uint32_t count) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_ = job;
      context_ = context;
      count_ = count;
      next_.store(0, std::memory_order_relaxed);
      busy_ = static_cast<int>(threads_.size());
      ++generation_;
    }
    start_.notify_all();
    work();
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return busy_ == 0; });
  }

 private:
  void work() {
    for (std::uint32_t i = next_.fetch_add(1, std::memory_order_relaxed); i < count_;
         i = next_.fetch_add(1, std::memory_order_relaxed))
      job_(context_, i);
  }
  void loop() {
    std::uint64_t seen = 0;
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(mutex_);
        start_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
      }
      work();
      std::lock_guard<std::mutex> lock(mutex_);
      if (--busy_ == 0) done_.notify_one();
    }
  }
  std::vector<std::thread> threads_;
  std::mutex mutex_;
  std::condition_variable start_, done_;
  Job job_ = nullptr;
  void* context_ = nullptr;
  std::uint32_t count_ = 0;
  std::atomic<std::uint32_t> next_{0};
  int busy_ = 0;
  std::uint64_t generation_ = 0;
  bool stop_ = false;
};

struct SemanticTsdf::Scratch {
  struct Corner {
    float d;
    std::uint8_t rgb[3];
    std::uint8_t observed;
    semantics::Label label;
  };
  Corner corners[kCorners * kCorners * kCorners];
  std::int16_t code_to_vertex[kEdgeCodes];
  const VertexChunk* chain[kMaxChunksPerBlock + 1];
};

}  // namespace qsg::reconstruction
