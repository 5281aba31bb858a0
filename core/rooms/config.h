// The room finder's settings (Config) and store sizes (Capacities). The paper's settings are Config::paper(); the
// fields past the filtration's are our refinements, each documented in its pass (core/rooms/refine/*.h) and in
// core/rooms/README.md with what it earned.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>

#include "core/scene_graph/scene_graph.h"

namespace qsg::rooms {

// How seed components are chosen from the clearance filtration.
enum class Seeding : std::uint8_t {
  // The paper: one dilation delta* for the whole graph by the alpha plateau rule on the Betti-0 curve; the
  // components alive at delta* (of at least min_component_size places) are the seeds.
  kPlateau,
  // Ours, per component, on the filtration's merge tree: sweeping the dilation down from d+, when two components
  // meet and each is at least min_component_size places and has persisted at least min_persistence_m (its largest
  // clearance minus the clearance where they meet), both become seeds with the places they hold at that moment.
  // Each room is cut at its own door's clearance, so a small room need not share delta* with a large hall.
  kPersistence,
};
const char* to_string(Seeding seeding);

// Defaults: persistence seeding and the refinements on, chosen on the IPA floor plans and generated buildings
// (bench/rooms/rooms_eval, bench/results/rooms.md); the paper's settings are paper().
struct Config {
  Seeding seeding = Seeding::kPersistence;
  double min_persistence_m = 0.4;  // kPersistence: smallest (birth - merge) clearance gap of a seed component
  // kPersistence: components meeting through a wider passage (clearance above this, i.e. an opening wider than
  // twice it) are one room whatever their persistence. Infinity: no limit.
  double max_door_clearance_m = std::numeric_limits<double>::infinity();
  double min_dilation_m = 0.5;    // d-: smallest dilation (clearance) of the filtration
  double max_dilation_m = 1.2;    // d+: largest dilation
  double dilation_step_m = 0.01;  // the Betti curve is sampled every step over [d-, d+]
  // Places; smaller components are not counted (and seed no room). The paper uses 15 with its sparser places;
  // ours are denser, about 3.3-3.9 per m^2 of floor (up to three 1 m cells between floor and ceiling), and since
  // the places' seeds come from zero crossings 8 lost small rooms (core/rooms/README.md).
  std::uint32_t min_component_size = 6;
  // The paper's alpha: only flat intervals longer than alpha x the longest one are candidates; among them the one
  // with the most components wins. 0 over-segments, 1 picks the most persistent interval.
  double plateau_alpha = 0.5;
  bool split_by_extent = true;  // refine/extent_split.h
  // Closed passages: a place-place edge of weight 0 or less is a passage a door stage closed (doors found on the
  // robot's surface). The filtration never crosses it (its clearance is 0, below d-), and with this on, every piece
  // of the places graph that the closed edges cut off and that holds no seed (at least min_component_size places)
  // is a room of its own: a corridor narrower than d- whose doors were all found, say, which the flood fill would
  // otherwise hand to the rooms on its doors. Without closed edges it does nothing.
  bool seed_closed_regions = true;
  bool merge_corridors = true;  // refine/corridor_merge.h
  std::uint32_t corridor_min_neighbours = 3;
  std::uint32_t corridor_min_open_edges = 20;
  // With sight lines, a place edge that crosses a long wall (SightLines::crosses_structure) is read as closed, as a
  // door's is: an edge the places layer left through a wall is no passage. The final door stage also writes weight
  // 0 on such edges (DoorConfig::sight_cut_edges, for the saved graph); during a run the room finder reads them
  // through the online door window's sight lines.
  bool close_edges_through_walls = true;
  bool merge_visible = true;  // refine/visibility_merge.h (whole-map sight lines only)
  double visible_min_share = 0.8;
  std::uint32_t visible_samples = 12;  // at most kMaxVisibleSamples
  std::uint32_t visible_max_rounds = 32;
  static constexpr std::uint32_t kMaxVisibleSamples = 32;
  double visible_local_radius_m = 2.25;  // the test near the rooms' boundary; 0: off
  double visible_local_min_share = 0.8;
  std::uint32_t visible_local_min_places = 3;
  bool visible_touching = true;  // rooms adjacent where their places' free-space spheres touch in sight
  // ... a sphere counting at most this radius there (it sizes the search's cells: one huge clearance must not make
  // the search quadratic in the places).
  double visible_touch_max_clearance_m = 4.0;
  double extent_saturation_m = 1.0;
  double split_min_extent_m = 1.0;
  double split_max_extent_m = 2.5;
  double split_min_persistence_m = 0.5;
  std::uint32_t split_min_component_size = 6;
  std::uint64_t building_index = 0;  // the building node is make_node_id('B', building_index)
  // Updates during a run (RoomFinder::update with window true) read only the active window: the active places, the
  // places of the rooms that hold one, and the places without a room. Rooms that hold no active place stay as they
  // were (their nodes and edges untouched) until the robot comes back; the final update reads the whole map. So an
  // update costs what the window and its rooms hold, not the building (issue 37). Room ids follow the graph's
  // room-place edges (the room a new room shares most places with) in every update. Off: every update reads the
  // whole graph (the paper's rooms, its footnote: "it still operates on the entire graph").
  bool window_updates = true;
  // ... and of an open room (one holding an active place) only the places within this of the active places' box;
  // its farther places are not read and keep their room, so one long room (a corridor) costs what its part near
  // the robot holds. Infinity: the whole room.
  double window_room_margin_m = 5.0;

  static Config paper();              // the paper's method and numbers: kPlateau, 15 places, alpha 0.5, no split
  std::size_t curve_samples() const;  // samples of the Betti curve (d-, d- + step, ..., d+)
  std::string check() const;          // empty when usable, else the bad field and why
  void print(std::FILE* out) const;
};

// Fixed sizes of the finder's stores: the scene graph's capacities (from_scene_graph), or a test's own.
struct Capacities {
  std::size_t places = 0;       // place nodes read per update (more are ignored and counted)
  std::size_t place_edges = 0;  // place-place edges read per update (more are ignored and counted)
  std::size_t rooms = 0;        // rooms per update (more seeds are dropped, smallest first, and counted)
  static Capacities from_scene_graph(const scene_graph::Capacities& graph);
  std::string check() const;
  void print(std::FILE* out) const;
};

}  // namespace qsg::rooms
