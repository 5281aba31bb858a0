// Marching-cubes case tables (256 cases), generated at first use from the algorithm's definition rather than
// typed in: for each sign pattern of a cube's eight corners the isosurface crosses every edge whose corners differ
// in sign; on each face the crossings pair into segments, the segments chain into closed loops, and each loop is
// fanned into triangles oriented so their normals point from the inside (negative) corners to the outside.
#pragma once

#include <array>
#include <cstdint>

namespace qsg::reconstruction {

// Corner c of a cube sits at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1) voxels from its minimum corner.
// Edge e runs along axis e / 4 from corner edge_corner(e, 0) (that axis' bit clear) to edge_corner(e, 1).
inline constexpr int kMaxCubeTriangles = 16;

struct MarchingCubesTables {
  std::array<std::array<std::uint8_t, 2>, 12> edge_corners{};   // corner indices of each edge (low, high)
  std::array<std::uint16_t, 256> edge_mask{};                    // bit e set when edge e is crossed
  std::array<std::uint8_t, 256> num_triangles{};
  std::array<std::array<std::int8_t, 3 * kMaxCubeTriangles>, 256> triangles{};  // edge indices, 3 per triangle
};

// The tables, built once (thread-safe static initialisation, no heap). A corner is "inside" (bit c of the case
// index set) when its signed distance is negative.
const MarchingCubesTables& marching_cubes_tables();

}  // namespace qsg::reconstruction
