// Repair pass: free-space edges (Config::free_space_edges). Places of neighbouring hash cells whose spheres of
// free space overlap are joined, certified by the ESDF along the segment; recompute_edges() offers them after
// the GVD's edges.
#include "core/places/places_internal.h"

namespace qsg::places {

// Whether the free space of two clusters is joined: a voxel of one, whose sphere overlaps the other's
// representative sphere (each cluster is a connected piece of GVD, so its voxels and their spheres connect to its
// representative), with the segment between them certified by the ESDF. The pair tested is chosen the same way
// from both ends (the smaller of the two tests' voxel refs), so both clusters agree on the edge and its weight.
bool Places::spheres_meet(std::uint32_t a, std::uint32_t b, float* weight_m) const {
  if (b < a) std::swap(a, b);
  const auto best_voxel = [this](std::uint32_t from, std::uint32_t to_cluster, std::uint32_t* out) {
    const Cluster& t = clusters_[to_cluster];
    const Eigen::Vector3d pt = center_m(coords(t.rep));
    double best = std::numeric_limits<double>::max();
    *out = kNoRef;
    for (std::uint32_t r = clusters_[from].head; r != kNoRef; r = vox(r).cluster_next) {
      const double reach = static_cast<double>(vox(r).distance_m) + static_cast<double>(t.clearance_m);
      // The deepest overlap (least distance minus reach) wins; ties by the smaller ref.
      const double slack = (center_m(coords(r)) - pt).norm() - reach;
      if (slack < 0.0 && (slack < best || (slack == best && r < *out))) {
        best = slack;
        *out = r;
      }
    }
    return best;
  };
  std::uint32_t va = kNoRef, vb = kNoRef;
  const double sa = best_voxel(a, b, &va), sb = best_voxel(b, a, &vb);
  if (va == kNoRef && vb == kNoRef) return false;
  const bool use_a = vb == kNoRef || (va != kNoRef && sa <= sb);
  return use_a ? segment_clearance(center_m(coords(va)), clusters_[b].position_m, weight_m)
               : segment_clearance(center_m(coords(vb)), clusters_[a].position_m, weight_m);
}

// recompute_edges(): the free-space candidates of a place, offered after its GVD edges.
void Places::free_space_edge_candidates(std::uint32_t cluster, EdgeCandidates* e) {
  const Cluster& c = clusters_[cluster];
  // Free-space edges (after the GVD's, which keep priority for the slots): places of the 27 cells around this
  // one whose spheres of free space overlap, certified by the ESDF along the segment between them.
  for (int oi = 0; oi <= 26; ++oi) {  // the 26 neighbour cells, then the cell itself
    const memory::Index3 cell = oi < 26 ? add(c.cell, kOffsets.o[oi].dx, kOffsets.o[oi].dy, kOffsets.o[oi].dz) : c.cell;
    const std::uint32_t* head = cells_.find(cell);
    for (std::uint32_t x = head != nullptr ? *head : kNoCluster; x != kNoCluster; x = clusters_[x].cell_next) {
      const Cluster& xc = clusters_[x];
      if (x == cluster || xc.state != kLive || xc.rep == kNoRef) continue;
      int k = 0;
      while (k < e->n && e->to[k] != x) ++k;
      if (k < e->n) continue;
      // Already two GVD hops away (through a GVD neighbour of this cluster): the GVD joins them.
      bool near = false;
      for (int j = 0; j < e->n && !near; ++j) {
        if (e->kind[j]) continue;
        const Cluster& g = clusters_[e->to[j]];
        for (int q = 0; q < g.num_edges && !near; ++q) near = g.edge_to[q] == x && !g.edge_free[q];
      }
      if (near) continue;
      float w = 0.0f;
      if (!spheres_meet(cluster, x, &w)) continue;
      offer_edge(c, e, x, w, kEdgeFree);
    }
  }
}

}  // namespace qsg::places
