// Repair pass: bridges (Config::bridge_fragments, bridge_*, enclosed_max_voxels, hold_distant_fragments). A
// small fragment of live places is joined to the nearest live place outside it through certified free space
// (a straight segment, else a path search); a fragment nothing can join is held back while it is an enclosed
// pocket or a distant island.
#include "core/places/places_internal.h"

namespace qsg::places {

// A live place whose component of live places is small (GVD pieces under furniture, or cut off by the theta-SMA
// and clearance filters) is joined to the nearest live place outside it whose straight segment stays in observed
// free space. Without it such pieces stay separate components of one free-space region. False-free: the segment
// must be certified by the ESDF voxel by voxel, so no bridge crosses a wall or unobserved space.
void Places::bridge_fragment(std::uint32_t cluster) {
  std::uint32_t members[kMaxBridgeFragment];
  int num = 0;
  members[num++] = cluster;
  const int limit = config_.bridge_max_fragment_places;
  for (int i = 0; i < num; ++i) {
    const Cluster& m = clusters_[members[i]];
    for (int k = 0; k < m.num_edges; ++k) {
      const std::uint32_t o = m.edge_to[k];
      bool seen = false;
      for (int j = 0; j < num && !seen; ++j) seen = members[j] == o;
      if (seen) continue;
      if (num == limit) {
        set_held(cluster, false);  // part of a larger component: nothing to do
        clusters_[cluster].bridge_check = 0;
        return;
      }
      members[num++] = o;
    }
  }
  const double max_len = config_.bridge_max_length_m;
  const int reach = static_cast<int>(std::ceil(max_len / config_.place_resolution_m));
  std::uint32_t best_from = kNoCluster, best_to = kNoCluster;
  double best_d2 = max_len * max_len;
  float best_w = 0.0f;
  bool candidates = false;  // some place outside the fragment is within reach (certified or not)
  for (int i = 0; i < num; ++i) {
    const Cluster& m = clusters_[members[i]];
    if (m.rep == kNoRef || m.num_edges == kMaxClusterEdges) continue;
    for (int dz = -reach; dz <= reach; ++dz)
      for (int dy = -reach; dy <= reach; ++dy)
        for (int dx = -reach; dx <= reach; ++dx) {
          const std::uint32_t* head = cells_.find(add(m.cell, dx, dy, dz));
          for (std::uint32_t x = head != nullptr ? *head : kNoCluster; x != kNoCluster; x = clusters_[x].cell_next) {
            const Cluster& xc = clusters_[x];
            if (xc.state != kLive || xc.rep == kNoRef || xc.num_edges == kMaxClusterEdges) continue;
            const double d2 = (xc.position_m - m.position_m).squaredNorm();
            if (d2 > best_d2 || (d2 == best_d2 && best_to != kNoCluster)) continue;
            bool inside = false;
            for (int j = 0; j < num && !inside; ++j) inside = members[j] == x;
            candidates = candidates || !inside;
            float w = 0.0f;
            if (inside || !segment_clearance(m.position_m, xc.position_m, &w) ||
                static_cast<double>(w) < config_.bridge_min_clearance_m)
              continue;
            best_from = members[i];
            best_to = x;
            best_d2 = d2;
            best_w = w;
          }
        }
  }
  if (best_to == kNoCluster && config_.bridge_path_search) {
    bool interrupted = false;
    best_w = bridge_by_path(members, num, &best_from, &best_to, &interrupted);
    if (interrupted) {
      ++counters_.bridge_searches_cut;  // out of time: bridge_check stays set and the held states as they were
      return;
    }
  }
  if (best_to == kNoCluster) {
    ++counters_.bridges_missing;  // stays flagged: retried next cycle, when more of the map is known
    // Places around, none reachable through free space, and only a few GVD voxels: a pocket enclosed by surfaces.
    std::uint32_t voxels = 0;
    for (int i = 0; i < num; ++i) voxels += clusters_[members[i]].count;
    const bool enclosed = candidates && static_cast<int>(voxels) <= config_.enclosed_max_voxels;
    bool distant = config_.hold_distant_fragments;
    for (int i = 0; i < num && distant; ++i)
      distant = (clusters_[members[i]].position_m - cycle_robot_m_).squaredNorm() > max_len * max_len;
    // Distance holds back only places not yet published: one in the graph stays there when the robot walks away.
    for (int i = 0; i < num; ++i) set_held(members[i], enclosed || (distant && !clusters_[members[i]].synced));
    return;
  }
  clusters_[cluster].bridge_check = 0;
  for (int i = 0; i < num; ++i) set_held(members[i], false);
  if (add_cluster_edge(best_from, best_to, best_w, kEdgeBridge)) ++counters_.bridges_added;
}

// No straight segment certified: a breadth-first search through the ESDF from the fragment's representative
// voxels, over free voxels whose distance is at least bridge_min_clearance_m, at most bridge_max_length_m / voxel
// steps, to the first GVD voxel of a live place outside the fragment (around furniture, past a pillar). Returns
// the bridge's weight (the search's clearance bound, a lower bound of the path's smallest distance) and sets
// from/to; to stays kNoCluster when nothing is reached. Scratch: the affected list (empty in this phase) and the
// kVisited flags, cleared before returning. One search can visit tens of thousands of voxels, so it checks the
// deadline's clock as the cycle's loops do and gives up when it has expired (*interrupted; the fragment is tried
// again next cycle). The work-unit cap is not checked here: lockstep runs stay identical however they are sliced.
float Places::bridge_by_path(const std::uint32_t* members, int num, std::uint32_t* from, std::uint32_t* to,
                             bool* interrupted) {
  *interrupted = false;
  const Deadline* deadline = deadline_;
  const std::uint32_t every =
      deadline == nullptr || deadline->check_every == 0 ? 1 : deadline->check_every;
  List& queue = lists_[kAffectedList];
  queue.clear();
  const float min_d = static_cast<float>(config_.bridge_min_clearance_m);
  const int max_steps = static_cast<int>(std::ceil(config_.bridge_max_length_m / voxel_m_));
  const auto member = [&](std::uint32_t c) {
    for (int j = 0; j < num; ++j)
      if (members[j] == c) return true;
    return false;
  };
  for (int i = 0; i < num; ++i) {
    const std::uint32_t r = clusters_[members[i]].rep;
    if (r == kNoRef || (vox(r).flags & kVisited) != 0 || !queue.push(r)) continue;
    vox(r).flags |= kVisited;  // only voxels in the queue carry the flag, so all of it is cleared below
  }
  std::uint32_t found = kNoCluster;
  std::size_t head = 0;
  for (int step = 0; step < max_steps && found == kNoCluster && !*interrupted && head < queue.size; ++step) {
    const std::size_t layer_end = queue.size;
    for (; head < layer_end && found == kNoCluster && !*interrupted; ++head) {
      const std::uint32_t r = queue.data[head];
      ++units_;
      if (deadline != nullptr && deadline->expired != nullptr && units_ % every == 0 &&
          deadline->expired(deadline->context)) {
        *interrupted = true;
        break;
      }
      for (const Offset& o : kOffsets.o) {
        const std::uint32_t n = neighbor(r, o.dx, o.dy, o.dz);
        if (n == kNoRef) continue;
        Voxel& nv = vox(n);
        if ((nv.flags & kVisited) != 0) continue;
        if ((nv.state != kFree && nv.state != kSeed) || nv.parent == kNoRef || nv.distance_m < min_d) continue;
        const std::uint32_t c = nv.cluster;
        if (c < clusters_.capacity() && clusters_.live(c) && !member(c)) {
          const Cluster& xc = clusters_[c];
          if (xc.state == kLive && xc.rep != kNoRef && xc.num_edges < kMaxClusterEdges) {
            found = c;
            break;
          }
        }
        if (!queue.push(n)) break;  // full (counted by the list): this voxel's neighbours stay unexplored
        nv.flags |= kVisited;
      }
    }
  }
  for (std::size_t k = 0; k < queue.size; ++k) vox(queue.data[k]).flags &= static_cast<std::uint8_t>(~kVisited);
  queue.clear();
  if (*interrupted || found == kNoCluster) return 0.0f;
  // The fragment's place nearest the one reached (with room for one more edge) takes the bridge.
  double best = std::numeric_limits<double>::max();
  for (int i = 0; i < num; ++i) {
    const Cluster& m = clusters_[members[i]];
    if (m.num_edges == kMaxClusterEdges) continue;
    const double d2 = (m.position_m - clusters_[found].position_m).squaredNorm();
    if (d2 < best) {
      best = d2;
      *from = members[i];
    }
  }
  if (best == std::numeric_limits<double>::max()) return 0.0f;
  *to = found;
  ++counters_.bridge_paths;
  return min_d;
}

// Holding a place back (or releasing it) changes what sync() publishes; a released place's held neighbours are
// re-checked, since the component they share is no longer a fragment.
void Places::set_held(std::uint32_t cluster, bool held) {
  Cluster& c = clusters_[cluster];
  if ((c.held != 0) == held) return;
  c.held = held ? 1 : 0;
  c.sync_dirty = 1;
  if (held) return;
  for (int k = 0; k < c.num_edges; ++k)
    if (clusters_[c.edge_to[k]].held) clusters_[c.edge_to[k]].bridge_check = 1;
}

// recompute_edges(): a place's bridges, offered last (they have the lowest priority at the neighbour limit).
void Places::kept_bridge_candidates(std::uint32_t cluster, EdgeCandidates* e) {
  const Cluster& c = clusters_[cluster];
  // Bridges stay while their segment is still certified free (the bridge pass adds them; a fragment that has
  // since joined the rest keeps its bridge as one more free-space edge).
  for (int k = 0; k < c.num_edges; ++k) {
    if (c.edge_free[k] != kEdgeBridge) continue;
    const std::uint32_t x = c.edge_to[k];
    int j = 0;
    while (j < e->n && e->to[j] != x) ++j;
    if (j < e->n || e->n == kMaxClusterEdges) continue;
    const Cluster& xc = clusters_[x];
    float w = 0.0f;
    if (xc.state != kLive || xc.rep == kNoRef ||
        (xc.position_m - c.position_m).norm() > config_.bridge_max_length_m ||
        !segment_clearance(c.position_m, xc.position_m, &w) ||
        static_cast<double>(w) < config_.bridge_min_clearance_m)
      continue;
    e->to[e->n] = x;
    e->weight[e->n] = w;
    e->kind[e->n] = kEdgeBridge;
    ++e->n;
  }
}

}  // namespace qsg::places
