// ObjectLayer's configuration: the per-label table (which labels make objects, their tolerance and sizes), the
// checks and prints of Config, Capacities and Counters, and the budget table's capacities.
#include "core/objects/object_layer_internal.h"

#include "budgets/budget_table.h"
#include "core/objects/objects_params.h"

namespace qsg::objects {

namespace {

bool is_large(semantics::Label l) {
  using namespace semantics;
  switch (l) {
    case kTable: case kCabinet: case kSofa: case kBed: case kChestOfDrawers: case kShower: case kBathtub:
    case kCounter: case kFireplace: case kShelving: case kGymEquipment: case kSeating: case kFurniture:
      return true;
    default:
      return false;
  }
}
bool is_small(semantics::Label l) {
  using namespace semantics;
  switch (l) {
    case kPicture: case kCushion: case kPlant: case kTowel: case kLighting: case kClothes: case kObjects:
    case kMirror: case kTvMonitor: case kBoardPanel:
      return true;
    default:
      return false;
  }
}

}  // namespace


LabelTable default_label_params() {
  LabelTable t{};
  for (semantics::Label l = 0; l < semantics::kNumObjectLabels; ++l) {
    LabelParams& p = t[l];
    p.enabled = !semantics::is_structure(l);
    p.tolerance_m = 0.2;
    p.min_vertices = is_small(l) ? 8 : 20;
    p.max_vertices = is_large(l) ? 200000 : 50000;
  }
  t[semantics::kBed].max_size_m = 2.3;
  t[semantics::kTable].max_size_m = 2.4;
  return t;
}

std::string Config::check() const {
  // The scalar settings within their declared ranges (objects_params.cc); then the per-label table, kept in code.
  if (std::string why = params::check(params_table(), *this); !why.empty()) return why;
  char buf[160];
  for (semantics::Label l = 0; l < semantics::kNumObjectLabels; ++l) {
    const LabelParams& p = labels[l];
    const char* name = semantics::object_label(l).name;
    if (p.enabled && semantics::is_structure(l)) {
      std::snprintf(buf, sizeof(buf), "labels[%u] (%s): a structure label never becomes an object", l, name);
      return buf;
    }
    if (!(p.tolerance_m >= 0.05 && p.tolerance_m <= 2.0)) {
      std::snprintf(buf, sizeof(buf), "labels[%u] (%s).tolerance_m must be in [0.05, 2] m", l, name);
      return buf;
    }
    if (p.min_vertices < 1 || p.max_vertices < p.min_vertices) {
      std::snprintf(buf, sizeof(buf), "labels[%u] (%s): need 1 <= min_vertices <= max_vertices", l, name);
      return buf;
    }
    if (!(p.max_size_m >= 0.0 && p.max_size_m <= 20.0)) {
      std::snprintf(buf, sizeof(buf), "labels[%u] (%s).max_size_m must be in [0, 20] m (0: no size prior)", l, name);
      return buf;
    }
  }
  return {};
}

void Config::print(std::FILE* out) const {
  std::fprintf(out,
               "objects: merge_overlapping=%d merge_intersecting=%d merge_by_size_prior=%d index_cell_m=%.2f "
               "max_keys_per_object=%u archive_after_s=%.1f archive_below_use=%.2f finish_keeps_concurrent_apart=%d; "
               "enabled labels (tolerance_m, min..max vertices[, max_size_m]):",
               merge_overlapping ? 1 : 0, merge_intersecting ? 1 : 0, merge_by_size_prior ? 1 : 0, index_cell_m,
               max_keys_per_object, archive_after_s, archive_below_use, finish_keeps_concurrent_apart ? 1 : 0);
  for (semantics::Label l = 0; l < semantics::kNumObjectLabels; ++l) {
    const LabelParams& p = labels[l];
    if (!p.enabled) continue;
    std::fprintf(out, " %s(%.2f,%u..%u", semantics::object_label(l).name, p.tolerance_m, p.min_vertices,
                 p.max_vertices);
    if (p.max_size_m > 0.0) std::fprintf(out, ",%.2f", p.max_size_m);
    std::fprintf(out, ")");
  }
  std::fprintf(out, "\n");
}

std::string Capacities::check() const {
  if (cluster_vertices == 0) return "cluster_vertices must be positive";
  if (tracked_vertices == 0) return "tracked_vertices must be positive";
  if (vertex_keys < ObjectLayer::kKeysPerChunk) return "vertex_keys must be at least 15";
  if (tracked_blocks == 0) return "tracked_blocks must be positive";
  if (objects == 0) return "objects must be positive";
  if (vertex_keys > std::numeric_limits<std::uint32_t>::max() / 2)
    return "vertex_keys too large for 32-bit mesh connections";
  return {};
}

void Capacities::print(std::FILE* out) const {
  std::fprintf(out,
               "objects capacities: cluster_vertices %zu, tracked_vertices %zu, vertex_keys %zu, tracked_blocks %zu, "
               "objects %zu\n",
               cluster_vertices, tracked_vertices, vertex_keys, tracked_blocks, objects);
}

Capacities capacities_from_budget() {
  namespace b = budgets::active::objects;
  Capacities c;
  c.cluster_vertices = b::kClusterVertices;
  c.tracked_vertices = b::kTrackedVertices;
  c.vertex_keys = b::kVertexKeys;
  c.tracked_blocks = b::kTrackedBlocks;
  c.objects = b::kObjects;
  return c;
}

void Counters::print(std::FILE* out) const {
  std::fprintf(
      out,
      "objects: updates=%" PRIu64 " presented=%" PRIu64 " candidates=%" PRIu64 " clusters=%" PRIu64
      " (too_small=%" PRIu64 " too_large=%" PRIu64 " joined=%" PRIu64 " overlap_merged=%" PRIu64
      ") objects created=%" PRIu64 " merged=%" PRIu64 " (overlap %" PRIu64 " intersect %" PRIu64 " size %" PRIu64
      ") archived_kept_apart=%" PRIu64 " archived_merged_full=%" PRIu64 " removed=%" PRIu64 " index queries=%" PRIu64
      " (scans %" PRIu64 ", visits %" PRIu64 ") boxes_recomputed=%" PRIu64 " vertices stale=%" PRIu64
      " released=%" PRIu64 " blocks released=%" PRIu64 " keys repeated=%" PRIu64 " capped=%" PRIu64
      " resampled=%" PRIu64 " overflow: candidate=%" PRIu64 " tracked=%" PRIu64 " key=%" PRIu64 " block=%" PRIu64
      " object=%" PRIu64 " graph_node=%" PRIu64 " graph_connection=%" PRIu64 "\n",
      updates, vertices_presented, candidates, clusters, clusters_too_small, clusters_too_large, clusters_joined,
      clusters_overlap_merged, objects_created, objects_merged, objects_overlap_merged, objects_intersect_merged,
      objects_size_merged, archived_kept_apart, archived_merged_full, objects_removed, index_queries, index_scans,
      index_visits, boxes_recomputed, vertices_stale, vertices_released, blocks_released, keys_repeated, keys_capped,
      keys_resampled, candidate_overflow, tracked_overflow, key_overflow, block_overflow, object_overflow,
      graph_node_failures, graph_connection_failures);
}

}  // namespace qsg::objects
