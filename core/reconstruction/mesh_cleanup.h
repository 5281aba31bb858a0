// Clean-up of an extracted mesh before it is written: what marching cubes, the archive's vertex merge and the
// archived/active seam leave behind and what mesh readers and processing tools trip over.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <vector>

#include "core/reconstruction/semantic_tsdf.h"

namespace qsg::reconstruction {

struct MeshCleanupStats {
  std::size_t degenerate = 0;       // a repeated corner, or an area under min_area_m2 (corners merged or collinear)
  std::size_t duplicated = 0;       // the same three corners in the same winding as an earlier triangle
  std::size_t back_to_back = 0;     // the same three corners in the opposite winding: a zero-thickness sheet
  std::size_t unreferenced = 0;     // vertices no triangle kept uses
  std::size_t non_manifold_edges = 0;  // left as they are: edges more than two kept triangles share (counted only)
  void print(std::FILE* out) const;
};

// Removes degenerate triangles, every later copy of a triangle (either winding: the first one met stays), then
// the vertices no triangle uses, and renumbers the rest in their order. old_to_new (optional) receives each old
// vertex's new index, or memory::kInvalidHandle for a removed one. Off the real-time path (heap).
MeshCleanupStats clean_mesh(Mesh* mesh, std::vector<std::uint32_t>* old_to_new = nullptr, double min_area_m2 = 1e-10);

}  // namespace qsg::reconstruction
