// places::Config's check and print, the printed capacities, counters and memory use, and the budget table's
// capacities.
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
  std::fprintf(out,
               "places: voxel_factor=%d max_distance_m=%.2f min_clearance_m=%.2f min_basis_angle_deg=%.1f "
               "min_basis_points=%d place_resolution_m=%.2f window_radius_m=%.1f slab_m=[-%.1f, +%.1f] "
               "min_tsdf_weight=%.2f free_space_edges=%d relink_inactive=%d bridge_fragments=%d "
               "bridge_max_fragment_places=%d bridge_max_length_m=%.2f bridge_min_clearance_m=%.2f "
               "enclosed_max_voxels=%d contract_removed=%d contract_search_places=%d unobserved_is_obstacle=%d "
               "unobserved_obstacle_above_m=%.2f rim_guard=%d signed_surface_seeds=%d correct_projective_distance=%d "
               "hold_distant_fragments=%d bridge_path_search=%d keep_distances_at_rim=%d "
               "revive_in_same_free_space=%d keep_edges_at_rim_m=%.2f relink_in_same_free_space=%d "
               "merge_revisited_within_m=%.2f\n",
               voxel_factor, max_distance_m, min_clearance_m, min_basis_angle_rad * 180.0 / 3.14159265358979,
               min_basis_points, place_resolution_m, window_radius_m, slab_below_m, slab_above_m, min_tsdf_weight,
               free_space_edges ? 1 : 0, relink_inactive ? 1 : 0, bridge_fragments ? 1 : 0,
               bridge_max_fragment_places, bridge_max_length_m, bridge_min_clearance_m, enclosed_max_voxels,
               contract_removed ? 1 : 0,
               contract_search_places, unobserved_is_obstacle ? 1 : 0,
               unobserved_obstacle_above_m, rim_guard ? 1 : 0, signed_surface_seeds ? 1 : 0,
               correct_projective_distance ? 1 : 0, hold_distant_fragments ? 1 : 0,
               bridge_path_search ? 1 : 0, keep_distances_at_rim ? 1 : 0, revive_in_same_free_space ? 1 : 0,
               keep_edges_at_rim_m, relink_in_same_free_space ? 1 : 0, merge_revisited_within_m);
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
