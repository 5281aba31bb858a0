// Inactive places (the paper's reconciliation of revisited places): the index of places that left the window,
// by hash cell, for revivals and for merging revisited places into live ones (Config::merge_revisited_within_m).
#include "core/places/places_internal.h"

namespace qsg::places {

void Places::park_inactive(const memory::Index3& cell, scene_graph::NodeId node) {
  if (inactive_free_ == kNoRef) {
    ++counters_.inactive_forgotten;
    return;
  }
  std::uint32_t* head = inactive_.find_or_insert(cell, kNoRef);
  if (head == nullptr) {  // the cell map is full (counted by the map)
    ++counters_.inactive_forgotten;
    return;
  }
  const std::uint32_t e = inactive_free_;
  inactive_free_ = inactive_entries_[e].next;
  inactive_entries_[e].node = node;
  inactive_entries_[e].next = *head;
  *head = e;
  inactive_high_water_ = std::max(inactive_high_water_, ++inactive_used_);
}

scene_graph::NodeId Places::take_inactive(const memory::Index3& cell) {
  std::uint32_t* head = inactive_.find(cell);
  if (head == nullptr) return scene_graph::kNoNode;
  const std::uint32_t e = *head;
  const scene_graph::NodeId node = inactive_entries_[e].node;
  *head = inactive_entries_[e].next;
  if (*head == kNoRef) inactive_.erase(cell);
  inactive_entries_[e].next = inactive_free_;
  inactive_free_ = e;
  --inactive_used_;
  return node;
}

// Config::merge_revisited_within_m: the inactive places of the 27 cells around a live place that lie within the
// distance and in its free space are merged into it. Index entries of nodes gone from the graph are dropped on
// the way; those of places still active (parked as they left, deactivated by this sync's start) are skipped.
void Places::merge_revisited(scene_graph::SceneGraph* graph, std::uint32_t cluster, SyncResult* r) {
  const Cluster& c = clusters_[cluster];
  const double radius = config_.merge_revisited_within_m;
  const Eigen::Vector3d& p = c.position_m;
  const memory::Index3 home{static_cast<std::int32_t>(std::floor(p.x() / config_.place_resolution_m)),
                            static_cast<std::int32_t>(std::floor(p.y() / config_.place_resolution_m)),
                            static_cast<std::int32_t>(std::floor(p.z() / config_.place_resolution_m))};
  for (int oi = 0; oi <= 26; ++oi) {
    const memory::Index3 cell = oi < 26 ? add(home, kOffsets.o[oi].dx, kOffsets.o[oi].dy, kOffsets.o[oi].dz) : home;
    std::uint32_t* head = inactive_.find(cell);
    if (head == nullptr) continue;
    std::uint32_t* link = head;
    while (*link != kNoRef) {
      const std::uint32_t e = *link;
      const scene_graph::NodeId m = inactive_entries_[e].node;
      const scene_graph::PlaceAttributes* pm = m != c.node ? graph->place(m) : nullptr;
      bool drop = pm == nullptr;  // gone from the graph (or the live node itself): forget it
      if (pm != nullptr && !pm->is_active && (pm->position_m - p).norm() <= radius &&
          same_free_space(pm->position_m, pm->distance_m, p, c.clearance_m)) {
        const scene_graph::SceneGraph::MergeResult mr = graph->merge_into(c.node, m);
        if (mr.status == scene_graph::Status::kOk) {
          ++counters_.revisits_merged;
          counters_.merge_edges_moved += mr.moved;
          ++r->nodes_removed;
          r->edges_removed += mr.dropped + mr.refused;
          if (mr.refused > 0) {
            ++r->refused;
            counters_.graph_refused += mr.refused;
            r->status = scene_graph::Status::kFull;
          }
          drop = true;
        }
      }
      if (!drop) {
        link = &inactive_entries_[e].next;
        continue;
      }
      *link = inactive_entries_[e].next;
      inactive_entries_[e].next = inactive_free_;
      inactive_free_ = e;
      --inactive_used_;
    }
    if (*head == kNoRef) inactive_.erase(cell);
  }
}

}  // namespace qsg::places
