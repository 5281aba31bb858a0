// The mesh archive: revisits replace what it holds (and keep what they did not see again), the archived and the
// active mesh join without a seam, a full archive coarsens instead of dropping surface, and integration on two
// threads gives the same bits as on one.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <tuple>
#include <utility>

#include "core/reconstruction/mesh_cleanup.h"
#include "core/reconstruction/ply_writer.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "tests/support/allocation_counter.h"

namespace qsg::reconstruction {
namespace {

constexpr messages::CameraIntrinsics kCamera{160, 120, 131.25, 131.25, 79.5, 59.5};

// A fronto-parallel wall at depth_m; only image columns in [first_col, last_col) see it (others invalid).
std::unique_ptr<messages::RgbdFrame> wall_frame(float depth_m, int first_col = 0, int last_col = kCamera.width) {
  auto f = std::make_unique<messages::RgbdFrame>();
  f->intrinsics = kCamera;
  f->has_labels = true;
  for (int i = 0; i < f->pixels(); ++i) {
    const int col = i % kCamera.width;
    f->depth_m[static_cast<std::size_t>(i)] = col >= first_col && col < last_col ? depth_m : 0.0f;
    f->labels[static_cast<std::size_t>(i)] = semantics::kWall;
    for (int k = 0; k < 3; ++k) f->rgb[static_cast<std::size_t>(3 * i + k)] = static_cast<std::uint8_t>(90 + 30 * k);
  }
  return f;
}

Capacities capacities(std::size_t archive_vertices = 1 << 16, std::size_t archive_triangles = 1 << 17) {
  Capacities c;
  c.max_blocks = 320;
  c.mesh_vertices = 1 << 16;
  c.mesh_triangles = 1 << 17;
  c.archive_vertices = archive_vertices;
  c.archive_triangles = archive_triangles;
  return c;
}

std::unique_ptr<SemanticTsdf> make_tsdf(const Config& config, const Capacities& c = capacities()) {
  auto t = std::make_unique<SemanticTsdf>();
  std::string error;
  EXPECT_TRUE(t->init(config, c, SemanticTsdf::plan(c).total_bytes(), &error)) << error;
  return t;
}

Eigen::Isometry3d at(double x) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, 0.0, 0.0);
  return T;
}

// Edges used by exactly one triangle: the border of an open surface, plus every crack.
std::size_t boundary_edges(const Mesh& mesh) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
  for (const MeshTriangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = t.v[k], b = t.v[(k + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  std::size_t n = 0;
  for (const auto& e : uses) n += e.second == 1 ? 1 : 0;
  return n;
}

std::size_t triangles_with_x_in(const Mesh& mesh, double lo, double hi) {
  std::size_t n = 0;
  for (const MeshTriangle& t : mesh.triangles) {
    const double x = (mesh.vertices[t.v[0]].x + mesh.vertices[t.v[1]].x + mesh.vertices[t.v[2]].x) / 3.0;
    n += x >= lo && x < hi ? 1 : 0;
  }
  return n;
}

TEST(MeshArchiveTest, RevisitsReplaceWhatTheArchiveHolds) {
  auto tsdf = make_tsdf(Config{});
  auto frame = wall_frame(2.03f);
  // Lap 1 along a 24 m wall, then away until all of it is archived; then two more laps and away again: every
  // block leaves the window three times.
  auto blind = wall_frame(2.03f, 0, 0);  // sees nothing: moving away only archives
  const auto leave = [&] {
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(tsdf->process(*blind, at(24.0 + 10.0 * (k + 1))));
  };
  for (int k = 0; k <= 48; ++k) ASSERT_TRUE(tsdf->process(*frame, at(0.5 * k)));
  leave();
  ASSERT_EQ(tsdf->active_blocks(), 0u);
  const std::size_t after_one_lap = tsdf->archive_triangles();
  for (int k = 48; k >= 0; --k) ASSERT_TRUE(tsdf->process(*frame, at(0.5 * k)));
  for (int k = 0; k <= 48; ++k) ASSERT_TRUE(tsdf->process(*frame, at(0.5 * k)));
  leave();
  const std::size_t after_three_laps = tsdf->archive_triangles();
  EXPECT_GT(tsdf->counters().archive_replaced, 1000u);
  // The same wall: the archive holds it once, not once per lap.
  EXPECT_LE(after_three_laps, after_one_lap + after_one_lap / 20);
  EXPECT_GE(after_three_laps, after_one_lap - after_one_lap / 20);
  Mesh archive;
  tsdf->extract_archive(&archive);
  // No triangle lies on top of another (a doubled surface would share the centroid).
  std::map<std::tuple<long, long, long>, int> centroids;
  for (const MeshTriangle& t : archive.triangles) {
    long c[3];
    for (int k = 0; k < 3; ++k) {
      double sum = 0.0;
      for (std::uint32_t v : t.v) sum += (&archive.vertices[v].x)[k];
      c[k] = std::lround(sum / 3.0 * 1000.0);
    }
    EXPECT_EQ(++centroids[std::make_tuple(c[0], c[1], c[2])], 1) << "doubled triangle at " << c[0] << " " << c[1] << " " << c[2];
  }
}

TEST(MeshArchiveTest, PartialRevisitKeepsWhatItDidNotSeeAgain) {
  auto tsdf = make_tsdf(Config{});
  // Lap 1 sees the whole image width; the revisit sees only its left half (x < 0 in the camera frame).
  auto full = wall_frame(2.03f);
  auto left = wall_frame(2.03f, 0, kCamera.width / 2);
  ASSERT_TRUE(tsdf->process(*full, at(0.0)));
  for (int k = 1; k <= 12; ++k) ASSERT_TRUE(tsdf->process(*full, at(2.0 * k)));  // archive it
  Mesh first;
  tsdf->extract_archive(&first);
  const std::size_t right_first = triangles_with_x_in(first, 0.3, 2.0);
  const std::size_t left_first = triangles_with_x_in(first, -2.0, -0.3);
  ASSERT_GT(right_first, 50u);
  ASSERT_GT(left_first, 50u);
  for (int k = 12; k >= 1; --k) ASSERT_TRUE(tsdf->process(*full, at(2.0 * k + 30.0)));  // far away: nothing seen
  ASSERT_TRUE(tsdf->process(*left, at(0.0)));
  for (int k = 1; k <= 12; ++k) ASSERT_TRUE(tsdf->process(*full, at(-2.0 * k - 30.0)));  // archive the revisit
  Mesh second;
  tsdf->extract_archive(&second);
  EXPECT_GT(tsdf->counters().archive_replaced, 0u) << "the left half was re-observed";
  EXPECT_EQ(triangles_with_x_in(second, 0.3, 2.0), right_first) << "the unseen right half must stay as it was";
  EXPECT_NEAR(static_cast<double>(triangles_with_x_in(second, -2.0, -0.3)), static_cast<double>(left_first),
              0.05 * left_first)
      << "the left half is replaced, not doubled";
}

TEST(MeshArchiveTest, ArchivedAndActiveMeshesJoinWithoutASeam) {
  // Same frames twice: once with a window that archives the start of the wall, once with nothing archived.
  Config archiving;
  archiving.archive_resolution_m = 0.001;  // merge only coincident vertices: the test isolates the seam
  Config keeping = archiving;
  keeping.window_radius_m = 200.0;
  auto a = make_tsdf(archiving);
  auto b = make_tsdf(keeping);
  auto frame = wall_frame(2.03f);
  for (int k = 0; k <= 24; ++k) {
    ASSERT_TRUE(a->process(*frame, at(0.5 * k)));
    ASSERT_TRUE(b->process(*frame, at(0.5 * k)));
  }
  ASSERT_GT(a->counters().blocks_archived, 10u);
  ASSERT_GT(a->active_blocks(), 10u);
  ASSERT_EQ(b->counters().blocks_archived, 0u);
  Mesh joined, reference;
  a->extract_full_mesh(&joined);
  b->extract_active_mesh(&reference);
  EXPECT_EQ(joined.triangles.size(), reference.triangles.size());
  EXPECT_EQ(joined.vertices.size(), reference.vertices.size()) << "border vertices must be shared, not doubled";
  EXPECT_EQ(boundary_edges(joined), boundary_edges(reference)) << "a crack between archive and window";
}

// Every vertex carries the time its visit saw it (the mean data time of its block's frames), through the archive,
// the active window and the clean-up: the deformation moves a revisit's surface with that visit's nodes.
TEST(MeshArchiveTest, VerticesCarryTheTimeTheirVisitSawThem) {
  auto tsdf = make_tsdf(Config{});
  auto first = wall_frame(2.03f), second = wall_frame(3.03f), blind = wall_frame(2.03f, 0, 0);
  const auto at_time = [](messages::RgbdFrame& f, double s) { f.sample_time_ns = static_cast<std::int64_t>(s * 1e9); };
  // Visit 1 (1 .. 49 s): the wall at 2 m. Away. Visit 2 (100 .. 124 s) along half of it, seeing it 1 m farther
  // (the odometry drifted): a second surface, the first one out of its truncation band, so both stay archived.
  for (int k = 0; k <= 48; ++k) {
    at_time(*first, 1.0 + k);
    ASSERT_TRUE(tsdf->process(*first, at(0.5 * k)));
  }
  for (int k = 0; k < 3; ++k) {
    at_time(*blind, 50.0 + k);
    ASSERT_TRUE(tsdf->process(*blind, at(40.0 + 10.0 * k)));
  }
  for (int k = 0; k <= 24; ++k) {
    at_time(*second, 100.0 + k);
    ASSERT_TRUE(tsdf->process(*second, at(0.5 * k)));
  }
  // At the end of visit 2: the full mesh holds archived vertices of visit 1 and active ones of visit 2.
  const auto check = [](const Mesh& m, bool want_first, bool want_second) {
    ASSERT_TRUE(m.has_vertex_times());
    std::size_t near = 0, far = 0;
    for (std::size_t i = 0; i < m.vertices.size(); ++i) {
      const double z = m.vertices[i].z, t = static_cast<double>(m.vertex_time_ns[i]) * 1e-9;
      if (std::abs(z - 2.03) < 0.15) {
        ++near;
        EXPECT_GE(t, 0.5) << "vertex " << i;
        EXPECT_LE(t, 49.5) << "vertex " << i;
      } else if (std::abs(z - 3.03) < 0.15) {
        ++far;
        EXPECT_GE(t, 99.5) << "vertex " << i;
        EXPECT_LE(t, 124.5) << "vertex " << i;
      }
    }
    if (want_first) {
      EXPECT_GT(near, 100u);
    }
    if (want_second) {
      EXPECT_GT(far, 100u);
    }
  };
  Mesh full;
  tsdf->extract_full_mesh(&full);
  ASSERT_GT(tsdf->active_blocks(), 0u);
  check(full, true, true);
  Mesh active;
  tsdf->extract_active_mesh(&active);
  check(active, false, true);  // visit 1's wall is archived
  for (int k = 0; k < 3; ++k) {
    at_time(*blind, 130.0 + k);
    ASSERT_TRUE(tsdf->process(*blind, at(-40.0 - 10.0 * k)));
  }
  ASSERT_EQ(tsdf->active_blocks(), 0u);
  Mesh archive;
  tsdf->extract_archive(&archive);
  check(archive, true, true);
  // The clean-up keeps the times with their vertices; a mesh read from a file has none.
  clean_mesh(&archive);
  check(archive, true, true);
  const std::string path = ::testing::TempDir() + "/vertex_times.ply";
  std::string error;
  ASSERT_TRUE(write_ply(path, archive, &error)) << error;
  Mesh read;
  ASSERT_TRUE(read_ply(path, &read, &error)) << error;
  EXPECT_FALSE(read.has_vertex_times());
}

TEST(MeshArchiveTest, FullArchiveCoarsensInsteadOfDroppingSurface) {
  Config config;
  config.archive_resolution_m = 0.02;
  config.archive_max_resolution_m = 0.32;
  auto tsdf = make_tsdf(config, capacities(/*archive_vertices=*/3000, /*archive_triangles=*/6400));
  auto frame = wall_frame(2.03f);
  for (int k = 0; k <= 100; ++k) ASSERT_TRUE(tsdf->process(*frame, at(0.5 * k)));
  EXPECT_GT(tsdf->counters().archive_coarsenings, 0u);
  EXPECT_GT(tsdf->archive_resolution_m(), config.archive_resolution_m);
  EXPECT_LE(tsdf->archive_resolution_m(), config.archive_max_resolution_m + 1e-9);
  EXPECT_LE(tsdf->archive_vertices(), 3000u);
  EXPECT_LE(tsdf->archive_triangles(), 6400u);
  Mesh archive;
  tsdf->extract_archive(&archive);
  // The whole archived stretch of wall is still there, metre by metre, only coarser.
  const double archived_to = 0.5 * 100 - config.window_radius_m - 1.0;
  for (double x = -1.0; x < archived_to; x += 1.0)
    EXPECT_GT(triangles_with_x_in(archive, x, x + 1.0), 0u) << "hole in the archive at x = " << x;
  for (const MeshVertex& v : archive.vertices) EXPECT_NEAR(v.z, 2.03, 0.35);
}

TEST(MeshArchiveTest, TwoIntegrationThreadsGiveTheSameBitsWithoutAllocating) {
  Config one;
  Config two;
  two.integration_threads = 2;
  auto a = make_tsdf(one);
  auto b = make_tsdf(two);
  auto frame = wall_frame(2.03f);
  for (int i = 0; i < frame->pixels(); ++i)  // a slanted wall, so blocks see different depths
    frame->depth_m[static_cast<std::size_t>(i)] = 1.5f + 0.01f * static_cast<float>(i % kCamera.width);
  for (int k = 0; k < 6; ++k) {
    ASSERT_TRUE(a->process(*frame, at(0.3 * k)));
    ASSERT_TRUE(b->process(*frame, at(0.3 * k)));
  }
  EXPECT_NO_ALLOCATIONS({
    for (int k = 6; k < 10; ++k) b->process(*frame, at(0.3 * k));
  });
  for (int k = 6; k < 10; ++k) a->process(*frame, at(0.3 * k));
  ASSERT_EQ(a->active_blocks(), b->active_blocks());
  std::size_t compared = 0;
  a->for_each_block([&](std::uint32_t, const SemanticTsdf::BlockView& va) {
    const std::uint32_t hb = b->find_block(va.index);
    SemanticTsdf::BlockView vb;
    ASSERT_TRUE(b->block_view(hb, &vb));
    EXPECT_EQ(std::memcmp(va.voxels, vb.voxels, sizeof(Voxel) * kBlockVoxels), 0);
    ++compared;
  });
  EXPECT_GT(compared, 20u);
}

TEST(MeshArchiveTest, BlockViewsExposeVoxelsAndWeldKeys) {
  auto tsdf = make_tsdf(Config{});
  auto frame = wall_frame(2.03f);
  ASSERT_TRUE(tsdf->process(*frame, at(0.0)));
  std::map<std::uint64_t, int> keys;
  std::size_t vertices = 0;
  tsdf->for_each_block([&](std::uint32_t h, const SemanticTsdf::BlockView& view) {
    EXPECT_EQ(view.integrated_stamp, tsdf->frame_stamp());
    SemanticTsdf::VertexCursor cursor;
    MeshVertex v;
    std::uint64_t key = 0;
    std::uint32_t n = 0;
    while (tsdf->next_block_vertex(h, &cursor, &v, &key)) {
      ++keys[key];
      ++n;
      EXPECT_NEAR(v.z, 2.03, 0.05);
    }
    EXPECT_EQ(n, view.num_vertices);
    vertices += n;
  });
  Mesh mesh;
  tsdf->extract_active_mesh(&mesh);
  EXPECT_EQ(keys.size(), mesh.vertices.size()) << "one key per welded vertex";
  EXPECT_GT(vertices, keys.size()) << "border vertices appear in both blocks";
  EXPECT_EQ(tsdf->find_block(memory::Index3{1000, 1000, 1000}), memory::kInvalidHandle);
}

}  // namespace
}  // namespace qsg::reconstruction
