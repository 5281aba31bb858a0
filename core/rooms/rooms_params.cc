#include "core/rooms/rooms_params.h"

#include "core/scene_graph/node_id.h"

namespace qsg::rooms {

const params::Table<Config>& params_table() {
  using params::above;
  using params::at_least;
  using params::in;
  constexpr auto paper = params::Origin::kPaper;
  constexpr auto refinement = params::Origin::kRefinement;
  constexpr auto project = params::Origin::kProject;
  static const params::Table<Config> table = [&] {
    params::Table<Config> t;
    // The paper's filtration and seeding.
    t.choice("seeding", &Config::seeding, {{"plateau", Seeding::kPlateau}, {"persistence", Seeding::kPersistence}},
             refinement, "plateau: the paper's one dilation for the graph; persistence: a merge tree per room");
    t.add("min_dilation_m", &Config::min_dilation_m, "m", in(0, 100), paper, "d-: smallest dilation of the filtration");
    t.add("max_dilation_m", &Config::max_dilation_m, "m", in(0, 100), paper,
          "d+: largest dilation (>= min_dilation_m)");
    t.add("dilation_step_m", &Config::dilation_step_m, "m", above(0, 10), paper, "the Betti curve's sampling step");
    t.add("min_component_size", &Config::min_component_size, "", in(1, 1000000), paper,
          "places; smaller components are not counted and seed no room");
    t.add("plateau_alpha", &Config::plateau_alpha, "", in(0, 1), paper,
          "plateau: flat intervals longer than alpha x the longest are candidates");
    t.add("min_persistence_m", &Config::min_persistence_m, "m", in(0, 100), refinement,
          "persistence: smallest (birth - merge) clearance gap of a seed component");
    t.add("max_door_clearance_m", &Config::max_door_clearance_m, "m", at_least(0), refinement,
          "persistence: components meeting through a wider passage are one room (inf: no limit)");
    t.flag("seed_closed_regions", &Config::seed_closed_regions, refinement,
           "pieces cut off by closed (door) edges that hold no seed are rooms of their own");
    // Refinements over the room partition.
    t.flag("split_by_extent", &Config::split_by_extent, refinement,
           "rooms are seeded again on the clearance extended past the storey's cap");
    t.add("extent_saturation_m", &Config::extent_saturation_m, "m", in(0, 100), refinement,
          "places with at least this clearance get an extended clearance");
    t.add("split_min_extent_m", &Config::split_min_extent_m, "m", in(0, 100), refinement,
          "the extended filtration's smallest dilation");
    t.add("split_max_extent_m", &Config::split_max_extent_m, "m", in(0, 100), refinement,
          "the extended filtration's largest dilation (>= split_min_extent_m)");
    t.add("split_min_persistence_m", &Config::split_min_persistence_m, "m", in(0, 100), refinement,
          "the split's seed persistence");
    t.add("split_min_component_size", &Config::split_min_component_size, "", in(1, 1000000), refinement,
          "the split's smallest seed (places)");
    t.flag("merge_corridors", &Config::merge_corridors, refinement,
           "adjacent rooms that each touch many rooms and meet through a wide opening are one corridor");
    t.add("corridor_min_neighbours", &Config::corridor_min_neighbours, "", in(0, 1000000), refinement,
          "rooms each must touch (>= 2 with the merge on)");
    t.add("corridor_min_open_edges", &Config::corridor_min_open_edges, "", in(0, 65535), refinement,
          "open place edges the two must meet through (>= 1 with the merge on)");
    t.flag("close_edges_through_walls", &Config::close_edges_through_walls, refinement,
           "with sight lines, place edges that cross a long wall are read as closed");
    t.flag("merge_visible", &Config::merge_visible, refinement,
           "adjacent rooms whose places see each other past every long wall are one room");
    t.add("visible_min_share", &Config::visible_min_share, "", above(0, 1), refinement,
          "share of clear sight lines for the merge");
    t.add("visible_samples", &Config::visible_samples, "", in(1, Config::kMaxVisibleSamples), refinement,
          "places of each room paired for sight lines");
    t.add("visible_max_rounds", &Config::visible_max_rounds, "", in(1, 1000000), refinement, "merge rounds");
    t.add("visible_local_radius_m", &Config::visible_local_radius_m, "m", in(0, 100), refinement,
          "sight lines near the boundary: places within this of the other room's edge ends (0: off)");
    t.add("visible_local_min_share", &Config::visible_local_min_share, "", in(0, 1), refinement,
          "... share of them clear (> 0 with the radius on)");
    t.add("visible_local_min_places", &Config::visible_local_min_places, "", in(0, 1000000), refinement,
          "... places on each side at least (>= 1 with the radius on)");
    t.flag("visible_touching", &Config::visible_touching, refinement,
           "rooms are adjacent also where free-space spheres of their places touch in sight");
    t.add("visible_touch_max_clearance_m", &Config::visible_touch_max_clearance_m, "m", above(0, 100), refinement,
          "... a sphere counting at most this radius");
    // Cost.
    t.flag("window_updates", &Config::window_updates, project,
           "updates during the run read the active places and their rooms; other rooms stay until revisited");
    t.add("window_room_margin_m", &Config::window_room_margin_m, "m", at_least(0), project,
          "window updates read an open room's places within this of the active places' box (inf: all)");
    // Outputs.
    t.add("building_index", &Config::building_index, "", in(0, static_cast<double>(scene_graph::kIndexMask)), project,
          "the building node is make_node_id('B', building_index)");
    return t;
  }();
  return table;
}

}  // namespace qsg::rooms
