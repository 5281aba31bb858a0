// The scene-graph mirror: sync() adds, updates, deactivates and removes the place nodes and edges that changed
// since the last sync, then runs the passes that work on the graph (revisit merging, relinks, contraction).
#include "core/places/places_internal.h"

namespace qsg::places {

// A graph write refused for another reason than a full store: counted in graph_errors, logged 1st, 2nd, 4th, ...
void log_graph_error(const char* what, scene_graph::Status status, std::uint64_t n) {
  if ((n & (n - 1)) == 0)
    std::fprintf(stderr, "places: the scene graph refused %s (%s), not for want of room; %llu so far\n", what,
                 scene_graph::to_string(status), static_cast<unsigned long long>(n));
}

// A graph write refused by a full store: counted (Counters::graph_refused, SyncResult::refused) and logged 1st,
// 2nd, 4th, ...; the place stays sync_dirty, so it is retried on the next sync.
void Places::refuse_graph_write(SyncResult* r, const char* what) {
  ++r->refused;
  ++counters_.graph_refused;
  r->status = scene_graph::Status::kFull;
  const std::uint64_t n = counters_.graph_refused;
  if ((n & (n - 1)) == 0)  // 1, 2, 4, ...: bounded logging
    std::fprintf(stderr, "places: scene graph %s store full; refused %llu so far (retried on the next sync)\n",
                 what, static_cast<unsigned long long>(n));
}

// A repair pass's edge (a relink, a contraction) into the graph: a full store is a counted refusal (the app sees it
// in graph_refused), any other refusal a logged graph error. True when the edge was added.
bool Places::add_repair_edge(scene_graph::SceneGraph* graph, scene_graph::NodeId a, scene_graph::NodeId b,
                             double weight_m, const char* what, SyncResult* r) {
  scene_graph::EdgeAttributes info;
  info.weighted = true;
  info.weight = weight_m;
  const bool full = graph->num_edges() >= graph->capacities().edges;
  const scene_graph::Status st = full ? scene_graph::Status::kFull : graph->add_edge(a, b, info);
  if (st == scene_graph::Status::kOk) {
    ++r->edges_added;
    return true;
  }
  if (st == scene_graph::Status::kFull) {
    if (full) graph->count_refused_edge();  // else the store counted it itself
    ++r->refused;
    ++counters_.graph_refused;
    r->status = scene_graph::Status::kFull;
  } else {
    log_graph_error(what, st, ++counters_.graph_errors);
  }
  return false;
}

void Places::for_each_published(void (*fn)(void*, scene_graph::NodeId, const Eigen::Vector3d&),
                                void* context) const {
  for (std::uint32_t h = 0; h < clusters_.capacity(); ++h) {
    if (!clusters_.live(h)) continue;
    const Cluster& c = clusters_[h];
    if (c.state == kLive && c.synced) fn(context, c.node, c.position_m);
  }
}

// The spine of the mirror: retired places first (inactive or removed, with the repairs a removal needs), then
// nodes (so every edge finds both ends), then edges, then the passes on the graph: revisit merging and relinks.
SyncResult Places::sync(scene_graph::SceneGraph* graph) {
  SyncResult r;
  if (!ready_ || graph == nullptr || !graph->initialized()) {
    r.status = scene_graph::Status::kMissingNode;
    return r;
  }
  sync_retired(graph, &r);
  sync_nodes(graph, &r);
  sync_edges(graph, &r);
  if (config_.merge_revisited_within_m > 0.0) {
    for (std::uint32_t h = 0; h < clusters_.capacity(); ++h) {
      if (!clusters_.live(h)) continue;
      Cluster& c = clusters_[h];
      if (c.state == kLive && c.merge_check && c.synced) merge_revisited(graph, h, &r);
      c.merge_check = 0;
    }
  }
  resolve_relinks(graph, &r);
  return r;
}

void Places::sync_retired(scene_graph::SceneGraph* graph, SyncResult* r) {
  // Retired clusters: places that left the window stay, inactive; removed places leave the graph. The first go
  // inactive before any removal, and the nodes this sync removes are listed (sorted), so the contraction counts
  // neither as a place that anchors an inactive one in the active graph.
  scene_graph::NodeId removing[kMaxRemovingPerSync];
  std::size_t num_removing = 0;
  for (std::uint32_t h = 0; h < clusters_.capacity(); ++h) {
    if (!clusters_.live(h)) continue;
    Cluster& c = clusters_[h];
    if (c.state == kLeft) {
      if (scene_graph::PlaceAttributes* p = graph->place(c.node)) {
        p->is_active = false;
        ++r->nodes_deactivated;
      }
      clusters_.release(h);
    } else if (c.state == kRemoved && c.synced && num_removing < kMaxRemovingPerSync) {
      removing[num_removing++] = c.node;  // beyond the array: still removed, only counted as a possible anchor
    }
  }
  std::sort(removing, removing + num_removing);
  for (std::uint32_t h = 0; h < clusters_.capacity(); ++h) {
    if (!clusters_.live(h)) continue;
    Cluster& c = clusters_[h];
    if (c.state == kRemoved) {
      if (config_.relink_inactive && c.synced) park_relinks(graph, c);  // its edges to inactive places
      if (config_.contract_removed && c.synced) contract_around(graph, c.node, removing, num_removing, r);
      if (graph->remove_node(c.node)) ++r->nodes_removed;
      clusters_.release(h);
    }
  }
}

// Adds or updates the nodes of live places that changed (a revived node only from its own free space; a held
// place withdrawn).
void Places::sync_nodes(scene_graph::SceneGraph* graph, SyncResult* r) {
  const scene_graph::Capacities& gc = graph->capacities();
  for (std::uint32_t h = 0; h < clusters_.capacity(); ++h) {
    if (!clusters_.live(h)) continue;
    Cluster& c = clusters_[h];
    if (c.state != kLive || !c.sync_dirty || c.rep == kNoRef) continue;
    if (c.revived) {
      // Config::revive_in_same_free_space: the inactive node came back only if it left from the same free space.
      c.revived = 0;
      const scene_graph::PlaceAttributes* old = graph->place(c.node);
      if (config_.revive_in_same_free_space && old != nullptr && !old->is_active &&
          !same_free_space(old->position_m, old->distance_m, c.position_m, c.clearance_m)) {
        park_inactive(c.cell, c.node);  // stays inactive where it was; a later place of the cell may revive it
        c.node = scene_graph::make_node_id(scene_graph::kPlacePrefix, next_node_index_++);
        c.synced = 0;
        --counters_.reactivated;
        ++counters_.revivals_refused;
      }
    }
    if (c.held) {
      // An enclosed pocket: not published; withdrawn if it was (unless inactive places hang on it).
      if (c.synced) {
        bool linked = false;
        graph->for_each_neighbor(c.node, [&](scene_graph::NodeId m, const scene_graph::EdgeRecord&) {
          const scene_graph::PlaceAttributes* pm =
              scene_graph::node_prefix(m) == scene_graph::kPlacePrefix ? graph->place(m) : nullptr;
          linked = linked || (pm != nullptr && !pm->is_active);
        });
        if (linked) {
          c.sync_dirty = 0;
          continue;
        }
        if (graph->remove_node(c.node)) ++r->nodes_removed;
        c.synced = 0;
      }
      c.sync_dirty = 0;
      continue;
    }
    scene_graph::PlaceAttributes attrs;
    attrs.position_m = c.position_m;
    attrs.is_active = true;
    attrs.distance_m = c.clearance_m;
    attrs.num_basis_points = c.num_basis;
    attrs.mesh_connections = c.connections;
    if (scene_graph::PlaceAttributes* p = graph->place(c.node)) {
      attrs.last_update_time_ns = p->last_update_time_ns;
      *p = attrs;
      ++r->nodes_updated;
      c.synced = 1;
      c.merge_check = 1;
      continue;
    }
    // Checked here so a full graph is a counted refusal in every build (the store's own policy may abort).
    if (graph->num_nodes(scene_graph::NodeKind::kPlace) >= gc.place_nodes || graph->num_nodes() >= gc.nodes()) {
      graph->count_refused_node(scene_graph::NodeKind::kPlace);  // shown under the store's own name
      refuse_graph_write(r, "place node");
      continue;
    }
    const scene_graph::Status st = graph->add_place(c.node, attrs);
    if (st == scene_graph::Status::kOk) {
      ++r->nodes_added;
      c.synced = 1;
      c.merge_check = 1;
    } else if (st == scene_graph::Status::kFull) {
      refuse_graph_write(r, "place node");
    } else {
      log_graph_error("a place node", st, ++counters_.graph_errors);
    }
  }
}

// Writes the edges of live places that changed, and removes those to active places that are no longer neighbours.
void Places::sync_edges(scene_graph::SceneGraph* graph, SyncResult* r) {
  const scene_graph::Capacities& gc = graph->capacities();
  for (std::uint32_t h = 0; h < clusters_.capacity(); ++h) {
    if (!clusters_.live(h)) continue;
    Cluster& c = clusters_[h];
    if (c.state != kLive || !c.sync_dirty || !c.synced) continue;
    bool complete = true;
    // Remove graph edges to active places that are no longer neighbours (edges to inactive places stay, and so do
    // edges with an end at the window's rim: Config::keep_edges_at_rim_m).
    const bool c_at_rim = at_window_rim(c.position_m);
    for (;;) {
      scene_graph::NodeId stale[32];
      int num_stale = 0;
      graph->for_each_neighbor(c.node, [&](scene_graph::NodeId m, const scene_graph::EdgeRecord&) {
        if (num_stale == 32 || scene_graph::node_prefix(m) != scene_graph::kPlacePrefix) return;
        const scene_graph::PlaceAttributes* pm = graph->place(m);
        if (pm == nullptr || !pm->is_active) return;
        for (int k = 0; k < c.num_edges; ++k)
          if (clusters_[c.edge_to[k]].node == m) return;
        if (c_at_rim || at_window_rim(pm->position_m)) {
          ++counters_.edges_kept_at_rim;
          return;
        }
        stale[num_stale++] = m;
      });
      for (int k = 0; k < num_stale; ++k)
        if (graph->remove_edge(c.node, stale[k])) ++r->edges_removed;
      if (num_stale < 32) break;
    }
    for (int k = 0; k < c.num_edges; ++k) {
      const Cluster& o = clusters_[c.edge_to[k]];
      if (!o.synced) {
        complete = false;
        continue;
      }
      const double w = c.edge_weight[k];
      if (scene_graph::EdgeAttributes* info = graph->edge_info(c.node, o.node)) {
        if (info->weight != w || !info->weighted) {
          info->weight = w;
          info->weighted = true;
          ++r->edges_updated;
        }
        continue;
      }
      if (graph->num_edges() >= gc.edges) {
        graph->count_refused_edge();
        refuse_graph_write(r, "edge");
        complete = false;
        continue;
      }
      scene_graph::EdgeAttributes info;
      info.weight = w;
      info.weighted = true;
      const scene_graph::Status st = graph->add_edge(c.node, o.node, info);
      if (st == scene_graph::Status::kOk) {
        ++r->edges_added;
      } else {
        if (st == scene_graph::Status::kFull) refuse_graph_write(r, "edge");  // the full store counted it itself
        else log_graph_error("a place edge", st, ++counters_.graph_errors);
        complete = false;
      }
    }
    if (complete) c.sync_dirty = 0;
  }
}

}  // namespace qsg::places
