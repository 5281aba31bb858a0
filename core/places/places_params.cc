#include "core/places/places_params.h"

namespace qsg::places {

const params::Table<Config>& params_table() {
  using params::above;
  using params::at_least;
  using params::in;
  constexpr auto paper = params::Origin::kPaper;
  constexpr auto refinement = params::Origin::kRefinement;
  constexpr auto project = params::Origin::kProject;
  static const params::Table<Config> table = [&] {
    params::Table<Config> t;
    // ESDF and GVD (the paper's section on places).
    t.add("voxel_factor", &Config::voxel_factor, "", in(1, kMaxVoxelFactor), project,
          "GVD voxel = voxel_factor x TSDF voxel");
    t.add("max_distance_m", &Config::max_distance_m, "m", above(0, 20), project, "wavefronts stop at this distance");
    t.add("min_clearance_m", &Config::min_clearance_m, "m", in(0, 20), paper,
          "GVD voxels closer to an obstacle are dropped (below max_distance_m)");
    t.add("min_basis_angle_rad", &Config::min_basis_angle_rad, "rad", above(0, 3.14159266), paper,
          "theta of the theta-SMA: smallest angle between two basis points");
    t.add("min_basis_points", &Config::min_basis_points, "", in(2, 8), paper,
          "n_b: GVD voxels with fewer basis points are not places");
    t.add("place_resolution_m", &Config::place_resolution_m, "m", above(0, 20), paper,
          "delta_p: side of the hash cells that cluster GVD voxels into places");
    t.add("window_radius_m", &Config::window_radius_m, "m", above(0, 100), paper,
          "ESDF blocks farther from the robot are freed (below the TSDF window minus one block)");
    t.add("slab_below_m", &Config::slab_below_m, "m", at_least(0), project, "the ESDF slab's depth below the robot");
    t.add("slab_above_m", &Config::slab_above_m, "m", at_least(0), project, "the ESDF slab's height above the robot");
    t.add("min_tsdf_weight", &Config::min_tsdf_weight, "", at_least(0), project,
          "TSDF voxels with more weight count as observed");
    t.flag("signed_surface_seeds", &Config::signed_surface_seeds, refinement,
          "surface seeds start at the TSDF's signed distance, not 0");
    t.flag("correct_projective_distance", &Config::correct_projective_distance, refinement,
          "seeds take their distance from nearby zero crossings, not the projective TSDF value");
    t.flag("unobserved_is_obstacle", &Config::unobserved_is_obstacle, refinement,
          "unobserved space beside free space bounds distances like an obstacle");
    t.add("unobserved_obstacle_above_m", &Config::unobserved_obstacle_above_m, "m", at_least(0), refinement,
          "... up to this height above the robot (0: the floor side only)");
    t.flag("rim_guard", &Config::rim_guard, refinement,
          "voxels at the window's vertical rim take their distance from the walls alone");
    t.flag("keep_distances_at_rim", &Config::keep_distances_at_rim, refinement,
          "distances from an obstacle whose block left the window are kept (orphans)");
    t.flag("free_space_edges", &Config::free_space_edges, paper,
          "places whose free-space spheres overlap are joined by an edge");
    // Repairs of the places graph (the project's refinements).
    t.flag("relink_inactive", &Config::relink_inactive, refinement,
          "a removed place's edges to inactive places move to a live place nearby");
    t.flag("relink_in_same_free_space", &Config::relink_in_same_free_space, refinement,
          "... only when the live place is in the same free space");
    t.flag("revive_in_same_free_space", &Config::revive_in_same_free_space, refinement,
          "an inactive node is revived only by a place in the same free space");
    t.add("keep_edges_at_rim_m", &Config::keep_edges_at_rim_m, "m", at_least(0), refinement,
          "edges certified inside are kept within this distance of the window's rim (below window_radius_m)");
    t.add("merge_revisited_within_m", &Config::merge_revisited_within_m, "m", in(0, 20), paper,
          "revisited places within this distance and in the same free space merge (0: off; <= place_resolution_m)");
    t.flag("bridge_fragments", &Config::bridge_fragments, refinement,
          "small fragments of live places are bridged to the nearest live place outside them");
    t.add("bridge_max_fragment_places", &Config::bridge_max_fragment_places, "", in(1, kMaxBridgeFragment),
          refinement, "largest fragment bridged");
    t.add("bridge_max_length_m", &Config::bridge_max_length_m, "m", above(0, 10), refinement, "longest bridge");
    t.add("bridge_min_clearance_m", &Config::bridge_min_clearance_m, "m", params::Range{0, 1e9, true, false},
          refinement, "smallest ESDF distance along a bridge");
    t.flag("bridge_path_search", &Config::bridge_path_search, refinement,
          "when no straight bridge is certified, search a path through free ESDF voxels");
    t.add("enclosed_max_voxels", &Config::enclosed_max_voxels, "", in(0, 1000000), refinement,
          "unbridgeable fragments of at most this many GVD voxels are enclosed pockets, kept out (0: off)");
    t.flag("hold_distant_fragments", &Config::hold_distant_fragments, refinement,
          "unbridgeable fragments far from the robot are held out of the graph until joined");
    t.flag("contract_removed", &Config::contract_removed, refinement,
          "removing a place never cuts the graph: its inactive neighbours are joined (edge contraction)");
    t.add("contract_search_places", &Config::contract_search_places, "", in(1, kMaxContractSearch), refinement,
          "graph nodes searched for an active place before contracting");
    return t;
  }();
  return table;
}

}  // namespace qsg::places
