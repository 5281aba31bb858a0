// Places sparsification (the paper's Algorithm 1): GVD voxels clustered per spatial-hash cell of side
// delta_p into connected clusters; each cluster's representative (position, clearance), mesh connections and
// edges to the clusters its voxels touch; the neighbour limit (kMaxClusterEdges) keeps each place's best edges.
#include "core/places/places_internal.h"

namespace qsg::places {

// ---------------------------------------------------------------------------------------------------------
// Clusters

std::uint32_t Places::new_cluster(const memory::Index3& cell) {
  const std::uint32_t h = clusters_.acquire();
  if (h == memory::kInvalidHandle) return h;
  Cluster& c = clusters_[h];
  c.cell = cell;
  // Back in a cell a place left when it went out of the window: the inactive node comes back to life.
  c.revived = 0;
  c.merge_check = 0;
  if (const scene_graph::NodeId old = take_inactive(cell); old != scene_graph::kNoNode) {
    c.node = old;
    c.synced = 1;
    c.revived = 1;
    ++counters_.reactivated;
  } else {
    c.node = scene_graph::make_node_id(scene_graph::kPlacePrefix, next_node_index_++);
  }
  link_cell(h);
  ++clusters_live_;
  counters_.places = clusters_live_;
  return h;
}

// Live clusters per hash cell (an intrusive list headed in cells_): the neighbourhood queries of free-space edges
// and relinks visit 27 cells instead of every cluster.
void Places::link_cell(std::uint32_t cluster) {
  Cluster& c = clusters_[cluster];
  std::uint32_t* head = cells_.find(c.cell);
  c.cell_next = head != nullptr ? *head : kNoCluster;
  if (cells_.insert(c.cell, cluster) == nullptr) c.cell_next = kNoCluster;  // full: counted by the map
}

void Places::unlink_cell(std::uint32_t cluster) {
  Cluster& c = clusters_[cluster];
  std::uint32_t* head = cells_.find(c.cell);
  if (head == nullptr) return;
  if (*head == cluster) {
    if (c.cell_next == kNoCluster) cells_.erase(c.cell);
    else *head = c.cell_next;
  } else {
    for (std::uint32_t h = *head; h != kNoCluster; h = clusters_[h].cell_next)
      if (clusters_[h].cell_next == cluster) {
        clusters_[h].cell_next = c.cell_next;
        break;
      }
  }
  c.cell_next = kNoCluster;
}

void Places::cluster_add_voxel(std::uint32_t cluster, std::uint32_t ref) {
  Voxel& v = vox(ref);
  Cluster& c = clusters_[cluster];
  v.cluster = cluster;
  v.cluster_next = c.head;
  c.head = ref;
  ++c.count;
}

void Places::cluster_remove_voxel(std::uint32_t cluster, std::uint32_t ref) {
  Cluster& c = clusters_[cluster];
  std::uint32_t* link = &c.head;
  while (*link != kNoRef && *link != ref) link = &vox(*link).cluster_next;
  if (*link == ref) {
    *link = vox(ref).cluster_next;
    --c.count;
  }
  Voxel& v = vox(ref);
  v.cluster = kNoCluster;
  v.cluster_next = kNoRef;
  if (c.rep == ref) c.rep = kNoRef;
}

void Places::drop_edge(std::uint32_t cluster, std::uint32_t other) {
  Cluster& c = clusters_[cluster];
  for (int k = 0; k < c.num_edges; ++k) {
    if (c.edge_to[k] != other) continue;
    --c.num_edges;
    c.edge_to[k] = c.edge_to[c.num_edges];
    c.edge_weight[k] = c.edge_weight[c.num_edges];
    c.edge_free[k] = c.edge_free[c.num_edges];
    c.sync_dirty = 1;
    c.bridge_check = 1;
    return;
  }
}

// A cluster without voxels: its node is removed (kRemoved) or kept inactive (kLeft, left the window) by the next
// sync(); the slot waits for that sync unless the node never reached the graph.
void Places::retire_cluster(std::uint32_t cluster, std::uint8_t state) {
  Cluster& c = clusters_[cluster];
  if (c.revived) {
    // It brought its cell's inactive node back but goes before the sync that would check and publish it: the node
    // was never touched, so it returns to its cell as it was. (Removing it would delete a place that another
    // free space, e.g. the floor below, still holds.) A place that leaves the window re-parks it below.
    c.revived = 0;
    if (counters_.reactivated > 0) --counters_.reactivated;
    if (state == kRemoved) {
      park_inactive(c.cell, c.node);
      c.node = scene_graph::kNoNode;
      c.synced = 0;
    }
  }
  for (int k = 0; k < c.num_edges; ++k) drop_edge(c.edge_to[k], cluster);
  c.num_edges = 0;
  unlink_cell(cluster);
  // Members (a merge moves them first) are detached by the caller; clear what is left.
  for (std::uint32_t r = c.head; r != kNoRef;) {
    Voxel& v = vox(r);
    const std::uint32_t next = v.cluster_next;
    v.cluster = kNoCluster;
    v.cluster_next = kNoRef;
    r = next;
  }
  c.head = kNoRef;
  c.count = 0;
  c.rep = kNoRef;
  c.dirty = 0;
  c.state = state;
  if (clusters_live_ > 0) --clusters_live_;
  counters_.places = clusters_live_;
  if (state == kLeft && c.synced) park_inactive(c.cell, c.node);  // refused (counted) when full
  if (!c.synced) clusters_.release(cluster);
}

void Places::merge_clusters(std::uint32_t into, std::uint32_t from) {
  Cluster& a = clusters_[into];
  Cluster& b = clusters_[from];
  std::uint32_t tail = kNoRef;
  for (std::uint32_t r = b.head; r != kNoRef; r = vox(r).cluster_next) {
    vox(r).cluster = into;
    tail = r;
  }
  if (tail != kNoRef) {
    vox(tail).cluster_next = a.head;
    a.head = b.head;
    a.count += b.count;
  }
  b.head = kNoRef;
  b.count = 0;
  if (b.revived && !a.synced) {
    // The merged place takes over the revival (both lie in one hash cell): the next sync checks it from the
    // merged place's position, instead of a fresh node beside the inactive one.
    a.node = b.node;
    a.synced = 1;
    a.revived = 1;
    b.node = scene_graph::kNoNode;
    b.synced = 0;
    b.revived = 0;
  }
  retire_cluster(from, kRemoved);
  a.dirty = 1;
  ++counters_.clusters_merged;
}

// One updated GVD voxel through the paper's Algorithm "Places Sparsification": join a cluster of the same
// hash cell that it touches, or start one; merge the other clusters of the same cell it touches. Edges between
// clusters of different cells are rebuilt from the GVD adjacency when the touched clusters are finalized.
void Places::sparsify_step(std::uint32_t ref) {
  Voxel& v = vox(ref);
  v.flags &= static_cast<std::uint8_t>(~kGvdChanged);
  const bool gvd = (v.flags & kGvd) != 0;
  if (gvd && v.cluster == kNoCluster) {
    const memory::Index3 cell = cell_of(ref);
    std::uint32_t c = kNoCluster;
    for (const Offset& o : kOffsets.o) {
      const std::uint32_t n = neighbor(ref, o.dx, o.dy, o.dz);
      if (n == kNoRef) continue;
      const Voxel& nv = vox(n);
      if ((nv.flags & kGvd) == 0 || nv.cluster >= kSplitPending) continue;
      if (clusters_[nv.cluster].cell == cell) {
        c = nv.cluster;
        break;
      }
    }
    if (c == kNoCluster) {
      c = new_cluster(cell);
      if (c == memory::kInvalidHandle) {
        ++counters_.clusters_refused;
        return;
      }
    }
    cluster_add_voxel(c, ref);
    for (const Offset& o : kOffsets.o) {
      const std::uint32_t n = neighbor(ref, o.dx, o.dy, o.dz);
      if (n == kNoRef) continue;
      const Voxel& nv = vox(n);
      if ((nv.flags & kGvd) == 0 || nv.cluster >= kSplitPending || nv.cluster == c) continue;
      if (clusters_[nv.cluster].cell == cell) merge_clusters(c, nv.cluster);
    }
    clusters_[c].dirty = 1;
  } else if (gvd) {
    if (v.cluster < kSplitPending) clusters_[v.cluster].dirty = 1;
  } else if (v.cluster < kSplitPending) {
    const std::uint32_t c = v.cluster;
    cluster_remove_voxel(c, ref);
    if (clusters_[c].count == 0) retire_cluster(c, kRemoved);
    else clusters_[c].dirty = 1;
  }
}

// A cluster that lost voxels may have fallen apart: its first voxel's component keeps the node, every other
// connected component becomes a new cluster (so each place is one connected piece of the GVD graph).
void Places::split_cluster(const reconstruction::SemanticTsdf& tsdf, std::uint32_t cluster) {
  Cluster& c = clusters_[cluster];
  if (c.count <= 1) return;
  List& stack = lists_[kAffectedList];  // empty in this phase: used as scratch
  List& pending = lists_[kEvalList];
  stack.clear();
  pending.clear();
  std::uint32_t visited = 1;
  vox(c.head).flags |= kVisited;
  stack.push(c.head);
  while (stack.size > 0) {
    const std::uint32_t r = stack.data[--stack.size];
    for (const Offset& o : kOffsets.o) {
      const std::uint32_t n = neighbor(r, o.dx, o.dy, o.dz);
      if (n == kNoRef) continue;
      Voxel& nv = vox(n);
      if (nv.cluster != cluster || (nv.flags & kVisited) != 0) continue;
      nv.flags |= kVisited;
      ++visited;
      stack.push(n);
    }
  }
  if (visited == c.count) {
    for (std::uint32_t r = c.head; r != kNoRef; r = vox(r).cluster_next)
      vox(r).flags &= static_cast<std::uint8_t>(~kVisited);
    return;
  }
  // Keep the visited component; park the rest.
  std::uint32_t* link = &c.head;
  while (*link != kNoRef) {
    Voxel& v = vox(*link);
    if ((v.flags & kVisited) != 0) {
      v.flags &= static_cast<std::uint8_t>(~kVisited);
      link = &v.cluster_next;
    } else {
      const std::uint32_t r = *link;
      *link = v.cluster_next;
      v.cluster = kSplitPending;
      v.cluster_next = kNoRef;
      --c.count;
      pending.push(r);
    }
  }
  if (c.rep != kNoRef && vox(c.rep).cluster != cluster) c.rep = kNoRef;
  for (std::size_t i = 0; i < pending.size; ++i) {
    const std::uint32_t start = pending.data[i];
    if (vox(start).cluster != kSplitPending) continue;
    const std::uint32_t nc = new_cluster(c.cell);
    if (nc == memory::kInvalidHandle) {
      ++counters_.clusters_refused;
      for (std::size_t k = i; k < pending.size; ++k)
        if (vox(pending.data[k]).cluster == kSplitPending) vox(pending.data[k]).cluster = kNoCluster;
      break;
    }
    ++counters_.clusters_split;
    stack.clear();
    cluster_add_voxel(nc, start);
    stack.push(start);
    while (stack.size > 0) {
      const std::uint32_t r = stack.data[--stack.size];
      for (const Offset& o : kOffsets.o) {
        const std::uint32_t n = neighbor(r, o.dx, o.dy, o.dz);
        if (n == kNoRef || vox(n).cluster != kSplitPending) continue;
        cluster_add_voxel(nc, n);
        stack.push(n);
      }
    }
    finalize_cluster(tsdf, nc, false);
  }
  stack.clear();
  pending.clear();
}

// ---------------------------------------------------------------------------------------------------------
// Node attributes

void Places::pick_representative(std::uint32_t cluster) {
  Cluster& c = clusters_[cluster];
  std::uint32_t best = kNoRef;
  for (std::uint32_t r = c.head; r != kNoRef; r = vox(r).cluster_next) {
    if (best == kNoRef) {
      best = r;
      continue;
    }
    const Voxel& v = vox(r);
    const Voxel& b = vox(best);
    if (v.num_basis > b.num_basis || (v.num_basis == b.num_basis && (v.distance_m > b.distance_m ||
                                                                     (v.distance_m == b.distance_m && r < best))))
      best = r;
  }
  c.rep = best;
  if (best == kNoRef) return;
  c.position_m = center_m(coords(best));
  c.clearance_m = vox(best).distance_m;
  c.num_basis = vox(best).num_basis;
}

// Each basis point of the representative voxel connects to the nearest mesh vertex of the TSDF block holding the
// surface point behind it (the seed continued by its own distance, away from the place), else of the seed's block.
void Places::compute_mesh_connections(const reconstruction::SemanticTsdf& tsdf, std::uint32_t cluster) {
  Cluster& c = clusters_[cluster];
  c.connections.clear();
  if (c.rep == kNoRef) return;
  std::uint32_t parents[scene_graph::kMaxPlaceConnections];
  const int n = std::min<int>(
      std::max(0, evaluate_gvd(c.rep, parents, static_cast<int>(scene_graph::kMaxPlaceConnections))),
      static_cast<int>(scene_graph::kMaxPlaceConnections));
  const double block_m = tsdf.block_size_m();
  const Eigen::Vector3d place = center_m(coords(c.rep));
  const auto block_of = [block_m](const Eigen::Vector3d& p) {
    return memory::Index3{static_cast<std::int32_t>(std::floor(p.x() / block_m)),
                          static_cast<std::int32_t>(std::floor(p.y() / block_m)),
                          static_cast<std::int32_t>(std::floor(p.z() / block_m))};
  };
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d seed = center_m(coords(parents[k]));
    const Eigen::Vector3d dir = (seed - place).normalized();
    const Eigen::Vector3d surface = seed + dir * static_cast<double>(vox(parents[k]).distance_m);
    // The block holding the surface point, else the seed's, else any neighbour of the surface's block (the
    // surface may sit in a block without vertices of its own when it lies on a block border).
    const memory::Index3 sb = block_of(surface);
    memory::Index3 candidates[29];
    int num = 0;
    candidates[num++] = sb;
    candidates[num++] = block_of(seed);
    for (const Offset& o : kOffsets.o) candidates[num++] = add(sb, o.dx, o.dy, o.dz);
    bool connected = false;
    for (int ci = 0; ci < num && !connected; ++ci) {
      const memory::Index3& tb = candidates[ci];
      const std::uint32_t th = tsdf.find_block(tb);
      if (th == memory::kInvalidHandle) continue;
      reconstruction::SemanticTsdf::VertexCursor cursor;
      reconstruction::MeshVertex mv;
      double best_d2 = std::numeric_limits<double>::max();
      std::uint32_t best = 0, index = 0;
      bool found = false;
      while (tsdf.next_block_vertex(th, &cursor, &mv, nullptr)) {
        const double d2 = (Eigen::Vector3d(mv.x, mv.y, mv.z) - surface).squaredNorm();
        if (d2 < best_d2) {
          best_d2 = d2;
          best = index;
          found = true;
        }
        ++index;
      }
      if (!found) continue;
      scene_graph::PlaceMeshConnection pc;
      pc.block = tb;
      pc.vertex = best;
      pc.voxel_pos_m = seed;
      c.connections.push_back(pc);
      connected = true;
    }
  }
}

// ---------------------------------------------------------------------------------------------------------
// Free space between places

// Config::revive_in_same_free_space: whether a place at `pb` with clearance `rb` lies in the same free space as the
// inactive place at `pa` with clearance `ra`: their spheres of free space overlap (the union of two overlapping free
// balls is connected free space, and no surface passes between them however thin), or the ESDF certifies the
// segment between them (every voxel on it free).
bool Places::same_free_space(const Eigen::Vector3d& pa, double ra, const Eigen::Vector3d& pb, double rb) const {
  if ((pb - pa).norm() < ra + rb) return true;
  float w = 0.0f;
  return segment_clearance(pa, pb, &w) && w > 0.0f;
}

// The smallest ESDF distance along the segment between two points (sampled every half voxel, both ends
// included, from the lexicographically smaller end so both clusters of an edge compute the same value); false
// when the segment crosses a voxel that holds a surface (distance 0), is occupied, unobserved or outside the
// window.
bool Places::segment_clearance(Eigen::Vector3d pa, Eigen::Vector3d pb, float* min_distance_m) const {
  if (std::lexicographical_compare(pb.data(), pb.data() + 3, pa.data(), pa.data() + 3)) std::swap(pa, pb);
  const int steps = std::max(1, static_cast<int>(std::ceil((pb - pa).norm() / (0.5 * voxel_m_))));
  float best = kUnreached;
  memory::Index3 last{std::numeric_limits<std::int32_t>::min(), 0, 0};
  for (int i = 0; i <= steps; ++i) {
    const Eigen::Vector3d p = (pa + (pb - pa) * (static_cast<double>(i) / steps)) / voxel_m_;
    const memory::Index3 g{static_cast<std::int32_t>(std::floor(p.x())), static_cast<std::int32_t>(std::floor(p.y())),
                           static_cast<std::int32_t>(std::floor(p.z()))};
    if (g == last) continue;
    last = g;
    const std::uint32_t ref = find_voxel(g);
    if (ref == kNoRef) return false;
    const Voxel& v = vox(ref);
    if ((v.state != kFree && v.state != kSeed) || v.parent == kNoRef || !(v.distance_m > 0.0f)) return false;
    best = std::min(best, v.distance_m);
  }
  *min_distance_m = best;
  return true;
}

// ---------------------------------------------------------------------------------------------------------
// Edges

// Edges from the GVD adjacency: cluster A joins cluster B when a voxel of A touches a voxel of B; the weight is
// the smallest clearance among the voxels through which the GVD passes from A to B (the touching pairs). Then the
// repair passes' candidates (free-space edges, kept bridges), and the edges written into both ends.
void Places::recompute_edges(std::uint32_t cluster) {
  const Cluster& c = clusters_[cluster];
  EdgeCandidates candidates;
  gvd_edge_candidates(cluster, &candidates);
  if (config_.free_space_edges && c.rep != kNoRef) free_space_edge_candidates(cluster, &candidates);
  if (config_.bridge_fragments && c.rep != kNoRef) kept_bridge_candidates(cluster, &candidates);
  write_edges(cluster, candidates);
}

// The neighbour limit: a candidate past kMaxClusterEdges replaces the worst one held if it is better (edge_better),
// else it is pruned; either way one candidate is not kept (Counters::edges_pruned).
void Places::offer_edge(const Cluster& c, EdgeCandidates* e, std::uint32_t x, float w, std::uint8_t kind) {
  const double d2 = (clusters_[x].position_m - c.position_m).squaredNorm();
  if (e->n < kMaxClusterEdges) {
    e->to[e->n] = x;
    e->weight[e->n] = w;
    e->kind[e->n] = kind;
    ++e->n;
    return;
  }
  ++counters_.edges_pruned;
  int worst = 0;
  double worst_d2 = (clusters_[e->to[0]].position_m - c.position_m).squaredNorm();
  for (int k = 1; k < e->n; ++k) {
    const double dk = (clusters_[e->to[k]].position_m - c.position_m).squaredNorm();
    if (edge_better(e->kind[worst], worst_d2, e->kind[k], dk)) {
      worst = k;
      worst_d2 = dk;
    }
  }
  if (!edge_better(kind, d2, e->kind[worst], worst_d2)) return;
  e->to[worst] = x;
  e->weight[worst] = w;
  e->kind[worst] = kind;
}

void Places::gvd_edge_candidates(std::uint32_t cluster, EdgeCandidates* e) {
  const Cluster& c = clusters_[cluster];
  for (std::uint32_t r = c.head; r != kNoRef; r = vox(r).cluster_next) {
    const Voxel& v = vox(r);
    for (const Offset& o : kOffsets.o) {
      const std::uint32_t nr = neighbor(r, o.dx, o.dy, o.dz);
      if (nr == kNoRef) continue;
      const Voxel& nv = vox(nr);
      if ((nv.flags & kGvd) == 0 || nv.cluster >= kSplitPending || nv.cluster == cluster) continue;
      const float w = std::min(v.distance_m, nv.distance_m);
      int k = 0;
      while (k < e->n && e->to[k] != nv.cluster) ++k;
      if (k < e->n) {
        e->weight[k] = std::min(e->weight[k], w);
      } else {
        offer_edge(c, e, nv.cluster, w, kEdgeGvd);
      }
    }
  }
}

// Drops the edges that are gone (from both ends), then writes the candidates into both ends; the other end at its
// limit makes room for a better edge (make_room) or the candidate is pruned at both ends.
void Places::write_edges(std::uint32_t cluster, const EdgeCandidates& candidates) {
  Cluster& c = clusters_[cluster];
  const EdgeCandidates* e = &candidates;
  // Drop the edges that are gone (from both ends), then write the others into both ends.
  for (int k = c.num_edges - 1; k >= 0; --k) {
    const std::uint32_t other = c.edge_to[k];
    bool kept = false;
    for (int j = 0; j < e->n && !kept; ++j) kept = e->to[j] == other;
    if (!kept) drop_edge(other, cluster);
  }
  int kept = 0;
  for (int j = 0; j < e->n; ++j) {
    Cluster& o = clusters_[e->to[j]];
    int k = 0;
    while (k < o.num_edges && o.edge_to[k] != cluster) ++k;
    if (k == o.num_edges) {
      if (o.num_edges == kMaxClusterEdges &&
          !make_room(e->to[j], e->kind[j], (o.position_m - c.position_m).squaredNorm())) {
        ++counters_.edges_pruned;
        continue;  // the other end holds better edges: not kept at either end (the lists stay symmetric)
      }
      k = o.num_edges;
      o.edge_to[k] = cluster;
      ++o.num_edges;
      o.bridge_check = 1;
      o.edge_weight[k] = e->weight[j];
      o.edge_free[k] = e->kind[j];
      o.sync_dirty = 1;
    } else if (o.edge_weight[k] != e->weight[j] || o.edge_free[k] != e->kind[j]) {
      o.edge_weight[k] = e->weight[j];
      o.edge_free[k] = e->kind[j];
      o.sync_dirty = 1;
    }
    c.edge_to[kept] = e->to[j];
    c.edge_weight[kept] = e->weight[j];
    c.edge_free[kept] = e->kind[j];
    ++kept;
  }
  c.num_edges = static_cast<std::uint8_t>(kept);
}

// The other end of a new edge is at the neighbour limit: its worst edge gives way (dropped at both of its ends) if
// the new one is better; false when every edge it holds is at least as good.
bool Places::make_room(std::uint32_t cluster, std::uint8_t kind, double d2) {
  Cluster& c = clusters_[cluster];
  int worst = -1;
  double worst_d2 = 0.0;
  for (int k = 0; k < c.num_edges; ++k) {
    const double dk = (clusters_[c.edge_to[k]].position_m - c.position_m).squaredNorm();
    if (worst < 0 || edge_better(c.edge_free[worst], worst_d2, c.edge_free[k], dk)) {
      worst = k;
      worst_d2 = dk;
    }
  }
  if (worst < 0 || !edge_better(kind, d2, c.edge_free[worst], worst_d2)) return false;
  const std::uint32_t other = c.edge_to[worst];
  drop_edge(cluster, other);
  drop_edge(other, cluster);
  ++counters_.edges_pruned;
  return true;
}

void Places::finalize_cluster(const reconstruction::SemanticTsdf& tsdf, std::uint32_t cluster, bool split_check) {
  clusters_[cluster].dirty = 0;
  if (split_check) split_cluster(tsdf, cluster);
  pick_representative(cluster);
  compute_mesh_connections(tsdf, cluster);
  recompute_edges(cluster);
  clusters_[cluster].sync_dirty = 1;
  clusters_[cluster].bridge_check = 1;
}

bool Places::add_cluster_edge(std::uint32_t a, std::uint32_t b, float weight_m, std::uint8_t kind) {
  Cluster& ca = clusters_[a];
  Cluster& cb = clusters_[b];
  for (int k = 0; k < ca.num_edges; ++k)
    if (ca.edge_to[k] == b) return false;
  if (ca.num_edges == kMaxClusterEdges || cb.num_edges == kMaxClusterEdges) {
    ++counters_.edges_refused;
    return false;
  }
  ca.edge_to[ca.num_edges] = b;
  ca.edge_weight[ca.num_edges] = weight_m;
  ca.edge_free[ca.num_edges] = kind;
  ++ca.num_edges;
  cb.edge_to[cb.num_edges] = a;
  cb.edge_weight[cb.num_edges] = weight_m;
  cb.edge_free[cb.num_edges] = kind;
  ++cb.num_edges;
  ca.sync_dirty = 1;
  cb.sync_dirty = 1;
  ca.bridge_check = 1;
  cb.bridge_check = 1;
  return true;
}

}  // namespace qsg::places
