#include "core/doors/door_params.h"

namespace qsg::rooms {

const params::Table<DoorConfig>& door_params_table() {
  using params::above;
  using params::in;
  constexpr auto refinement = params::Origin::kRefinement;
  using C = DoorConfig;
  static const params::Table<C> table = [&] {
    params::Table<C> t;
    // The slice and its raster.
    t.add("cell_m", &C::cell_m, "m", above(0, 1), refinement, "raster resolution");
    t.add("slice_above_robot_m", &C::slice_above_robot_m, "m", in(-10, 10), refinement,
          "the slice's height above the robot's (camera's) on each storey");
    t.add("slice_half_band_m", &C::slice_half_band_m, "m", above(0, 10), refinement,
          "surface within +- this of the slice height is read");
    t.add("min_wall_height_m", &C::min_wall_height_m, "m", in(0, 20), refinement,
          "vertical extent of surface in a cell to be wall (<= 2 x slice_half_band_m)");
    t.add("mapped_radius_m", &C::mapped_radius_m, "m", above(0, 100), refinement,
          "free cells within this of a place are mapped free space");
    t.add("place_band_m", &C::place_band_m, "m", in(0, 100), refinement,
          "places within +- this of the slice height mark mapped space");
    // Door candidates.
    t.add("min_width_m", &C::min_width_m, "m", above(0, 10), refinement, "narrowest door (jamb to jamb)");
    t.add("max_width_m", &C::max_width_m, "m", above(0, 10), refinement, "widest door (>= min_width_m)");
    t.add("min_rise_m", &C::min_rise_m, "m", in(0, 10), refinement, "clearance rise on both sides of the door line");
    t.add("rise_reach_m", &C::rise_reach_m, "m", above(0, 100), refinement, "... within this distance of it");
    t.add("max_off_centre", &C::max_off_centre, "", in(0, 1), refinement,
          "|d1 - d2| / (d1 + d2) of the jambs' distances from the axis cell");
    t.add("suppression_m", &C::suppression_m, "m", in(0, 100), refinement,
          "of two critical cells closer than this, the narrower stays");
    // Storeys.
    t.add("storey_bin_m", &C::storey_bin_m, "m", above(0, 10), refinement, "robot heights are binned this finely");
    t.add("storey_min_share", &C::storey_min_share, "", in(0, 1), refinement,
          "a local maximum bin holding this share of the poses is a storey");
    t.add("storey_separation_m", &C::storey_separation_m, "m", in(0, 100), refinement,
          "of two storeys closer than this, the one with more poses stays");
    // Closing edges.
    t.add("cut_extension_m", &C::cut_extension_m, "m", in(0, 10), refinement,
          "door lines lengthened by this at both ends");
    t.add("cut_max_dz_m", &C::cut_max_dz_m, "m", in(0, 10), refinement,
          "edges whose ends lie within this of the slice's height are closed");
    // The online stage's memory.
    t.add("online_misses_to_drop", &C::online_misses_to_drop, "", in(1, 255), refinement,
          "a kept door missed by this many window passes in a row is dropped");
    t.add("online_match_m", &C::online_match_m, "m", in(0, 100), refinement,
          "a found door this close to a kept one is that door, seen again");
    // Bypassed doors.
    t.add("bypass_max_m", &C::bypass_max_m, "m", in(0, 100), refinement,
          "a door the places graph goes round within this path length is dropped (0: off)");
    t.add("bypass_extension_m", &C::bypass_extension_m, "m", in(0, 100), refinement,
          "... not crossing its line lengthened by this");
    t.add("bypass_max_edge_m", &C::bypass_max_edge_m, "m", above(0, 100), refinement,
          "... in steps of at most this");
    // Sight lines.
    t.add("sight_wall_dilation_m", &C::sight_wall_dilation_m, "m", in(0, 1), refinement, "walls thickened by this");
    t.add("sight_min_wall_m", &C::sight_min_wall_m, "m", in(0, 1000), refinement,
          "pieces at least this across are structure (shorter: furniture)");
    t.add("sight_furniture_max_m", &C::sight_furniture_max_m, "m", in(0, 1000), refinement,
          "thick islands spanning less than this are furniture (0: off)");
    t.add("sight_furniture_min_width_m", &C::sight_furniture_min_width_m, "m", above(0, 100), refinement,
          "... when their mean width exceeds this");
    t.flag("sight_cut_edges", &C::sight_cut_edges, refinement, "place edges through structure are closed");
    return t;
  }();
  return table;
}

}  // namespace qsg::rooms
