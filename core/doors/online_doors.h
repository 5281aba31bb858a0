// The door stage during a run: the offline detector (detect_doors_in_raster) on a fixed square window around the
// robot, sliced from the robot's surface as the loop paints it into a WallMap, in buffers carved at start-up. Each
// pass updates the doors of the window's interior (the window less the mapped radius, on the robot's storey) in a
// DoorSet: found again, new, or missed, a door dropped only after DoorConfig::online_misses_to_drop passes in a row
// missed it (DoorSet::update_window). The room finder reads the set (RoomFinder::update), so rooms found during a
// run are split at doors without allocating. The final pass on the whole mesh (find_doors, when a run finishes) is
// unchanged.
//
// A pass runs only while the robot's height holds still (not on stairs), in steps that let the caller keep its locks
// short:
//   begin_pass(robot)   the window and the slice height (robot height + slice_above_robot_m);
//   add_places(graph)   the places in the window's band (found in the graph's grid, not by a scan) and the place
//                       edges between them (the caller holds whatever guards the graph): the window's places graph,
//                       on which a found door that the places go round is dropped (DoorConfig::bypass_max_m, as
//                       find_doors does); add_place(p) takes one position only, and without a places graph no
//                       door is dropped;
//   rasterize()         the wall raster from the WallMap (the caller holds whatever guards the painting);
//   detect()            the detection and the DoorSet's update (no shared state but the DoorSet), and the window's
//                       sight lines (sight(): its slice's long walls, WallSight::set_window_slice), which the room
//                       finder reads until the next pass.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>

#include "core/memory/arena.h"
#include "core/doors/door_detector.h"
#include "core/doors/wall_map.h"
#include "core/doors/wall_sight.h"
#include "core/scene_graph/scene_graph.h"

namespace qsg::rooms {

// Resources: the budget table's "doors" arena (from_budget()), or a test's own.
struct OnlineDoorCapacities {
  std::size_t wall_tiles = 0;   // WallMap tiles (4 KB each, 1.6 m x 1.6 m x 1.6 m): a storey takes two per column
  std::size_t window_side = 0;  // cells; the window is window_side x cell_m wide (384: 19.2 m at 0.05 m)
  std::size_t places = 0;       // places in one window
  std::size_t doors = 0;        // doors kept (the DoorSet)
  std::size_t candidates = 0;   // critical cells in one window
  std::size_t place_edges = 0;  // place edges in one window (the bypass search's graph)
  std::string check() const;
  static OnlineDoorCapacities from_budget();  // the active board's "doors" arena capacities
};

struct PassResult {
  bool ran = false;            // false: not begun, climbing, or the detection refused its inputs
  bool climbing = false;       // the robot's height moved more than storey_bin_m since the previous pass: no slice
  double slice_z_m = 0.0;
  std::size_t places = 0;      // places in the window and the slice's band
  std::size_t places_dropped = 0;  // beyond OnlineDoorCapacities::places
  std::size_t found = 0;       // doors in the window's interior
  std::size_t matched = 0;     // ... that were kept doors, found again
  std::size_t added = 0;       // ... new to the DoorSet
  std::size_t refused = 0;     // ... that the full DoorSet could not take
  std::size_t missed = 0;      // kept doors of the interior this pass did not find, still kept
  std::size_t removed = 0;     // ... dropped at DoorConfig::online_misses_to_drop passes in a row
  std::size_t bypassed = 0;    // found doors the window's places go round, dropped before the DoorSet's update
  std::size_t bypass_searches_cut = 0;  // ... searches stopped short (their doors kept)
  std::size_t bypass_refused = 0;       // places and place edges beyond the window's graph capacities
  std::size_t sight_structure_cells = 0;  // the window's sight lines: cells of long walls (0: no sight this pass)
  DoorStats stats;
};

class OnlineDoors {
 public:
  OnlineDoors() = default;
  OnlineDoors(const OnlineDoors&) = delete;
  OnlineDoors& operator=(const OnlineDoors&) = delete;

  static memory::ArenaPlan plan(const OnlineDoorCapacities& capacities);
  // Checks the config and capacities and carves every buffer from one arena of at most budget_bytes (0: exactly
  // the plan). Start-up only; false with the reason in *error.
  bool init(const DoorConfig& config, const OnlineDoorCapacities& capacities, std::size_t budget_bytes,
            std::string* error);
  bool initialized() const { return ready_; }

  WallMap& wall_map() { return wall_map_; }
  const WallMap& wall_map() const { return wall_map_; }
  const DoorSet& doors() const { return doors_; }
  // The last pass's sight lines (empty before the first pass, and after a pass that did not run).
  const WallSight& sight() const { return sight_; }

  // A robot whose height moved more than storey_bin_m since the previous begin_pass is on stairs or a ramp: its
  // slice would cut the storey at the wrong height (and replace the doors there), so that pass does not run.
  void begin_pass(const Eigen::Vector3d& robot_m);
  void add_place(const Eigen::Vector3d& position_m);
  // The places in the window's band (add_place, in the node table's order), and the window's places graph: those
  // places and the place edges between them.
  void add_places(const scene_graph::SceneGraph& graph);
  void rasterize();
  PassResult detect();

  // Forgets every door (the final pass's doors replace them, for example).
  void clear_doors() { doors_.clear(); }

  const DoorConfig& config() const { return config_; }
  const OnlineDoorCapacities& capacities() const { return capacities_; }
  const DoorRaster& window() const { return raster_; }
  const memory::Arena& arena() const { return arena_; }
  template <typename Fn>
  void for_each_resource(Fn&& fn) const {  // fn(const memory::ResourceStats&)
    fn(arena_.stats());
    fn(wall_map_.tile_stats());
    fn(doors_.stats());
  }

 private:
  bool inside_interior(const Eigen::Vector2d& p) const;
  // In the window and the slice's band (after begin_pass); *c, *r: its raster cell.
  bool takes(const Eigen::Vector3d& p, int* c, int* r) const;
  DoorConfig config_;
  OnlineDoorCapacities capacities_;
  memory::Arena arena_;
  WallMap wall_map_;
  DoorSet doors_;
  DoorWorkspace workspace_;
  BypassGraph bypass_;
  WallSight sight_;
  Door* found_ = nullptr;  // one pass's doors (capacities_.candidates)
  DoorRaster raster_;
  double slice_z_m_ = 0.0;
  bool begun_ = false;
  bool climbing_ = false;
  double last_robot_z_m_ = std::numeric_limits<double>::quiet_NaN();
  std::size_t num_places_ = 0;
  std::size_t places_dropped_ = 0;
  bool ready_ = false;
};

}  // namespace qsg::rooms
