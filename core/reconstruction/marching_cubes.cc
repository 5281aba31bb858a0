// Generation of the marching-cubes tables from the definition of the algorithm (see marching_cubes.h).
#include "core/reconstruction/marching_cubes.h"

#include <cstdlib>

namespace qsg::reconstruction {
namespace {

struct Vec {
  double x, y, z;
};
Vec corner_position(int c) { return {double(c & 1), double((c >> 1) & 1), double((c >> 2) & 1)}; }

// Edge index of the edge joining corners a and b (which differ in exactly one bit).
int edge_between(int a, int b) {
  const int diff = a ^ b;
  const int axis = diff == 1 ? 0 : (diff == 2 ? 1 : 2);
  const int low = a & b;
  // The two other axes' bits of the low corner, in increasing axis order, index the 4 edges of an axis.
  int combo = 0, bit = 0;
  for (int ax = 0; ax < 3; ++ax) {
    if (ax == axis) continue;
    combo |= ((low >> ax) & 1) << bit;
    ++bit;
  }
  return axis * 4 + combo;
}

MarchingCubesTables build() {
  MarchingCubesTables t;
  for (int e = 0; e < 12; ++e) {
    const int axis = e / 4, combo = e % 4;
    int low = 0, bit = 0;
    for (int ax = 0; ax < 3; ++ax) {
      if (ax == axis) continue;
      low |= ((combo >> bit) & 1) << ax;
      ++bit;
    }
    t.edge_corners[static_cast<std::size_t>(e)] = {static_cast<std::uint8_t>(low),
                                                   static_cast<std::uint8_t>(low | (1 << axis))};
  }
  for (int cube = 0; cube < 256; ++cube) {
    const auto inside = [cube](int c) { return ((cube >> c) & 1) != 0; };
    std::uint16_t mask = 0;
    for (int e = 0; e < 12; ++e) {
      const auto& ec = t.edge_corners[static_cast<std::size_t>(e)];
      if (inside(ec[0]) != inside(ec[1])) mask = static_cast<std::uint16_t>(mask | (1u << e));
    }
    t.edge_mask[static_cast<std::size_t>(cube)] = mask;
    // Segments on the six faces. Each crossed edge lies on two faces and takes part in exactly one segment per
    // face, so the segments form disjoint loops. On an ambiguous face (diagonal corners alike) the inside
    // corners are cut off separately: the rule reads only the face's own four corners, so the two cubes sharing
    // the face make the same choice and the surface stays closed across cubes.
    int link[12][2];
    int degree[12] = {};
    for (int axis = 0; axis < 3; ++axis) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      for (int side = 0; side < 2; ++side) {
        const int base = side << axis;
        const int ring[4] = {base, base | (1 << u), base | (1 << u) | (1 << v), base | (1 << v)};
        int crossed[4], n = 0;
        for (int k = 0; k < 4; ++k)
          if (inside(ring[k]) != inside(ring[(k + 1) % 4])) crossed[n++] = k;  // face edge k: ring[k]-ring[k+1]
        const auto add = [&](int fa, int fb) {
          const int ea = edge_between(ring[fa], ring[(fa + 1) % 4]);
          const int eb = edge_between(ring[fb], ring[(fb + 1) % 4]);
          link[ea][degree[ea]++] = eb;
          link[eb][degree[eb]++] = ea;
        };
        if (n == 2) {
          add(crossed[0], crossed[1]);
        } else if (n == 4) {
          for (int k = 0; k < 4; ++k)
            if (inside(ring[k])) add((k + 3) % 4, k);  // the two face edges next to inside corner k
        }
      }
    }
    bool used[12] = {};
    int num_tri = 0;
    for (int start = 0; start < 12; ++start) {
      if (!(mask & (1u << start)) || used[start]) continue;
      int loop[12], len = 0;
      int prev = -1, cur = start;
      while (!used[cur]) {
        used[cur] = true;
        loop[len++] = cur;
        const int next = link[cur][0] != prev ? link[cur][0] : link[cur][1];
        prev = cur;
        cur = next;
      }
      // Orientation: the loop's (Newell) normal must agree with the inside-to-outside directions of its edges.
      Vec normal{0, 0, 0}, outward{0, 0, 0};
      for (int i = 0; i < len; ++i) {
        const auto& ea = t.edge_corners[static_cast<std::size_t>(loop[i])];
        const auto& eb = t.edge_corners[static_cast<std::size_t>(loop[(i + 1) % len])];
        const Vec a0 = corner_position(ea[0]), a1 = corner_position(ea[1]);
        const Vec b0 = corner_position(eb[0]), b1 = corner_position(eb[1]);
        const Vec p{(a0.x + a1.x) / 2, (a0.y + a1.y) / 2, (a0.z + a1.z) / 2};
        const Vec q{(b0.x + b1.x) / 2, (b0.y + b1.y) / 2, (b0.z + b1.z) / 2};
        normal.x += (p.y - q.y) * (p.z + q.z);
        normal.y += (p.z - q.z) * (p.x + q.x);
        normal.z += (p.x - q.x) * (p.y + q.y);
        const double s = inside(ea[0]) ? 1.0 : -1.0;  // from the inside corner to the outside one
        outward.x += s * (a1.x - a0.x);
        outward.y += s * (a1.y - a0.y);
        outward.z += s * (a1.z - a0.z);
      }
      const bool flip = normal.x * outward.x + normal.y * outward.y + normal.z * outward.z < 0;
      for (int i = 1; i + 1 < len; ++i) {
        if (num_tri >= kMaxCubeTriangles) std::abort();  // cannot happen for 12 edges; a broken generator
        auto& tri = t.triangles[static_cast<std::size_t>(cube)];
        const int a = loop[0], b = flip ? loop[i + 1] : loop[i], c = flip ? loop[i] : loop[i + 1];
        tri[static_cast<std::size_t>(3 * num_tri + 0)] = static_cast<std::int8_t>(a);
        tri[static_cast<std::size_t>(3 * num_tri + 1)] = static_cast<std::int8_t>(b);
        tri[static_cast<std::size_t>(3 * num_tri + 2)] = static_cast<std::int8_t>(c);
        ++num_tri;
      }
    }
    t.num_triangles[static_cast<std::size_t>(cube)] = static_cast<std::uint8_t>(num_tri);
  }
  return t;
}

}  // namespace

const MarchingCubesTables& marching_cubes_tables() {
  static const MarchingCubesTables tables = build();
  return tables;
}

}  // namespace qsg::reconstruction
