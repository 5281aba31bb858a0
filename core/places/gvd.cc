// The GVD (the paper's Layer 3): voxels where wavefronts from different obstacles meet, filtered to the
// theta-simplified medial axis (theta-SMA) and by clearance.
#include "core/places/places_internal.h"

namespace qsg::places {

// The number of basis points of a voxel (0 when it cannot be on the GVD). Following the brushfire GVD of Lau et
// al., a voxel is where wavefronts meet when a neighbour's parent is a different obstacle (not adjacent to this
// voxel's parent) and this voxel is at least as close to being equidistant from both parents as the neighbour
// is (so the GVD is one voxel thick, both voxels only on exact ties). The theta-SMA keeps a basis point only when
// it makes an angle >= theta with every other basis point seen from the voxel.
int Places::evaluate_gvd(std::uint32_t ref, std::uint32_t* basis_parents, int max_parents) const {
  const Voxel& v = vox(ref);
  if (v.state != kFree || v.parent == kNoRef || v.distance_m < static_cast<float>(config_.min_clearance_m)) return 0;
  // Nearer unknown space than any surface: the true clearance and the true GVD are not known here.
  if (vox(v.parent).state == kUnobserved) return 0;
  // Beside an orphan (its obstacle left the window) the basis points are not known: keep the state, as at the rim.
  if ((v.aux & kOrphan) != 0 || (vox(v.parent).aux & kOrphan) != 0) return kRim;
  const memory::Index3 g = coords(ref);
  const memory::Index3 pv = coords(v.parent);
  const float pv_d = vox(v.parent).distance_m;
  const float s = static_cast<float>(voxel_m_);
  const Eigen::Vector3f a(static_cast<float>(pv.x - g.x), static_cast<float>(pv.y - g.y), static_cast<float>(pv.z - g.z));
  const float la = a.norm();
  if (la <= 0.0f) return 0;
  Eigen::Vector3f dirs[kMaxBasis];
  std::uint32_t parents[kMaxBasis];
  int count = 1;
  dirs[0] = a / la;
  parents[0] = v.parent;
  for (const Offset& o : kOffsets.o) {
    const std::uint32_t n = neighbor(ref, o.dx, o.dy, o.dz);
    // At the window's vertical rim (the block above or below left the window, or never fit in it) the floor or
    // ceiling beyond is not known here: the distance is an upper bound (kRim: gvd_step adds no GVD voxel here and
    // keeps the ones it has, whose places leave the window as they were). See Config::rim_guard.
    if (n == kNoRef) {
      if (config_.rim_guard && o.dz != 0) return kRim;
      continue;
    }
    const Voxel& nv = vox(n);
    if ((nv.state != kFree && nv.state != kSeed) || nv.parent == kNoRef || nv.parent == v.parent) continue;
    if ((nv.aux & kOrphan) != 0 || (vox(nv.parent).aux & kOrphan) != 0) return kRim;
    if (vox(nv.parent).state == kUnobserved) continue;  // a frontier is not a basis point
    const memory::Index3 pn = coords(nv.parent);
    // The same obstacle: adjacent seeds, or a band seed (distance > 0, one voxel off its surface) and a surface
    // seed two voxels away: a flat ceiling's band layer and its surface layer, seen from just beneath, would
    // otherwise look like two obstacles 45-50 degrees apart and raise a sheet under every ceiling.
    const int same_reach = 1 + ((pv_d > 0.0f) != (vox(nv.parent).distance_m > 0.0f) ? 1 : 0);
    if (chebyshev(pn, pv) <= same_reach) continue;
    const Eigen::Vector3f b(static_cast<float>(pn.x - g.x), static_cast<float>(pn.y - g.y), static_cast<float>(pn.z - g.z));
    const float lb = b.norm();
    if (lb <= 0.0f || a.dot(b) > la * lb * cos_theta_) continue;
    if (nv.state == kFree) {
      const float s_vn = vox(nv.parent).distance_m + lb * s - v.distance_m;
      const float s_nv = pv_d + dist_vox(add(g, o.dx, o.dy, o.dz), pv) * s - nv.distance_m;
      if (s_vn > s_nv + 1e-5f) continue;  // the neighbour is nearer the bisector: it is the GVD voxel
    }
    const Eigen::Vector3f u = b / lb;
    bool distinct = true;
    for (int k = 0; k < count && distinct; ++k) distinct = u.dot(dirs[k]) <= cos_theta_;
    if (distinct && count < kMaxBasis) {
      dirs[count] = u;
      parents[count] = nv.parent;
      ++count;
    }
  }
  for (int k = 0; k < count && k < max_parents; ++k) basis_parents[k] = parents[k];
  return count;
}

void Places::gvd_step(std::uint32_t ref) {
  Voxel& v = vox(ref);
  v.flags &= static_cast<std::uint8_t>(~kEval);
  const int nb = evaluate_gvd(ref, nullptr, 0);
  if (nb == kRim && (v.flags & kGvd) != 0) return;  // keeps its state until its block leaves the window
  const bool is = nb >= config_.min_basis_points;
  const bool was = (v.flags & kGvd) != 0;
  const std::uint8_t basis = static_cast<std::uint8_t>(is ? nb : 0);
  if (is == was && basis == v.num_basis) return;
  if (is && !was) {
    v.flags |= kGvd;
    ++counters_.gvd_voxels;
  } else if (!is && was) {
    v.flags &= static_cast<std::uint8_t>(~kGvd);
    if (counters_.gvd_voxels > 0) --counters_.gvd_voxels;
  }
  v.num_basis = basis;
  if ((v.flags & kGvdChanged) == 0) {
    v.flags |= kGvdChanged;
    lists_[kChangedList].push(ref);
  }
}

// An affected voxel (its distance or parent changed): it and its neighbours are re-tested for the GVD, and a GVD
// voxel whose distance moved changes its place's clearance or an edge weight.
void Places::expand_affected(std::uint32_t r) {
  Voxel& v = vox(r);
  v.flags &= static_cast<std::uint8_t>(~kAffected);
  if ((v.flags & (kGvd | kGvdChanged)) == kGvd) {
    v.flags |= kGvdChanged;
    lists_[kChangedList].push(r);
  }
  if ((v.flags & kEval) == 0) {
    v.flags |= kEval;
    lists_[kEvalList].push(r);
  }
  for (const Offset& o : kOffsets.o) {
    const std::uint32_t n = neighbor(r, o.dx, o.dy, o.dz);
    if (n == kNoRef || (vox(n).flags & kEval) != 0) continue;
    vox(n).flags |= kEval;
    lists_[kEvalList].push(n);
  }
}

}  // namespace qsg::places
