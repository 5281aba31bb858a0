// Mesh clean-up before export (see mesh_cleanup.h).
#include "core/reconstruction/mesh_cleanup.h"

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <unordered_map>

#include "core/memory/pool.h"

namespace qsg::reconstruction {
namespace {

// A triangle's corners sorted, with the winding kept apart: equal keys are the same triangle.
struct TriangleKey {
  std::array<std::uint32_t, 3> sorted;
  friend bool operator==(const TriangleKey& a, const TriangleKey& b) { return a.sorted == b.sorted; }
};
struct TriangleKeyHash {
  std::size_t operator()(const TriangleKey& k) const {
    std::uint64_t h = 1469598103934665603ull;
    for (std::uint32_t v : k.sorted) h = (h ^ v) * 1099511628211ull;
    return static_cast<std::size_t>(h);
  }
};

// +1 or -1: whether (a, b, c) is an even or odd permutation of its sorted order.
int winding(const MeshTriangle& t) {
  int swaps = 0;
  std::array<std::uint32_t, 3> v{{t.v[0], t.v[1], t.v[2]}};
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2 - i; ++j)
      if (v[j] > v[j + 1]) {
        std::swap(v[j], v[j + 1]);
        ++swaps;
      }
  return swaps % 2 == 0 ? 1 : -1;
}

Eigen::Vector3d position(const MeshVertex& v) { return Eigen::Vector3d(v.x, v.y, v.z); }

}  // namespace

void MeshCleanupStats::print(std::FILE* out) const {
  std::fprintf(out, "mesh clean-up: %zu degenerate, %zu duplicated and %zu back-to-back triangles removed, %zu "
               "unreferenced vertices removed; %zu non-manifold edges left\n", degenerate, duplicated, back_to_back,
               unreferenced, non_manifold_edges);
}

MeshCleanupStats clean_mesh(Mesh* mesh, std::vector<std::uint32_t>* old_to_new, double min_area_m2) {
  MeshCleanupStats stats;
  const std::size_t n = mesh->vertices.size();
  std::unordered_map<TriangleKey, int, TriangleKeyHash> seen;  // key -> winding of the kept copy
  seen.reserve(mesh->triangles.size());
  std::size_t kept = 0;
  for (const MeshTriangle& t : mesh->triangles) {
    if (t.v[0] >= n || t.v[1] >= n || t.v[2] >= n || t.v[0] == t.v[1] || t.v[1] == t.v[2] || t.v[0] == t.v[2]) {
      ++stats.degenerate;
      continue;
    }
    const Eigen::Vector3d a = position(mesh->vertices[t.v[0]]);
    const double area_m2 =
        0.5 * (position(mesh->vertices[t.v[1]]) - a).cross(position(mesh->vertices[t.v[2]]) - a).norm();
    if (!(area_m2 >= min_area_m2)) {
      ++stats.degenerate;
      continue;
    }
    TriangleKey key{{{t.v[0], t.v[1], t.v[2]}}};
    std::sort(key.sorted.begin(), key.sorted.end());
    const auto [it, inserted] = seen.emplace(key, winding(t));
    if (!inserted) {
      ++(it->second == winding(t) ? stats.duplicated : stats.back_to_back);
      continue;
    }
    mesh->triangles[kept++] = t;
  }
  mesh->triangles.resize(kept);

  const bool times = mesh->has_vertex_times();
  std::vector<std::uint32_t> remap(n, memory::kInvalidHandle);
  for (const MeshTriangle& t : mesh->triangles)
    for (std::uint32_t v : t.v) remap[v] = 0;
  std::uint32_t next = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (remap[i] == memory::kInvalidHandle) {
      ++stats.unreferenced;
      continue;
    }
    remap[i] = next;
    if (times) mesh->vertex_time_ns[next] = mesh->vertex_time_ns[i];
    mesh->vertices[next++] = mesh->vertices[i];
  }
  mesh->vertices.resize(next);
  if (times) mesh->vertex_time_ns.resize(next);
  else mesh->vertex_time_ns.clear();
  for (MeshTriangle& t : mesh->triangles)
    for (std::uint32_t& v : t.v) v = remap[v];
  std::unordered_map<std::uint64_t, std::uint32_t> edge_uses;
  edge_uses.reserve(3 * mesh->triangles.size());
  for (const MeshTriangle& t : mesh->triangles)
    for (int k = 0; k < 3; ++k) {
      const std::uint64_t a = std::min(t.v[k], t.v[(k + 1) % 3]), b = std::max(t.v[k], t.v[(k + 1) % 3]);
      if (++edge_uses[(a << 32) | b] == 3) ++stats.non_manifold_edges;
    }
  if (old_to_new != nullptr) *old_to_new = std::move(remap);
  return stats;
}

}  // namespace qsg::reconstruction
