// Exploration trajectories for the simulated robot: a tour that visits every reachable room of a world through
// its doors and returns to the start, planned on a 2.5D traversability graph (so stairs join floors), plus
// scripted trajectories through given waypoints.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "drivers/render/ray_scene.h"
#include "drivers/replay/trajectory.h"
#include "drivers/world/world.h"
#include "drivers/world/world_query.h"

namespace qsg::sim {

// Poses are of the robot's camera body frame (x forward, y left, z up) at camera height; the optical frame of
// the camera is body_R_optical() away (x right, y down, z forward).
Eigen::Matrix3d body_R_optical();

struct ExplorationConfig {
  double resolution_m = 0.1;         // traversability grid cell
  double robot_radius_m = 0.25;      // walls and furniture stay at least this far from the path
  double max_step_m = 0.2;           // largest height change between neighbouring cells (stair riser)
  double camera_height_m = 0.5;      // above the ground: quadruped 0.5, hand-held 1.2
  double speed_m_s = 0.7;            // 0.5-1 m/s
  double yaw_rate_rad_s = 0.8;       // turns slower than this happen in place
  double rate_hz = 30.0;             // pose samples per second
  double preferred_clearance_m = 0.8;  // the planner pays to come closer to obstacles than this
  bool spin_in_rooms = true;         // turn once around at each room's centre, so the camera sees all of it
  // A room the robot cannot enter (its doors narrower than the robot, or none in the scan) is looked into from the
  // reachable spot that sees most of it within peek_range_m: the tour goes there from the room it lies in, faces
  // the room and sweeps the camera +-peek_sweep_deg, as a frontier-driven exploration would look through a door it
  // cannot pass. Off: such rooms are seen only in passing.
  bool look_into_unreachable_rooms = true;
  double peek_range_m = 4.0;         // within the TSDF's integration range (core/reconstruction: 4.5 m)
  double peek_sweep_deg = 45.0;
  bool return_to_start = true;
  // The same tour walked this many times in a row (a long mission; needs return_to_start): the robot turns back to
  // its starting heading at the end of each.
  std::int32_t tours = 1;
  std::int32_t start_room = -1;      // -1: the room with the lowest id that has free space
  std::int64_t start_time_ns = 0;
  // The traversability grid's cells (x-y extent / resolution_m squared) may not exceed this: a world wider than
  // that at this resolution is refused by name before the grid is allocated (a cell is about 24 bytes plus its
  // nodes; 4 Mi cells is 200 m x 200 m at 0.1 m). Range 1 .. 2^28.
  std::size_t max_grid_cells = std::size_t{4} << 20;

  std::string check() const;  // empty when usable, else the bad field
  void print(std::FILE* out) const;
};

struct ExplorationResult {
  bool ok = false;
  std::string error;
  replay::Trajectory trajectory;             // camera body poses at rate_hz
  std::vector<std::int32_t> room_order;      // rooms in the order they were visited (start first)
  std::vector<std::int32_t> unreachable_rooms;
  std::vector<std::int32_t> peeked_rooms;    // unreachable rooms the tour looks into (look_into_unreachable_rooms)
  double length_m = 0.0;
  double duration_s = 0.0;
  std::size_t graph_nodes = 0;
};

// Plans the tour. `scene` and `free_space` must have been built from `world`.
ExplorationResult plan_exploration(const world::World& world, const render::RayScene& scene,
                                   const world::FreeSpaceIndex& free_space, const ExplorationConfig& config);

// A scripted trajectory: straight segments through the waypoints (x, y, yaw ignored: heading follows the
// path; z is the camera height above the world origin) at the config's speed, yaw rate and sample rate.
ExplorationResult scripted_trajectory(const std::vector<Eigen::Vector3d>& waypoints_m, const ExplorationConfig& config);

}  // namespace qsg::sim
