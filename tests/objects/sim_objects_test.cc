// Objects found in a rendered generated building: ground-truth poses, noise-free depth and labels, 0.1 m voxels;
// every estimated object must match a ground-truth object (same label, centroid within 0.5 m) and most observed
// ground-truth objects must be found.
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "core/objects/object_layer.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/scene_graph/scene_graph.h"
#include "drivers/render/ray_scene.h"
#include "drivers/sim/exploration.h"
#include "drivers/sim/sim_camera.h"
#include "drivers/world/building_generator.h"
#include "drivers/world/world_query.h"
#include "tests/scene_graph/test_graph.h"

namespace qsg::objects {
namespace {

constexpr double kMatchRadiusM = 0.5;

TEST(SimObjectsTest, ObjectsOfARenderedBuildingMatchGroundTruth) {
  world::BuildingConfig bc;
  bc.num_rooms = 3;
  bc.seed = 3;
  bc.room_size_max_m = 4.0;
  const world::World w = world::generate_building(bc);
  ASSERT_FALSE(w.objects.empty());
  render::RayScene scene;
  std::string error;
  ASSERT_TRUE(scene.build(w, &error)) << error;
  const world::FreeSpaceIndex free_space(w);
  sim::ExplorationConfig ec;
  const sim::ExplorationResult tour = sim::plan_exploration(w, scene, free_space, ec);
  ASSERT_TRUE(tour.ok) << tour.error;

  sim::SimCamera camera;
  sim::SimCamera::Config cc;
  cc.intrinsics = messages::CameraIntrinsics{160, 120, 131.25, 131.25, 79.5, 59.5};
  cc.rate_hz = ec.speed_m_s / 0.5;  // a keyframe every 0.5 m (and during spins, every 0.7 rad)
  ASSERT_TRUE(camera.init(cc, render::Renderer::Config{}, w, tour.trajectory, &error)) << error;

  reconstruction::Capacities rc;
  rc.max_blocks = 1024;
  rc.mesh_vertices = 1 << 18;
  rc.mesh_triangles = 1 << 19;
  rc.archive_vertices = 1 << 18;
  rc.archive_triangles = 1 << 19;
  reconstruction::SemanticTsdf tsdf;
  ASSERT_TRUE(tsdf.init(reconstruction::Config{}, rc, reconstruction::SemanticTsdf::plan(rc).total_bytes(), &error))
      << error;
  Capacities oc;
  oc.cluster_vertices = 32768;
  oc.tracked_vertices = 65536;
  oc.vertex_keys = 131072;
  oc.tracked_blocks = 1024;
  oc.objects = 256;
  ObjectLayer layer;
  ASSERT_TRUE(layer.init(Config{}, oc, ObjectLayer::plan(oc).total_bytes(), &error)) << error;
  scene_graph::Capacities gc = scene_graph::testing::small_capacities();
  gc.object_nodes = 256;
  gc.mesh_connections = 1 << 18;
  auto graph = scene_graph::testing::make_graph(gc);

  auto frame = std::make_unique<messages::RgbdFrame>();
  int frames = 0;
  for (;;) {
    const drivers::ReadStatus status = camera.read(*frame, 0);
    if (status == drivers::ReadStatus::kEndOfStream) break;
    if (status != drivers::ReadStatus::kOk) continue;
    Eigen::Isometry3d T;
    std::int64_t t_ns = 0;
    ASSERT_TRUE(camera.camera_pose(frame->sequence, &T, &t_ns));
    ASSERT_TRUE(tsdf.process(*frame, T));
    layer.update(tsdf, static_cast<std::uint64_t>(t_ns));
    ASSERT_TRUE(layer.sync(graph.get()));
    ++frames;
  }
  ASSERT_GT(frames, 20);

  // Observed ground-truth objects: enough mesh vertices of their label inside their (inflated) box.
  reconstruction::Mesh mesh;
  tsdf.extract_full_mesh(&mesh);
  std::vector<bool> observed(w.objects.size(), false);
  std::size_t num_observed = 0;
  for (std::size_t i = 0; i < w.objects.size(); ++i) {
    const world::Object& o = w.objects[i];
    const Eigen::Vector3d half = o.box.half_extents_m + Eigen::Vector3d::Constant(0.15);
    int inside = 0;
    for (const reconstruction::MeshVertex& v : mesh.vertices) {
      if (v.label != o.label) continue;
      const Eigen::Vector3d local = o.box.world_R_box.conjugate() * (Eigen::Vector3d(v.x, v.y, v.z) - o.box.center_m);
      inside += (local.cwiseAbs().array() <= half.array()).all() ? 1 : 0;
    }
    observed[i] = inside >= 20;
    num_observed += observed[i] ? 1 : 0;
  }
  ASSERT_GT(num_observed, 0u);

  std::size_t found = 0, estimated = 0, correct = 0;
  std::vector<bool> gt_found(w.objects.size(), false);
  layer.for_each_object([&](const ObjectView& est) {
    ++estimated;
    bool match = false;
    for (std::size_t i = 0; i < w.objects.size(); ++i) {
      const world::Object& o = w.objects[i];
      if (o.label == est.label && (o.box.center_m - est.position_m).norm() <= kMatchRadiusM) {
        match = true;
        gt_found[i] = true;
      }
    }
    correct += match ? 1 : 0;
    if (!match)
      std::printf("unmatched estimate: %s at (%.2f %.2f %.2f), %llu vertices\n", semantics::object_label(est.label).name,
                  est.position_m.x(), est.position_m.y(), est.position_m.z(),
                  static_cast<unsigned long long>(est.num_vertices));
  });
  for (std::size_t i = 0; i < w.objects.size(); ++i) {
    if (observed[i] && gt_found[i]) ++found;
    if (observed[i] && !gt_found[i])
      std::printf("missed: %s at (%.2f %.2f %.2f)\n", semantics::object_label(w.objects[i].label).name,
                  w.objects[i].box.center_m.x(), w.objects[i].box.center_m.y(), w.objects[i].box.center_m.z());
  }
  std::printf("%d frames; %zu ground-truth objects, %zu observed, %zu found; %zu estimated, %zu correct\n", frames,
              w.objects.size(), num_observed, found, estimated, correct);
  layer.counters().print(stdout);
  EXPECT_GE(static_cast<double>(found), 0.8 * static_cast<double>(num_observed));
  EXPECT_GE(static_cast<double>(correct), 0.8 * static_cast<double>(estimated));
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kObject), layer.num_objects());
}

}  // namespace
}  // namespace qsg::objects
