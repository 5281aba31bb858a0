// places::Config's check and print (both from its table, places_params.cc), the printed capacities, counters and
// memory use, and the budget table's capacities.
#include "core/places/places_internal.h"

#include "budgets/budget_table.h"
#include "core/places/places_params.h"

namespace qsg::places {

std::string Config::check() const {
  // Each field within its declared range (places_params.cc), then the rules between fields.
  if (std::string why = params::check(params_table(), *this); !why.empty()) return why;
  if (!(min_clearance_m < max_distance_m)) return "min_clearance_m must be below max_distance_m";
  if (!(slab_below_m + slab_above_m > 0.0)) return "slab_below_m and slab_above_m must not both be 0";
  if (!(keep_edges_at_rim_m < window_radius_m))
    return "keep_edges_at_rim_m must be below window_radius_m (at or beyond the radius, no edge would ever go)";
  if (!(merge_revisited_within_m <= place_resolution_m))
    return "merge_revisited_within_m must be at most place_resolution_m (the merge searches the neighbouring cells)";
  return {};
}

void Config::print(std::FILE* out) const {
  params::print(params::sections_of("places", params_table()), this, out);  // every field, from the table
}

void Capacities::print(std::FILE* out) const {
  std::fprintf(out,
               "places capacities: max_blocks=%zu place_nodes=%zu inactive_cells=%zu observed_blocks=%zu "
               "pending_relinks=%zu\n",
               max_blocks, place_nodes, inactive_cells, observed_blocks, pending_relinks);
}

void Counters::print(std::FILE* out) const {
  std::fprintf(out,
               "places: updates=%llu cycles=%llu tsdf_blocks_read=%llu voxels updated=%llu raised=%llu orphaned=%llu "
               "frontier_seeds=%llu "
               "occupied_seeds=%llu blocks "
               "allocated=%llu freed=%llu refused=%llu gvd_voxels=%llu places=%llu merged=%llu split=%llu "
               "refused clusters=%llu edges=%llu graph=%llu free_space_edges=%llu relinked=%llu "
               "relinks_dropped=%llu relinks_refused=%llu views=%llu views_merged=%llu observed_refused=%llu "
               "rays=%llu bridges=%llu bridges_added=%llu bridge_paths=%llu bridge_searches_cut=%llu bridges_missing=%llu "
               "contracted=%llu enclosed_held=%llu reactivated=%llu revivals_refused=%llu edges_kept_at_rim=%llu "
               "relinks_apart=%llu edges_pruned=%llu\n",
               (unsigned long long)updates, (unsigned long long)cycles, (unsigned long long)tsdf_blocks_read,
               (unsigned long long)voxels_updated, (unsigned long long)voxels_raised,
               (unsigned long long)voxels_orphaned, (unsigned long long)frontier_seeds, (unsigned long long)occupied_seeds,
               (unsigned long long)blocks_allocated, (unsigned long long)blocks_freed,
               (unsigned long long)blocks_refused, (unsigned long long)gvd_voxels, (unsigned long long)places,
               (unsigned long long)clusters_merged, (unsigned long long)clusters_split,
               (unsigned long long)clusters_refused, (unsigned long long)edges_refused,
               (unsigned long long)graph_refused, (unsigned long long)free_space_edges,
               (unsigned long long)relinked, (unsigned long long)relinks_dropped, (unsigned long long)relinks_refused,
               (unsigned long long)views_observed, (unsigned long long)views_merged,
               (unsigned long long)observed_refused, (unsigned long long)rays_carved, (unsigned long long)bridges,
               (unsigned long long)bridges_added, (unsigned long long)bridge_paths,
               (unsigned long long)bridge_searches_cut, (unsigned long long)bridges_missing,
               (unsigned long long)contracted, (unsigned long long)enclosed_held, (unsigned long long)reactivated,
               (unsigned long long)revivals_refused, (unsigned long long)edges_kept_at_rim,
               (unsigned long long)relinks_apart, (unsigned long long)edges_pruned);
}

void MemoryUse::print(std::FILE* out) const {
  constexpr double kMiB = 1024.0 * 1024.0;
  std::fprintf(out,
               "places memory: ESDF+GVD blocks %zu of %zu x %zu bytes = %.2f MiB (planned %.2f MiB); work lists "
               "%.2f MiB (planned %.2f MiB); window total %.2f MiB; place bookkeeping %.2f MiB (planned %.2f MiB); "
               "arena %.2f MiB\n",
               blocks_high_water, blocks_capacity, block_bytes, esdf_used_bytes / kMiB, esdf_planned_bytes / kMiB,
               work_lists_used_bytes / kMiB, work_lists_planned_bytes / kMiB, window_used_bytes() / kMiB,
               places_used_bytes / kMiB, places_planned_bytes / kMiB, arena_planned_bytes / kMiB);
}

Capacities capacities_from_budget() {
  Capacities c;
  c.max_blocks = budgets::active::places::kMaxBlocks;
  c.place_nodes = budgets::active::places::kPlaceNodes;
  c.inactive_cells = budgets::active::places::kInactiveCells;
  c.observed_blocks = budgets::active::places::kObservedBlocks;
  c.pending_relinks = budgets::active::places::kPendingRelinks;
  return c;
}

std::size_t arena_bytes_from_budget() { return budgets::active::places::kArenaBytes; }

}  // namespace qsg::places
