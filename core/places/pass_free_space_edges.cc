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

}  // namespace qsg::places
