// Accuracy of the reconstruction on real data: the five Redwood frames (PrimeSense depth, trajectory poses) fused
// at 2 cm voxels; the mesh must lie on the measured depth (issue 4: median vertex distance below 2 cm).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "core/reconstruction/semantic_tsdf.h"
#include "drivers/replay/redwood_replay.h"
#include "tests/support/test_data.h"

namespace qsg::reconstruction {
namespace {

// Back-projected depth points in a uniform grid: points sorted by cell, a sorted cell-key list to find a cell's
// range. Exact nearest-point queries by growing shells of cells (no heap per query).
class PointGrid {
 public:
  PointGrid(std::vector<Eigen::Vector3f> points, float cell_m) : cell_m_(cell_m) {
    std::vector<std::pair<std::uint64_t, Eigen::Vector3f>> keyed;
    keyed.reserve(points.size());
    for (const Eigen::Vector3f& p : points) keyed.emplace_back(key(cell_of(p)), p);
    std::sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    points_.reserve(keyed.size());
    for (std::size_t i = 0; i < keyed.size(); ++i) {
      if (i == 0 || keyed[i].first != keyed[i - 1].first) {
        keys_.push_back(keyed[i].first);
        starts_.push_back(static_cast<std::uint32_t>(i));
      }
      points_.push_back(keyed[i].second);
    }
    starts_.push_back(static_cast<std::uint32_t>(points_.size()));
  }

  // Distance to the nearest point, or max_m when none lies within max_m.
  float nearest(const Eigen::Vector3f& q, float max_m) const {
    const Eigen::Vector3i c = cell_of(q);
    float best2 = max_m * max_m;
    const int max_ring = static_cast<int>(std::ceil(max_m / cell_m_)) + 1;
    for (int r = 0; r <= max_ring; ++r) {
      // Every point outside the shells visited so far is at least (r - 1) cells away from q.
      const float reach = static_cast<float>(r - 1) * cell_m_;
      if (r > 0 && reach * reach >= best2) break;
      for (int dx = -r; dx <= r; ++dx)
        for (int dy = -r; dy <= r; ++dy)
          for (int dz = -r; dz <= r; ++dz) {
            if (std::max(std::abs(dx), std::max(std::abs(dy), std::abs(dz))) != r) continue;
            const std::uint64_t k = key(c + Eigen::Vector3i(dx, dy, dz));
            const auto it = std::lower_bound(keys_.begin(), keys_.end(), k);
            if (it == keys_.end() || *it != k) continue;
            const std::size_t slot = static_cast<std::size_t>(it - keys_.begin());
            for (std::uint32_t i = starts_[slot]; i < starts_[slot + 1]; ++i)
              best2 = std::min(best2, (points_[i] - q).squaredNorm());
          }
    }
    return std::sqrt(best2);
  }

 private:
  Eigen::Vector3i cell_of(const Eigen::Vector3f& p) const { return (p / cell_m_).array().floor().cast<int>(); }
  // 21 bits per axis (cells of a few cm: +-20 km), offset so the packing is unsigned.
  static std::uint64_t key(const Eigen::Vector3i& c) {
    const auto part = [](int v) {
      return static_cast<std::uint64_t>(static_cast<std::uint32_t>(v + (1 << 20))) & 0x1FFFFFu;
    };
    return (part(c.x()) << 42) | (part(c.y()) << 21) | part(c.z());
  }

  float cell_m_;
  std::vector<std::uint64_t> keys_;
  std::vector<std::uint32_t> starts_;
  std::vector<Eigen::Vector3f> points_;
};

TEST(RedwoodMeshTest, MeshOfFiveRealFramesLiesOnTheMeasuredDepth) {
  const std::string folder = ::qsg::testing::repo_test_data("rgbd/redwood/RGBD");
  replay::RedwoodReplay replay;
  replay::RedwoodReplay::Config replay_config;
  replay_config.camera_json = "../camera_primesense.json";
  std::string error;
  if (!replay.open(folder, replay_config, &error))
    GTEST_SKIP() << "Redwood frames in tests/data/rgbd/redwood/RGBD not readable (" << error << "); skipping";
  ASSERT_EQ(replay.size(), 5u);
  ASSERT_EQ(replay.log().size(), 5u);

  Config config;
  config.voxel_size_m = 0.02;
  // The five frames (nearly the same view of a room corner) touch ~600 blocks of 16 cm and give ~2 * 10^4
  // vertices; the pools leave a 3x margin (16 MB of voxels).
  Capacities caps;
  caps.max_blocks = 2048;
  caps.mesh_vertices = 1 << 17;
  caps.mesh_triangles = 1 << 18;
  caps.archive_vertices = 1 << 10;
  caps.archive_triangles = 1 << 11;
  SemanticTsdf tsdf;
  ASSERT_TRUE(tsdf.init(config, caps, SemanticTsdf::plan(caps).total_bytes(), &error)) << error;

  const auto start = std::chrono::steady_clock::now();
  auto frame = std::make_unique<messages::RgbdFrame>();
  std::vector<Eigen::Vector3f> depth_points;  // every 2nd pixel of every frame, in the world frame
  int frames = 0;
  while (replay.read(*frame, 0) == drivers::ReadStatus::kOk) {
    const replay::RedwoodLogEntry* entry = nullptr;
    for (const replay::RedwoodLogEntry& e : replay.log())
      if (e.id[0] == static_cast<std::int64_t>(frame->sequence)) entry = &e;
    ASSERT_NE(entry, nullptr) << "no trajectory pose for frame " << frame->sequence;
    Eigen::Isometry3d world_T_camera = Eigen::Isometry3d::Identity();
    world_T_camera.matrix() = entry->world_T_camera;
    ASSERT_TRUE(tsdf.integrate(*frame, world_T_camera)) << "frame " << frame->sequence;
    ++frames;

    const messages::CameraIntrinsics& k = frame->intrinsics;
    for (int v = 0; v < k.height; v += 2)
      for (int u = 0; u < k.width; u += 2) {
        const float d = frame->depth_m[static_cast<std::size_t>(v * k.width + u)];
        if (!(d > config.min_range_m && d <= config.max_range_m)) continue;
        const Eigen::Vector3d p_c((u - k.cx) / k.fx * d, (v - k.cy) / k.fy * d, d);
        depth_points.push_back((world_T_camera * p_c).cast<float>());
      }
  }
  ASSERT_EQ(frames, 5) << replay.last_error();
  tsdf.update_mesh();
  Mesh mesh;
  tsdf.extract_active_mesh(&mesh);
  const double fuse_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  tsdf.counters().print(stdout);
  EXPECT_EQ(tsdf.counters().blocks_refused, 0u) << "the block pool was too small for the scene";
  EXPECT_EQ(tsdf.counters().mesh_overflow, 0u) << "the active mesh pools were too small";
  ASSERT_GT(mesh.vertices.size(), 10000u) << "the mesh of five 640x480 frames at 2 cm must be substantial";
  ASSERT_GT(depth_points.size(), 100000u);

  // Exact nearest-point distances up to 10 cm (farther vertices count as 10 cm: only the tail is clipped).
  constexpr float kMaxSearchM = 0.10f;
  const PointGrid grid(std::move(depth_points), 0.02f);
  std::vector<float> distances;
  distances.reserve(mesh.vertices.size());
  double sum = 0.0;
  for (const MeshVertex& v : mesh.vertices) {
    distances.push_back(grid.nearest(Eigen::Vector3f(v.x, v.y, v.z), kMaxSearchM));
    sum += distances.back();
  }
  const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double mean = sum / static_cast<double>(distances.size());
  const auto quantile = [&](double q) {
    const std::size_t i = static_cast<std::size_t>(q * static_cast<double>(distances.size() - 1));
    std::nth_element(distances.begin(), distances.begin() + static_cast<std::ptrdiff_t>(i), distances.end());
    return static_cast<double>(distances[i]);
  };
  const double median = quantile(0.5);
  const double p90 = quantile(0.9);
  std::printf("redwood mesh: %zu vertices %zu triangles, %d frames at %.3f m voxels; vertex-to-depth distance "
              "median %.4f m mean %.4f m p90 %.4f m; fuse+mesh %.3f s, total %.3f s\n",
              mesh.vertices.size(), mesh.triangles.size(), frames, config.voxel_size_m, median, mean, p90, fuse_s,
              total_s);
  RecordProperty("vertices", static_cast<int>(mesh.vertices.size()));
  RecordProperty("median_distance_mm", static_cast<int>(std::lround(median * 1000.0)));
  RecordProperty("mean_distance_mm", static_cast<int>(std::lround(mean * 1000.0)));
  RecordProperty("p90_distance_mm", static_cast<int>(std::lround(p90 * 1000.0)));
  EXPECT_LT(median, 0.02) << "issue 4: median distance between mesh vertices and back-projected depth below 2 cm";
}

}  // namespace
}  // namespace qsg::reconstruction
