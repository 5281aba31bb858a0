// The semantic TSDF on synthetic depth: invalid depth, welding across blocks, the window and eviction, the
// label votes, no allocation per frame, PLY round trip.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <set>
#include <tuple>
#include <unistd.h>
#include <map>

#include "core/reconstruction/ply_writer.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "tests/support/allocation_counter.h"

namespace qsg::reconstruction {
namespace {

constexpr messages::CameraIntrinsics kCamera{160, 120, 131.25, 131.25, 79.5, 59.5};

// A fronto-parallel wall at depth_m filling the image (camera optical frame = world frame at identity).
std::unique_ptr<messages::RgbdFrame> wall_frame(float depth_m, semantics::Label label = semantics::kWall) {
  auto f = std::make_unique<messages::RgbdFrame>();
  f->intrinsics = kCamera;
  f->has_labels = true;
  for (int i = 0; i < f->pixels(); ++i) {
    f->depth_m[static_cast<std::size_t>(i)] = depth_m;
    f->labels[static_cast<std::size_t>(i)] = label;
    for (int k = 0; k < 3; ++k) f->rgb[static_cast<std::size_t>(3 * i + k)] = static_cast<std::uint8_t>(100 + 20 * k);
  }
  return f;
}

Capacities small_capacities() {
  Capacities c;
  c.max_blocks = 256;
  c.mesh_vertices = 1 << 16;
  c.mesh_triangles = 1 << 17;
  c.archive_vertices = 1 << 16;
  c.archive_triangles = 1 << 17;
  return c;
}

std::unique_ptr<SemanticTsdf> make_tsdf(const Config& config = Config{}, const Capacities& c = small_capacities()) {
  auto t = std::make_unique<SemanticTsdf>();
  std::string error;
  EXPECT_TRUE(t->init(config, c, SemanticTsdf::plan(c).total_bytes(), &error)) << error;
  return t;
}

Eigen::Isometry3d at(double x, double y, double z) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

TEST(SemanticTsdfTest, ConfigAndBudgetErrorsNameTheField) {
  SemanticTsdf t;
  std::string error;
  Config config;
  config.voxel_size_m = 0.01;
  EXPECT_FALSE(t.init(config, small_capacities(), 1u << 30, &error));
  EXPECT_NE(error.find("voxel_size_m"), std::string::npos) << error;
  config = Config{};
  config.window_radius_m = 3.0;
  EXPECT_FALSE(t.init(config, small_capacities(), 1u << 30, &error));
  EXPECT_NE(error.find("window_radius_m"), std::string::npos) << error;
  EXPECT_FALSE(t.init(Config{}, small_capacities(), 1000, &error)) << "a 1 kB budget cannot hold the plan";
  EXPECT_FALSE(error.empty());
}

TEST(SemanticTsdfTest, InvalidDepthIsCountedAndNotIntegrated) {
  auto tsdf = make_tsdf();
  auto frame = wall_frame(0.0f);
  const float bad[] = {0.0f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(), 9.0f,
                       -1.0f, 0.05f};
  for (int i = 0; i < frame->pixels(); ++i) frame->depth_m[static_cast<std::size_t>(i)] = bad[i % 6];
  ASSERT_TRUE(tsdf->process(*frame, Eigen::Isometry3d::Identity()));
  EXPECT_EQ(tsdf->counters().pixels_invalid, static_cast<std::uint64_t>(frame->pixels()));
  EXPECT_EQ(tsdf->counters().pixels_valid, 0u);
  EXPECT_EQ(tsdf->active_blocks(), 0u) << "nothing valid, nothing allocated";
  // Half valid: only those are counted valid; the invalid half leaves no trace at its pixels' rays.
  for (int i = 0; i < frame->pixels(); ++i)
    frame->depth_m[static_cast<std::size_t>(i)] = (i % kCamera.width) < kCamera.width / 2 ? 2.0f : bad[i % 6];
  ASSERT_TRUE(tsdf->process(*frame, Eigen::Isometry3d::Identity()));
  EXPECT_EQ(tsdf->counters().pixels_valid, static_cast<std::uint64_t>(frame->pixels() / 2));
  EXPECT_GT(tsdf->active_blocks(), 0u);
  const Voxel* left = tsdf->voxel_at({-0.5, 0.0, 2.0});   // left half of the image: valid wall
  ASSERT_NE(left, nullptr);
  EXPECT_GT(left->weight_q, 0);
  EXPECT_NEAR(tsdf->sdf_m(*left), 0.0, 0.06);
  const Voxel* right = tsdf->voxel_at({0.6, 0.0, 2.0});  // right half: invalid pixels only
  EXPECT_TRUE(right == nullptr || right->weight_q == 0);
}

TEST(SemanticTsdfTest, PlaneAcrossBlocksMeshesWithoutDuplicateVertices) {
  auto tsdf = make_tsdf();
  auto frame = wall_frame(2.03f);
  for (int k = 0; k < 3; ++k) ASSERT_TRUE(tsdf->process(*frame, Eigen::Isometry3d::Identity()));
  Mesh mesh;
  tsdf->extract_active_mesh(&mesh);
  ASSERT_GT(mesh.vertices.size(), 100u);
  std::set<std::tuple<float, float, float>> unique;
  float min_x = 1e9f, max_x = -1e9f;
  for (const MeshVertex& v : mesh.vertices) {
    unique.insert({v.x, v.y, v.z});
    EXPECT_NEAR(v.z, 2.03, 0.01);
    EXPECT_EQ(v.label, semantics::kWall);
    min_x = std::min(min_x, v.x);
    max_x = std::max(max_x, v.x);
  }
  EXPECT_EQ(unique.size(), mesh.vertices.size()) << "a vertex was duplicated at a block border";
  EXPECT_GT(max_x - min_x, 2 * 0.8) << "the plane must span at least three blocks";
  // A grid of quads: inside the patch every triangle side is shared by exactly two triangles.
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> sides;
  for (const MeshTriangle& t : mesh.triangles)
    for (int j = 0; j < 3; ++j) {
      const std::uint32_t a = t.v[j], b = t.v[(j + 1) % 3];
      ++sides[{std::min(a, b), std::max(a, b)}];
    }
  std::size_t boundary = 0;
  for (const auto& s : sides) {
    EXPECT_LE(s.second, 2);
    boundary += s.second == 1 ? 1 : 0;
  }
  // Boundary sides only along the patch's rim (about its perimeter in voxels, two sides per voxel at most).
  const double extent_voxels = (max_x - min_x) / 0.1;
  EXPECT_LT(static_cast<double>(boundary), 8.0 * extent_voxels) << "holes inside the plane";
}

TEST(SemanticTsdfTest, LabelVotesFollowTheMajorityWithTwoPairs) {
  auto tsdf = make_tsdf();
  auto wall = wall_frame(2.03f, semantics::kWall);
  auto door = wall_frame(2.03f, semantics::kDoor);
  auto chair = wall_frame(2.03f, semantics::kChair);
  for (int k = 0; k < 4; ++k) tsdf->integrate(*wall, Eigen::Isometry3d::Identity());
  tsdf->integrate(*door, Eigen::Isometry3d::Identity());
  tsdf->integrate(*chair, Eigen::Isometry3d::Identity());  // a third label: replaces or decrements the weakest
  const Voxel* v = tsdf->voxel_at({0.0, 0.0, 2.0});
  ASSERT_NE(v, nullptr);
  EXPECT_EQ(SemanticTsdf::best_label(*v), semantics::kWall);
  for (int k = 0; k < 6; ++k) tsdf->integrate(*door, Eigen::Isometry3d::Identity());
  EXPECT_EQ(SemanticTsdf::best_label(*v), semantics::kDoor) << "the new majority wins";
}

// Late labels (segmentation finished after the keyframe was integrated): the label pass over the frame's own depth
// and pose gives every voxel the votes the labelled frame would have given in one pass, allocates nothing, and
// re-meshes the blocks whose labels changed; samples whose block is not active are counted, not allocated.
TEST(SemanticTsdfTest, LateLabelVotesEqualVotesGivenWithTheGeometry) {
  auto together = make_tsdf();
  auto late = make_tsdf();
  auto chair = wall_frame(2.03f, semantics::kChair);
  auto wall = wall_frame(2.03f, semantics::kWall);
  const Eigen::Isometry3d pose = at(0.1, -0.05, 0.02);
  ASSERT_TRUE(together->process(*wall, pose));
  ASSERT_TRUE(late->process(*wall, pose));
  for (int k = 0; k < 2; ++k) ASSERT_TRUE(together->process(*chair, pose));
  chair->has_labels = false;
  for (int k = 0; k < 2; ++k) ASSERT_TRUE(late->process(*chair, pose));  // geometry only
  chair->has_labels = true;
  const std::size_t blocks = late->active_blocks();
  EXPECT_NO_ALLOCATIONS(for (int k = 0; k < 2; ++k) ASSERT_TRUE(late->integrate_label_votes(*chair, pose)));
  EXPECT_EQ(late->active_blocks(), blocks);
  EXPECT_EQ(late->counters().label_frames, 2u);
  EXPECT_EQ(late->counters().label_samples_missed, 0u);
  std::size_t compared = 0;
  together->for_each_block([&](std::uint32_t, const SemanticTsdf::BlockView& a) {
    const std::uint32_t h = late->find_block(a.index);
    ASSERT_NE(h, memory::kInvalidHandle);
    SemanticTsdf::BlockView b;
    ASSERT_TRUE(late->block_view(h, &b));
    for (int i = 0; i < kBlockVoxels; ++i) {
      const Voxel& x = a.voxels[i];
      const Voxel& y = b.voxels[i];
      ASSERT_EQ(x.weight_q, y.weight_q);
      ASSERT_EQ(x.sdf_q, y.sdf_q);
      for (int k = 0; k < kLabelPairs; ++k) {
        ASSERT_EQ(x.votes[k].label, y.votes[k].label) << "voxel " << i;
        ASSERT_EQ(x.votes[k].weight_q, y.votes[k].weight_q) << "voxel " << i;
      }
      compared += x.weight_q > 0 ? 1 : 0;
    }
  });
  EXPECT_GT(compared, 1000u);
  // The blocks whose labels changed were marked dirty: the next meshing gives the surface the new label.
  late->update_mesh();
  Mesh mesh;
  late->extract_active_mesh(&mesh);
  ASSERT_GT(mesh.vertices.size(), 100u);
  for (const MeshVertex& v : mesh.vertices) EXPECT_EQ(v.label, semantics::kChair);
  // A frame seen from where no block is active: nothing allocated, every sample counted as missed.
  EXPECT_TRUE(late->integrate_label_votes(*chair, at(40.0, 0.0, 0.0)));
  EXPECT_EQ(late->active_blocks(), blocks);
  EXPECT_GT(late->counters().label_samples_missed, 0u);
  // Without labels there is nothing to vote.
  wall->has_labels = false;
  EXPECT_FALSE(late->integrate_label_votes(*wall, pose));
}

TEST(SemanticTsdfTest, WindowArchivesFarBlocksAndPoolEvictionKeepsMemoryFixed) {
  Capacities c = small_capacities();
  c.max_blocks = 48;
  auto tsdf = make_tsdf(Config{}, c);
  const std::size_t bytes = tsdf->arena_bytes();
  auto frame = wall_frame(2.03f);
  // Walk along x in 1 m steps: the window (8 m) archives the blocks left behind; the pool (48) is smaller than
  // what one window holds, so the farthest blocks are evicted early.
  for (int k = 0; k < 30; ++k) ASSERT_TRUE(tsdf->process(*frame, at(k * 1.0, 0, 0)));
  EXPECT_LE(tsdf->active_blocks(), c.max_blocks);
  EXPECT_GT(tsdf->counters().blocks_archived, 0u);
  EXPECT_GT(tsdf->counters().blocks_evicted, 0u);
  EXPECT_EQ(tsdf->arena_bytes(), bytes);
  Mesh archive;
  tsdf->extract_archive(&archive);
  EXPECT_GT(archive.triangles.size(), 100u);
  for (const MeshVertex& v : archive.vertices) EXPECT_NEAR(v.z, 2.03, 0.05);
  // Archived x range: well behind the last camera position.
  float min_x = 1e9f;
  for (const MeshVertex& v : archive.vertices) min_x = std::min(min_x, v.x);
  EXPECT_LT(min_x, 0.0f);
  // Without eviction pressure nothing is evicted early.
  auto roomy = make_tsdf();
  for (int k = 0; k < 30; ++k) ASSERT_TRUE(roomy->process(*frame, at(k * 1.0, 0, 0)));
  EXPECT_EQ(roomy->counters().blocks_evicted, 0u);
  EXPECT_GT(roomy->counters().blocks_archived, 0u);
  for (std::uint32_t i = 0; i < 1; ++i) {
    Mesh full;
    roomy->extract_full_mesh(&full);
    EXPECT_GT(full.vertices.size(), roomy->archive_vertices());
  }
}

TEST(SemanticTsdfTest, NoHeapAllocationPerFrameAfterWarmUp) {
  auto tsdf = make_tsdf();
  auto frame = wall_frame(2.03f);
  for (int k = 0; k < 12; ++k) ASSERT_TRUE(tsdf->process(*frame, at(k * 0.5, 0, 0)));
  EXPECT_NO_ALLOCATIONS({
    for (int k = 12; k < 18; ++k) tsdf->process(*frame, at(k * 0.5, 0.05 * k, 0));
  });
  EXPECT_GT(tsdf->counters().blocks_archived, 0u) << "the measured frames must include archiving";
}

TEST(PlyWriterTest, WritesAndReadsBackAMesh) {
  auto tsdf = make_tsdf();
  auto frame = wall_frame(2.03f, semantics::kPicture);
  ASSERT_TRUE(tsdf->process(*frame, Eigen::Isometry3d::Identity()));
  Mesh mesh;
  tsdf->extract_active_mesh(&mesh);
  ASSERT_FALSE(mesh.triangles.empty());
  const std::string path = ::testing::TempDir() + "/qsg_reconstruction_test.ply";
  std::string error;
  ASSERT_TRUE(write_ply(path, mesh, &error)) << error;
  Mesh back;
  ASSERT_TRUE(read_ply(path, &back, &error)) << error;
  ASSERT_EQ(back.vertices.size(), mesh.vertices.size());
  ASSERT_EQ(back.triangles.size(), mesh.triangles.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    EXPECT_EQ(back.vertices[i].x, mesh.vertices[i].x);
    EXPECT_EQ(back.vertices[i].z, mesh.vertices[i].z);
    EXPECT_EQ(back.vertices[i].g, mesh.vertices[i].g);
    EXPECT_EQ(back.vertices[i].label, semantics::kPicture);
  }
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(back.triangles[i].v[k], mesh.triangles[i].v[k]);
  // Header as Open3D / MeshLab expect it.
  std::FILE* f = std::fopen(path.c_str(), "rb");
  ASSERT_NE(f, nullptr);
  char head[64] = {};
  ASSERT_EQ(std::fread(head, 1, 36, f), 36u);
  std::fclose(f);
  EXPECT_EQ(std::string(head, 36), "ply\nformat binary_little_endian 1.0\n");
  // Truncated file: a clear error naming the file.
  {
    std::FILE* t = std::fopen(path.c_str(), "r+b");
    ASSERT_NE(t, nullptr);
    std::fclose(t);
    std::FILE* src = std::fopen(path.c_str(), "rb");
    std::fseek(src, 0, SEEK_END);
    const long size = std::ftell(src);
    std::fclose(src);
    ASSERT_EQ(truncate(path.c_str(), size - 10), 0);
  }
  EXPECT_FALSE(read_ply(path, &back, &error));
  EXPECT_NE(error.find(path), std::string::npos);
  EXPECT_NE(error.find("truncated"), std::string::npos) << error;
  EXPECT_FALSE(read_ply(path + ".missing", &back, &error));
  std::remove(path.c_str());
}

}  // namespace
}  // namespace qsg::reconstruction
