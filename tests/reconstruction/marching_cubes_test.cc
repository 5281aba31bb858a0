// The generated marching-cubes tables: every case triangulates exactly its crossed edges into a closed,
// consistently oriented surface patch.
#include <gtest/gtest.h>

#include <map>
#include <utility>

#include "core/reconstruction/marching_cubes.h"

namespace qsg::reconstruction {
namespace {

TEST(MarchingCubesTest, TrivialAndSingleCornerCases) {
  const MarchingCubesTables& t = marching_cubes_tables();
  EXPECT_EQ(t.num_triangles[0], 0);
  EXPECT_EQ(t.num_triangles[255], 0);
  for (int c = 0; c < 8; ++c) {
    EXPECT_EQ(t.num_triangles[static_cast<std::size_t>(1 << c)], 1) << "corner " << c;
    EXPECT_EQ(t.num_triangles[static_cast<std::size_t>(255 ^ (1 << c))], 1) << "all but corner " << c;
  }
  // Corner 0 inside: the triangle joins the three edges at corner 0 (one per axis, combo 0).
  const auto& tri = t.triangles[1];
  int axes = 0;
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(tri[static_cast<std::size_t>(k)] % 4, 0);
    axes |= 1 << (tri[static_cast<std::size_t>(k)] / 4);
  }
  EXPECT_EQ(axes, 7);
  // A half-space case (bottom four corners inside): a quad, two triangles.
  EXPECT_EQ(t.num_triangles[0x0F], 2);
}

TEST(MarchingCubesTest, EveryCaseUsesExactlyItsCrossedEdgesAndIsClosedAndOriented) {
  const MarchingCubesTables& t = marching_cubes_tables();
  for (int cube = 0; cube < 256; ++cube) {
    SCOPED_TRACE("case " + std::to_string(cube));
    EXPECT_EQ(t.edge_mask[static_cast<std::size_t>(cube)], t.edge_mask[static_cast<std::size_t>(255 - cube)]);
    std::uint16_t used = 0;
    std::map<std::pair<int, int>, int> directed;  // triangle edges (cube edge a -> cube edge b)
    const auto& tri = t.triangles[static_cast<std::size_t>(cube)];
    for (int k = 0; k < t.num_triangles[static_cast<std::size_t>(cube)]; ++k) {
      for (int j = 0; j < 3; ++j) {
        const int a = tri[static_cast<std::size_t>(3 * k + j)], b = tri[static_cast<std::size_t>(3 * k + (j + 1) % 3)];
        used = static_cast<std::uint16_t>(used | (1u << a));
        ++directed[{a, b}];
      }
    }
    EXPECT_EQ(used, t.edge_mask[static_cast<std::size_t>(cube)]);
    // Closed and oriented: a triangle side between two cube edges that do not share a cube face lies inside the
    // cube and must be met once in each direction; a side on a face is the patch's boundary and appears once.
    for (const auto& [e, n] : directed) {
      EXPECT_EQ(n, 1) << "side " << e.first << "-" << e.second << " used twice in one direction";
      const auto corners = [&](int edge) { return t.edge_corners[static_cast<std::size_t>(edge)]; };
      // Two edges share a face when some axis bit is equal on all four corners.
      int common = 0b111;
      const auto ca = corners(e.first), cb = corners(e.second);
      for (int ax = 0; ax < 3; ++ax) {
        const int bit = (ca[0] >> ax) & 1;
        if (((ca[1] >> ax) & 1) != bit || ((cb[0] >> ax) & 1) != bit || ((cb[1] >> ax) & 1) != bit)
          common &= ~(1 << ax);
      }
      if (common == 0) {
        EXPECT_EQ(directed.count({e.second, e.first}), 1u) << e.first << "-" << e.second;
      }
    }
  }
}

}  // namespace
}  // namespace qsg::reconstruction
