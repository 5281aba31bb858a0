// Ground truth of a simulated world for scoring every layer: objects (label, centroid, box), rooms (type,
// footprint, free-space voxels), and a reference free-space skeleton (the theta-simplified medial axis: GVD
// voxels with their clearance and basis points), computed from the world geometry, not from sensor data.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "drivers/replay/trajectory.h"
#include "drivers/world/world.h"
#include "drivers/world/world_query.h"

namespace qsg::sim {

struct GroundTruthConfig {
  double voxel_size_m = 0.1;
  double max_clearance_m = 3.0;      // distances are capped here
  double gvd_min_clearance_m = 0.2;  // skeleton voxels closer than this to an obstacle are dropped
  double gvd_min_angle_rad = 0.785;  // theta of the theta-SMA: smallest angle between two basis points (45 deg)
  void print(std::FILE* out) const;
};

inline constexpr std::int16_t kVoxelOccupied = -2;
inline constexpr std::int16_t kVoxelFreeNoRoom = -1;

struct GvdVoxel {
  Eigen::Vector3f position_m;
  float clearance_m = 0.0f;
  std::uint8_t num_basis_points = 0;
};

struct GroundTruth {
  GroundTruthConfig config;
  Eigen::Vector3d origin_m = Eigen::Vector3d::Zero();  // corner of voxel (0, 0, 0)
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();
  std::vector<std::int16_t> voxel_room;   // x fastest; room index, kVoxelFreeNoRoom or kVoxelOccupied
  std::vector<float> clearance_m;         // distance from the voxel centre to the nearest surface (0 if occupied)
  std::vector<GvdVoxel> gvd;
  std::vector<std::size_t> room_free_voxels;  // per World::rooms entry

  std::size_t index(int x, int y, int z) const {
    return (static_cast<std::size_t>(z) * dims.y() + y) * dims.x() + x;
  }
  Eigen::Vector3d center(int x, int y, int z) const {
    return origin_m + (Eigen::Vector3d(x, y, z) + Eigen::Vector3d::Constant(0.5)) * config.voxel_size_m;
  }
  // Distance from p to the nearest GVD voxel (brute force over the skeleton; for evaluation, not real time).
  double distance_to_gvd(const Eigen::Vector3d& p_m) const;
};

// Computes occupancy, clearance, rooms and the skeleton over the world's bounds. Returns false with a reason
// when the grid would exceed max_voxels.
bool compute_ground_truth(const world::World& world, const world::FreeSpaceIndex& free_space,
                          const GroundTruthConfig& config, GroundTruth* truth, std::string* error,
                          std::size_t max_voxels = 60u << 20);

// Writes into `dir` (which must exist): objects.json, rooms.json (with the free-space grid's description),
// free_space.bin (int16 per voxel, x fastest, little endian), gvd.ply (binary PLY: x y z clearance
// num_basis_points), and the ground-truth trajectory (TUM) when it is not empty.
bool write_ground_truth(const std::string& dir, const world::World& world, const GroundTruth& truth,
                        const replay::Trajectory& trajectory, std::string* error);

}  // namespace qsg::sim
