// Accuracy of the reconstruction against ground truth: a rendered box room with a table, exact poses and
// noise-free depth; vertex distances to the true surfaces, vertex labels and coverage of the observed surface.
#include <gtest/gtest.h>

#include <cstdint>

#include <cmath>
#include <memory>
#include <unordered_map>
#include <vector>

#include "core/reconstruction/semantic_tsdf.h"
#include "drivers/render/renderer.h"
#include "drivers/sim/exploration.h"
#include "drivers/world/world.h"

namespace qsg::reconstruction {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Room interior [0, 4] x [0, 3] x [0, 2.5]; walls 0.1 m thick outside it; a table-sized box inside.
const Eigen::Vector3d kTableCenter(2.6, 1.0, 0.4), kTableHalf(0.4, 0.3, 0.4);

world::World box_room_with_table() {
  world::World w;
  w.name = "box_room";
  const auto add = [&](Eigen::Vector3d c, Eigen::Vector3d half, semantics::Label label) {
    world::BoxShape b;
    b.center_m = c;
    b.half_extents_m = half;
    world::Material m;
    m.label = label;
    w.add_box(b, m, -1, 0);
  };
  add({2, 1.5, -0.05}, {2.2, 1.7, 0.05}, semantics::kFloor);
  add({2, 1.5, 2.55}, {2.2, 1.7, 0.05}, semantics::kCeiling);
  add({-0.05, 1.5, 1.25}, {0.05, 1.7, 1.3}, semantics::kWall);
  add({4.05, 1.5, 1.25}, {0.05, 1.7, 1.3}, semantics::kWall);
  add({2, -0.05, 1.25}, {2.2, 0.05, 1.3}, semantics::kWall);
  add({2, 3.05, 1.25}, {2.2, 0.05, 1.3}, semantics::kWall);
  add(kTableCenter, kTableHalf, semantics::kTable);
  return w;
}

// Distance to the nearest true surface and its label.
double true_distance(const Eigen::Vector3d& p, semantics::Label* label) {
  const double planes[6] = {std::fabs(p.x()), std::fabs(4 - p.x()), std::fabs(p.y()),
                            std::fabs(3 - p.y()), std::fabs(p.z()), std::fabs(2.5 - p.z())};
  int best = 0;
  for (int i = 1; i < 6; ++i)
    if (planes[i] < planes[best]) best = i;
  double d = planes[best];
  *label = best == 4 ? semantics::kFloor : (best == 5 ? semantics::kCeiling : semantics::kWall);
  const Eigen::Vector3d q = (p - kTableCenter).cwiseAbs() - kTableHalf;
  const double box = q.maxCoeff() > 0 ? q.cwiseMax(0.0).norm() : -q.maxCoeff();
  if (box < d) {
    d = box;
    *label = semantics::kTable;
  }
  return d;
}

Eigen::Isometry3d camera_pose(const Eigen::Vector3d& p, double yaw, double pitch) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix() *
               sim::body_R_optical();
  T.translation() = p;
  return T;
}

struct CellHash {
  std::size_t operator()(const Eigen::Vector3i& c) const {
    // Unsigned arithmetic: signed overflow is undefined (UBSan flags it).
    return (static_cast<std::size_t>(static_cast<std::uint32_t>(c.x())) * 73856093u) ^
           (static_cast<std::size_t>(static_cast<std::uint32_t>(c.y())) * 19349663u) ^
           (static_cast<std::size_t>(static_cast<std::uint32_t>(c.z())) * 83492791u);
  }
};

TEST(ReconstructionAccuracyTest, RenderedRoomMeshIsAccurateLabelledAndComplete) {
  const world::World w = box_room_with_table();
  render::Renderer renderer;
  std::string error;
  ASSERT_TRUE(renderer.init(render::Renderer::Config{}, w, &error)) << error;
  const messages::CameraIntrinsics camera{160, 120, 131.25, 131.25, 79.5, 59.5};

  Config config;
  Capacities caps;
  caps.max_blocks = 512;
  caps.mesh_vertices = 1 << 17;
  caps.mesh_triangles = 1 << 18;
  caps.archive_vertices = 1 << 10;
  caps.archive_triangles = 1 << 11;
  SemanticTsdf tsdf;
  ASSERT_TRUE(tsdf.init(config, caps, SemanticTsdf::plan(caps).total_bytes(), &error)) << error;

  auto frame = std::make_unique<messages::RgbdFrame>();
  frame->depth_scale_m = 0.0f;
  std::vector<Eigen::Vector3d> observed;  // true surface points seen within range
  const Eigen::Vector3d positions[2] = {{1.2, 1.6, 1.3}, {3.2, 2.2, 1.0}};
  std::uint64_t seq = 0;
  for (const Eigen::Vector3d& pos : positions)
    for (double pitch : {-0.45, 0.1, 0.6})
      for (int k = 0; k < 8; ++k) {
        const Eigen::Isometry3d T = camera_pose(pos, 2 * kPi * k / 8, pitch);
        ASSERT_TRUE(renderer.render(T, camera, seq++, *frame, &error)) << error;
        ASSERT_TRUE(tsdf.process(*frame, T));
        for (int v = 0; v < camera.height; v += 4)
          for (int u = 0; u < camera.width; u += 4) {
            const float d = frame->depth_m[static_cast<std::size_t>(v * camera.width + u)];
            if (!(d > 0.1f && d <= config.max_range_m)) continue;
            observed.push_back(T * Eigen::Vector3d((u - camera.cx) / camera.fx * d, (v - camera.cy) / camera.fy * d, d));
          }
      }
  Mesh mesh;
  tsdf.extract_active_mesh(&mesh);
  ASSERT_GT(mesh.vertices.size(), 1000u);
  ASSERT_GT(observed.size(), 1000u);

  double sum = 0.0;
  std::size_t correct = 0;
  const double voxel = config.voxel_size_m;
  std::unordered_map<Eigen::Vector3i, std::vector<Eigen::Vector3d>, CellHash> grid;
  for (const MeshVertex& v : mesh.vertices) {
    const Eigen::Vector3d p(v.x, v.y, v.z);
    semantics::Label truth;
    sum += true_distance(p, &truth);
    correct += v.label == truth ? 1 : 0;
    grid[(p / voxel).array().floor().cast<int>()].push_back(p);
  }
  const double mean = sum / static_cast<double>(mesh.vertices.size());
  const double label_rate = static_cast<double>(correct) / static_cast<double>(mesh.vertices.size());
  std::size_t covered = 0;
  for (const Eigen::Vector3d& p : observed) {
    const Eigen::Vector3i c = (p / voxel).array().floor().cast<int>();
    bool hit = false;
    for (int dx = -1; dx <= 1 && !hit; ++dx)
      for (int dy = -1; dy <= 1 && !hit; ++dy)
        for (int dz = -1; dz <= 1 && !hit; ++dz) {
          const auto it = grid.find(c + Eigen::Vector3i(dx, dy, dz));
          if (it == grid.end()) continue;
          for (const Eigen::Vector3d& q : it->second)
            if ((q - p).norm() <= voxel) {
              hit = true;
              break;
            }
        }
    covered += hit ? 1 : 0;
  }
  const double coverage = static_cast<double>(covered) / static_cast<double>(observed.size());
  std::printf("vertices %zu mean distance %.4f m, labels %.3f, coverage %.3f of %zu points\n", mesh.vertices.size(),
              mean, label_rate, coverage, observed.size());
  EXPECT_LE(mean, 0.5 * voxel);
  EXPECT_GE(label_rate, 0.95);
  EXPECT_GE(coverage, 0.95);
}

}  // namespace
}  // namespace qsg::reconstruction
