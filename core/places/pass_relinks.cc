// Repair pass: relinks (Config::relink_inactive, relink_in_same_free_space). A removed place's edges to inactive
// places move to the live place that replaces it, in the same free space.
#include "core/places/places_internal.h"

namespace qsg::places {

// A removed place's edges to inactive places would vanish with it: they are parked (at most pending_relinks) for
// the live place that replaces it.
void Places::park_relinks(scene_graph::SceneGraph* graph, const Cluster& c) {
  graph->for_each_neighbor(c.node, [&](scene_graph::NodeId m, const scene_graph::EdgeRecord& e) {
    if (scene_graph::node_prefix(m) != scene_graph::kPlacePrefix) return;
    const scene_graph::PlaceAttributes* pm = graph->place(m);
    if (pm == nullptr || pm->is_active) return;
    if (num_relinks_ == capacities_.pending_relinks) {
      ++counters_.relinks_refused;
      return;
    }
    Relink& l = relinks_[num_relinks_++];
    relinks_high_water_ = std::max(relinks_high_water_, num_relinks_);
    l.inactive = m;
    l.position_m = c.position_m;
    l.clearance_m = c.clearance_m;
    l.weight_m = e.info.weighted ? static_cast<float>(e.info.weight) : c.clearance_m;
    l.cell = c.cell;
  });
}

// The live, synced place of the cell or a neighbouring cell nearest to a removed place, among those whose
// sphere of free space overlaps the removed place's (so the two spheres' union joins them through free space).
std::uint32_t Places::replacement_for(const Eigen::Vector3d& position_m, double clearance_m,
                                      const memory::Index3& cell) const {
  std::uint32_t best = kNoCluster;
  double best_d2 = std::numeric_limits<double>::max();
  for (int oi = 0; oi <= 26; ++oi) {
    const memory::Index3 nc = oi < 26 ? add(cell, kOffsets.o[oi].dx, kOffsets.o[oi].dy, kOffsets.o[oi].dz) : cell;
    const std::uint32_t* head = cells_.find(nc);
    for (std::uint32_t x = head != nullptr ? *head : kNoCluster; x != kNoCluster; x = clusters_[x].cell_next) {
      const Cluster& xc = clusters_[x];
      if (xc.state != kLive || !xc.synced || xc.rep == kNoRef) continue;
      const double reach = clearance_m + static_cast<double>(xc.clearance_m);
      const double d2 = (xc.position_m - position_m).squaredNorm();
      float w = 0.0f;
      if (d2 >= reach * reach || d2 >= best_d2 || !segment_clearance(position_m, xc.position_m, &w)) continue;
      best = x;
      best_d2 = d2;
    }
  }
  return best;
}

// Moves the parked edges of removed places to their replacements; an edge waits while the removed place's
// position is inside the window (its replacement may appear in a later cycle) and is dropped after.
void Places::resolve_relinks(scene_graph::SceneGraph* graph, SyncResult* r) {
  std::size_t kept = 0;
  for (std::size_t i = 0; i < num_relinks_; ++i) {
    const Relink l = relinks_[i];
    const scene_graph::PlaceAttributes* pi = graph->place(l.inactive);
    if (pi == nullptr || pi->is_active) continue;  // gone, or back in the window with edges of its own
    std::uint32_t x = replacement_for(l.position_m, l.clearance_m, l.cell);
    if (x != kNoCluster && config_.relink_in_same_free_space &&
        !same_free_space(pi->position_m, pi->distance_m, clusters_[x].position_m, clusters_[x].clearance_m)) {
      ++counters_.relinks_apart;  // waits for another replacement, or is dropped as below
      x = kNoCluster;
    }
    if (x != kNoCluster && clusters_[x].node == l.inactive) {
      ++counters_.relinked;  // the place is its own replacement (it came back as the cluster): nothing to join
      continue;
    }
    if (x != kNoCluster) {
      const Cluster& xc = clusters_[x];
      const double weight = std::min({static_cast<double>(l.weight_m), static_cast<double>(l.clearance_m),
                                      static_cast<double>(xc.clearance_m)});
      if (graph->edge_info(l.inactive, xc.node) == nullptr &&
          !add_repair_edge(graph, l.inactive, xc.node, weight, "a relink edge", r)) {
        relinks_[kept++] = l;  // retried on the next sync
        continue;
      }
      ++counters_.relinked;
      continue;
    }
    const memory::Index3 g{static_cast<std::int32_t>(std::floor(l.position_m.x() / voxel_m_)),
                           static_cast<std::int32_t>(std::floor(l.position_m.y() / voxel_m_)),
                           static_cast<std::int32_t>(std::floor(l.position_m.z() / voxel_m_))};
    if (find_voxel(g) != kNoRef) relinks_[kept++] = l;
    else ++counters_.relinks_dropped;
  }
  num_relinks_ = kept;
}

}  // namespace qsg::places
