// Peer comparison for Layer 1: the same frozen rendered frames integrated into our semantic TSDF (integrate +
// mesh update per frame) and into Open3D's ScalableTSDFVolume (integrate + ExtractTriangleMesh per frame) at
// equal voxel size, truncation and depth range, reported in one run with the ratio. Optional: built only when
// Open3D is installed (benchmarks only; nothing else depends on it). Run with OMP_NUM_THREADS=1 for one core.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "bench/frozen_frames.h"
#include "core/reconstruction/ply_writer.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "open3d/io/TriangleMeshIO.h"
#include "open3d/camera/PinholeCameraIntrinsic.h"
#include "open3d/geometry/Image.h"
#include "open3d/geometry/RGBDImage.h"
#include "open3d/geometry/TriangleMesh.h"
#include "open3d/pipelines/integration/ScalableTSDFVolume.h"

namespace {

using namespace qsg;

constexpr int kWidth = 640;
constexpr int kHeight = 480;
constexpr double kVoxelM = 0.1;
constexpr double kTruncationVoxels = 3.0;
constexpr double kMaxRangeM = 4.5;

struct Frames {
  std::unique_ptr<bench::FrozenFrames> ours;
  std::vector<std::shared_ptr<open3d::geometry::RGBDImage>> open3d_images;  // the same frames, converted once
};

// The frozen frames of bm_reconstruction at 640x480, plus their conversion to Open3D images (untimed).
const Frames& frames() {
  static std::unique_ptr<Frames> cache;
  if (cache) return *cache;
  cache = std::make_unique<Frames>();
  cache->ours = bench::render_frozen_frames(kWidth, kHeight);
  for (const auto& frame : cache->ours->frames) {
    open3d::geometry::Image depth;
    depth.Prepare(kWidth, kHeight, 1, 4);
    open3d::geometry::Image color;
    color.Prepare(kWidth, kHeight, 3, 1);
    for (int v = 0; v < kHeight; ++v) {
      for (int u = 0; u < kWidth; ++u) {
        const int i = v * kWidth + u;
        const float d = frame->depth_m[static_cast<std::size_t>(i)];
        *depth.PointerAt<float>(u, v) = std::isfinite(d) ? d : 0.0f;  // Open3D skips 0; NaN would not be skipped
        for (int c = 0; c < 3; ++c) {
          *color.PointerAt<std::uint8_t>(u, v, c) = frame->rgb[static_cast<std::size_t>(3 * i + c)];
        }
      }
    }
    // Depth already in metres (scale 1); beyond 4.5 m is dropped like our max_range_m; colour kept as RGB8.
    cache->open3d_images.push_back(
        open3d::geometry::RGBDImage::CreateFromColorAndDepth(color, depth, 1.0, kMaxRangeM, false));
  }
  return *cache;
}

// Our TSDF at the settings Open3D gets (voxel, truncation, range), carved from the board's capacities.
bool init_ours(reconstruction::SemanticTsdf* tsdf, std::string* error) {
  reconstruction::Config config;
  config.voxel_size_m = kVoxelM;
  config.truncation_voxels = kTruncationVoxels;
  config.max_range_m = kMaxRangeM;
  const reconstruction::Capacities caps = reconstruction::capacities_from_budget();
  return tsdf->init(config, caps, reconstruction::SemanticTsdf::plan(caps).total_bytes(), error);
}

void BM_Ours_IntegrateAndMesh(benchmark::State& state) {
  const Frames& all = frames();
  const bench::FrozenFrames& data = *all.ours;
  if (data.frames.empty()) {
    state.SkipWithError("no frames rendered");
    return;
  }
  reconstruction::SemanticTsdf tsdf;
  std::string error;
  if (!init_ours(&tsdf, &error)) {
    state.SkipWithError(error.c_str());
    return;
  }
  std::size_t k = 0;
  for (auto _ : state) {
    tsdf.integrate(*data.frames[k], data.poses[k]);
    tsdf.update_mesh();
    k = (k + 1) % data.frames.size();
  }
  state.counters["frames"] = static_cast<double>(data.frames.size());
  state.counters["active_blocks"] = static_cast<double>(tsdf.active_blocks());
}

void BM_Open3d_IntegrateAndExtract(benchmark::State& state) {
  const Frames& all = frames();
  const bench::FrozenFrames& data = *all.ours;
  if (all.open3d_images.empty()) {
    state.SkipWithError("no frames rendered");
    return;
  }
  open3d::pipelines::integration::ScalableTSDFVolume volume(
      kVoxelM, kVoxelM * kTruncationVoxels, open3d::pipelines::integration::TSDFVolumeColorType::RGB8);
  const messages::CameraIntrinsics& in = data.intrinsics;
  const open3d::camera::PinholeCameraIntrinsic intrinsic(in.width, in.height, in.fx, in.fy, in.cx, in.cy);
  std::size_t k = 0;
  std::size_t triangles = 0;
  for (auto _ : state) {
    // Open3D's extrinsic is world -> camera.
    volume.Integrate(*all.open3d_images[k], intrinsic, data.poses[k].inverse().matrix());
    const std::shared_ptr<open3d::geometry::TriangleMesh> mesh = volume.ExtractTriangleMesh();
    triangles = mesh->triangles_.size();
    benchmark::DoNotOptimize(triangles);
    k = (k + 1) % all.open3d_images.size();
  }
  state.counters["frames"] = static_cast<double>(all.open3d_images.size());
  state.counters["triangles"] = static_cast<double>(triangles);
  state.counters["volume_units"] = static_cast<double>(volume.volume_units_.size());
}

// Times one pass over the frozen frames with each system, back to back, and reports Open3D / ours.
void BM_Ratio_Open3dOverOurs(benchmark::State& state) {
  const Frames& all = frames();
  const bench::FrozenFrames& data = *all.ours;
  if (data.frames.empty()) {
    state.SkipWithError("no frames rendered");
    return;
  }
  const messages::CameraIntrinsics& in = data.intrinsics;
  const open3d::camera::PinholeCameraIntrinsic intrinsic(in.width, in.height, in.fx, in.fy, in.cx, in.cy);
  double ours_s = 0.0;
  double open3d_s = 0.0;
  std::size_t passes = 0;
  for (auto _ : state) {
    state.PauseTiming();
    auto tsdf = std::make_unique<reconstruction::SemanticTsdf>();
    std::string error;
    if (!init_ours(tsdf.get(), &error)) {
      state.SkipWithError(error.c_str());
      return;
    }
    open3d::pipelines::integration::ScalableTSDFVolume volume(
        kVoxelM, kVoxelM * kTruncationVoxels, open3d::pipelines::integration::TSDFVolumeColorType::RGB8);
    state.ResumeTiming();
    auto t0 = std::chrono::steady_clock::now();
    for (std::size_t k = 0; k < data.frames.size(); ++k) {
      tsdf->integrate(*data.frames[k], data.poses[k]);
      tsdf->update_mesh();
    }
    auto t1 = std::chrono::steady_clock::now();
    for (std::size_t k = 0; k < all.open3d_images.size(); ++k) {
      volume.Integrate(*all.open3d_images[k], intrinsic, data.poses[k].inverse().matrix());
      const std::shared_ptr<open3d::geometry::TriangleMesh> mesh = volume.ExtractTriangleMesh();
      benchmark::DoNotOptimize(mesh->triangles_.size());
    }
    auto t2 = std::chrono::steady_clock::now();
    ours_s += std::chrono::duration<double>(t1 - t0).count();
    open3d_s += std::chrono::duration<double>(t2 - t1).count();
    ++passes;
    state.PauseTiming();
    tsdf.reset();  // the arena is released outside the timed region
    state.ResumeTiming();
  }
  const double n = static_cast<double>(passes * data.frames.size());
  const double ours_ms = 1e3 * ours_s / n;
  const double open3d_ms = 1e3 * open3d_s / n;
  state.counters["ours_ms_per_frame"] = ours_ms;
  state.counters["open3d_ms_per_frame"] = open3d_ms;
  state.counters["ratio_open3d_over_ours"] = ours_ms > 0.0 ? open3d_ms / ours_ms : 0.0;
}

// Interoperability, not speed: Open3D reads our binary PLY back with the same vertices, triangles and colours.
void BM_Open3dReadsOurPly(benchmark::State& state) {
  const bench::FrozenFrames& data = *frames().ours;
  reconstruction::SemanticTsdf tsdf;
  std::string error;
  if (data.frames.empty() || !init_ours(&tsdf, &error)) {
    state.SkipWithError("no frames or no TSDF");
    return;
  }
  for (std::size_t k = 0; k < data.frames.size(); ++k) tsdf.process(*data.frames[k], data.poses[k]);
  reconstruction::Mesh mesh;
  tsdf.extract_full_mesh(&mesh);
  const std::string path = "/tmp/qsg_open3d_interop.ply";
  if (!reconstruction::write_ply(path, mesh, &error)) {
    state.SkipWithError(error.c_str());
    return;
  }
  open3d::geometry::TriangleMesh read;
  for (auto _ : state) benchmark::DoNotOptimize(open3d::io::ReadTriangleMesh(path, read));
  bool colours_match = read.vertex_colors_.size() == mesh.vertices.size();
  for (std::size_t i = 0; colours_match && i < mesh.vertices.size(); i += 97)
    colours_match = std::abs(read.vertex_colors_[i].x() * 255.0 - mesh.vertices[i].r) < 0.51 &&
                    std::abs(read.vertices_[i].x() - mesh.vertices[i].x) < 1e-6;
  if (read.vertices_.size() != mesh.vertices.size() || read.triangles_.size() != mesh.triangles.size() || !colours_match)
    state.SkipWithError("Open3D read something else than we wrote");
  state.counters["vertices"] = static_cast<double>(read.vertices_.size());
  state.counters["triangles"] = static_cast<double>(read.triangles_.size());
}

BENCHMARK(BM_Open3dReadsOurPly)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_Ours_IntegrateAndMesh)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Open3d_IntegrateAndExtract)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Ratio_Open3dOverOurs)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
