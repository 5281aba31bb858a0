// rooms_eval's options: the command line, its help, and the stages' settings (--set SECTION.KEY=VALUE from the
// places, rooms and doors parameter tables).
#pragma once

#include <string>
#include <vector>

#include "bench/sim_tour.h"
#include "core/doors/door_detector.h"
#include "core/params/params.h"
#include "core/places/places.h"
#include "core/rooms/room_finder.h"
#include "drivers/sim/exploration.h"

#ifndef QSG_SHARED_DATA_DIR
#define QSG_SHARED_DATA_DIR "../shared/data"
#endif

namespace qsg::bench {

struct RoomsEvalOptions {
  std::string plans_dir = std::string(QSG_SHARED_DATA_DIR) + "/floorplans/ipa";
  std::vector<std::string> maps{"lab_ipa", "Freiburg52_scan", "lab_c_scan", "lab_intel", "office_a", "office_e"};
  std::vector<std::string> variants{"plain", "furnished"};
  int generated = 2;          // two-floor generated buildings (seeds 1..N)
  int generated_rooms = 12;
  // Room labels alone on this many more generated two-floor buildings (seeds 1001..1000+N), on their ground-truth
  // rooms and objects: no exploration, so it is cheap enough to score hundreds of rooms.
  int label_buildings = 0;
  int width = 320;
  int height = 240;
  double hfov_deg = 90.0;
  double rate_hz = 2.0;       // keyframes per second along the tour
  double max_reach_m = 3.0;   // free cells farther (geodesically) from every place stay unlabelled
  double robot_radius_m = sim::ExplorationConfig{}.robot_radius_m;  // doors narrower than twice this stay shut
  // --look-into-unreachable 0|1: the tour looks into the rooms it cannot enter (sim::ExplorationConfig). Cached
  // explorations made with it on are named "<plan>.peek", so one made without is never read back as if made with it.
  bool look_into_unreachable = sim::ExplorationConfig{}.look_into_unreachable_rooms;
  // --furniture-height-m H: the furnished plans' furniture (occupied there, free in the plain plan) extruded to H
  // instead of the walls' 2.5 m (the benchmark's own use: furniture as floor-to-ceiling posts). 0: the benchmark's.
  double furniture_height_m = 0.0;
  // The stages' settings, each set by --set section.key=value from its parameter table (core/params): places
  // (places::Config, e.g. places.merge_revisited_within_m), rooms (rooms::Config) and doors (rooms::DoorConfig).
  places::Config places;
  rooms::Config rooms;
  std::string json_path;
  // Tuning aid: the frontend's graph of each run is saved here (Spark-DSG JSON) and read back on the next run
  // instead of exploring again, so room parameters can be swept in seconds. Empty: always explore.
  std::string cache_dir;
  // --images DIR: per plan (per floor of a generated building), a PNG of the estimated rooms beside the ground truth
  std::string images_dir;
  // --dump-places DIR: per plan (per floor of a generated building), a text file of its places and place-place
  // edges with their estimated and ground-truth rooms, for offline study of the room finder
  // (bench/rooms/finder_sandbox.py reads it).
  std::string dump_dir;
  // --door-oracle-m C (IPA plans): before the room finder's scored run, every place-place edge between two
  // ground-truth rooms gets clearance C, a perfect door and opening detector. The score is then the bound such a
  // cue would give the room finder, not the room finder's own. Negative: off.
  double door_oracle_m = -1.0;
  // --doors 1: doors and openings detected on the robot's own surface (rooms::find_doors, one slice per storey the
  // robot walked) close the place edges that cross them before the room finder runs, as the app does when a run
  // finishes.
  bool doors = true;
  // --doors online: the door stage the app runs during a run instead (rooms::OnlineDoors): the loop paints each
  // re-meshed block into the wall map, every --online-every N-th frontend update runs a window pass around the
  // robot, and the room finder reads the online doors (no final stage). The doors are cached beside the graph.
  bool online_doors = false;
  int online_every = 4;
  rooms::DoorConfig door;
  // --odometry gt|sim|vio, --odometry-seed N: the poses the map is built from (scored in the world frame). Caches
  // explored with drifting odometry are named "<plan>.odom-<level>-<seed>".
  bench::OdometryOption odometry;
};

// The stage settings --set reaches, from their parameter tables: one declaration per setting (core/params).
const params::Schema<RoomsEvalOptions>& rooms_eval_schema();
// False on --help, a bad option or a bad value (a message on stderr).
bool parse_rooms_eval(int argc, char** argv, RoomsEvalOptions* o);
void print_rooms_eval_usage(const char* argv0);

}  // namespace qsg::bench
