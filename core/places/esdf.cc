// The ESDF over the active window (the paper's Layer 3, after Voxblox and FIESTA): voxel geometry, the work
// lists, each voxel's parent list (the voxels whose distance comes from it), ESDF blocks seeded from the TSDF's
// zero crossings and carved free space, and the raise and lower waves of the incremental brushfire.
#include "core/places/places_internal.h"

namespace qsg::places {

// ---------------------------------------------------------------------------------------------------------
// Geometry

Places::Voxel& Places::vox(std::uint32_t ref) { return blocks_[ref / kBlockVoxels].voxels[ref % kBlockVoxels]; }

const Places::Voxel& Places::vox(std::uint32_t ref) const {
  return blocks_[ref / kBlockVoxels].voxels[ref % kBlockVoxels];
}

// A voxel whose distance spreads to its neighbours: a reached free voxel, a surface seed, or a seed made in
// lower_step from an unobserved voxel (a frontier) or an occupied one beside free space (its own parent).
bool Places::is_source(std::uint32_t ref) const {
  const Voxel& v = vox(ref);
  if (v.parent == kNoRef) return false;
  return v.state == kFree || v.state == kSeed || ((v.state == kUnobserved || v.state == kOccupied) && v.parent == ref);
}

memory::Index3 Places::coords(std::uint32_t ref) const {
  const memory::Index3& b = blocks_[ref / kBlockVoxels].index;
  const int i = static_cast<int>(ref % kBlockVoxels);
  return {b.x * kBlockSide + (i & 7), b.y * kBlockSide + ((i >> 3) & 7), b.z * kBlockSide + (i >> 6)};
}

std::uint32_t Places::neighbor(std::uint32_t ref, int dx, int dy, int dz) const {
  const std::uint32_t h = ref / kBlockVoxels;
  const int i = static_cast<int>(ref % kBlockVoxels);
  const int x = (i & 7) + dx, y = ((i >> 3) & 7) + dy, z = (i >> 6) + dz;
  const int bx = x < 0 ? -1 : (x >= kBlockSide ? 1 : 0);
  const int by = y < 0 ? -1 : (y >= kBlockSide ? 1 : 0);
  const int bz = z < 0 ? -1 : (z >= kBlockSide ? 1 : 0);
  const std::uint32_t nb = (bx | by | bz) == 0 ? h : blocks_[h].nbr[(bx + 1) + 3 * (by + 1) + 9 * (bz + 1)];
  if (nb == memory::kInvalidHandle) return kNoRef;
  return make_ref(nb, (x & 7) + kBlockSide * ((y & 7) + kBlockSide * (z & 7)));
}

std::uint32_t Places::find_voxel(const memory::Index3& g) const {
  const memory::Index3 b{floor_div(g.x, kBlockSide), floor_div(g.y, kBlockSide), floor_div(g.z, kBlockSide)};
  const std::uint32_t* h = block_index_.find(b);
  if (h == nullptr) return kNoRef;
  return make_ref(*h, (g.x - b.x * kBlockSide) + kBlockSide * ((g.y - b.y * kBlockSide) + kBlockSide * (g.z - b.z * kBlockSide)));
}

Eigen::Vector3d Places::center_m(const memory::Index3& g) const {
  return Eigen::Vector3d((g.x + 0.5) * voxel_m_, (g.y + 0.5) * voxel_m_, (g.z + 0.5) * voxel_m_);
}

bool Places::block_in_window(const memory::Index3& b) const {
  const double side = voxel_m_ * kBlockSide;
  const Eigen::Vector3d c((b.x + 0.5) * side, (b.y + 0.5) * side, (b.z + 0.5) * side);
  if ((c - cycle_robot_m_).squaredNorm() > config_.window_radius_m * config_.window_radius_m) return false;
  const double z0 = b.z * side, z1 = z0 + side;
  return z1 > cycle_robot_m_.z() - config_.slab_below_m && z0 < cycle_robot_m_.z() + config_.slab_above_m;
}

// Config::keep_edges_at_rim_m: whether a point lies within that distance of the window's sphere around the
// cycle's robot position.
bool Places::at_window_rim(const Eigen::Vector3d& p) const {
  const double margin = config_.keep_edges_at_rim_m;
  if (!(margin > 0.0)) return false;
  return config_.window_radius_m - (p - cycle_robot_m_).norm() < margin;
}

memory::Index3 Places::cell_of(std::uint32_t ref) const {
  const Eigen::Vector3d p = center_m(coords(ref)) / config_.place_resolution_m;
  return {static_cast<std::int32_t>(std::floor(p.x())), static_cast<std::int32_t>(std::floor(p.y())),
          static_cast<std::int32_t>(std::floor(p.z()))};
}

// ---------------------------------------------------------------------------------------------------------
// Worklists

void Places::push_lower(std::uint32_t ref) {
  Voxel& v = vox(ref);
  if ((v.flags & kInLower) != 0 || blocks_[ref / kBlockVoxels].dying) return;
  // Each voxel is queued at most once (flag), so the ring holding one slot per voxel never overflows.
  v.flags |= kInLower;
  lower_ring_[(lower_head_ + lower_size_) % lower_capacity_] = ref;
  ++lower_size_;
  if (lower_size_ > lower_high_water_) lower_high_water_ = lower_size_;
}

void Places::push_raise(std::uint32_t ref) {
  Voxel& v = vox(ref);
  if ((v.flags & kInRaise) != 0 || blocks_[ref / kBlockVoxels].dying) return;
  v.flags |= kInRaise;
  lists_[kRaiseList].push(ref);
}

void Places::mark_affected(std::uint32_t ref) {
  Voxel& v = vox(ref);
  if ((v.flags & kAffected) != 0 || blocks_[ref / kBlockVoxels].dying) return;
  v.flags |= kAffected;
  lists_[kAffectedList].push(ref);
}

// ---------------------------------------------------------------------------------------------------------
// Parent lists

void Places::set_parent(std::uint32_t ref, std::uint32_t parent, float distance_m) {
  Voxel& v = vox(ref);
  if (v.parent != parent || (v.aux & kOrphan) != 0) {
    clear_parent(ref);
    if (parent != ref) {
      Voxel& p = vox(parent);
      v.prev = parent;
      v.next = p.next;
      if (p.next != kNoRef) vox(p.next).prev = ref;
      p.next = ref;
    }
    v.parent = parent;
  }
  v.distance_m = distance_m;
}

void Places::clear_parent(std::uint32_t ref) {
  Voxel& v = vox(ref);
  v.aux &= static_cast<std::uint8_t>(~kOrphan);
  if (v.parent == kNoRef) return;
  if (v.parent != ref) {
    if (v.prev != kNoRef) vox(v.prev).next = v.next;
    if (v.next != kNoRef) vox(v.next).prev = v.prev;
    v.prev = kNoRef;
    v.next = kNoRef;
  }
  v.parent = kNoRef;
  v.distance_m = kUnreached;
}

// Unlinks every voxel whose distance came from parent_ref (its list of dependents) and hands each to fn(ref, voxel).
template <typename Fn>
void Places::detach_dependents(std::uint32_t parent_ref, Fn&& fn) {
  Voxel& s = vox(parent_ref);
  std::uint32_t d = s.next;
  while (d != kNoRef) {
    Voxel& dv = vox(d);
    const std::uint32_t next = dv.next;
    dv.prev = kNoRef;
    dv.next = kNoRef;
    fn(d, dv);
    d = next;
  }
  s.next = kNoRef;
}

// Every voxel whose distance came from this seed is reset and queued for the raise wave, which hands the hole
// back to the neighbours that still have valid parents (FIESTA-style: exact, no stale distances remain).
void Places::raise_dependents(std::uint32_t seed_ref, bool include_seed) {
  detach_dependents(seed_ref, [&](std::uint32_t d, Voxel& dv) {
    dv.parent = kNoRef;
    dv.distance_m = kUnreached;
    push_raise(d);
    mark_affected(d);
    ++counters_.voxels_raised;
  });
  if (include_seed) {
    Voxel& s = vox(seed_ref);
    s.parent = kNoRef;
    s.distance_m = kUnreached;
    s.aux &= static_cast<std::uint8_t>(~kOrphan);
  }
}

// The dependents of a voxel whose block is leaving the window: those in blocks that stay keep their distance and
// become their own parents (orphans, see Config::keep_distances_at_rim); those in dying blocks are just unlinked.
void Places::orphan_dependents(std::uint32_t parent_ref) {
  detach_dependents(parent_ref, [&](std::uint32_t d, Voxel& dv) {
    if (blocks_[d / kBlockVoxels].dying) {
      dv.parent = kNoRef;
      dv.distance_m = kUnreached;
    } else {
      dv.parent = d;
      dv.aux |= kOrphan;
      ++counters_.voxels_orphaned;
    }
  });
  Voxel& s = vox(parent_ref);
  s.parent = kNoRef;
  s.distance_m = kUnreached;
  s.aux &= static_cast<std::uint8_t>(~kOrphan);
}

void Places::apply_state(std::uint32_t ref, std::uint8_t state, float seed_m) {
  Voxel& v = vox(ref);
  const std::uint8_t old = v.state;
  if (state == kSeed) {
    if (old == kSeed) {
      if (std::fabs(seed_m - v.distance_m) < kEps) return;
      // Reset and refill the dependents: exact whichever way the seed moved (a dependent reached through a
      // voxel that has since taken another parent would otherwise keep a stale distance).
      raise_dependents(ref, false);
      v.distance_m = seed_m;
    } else {
      if (v.parent == ref) raise_dependents(ref, true);  // a frontier or occupied seed: its dependents go with it
      else clear_parent(ref);
      v.state = kSeed;
      set_parent(ref, ref, seed_m);
    }
    push_lower(ref);
    mark_affected(ref);
    ++counters_.voxels_updated;
    return;
  }
  if (state == old) return;
  // A seed, or a frontier or occupied seed (its own parent, see lower_step), hands its dependents back.
  if (old == kSeed || v.parent == ref) raise_dependents(ref, true);
  else clear_parent(ref);
  v.state = state;
  v.distance_m = kUnreached;
  mark_affected(ref);
  ++counters_.voxels_updated;
  if (state == kFree) push_raise(ref);  // refilled from its neighbours
}

// ---------------------------------------------------------------------------------------------------------
// Blocks

// Distance from the centre of the ESDF voxel whose first TSDF voxel is (x0, y0, z0) of TSDF block `tb` to the
// surface, from the TSDF's zero crossings: along each axis, each of the factor^2 TSDF columns through the voxel is
// searched outwards from the centre (up to two TSDF voxels beyond the ESDF voxel) for the nearest sign change,
// interpolated linearly; d_a is the mean crossing distance of the columns that have one. A plane at distance d
// with normal n crosses axis a at d / |n_a|, so d = 1 / sqrt(sum 1 / d_a^2) over the axes with a crossing
// (exact for a plane; nearer for corners). Interpolation uses ratios of TSDF values, so the projective
// overestimate cancels. False when no column crosses.
bool Places::crossing_distance(const reconstruction::SemanticTsdf& tsdf, const memory::Index3& tb, int x0, int y0,
                               int z0, float* distance_m) const {
  const int f = config_.voxel_factor;
  constexpr int kSide = reconstruction::kBlockSide;
  const std::uint16_t min_w = static_cast<std::uint16_t>(
      std::min(65535.0, std::floor(config_.min_tsdf_weight * reconstruction::kWeightScale)));
  // TSDF blocks around tb, looked up once each on first use.
  bool looked[27] = {};
  const reconstruction::Voxel* voxels[27] = {};
  const auto sample = [&](int x, int y, int z, float* value) {
    const int bx = x < 0 ? -1 : (x >= kSide ? 1 : 0), by = y < 0 ? -1 : (y >= kSide ? 1 : 0),
              bz = z < 0 ? -1 : (z >= kSide ? 1 : 0);
    const int slot = (bx + 1) + 3 * ((by + 1) + 3 * (bz + 1));
    if (!looked[slot]) {
      looked[slot] = true;
      const std::uint32_t handle = tsdf.find_block({tb.x + bx, tb.y + by, tb.z + bz});
      reconstruction::SemanticTsdf::BlockView view;
      if (handle != memory::kInvalidHandle && tsdf.block_view(handle, &view)) voxels[slot] = view.voxels;
    }
    if (voxels[slot] == nullptr) return false;
    const reconstruction::Voxel& v =
        voxels[slot][(x - bx * kSide) + kSide * ((y - by * kSide) + kSide * (z - bz * kSide))];
    if (v.weight_q <= min_w) return false;
    *value = tsdf.sdf_m(v);
    return true;
  };
  const float tv = static_cast<float>(tsdf_voxel_m_);
  const float centre = 0.5f * static_cast<float>(f);  // the ESDF voxel's centre, in TSDF voxels from (x0, y0, z0)
  float inv_sq = 0.0f;
  for (int axis = 0; axis < 3; ++axis) {
    float sum = 0.0f;
    int count = 0;
    for (int u = 0; u < f; ++u)
      for (int w = 0; w < f; ++w) {
        // Samples along the column at TSDF offsets k = -2 .. f + 1 (centres at k + 0.5).
        float best = std::numeric_limits<float>::infinity();
        float prev = 0.0f;
        bool have_prev = false;
        for (int k = -2; k <= f + 1; ++k) {
          int c[3];
          c[axis] = k;
          c[(axis + 1) % 3] = u;
          c[(axis + 2) % 3] = w;
          float value = 0.0f;
          if (!sample(x0 + c[0], y0 + c[1], z0 + c[2], &value)) {
            have_prev = false;
            continue;
          }
          if (have_prev && (prev > 0.0f) != (value > 0.0f)) {
            const float at = static_cast<float>(k) - 0.5f + prev / (prev - value);  // crossing, in TSDF voxels
            best = std::min(best, std::fabs(at - centre));
          }
          prev = value;
          have_prev = true;
        }
        if (best < std::numeric_limits<float>::infinity()) {
          sum += best;
          ++count;
        }
      }
    if (count > 0) {
      const float d = std::max(1e-3f, sum / static_cast<float>(count) * tv);
      inv_sq += 1.0f / (d * d);
    }
  }
  if (inv_sq <= 0.0f) return false;
  *distance_m = 1.0f / std::sqrt(inv_sq);
  return true;
}

// Classifies the ESDF voxels covered by one TSDF block (sub-block `sub` of the ESDF block). An ESDF voxel
// averages its factor^3 TSDF voxels (its centre is their common corner, where the mean is the TSDF's trilinear
// value): unobserved when none is observed (free if carved), free at the truncation distance, a seed inside the
// band (and on a zero crossing), occupied behind the surface.
void Places::seed_sub_block(const reconstruction::SemanticTsdf& tsdf, std::uint32_t handle, int sub, bool carve) {
  const int f = config_.voxel_factor;
  Block& b = blocks_[handle];
  const int sx = sub % f, sy = (sub / f) % f, sz = sub / (f * f);
  const memory::Index3 tb{b.index.x * f + sx, b.index.y * f + sy, b.index.z * f + sz};
  const std::uint32_t th = tsdf.find_block(tb);
  reconstruction::SemanticTsdf::BlockView view;
  if (th == memory::kInvalidHandle || !tsdf.block_view(th, &view)) return;  // archived or never seen: keep
  b.tsdf_stamp[sub] = view.integrated_stamp;
  b.tsdf_seen[sub] = 1;
  // The views that saw this block: those observe() recorded for the cycle, else (no observe() calls) the latest
  // frame from the robot's position when the block was part of it.
  const int cycle_set = 1 - pending_;
  std::uint32_t seen_by = 0;
  if (carve && num_views_[cycle_set] > 0) {
    const std::uint32_t* mask = observed_[cycle_set].find(tb);
    seen_by = mask != nullptr ? *mask : 0u;
  }
  const bool legacy = carve && !observing_ && view.integrated_stamp == tsdf.frame_stamp();
  carve = seen_by != 0 || legacy;
  ++counters_.tsdf_blocks_read;
  const int n = kBlockSide / f;  // ESDF voxels per side of the TSDF block
  const std::uint16_t min_w = static_cast<std::uint16_t>(
      std::min(65535.0, std::floor(config_.min_tsdf_weight * reconstruction::kWeightScale)));
  const float clamp_m = tsdf_trunc_m_ * 0.999f;
  for (int ez = 0; ez < n; ++ez)
    for (int ey = 0; ey < n; ++ey)
      for (int ex = 0; ex < n; ++ex) {
        int observed = 0, positive = 0;
        float sum = 0.0f;
        for (int kz = 0; kz < f; ++kz)
          for (int ky = 0; ky < f; ++ky)
            for (int kx = 0; kx < f; ++kx) {
              const int tx = ex * f + kx, ty = ey * f + ky, tz = ez * f + kz;
              const reconstruction::Voxel& tv =
                  view.voxels[tx + reconstruction::kBlockSide * (ty + reconstruction::kBlockSide * tz)];
              if (tv.weight_q <= min_w) continue;
              const float s = tsdf.sdf_m(tv);
              sum += s;
              ++observed;
              positive += s > 0.0f ? 1 : 0;
            }
        const int local = (sx * n + ex) + kBlockSide * ((sy * n + ey) + kBlockSide * (sz * n + ez));
        const std::uint32_t ref = make_ref(handle, local);
        std::uint8_t state = (vox(ref).flags & kCarved) != 0 ? kFree : kUnobserved;
        float seed = 0.0f;
        if (observed > 0) {
          float mean = sum / static_cast<float>(observed);
          // The TSDF's projective distances (along camera rays) overestimate the distance to a surface seen at a
          // grazing angle by 1/sin(angle): a floor seen 2 m ahead from 0.5 m, x4, up to the truncation. Seeds
          // that far off put every voxel near a floor or a ceiling farther from it than it is, and raise GVD
          // sheets between patches of the same floor. Where the zero crossing is found near the voxel, its
          // position (interpolated, so the projective scale cancels) gives the Euclidean distance instead.
          if (config_.correct_projective_distance && mean < clamp_m) {
            float d = 0.0f;
            if (crossing_distance(tsdf, tb, ex * f, ey * f, ez * f, &d)) mean = std::copysign(d, mean);
          }
          if (mean >= clamp_m) {
            state = kFree;
          } else if (mean > 0.0f) {
            state = kSeed;
            seed = mean;
          } else if (positive > 0) {
            // A zero crossing inside the voxel: the surface itself, a seed (the TSDF's projective distances
            // overestimate at grazing angles, so the band alone can miss a surface seen obliquely), at the signed
            // distance of its centre behind the surface (<= 0; 0 when signed_surface_seeds is off).
            state = kSeed;
            if (config_.signed_surface_seeds) seed = std::max(mean, -0.5f * static_cast<float>(voxel_m_));
          } else {
            state = kOccupied;
          }
        }
        apply_state(ref, state, seed);
        // Seen from the camera: the space between holds nothing.
        if (carve && (state == kSeed || (state == kFree && observed > 0))) {
          if (legacy) carve_ray(tsdf, cycle_robot_m_, ref);
          for (int k = 0; k < num_views_[cycle_set]; ++k)
            if ((seen_by >> k) & 1u) carve_ray(tsdf, views_m_[cycle_set][k], ref);
        }
      }
}

// Marks the voxels between the robot and a voxel it has just observed as free (stops at anything the TSDF
// knows as occupied). Samples the segment every half voxel; allocates blocks on the way inside the window.
void Places::carve_ray(const reconstruction::SemanticTsdf& tsdf, const Eigen::Vector3d& origin_m,
                       std::uint32_t target) {
  ++counters_.rays_carved;
  const memory::Index3 goal = coords(target);
  const Eigen::Vector3d b = center_m(goal);
  const Eigen::Vector3d a = origin_m;
  const double len = (b - a).norm();
  const int steps = static_cast<int>(std::ceil(len / (0.5 * voxel_m_)));
  memory::Index3 last{std::numeric_limits<std::int32_t>::min(), 0, 0};
  for (int i = 0; i < steps; ++i) {
    const Eigen::Vector3d p = (a + (b - a) * (static_cast<double>(i) / steps)) / voxel_m_;
    const memory::Index3 g{static_cast<std::int32_t>(std::floor(p.x())), static_cast<std::int32_t>(std::floor(p.y())),
                           static_cast<std::int32_t>(std::floor(p.z()))};
    if (g == last) continue;
    last = g;
    if (g == goal) break;
    ++units_;
    std::uint32_t ref = find_voxel(g);
    if (ref == kNoRef) {
      const memory::Index3 blk{floor_div(g.x, kBlockSide), floor_div(g.y, kBlockSide), floor_div(g.z, kBlockSide)};
      if (allocate_block(tsdf, blk, true) == memory::kInvalidHandle) continue;
      ref = find_voxel(g);
      if (ref == kNoRef) continue;
    }
    Voxel& v = vox(ref);
    if (v.state == kOccupied) break;
    if ((v.flags & kCarved) != 0) continue;
    v.flags |= kCarved;
    if (v.state == kUnobserved) apply_state(ref, kFree, 0.0f);
  }
}

std::uint32_t Places::allocate_block(const reconstruction::SemanticTsdf& tsdf, const memory::Index3& index,
                                     bool read_tsdf) {
  if (const std::uint32_t* h = block_index_.find(index)) return *h;
  if (!block_in_window(index)) return memory::kInvalidHandle;
  const std::uint32_t h = blocks_.acquire();
  if (h == memory::kInvalidHandle) {
    ++counters_.blocks_refused;
    return h;
  }
  if (block_index_.insert(index, h) == nullptr) {
    blocks_.release(h);
    ++counters_.blocks_refused;
    return memory::kInvalidHandle;
  }
  Block& b = blocks_[h];
  b.index = index;
  for (int k = 0; k < 27; ++k) b.nbr[k] = memory::kInvalidHandle;
  b.nbr[13] = h;
  std::fill(std::begin(b.tsdf_stamp), std::end(b.tsdf_stamp), 0u);
  std::fill(std::begin(b.tsdf_seen), std::end(b.tsdf_seen), std::uint8_t{0});
  b.dying = 0;
  for (const Offset& o : kOffsets.o) {
    const std::uint32_t* n = block_index_.find(add(index, o.dx, o.dy, o.dz));
    if (n == nullptr) continue;
    b.nbr[o.block_slot] = *n;
    blocks_[*n].nbr[26 - o.block_slot] = h;
  }
  ++counters_.blocks_allocated;
  const int f = config_.voxel_factor;
  if (read_tsdf)
    for (int sub = 0; sub < f * f * f; ++sub) seed_sub_block(tsdf, h, sub, false);
  // Wavefronts of the neighbours flow into the new block: queue their valid voxels along its faces.
  for (int local = 0; local < kBlockVoxels; ++local) {
    const int x = local & 7, y = (local >> 3) & 7, z = local >> 6;
    if (x != 0 && x != 7 && y != 0 && y != 7 && z != 0 && z != 7) continue;
    const std::uint32_t ref = make_ref(h, local);
    for (const Offset& o : kOffsets.o) {
      const std::uint32_t n = neighbor(ref, o.dx, o.dy, o.dz);
      if (n == kNoRef || n / kBlockVoxels == h) continue;
      if (is_source(n)) push_lower(n);
    }
  }
  return h;
}

// Called for every dying block before any is released: detaches its voxels from lists, parents and clusters.
void Places::evict_block_voxels(std::uint32_t handle) {
  for (int local = 0; local < kBlockVoxels; ++local) {
    const std::uint32_t ref = make_ref(handle, local);
    Voxel& v = vox(ref);
    if (v.cluster != kNoCluster) {
      const std::uint32_t c = v.cluster;
      cluster_remove_voxel(c, ref);
      if (clusters_[c].count == 0) retire_cluster(c, kLeft);
      else clusters_[c].dirty = 1;
    }
    if ((v.flags & kGvd) != 0 && counters_.gvd_voxels > 0) --counters_.gvd_voxels;
    if (v.state == kSeed || v.parent == ref) {
      // Dependents outside the dying blocks lose their parent (frontier, occupied and orphan parents too). The
      // obstacle is still there, only outside the window: they keep their distance as orphans. Off, they are
      // raised like the dependents of a vanished seed (push_raise is a no-op for the dying blocks' own voxels).
      if (config_.keep_distances_at_rim) orphan_dependents(ref);
      else raise_dependents(ref, /*include_seed=*/true);
    } else {
      clear_parent(ref);
    }
    v.flags = 0;
    v.aux = 0;
  }
}

void Places::release_block(std::uint32_t handle) {
  Block& b = blocks_[handle];
  for (const Offset& o : kOffsets.o) {
    const std::uint32_t n = b.nbr[o.block_slot];
    if (n != memory::kInvalidHandle) blocks_[n].nbr[26 - o.block_slot] = memory::kInvalidHandle;
  }
  block_index_.erase(b.index);
  blocks_.release(handle);
  ++counters_.blocks_freed;
}

void Places::begin_cycle(const reconstruction::SemanticTsdf& tsdf, const Eigen::Vector3d& robot_m) {
  cycle_robot_m_ = robot_m;
  voxel_m_ = tsdf.config().voxel_size_m * config_.voxel_factor;
  tsdf_voxel_m_ = tsdf.config().voxel_size_m;
  tsdf_trunc_m_ = static_cast<float>(tsdf.config().voxel_size_m * tsdf.config().truncation_voxels);
  // Blocks that left the window: detach all of them first (parents may sit in another dying block), then free.
  bool any = false;
  blocks_.for_each([&](std::uint32_t, Block& b) {
    b.dying = block_in_window(b.index) ? 0 : 1;
    any = any || b.dying;
  });
  if (any) {
    for (std::uint32_t h = 0; h < blocks_.capacity(); ++h)
      if (blocks_.live(h) && blocks_[h].dying) evict_block_voxels(h);
    for (std::uint32_t h = 0; h < blocks_.capacity(); ++h)
      if (blocks_.live(h) && blocks_[h].dying) release_block(h);
  }
  // The views observed since the last cycle become this cycle's; observe() fills the other set meanwhile.
  pending_ = 1 - pending_;
  observed_[pending_].clear();
  num_views_[pending_] = 0;
  const int cycle_set = 1 - pending_;
  // TSDF blocks integrated since they were last read, and those a view of this cycle saw (already read when a
  // cycle that started before their frame read them after it).
  List& dirty = lists_[kDirtyList];
  dirty.clear();
  const int f = config_.voxel_factor;
  tsdf.for_each_block([&](std::uint32_t, const reconstruction::SemanticTsdf::BlockView& view) {
    ++units_;
    const bool viewed = num_views_[cycle_set] > 0 && observed_[cycle_set].find(view.index) != nullptr;
    const memory::Index3 e{floor_div(view.index.x, f), floor_div(view.index.y, f), floor_div(view.index.z, f)};
    if (!block_in_window(e)) return;
    std::uint32_t h = memory::kInvalidHandle;
    if (const std::uint32_t* found = block_index_.find(e)) h = *found;
    else h = allocate_block(tsdf, e, false);  // its TSDF blocks are read (and carved to) in the seed phase
    if (h == memory::kInvalidHandle) return;
    const int sub = (view.index.x - e.x * f) + f * ((view.index.y - e.y * f) + f * (view.index.z - e.z * f));
    const Block& b = blocks_[h];
    if (!b.tsdf_seen[sub] || b.tsdf_stamp[sub] != view.integrated_stamp || viewed)
      dirty.push(h * static_cast<std::uint32_t>(kMaxVoxelFactor * kMaxVoxelFactor * kMaxVoxelFactor) +
                 static_cast<std::uint32_t>(sub));
  });
}

bool Places::observe(const reconstruction::SemanticTsdf& tsdf, const Eigen::Isometry3d& world_T_camera) {
  if (!ready_) return false;
  ++counters_.views_observed;
  observing_ = true;
  const std::uint32_t stamp = tsdf.frame_stamp();
  int& n = num_views_[pending_];
  int k = n;
  if (n > 0 && view_stamp_[pending_][n - 1] == stamp) {
    k = n - 1;  // the same frame again
  } else if (n == kMaxViews) {
    k = kMaxViews - 1;  // every slot used: the newest view takes the last slot (its blocks keep their bit)
    ++counters_.views_merged;
  } else {
    ++n;
  }
  views_m_[pending_][k] = world_T_camera.translation();
  view_stamp_[pending_][k] = stamp;
  const std::uint32_t bit = 1u << k;
  memory::SpatialHash<std::uint32_t>& set = observed_[pending_];
  tsdf.for_each_block([&](std::uint32_t, const reconstruction::SemanticTsdf::BlockView& view) {
    if (view.integrated_stamp != stamp) return;
    bool inserted = false;
    std::uint32_t* mask = set.find_or_insert(view.index, bit, &inserted);
    if (mask == nullptr) ++counters_.observed_refused;
    else if (!inserted) *mask |= bit;
  });
  return true;
}

// ---------------------------------------------------------------------------------------------------------
// Waves

void Places::raise_step(std::uint32_t ref) {
  Voxel& v = vox(ref);
  v.flags &= static_cast<std::uint8_t>(~kInRaise);
  if (is_source(ref)) push_lower(ref);
  for (const Offset& o : kOffsets.o) {
    const std::uint32_t n = neighbor(ref, o.dx, o.dy, o.dz);
    if (n == kNoRef) continue;
    if (is_source(n)) push_lower(n);
  }
}

void Places::lower_step(const reconstruction::SemanticTsdf& tsdf, std::uint32_t ref) {
  Voxel& v = vox(ref);
  v.flags &= static_cast<std::uint8_t>(~kInLower);
  if (!is_source(ref)) return;
  const std::uint32_t parent = v.parent;
  const memory::Index3 pc = coords(parent);
  const float pd = vox(parent).distance_m;
  const memory::Index3 g = coords(ref);
  const float max_d = static_cast<float>(config_.max_distance_m);
  const float s = static_cast<float>(voxel_m_);
  for (const Offset& o : kOffsets.o) {
    const memory::Index3 gn = add(g, o.dx, o.dy, o.dz);
    const float cand = pd + dist_vox(gn, pc) * s;
    if (cand > max_d) continue;
    std::uint32_t n = neighbor(ref, o.dx, o.dy, o.dz);
    if (n == kNoRef) {
      // The wavefront reaches space no ESDF block holds yet: allocate it inside the window.
      const memory::Index3 nb{floor_div(gn.x, kBlockSide), floor_div(gn.y, kBlockSide), floor_div(gn.z, kBlockSide)};
      if (allocate_block(tsdf, nb, true) == memory::kInvalidHandle) continue;
      n = neighbor(ref, o.dx, o.dy, o.dz);
      if (n == kNoRef) continue;
    }
    Voxel& nv = vox(n);
    if (v.state == kFree && nv.parent == kNoRef && !blocks_[n / kBlockVoxels].dying &&
        ((nv.state == kUnobserved && config_.unobserved_is_obstacle &&
          (gn.z + 1) * voxel_m_ <= cycle_robot_m_.z() + config_.unobserved_obstacle_above_m) ||
         nv.state == kOccupied)) {
      // Free space meets space no sensor has seen: a surface may lie right there. The unobserved voxel becomes a
      // frontier seed at distance 0, so distances here are bounded by it (unknown space counts as an obstacle);
      // the GVD ignores frontier basis points (evaluate_gvd), so no sheet forms between a surface and the unknown.
      // Free space right beside space behind a surface (a floor seen only at a grazing angle leaves no band voxel
      // between them) has the surface within a voxel: the occupied voxel is a seed at distance 0, a real one.
      set_parent(n, n, 0.0f);
      push_lower(n);
      ++(nv.state == kOccupied ? counters_.occupied_seeds : counters_.frontier_seeds);
      continue;
    }
    if (nv.state != kFree) continue;
    // An orphan takes a real parent again when the wave offers about its distance (within half a voxel: the same
    // obstacle, re-read, or one as near); its own dependents are refilled first (their lists hang off it).
    const bool adopt = (nv.aux & kOrphan) != 0 && cand <= nv.distance_m + 0.5f * s;
    if (cand + kEps < nv.distance_m || adopt) {
      if ((nv.aux & kOrphan) != 0) raise_dependents(n, false);
      set_parent(n, parent, cand);
      push_lower(n);
      mark_affected(n);
      ++counters_.voxels_updated;
    }
  }
}

}  // namespace qsg::places
