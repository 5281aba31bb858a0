// Odometry levels for the evaluations on the simulated robot (ground truth, the simulator's default drift, a
// VIO-like drift of about 1 % of distance), and the camera poses a mapping pipeline is handed at each level.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>

#include "drivers/replay/trajectory.h"
#include "drivers/sim/drifting_odometry.h"

namespace qsg::sim {

enum class OdometryLevel : std::uint8_t {
  kGroundTruth,  // "gt": the true poses, bit for bit
  kSim,          // "sim": qsg_simulate's default drift (kSimDrift)
  kVio,          // "vio": a visual-inertial estimator's drift, about 1 % of distance (kVioDrift)
};
const char* to_string(OdometryLevel level);
// "gt", "sim" or "vio"; false for anything else.
bool parse_odometry_level(const std::string& name, OdometryLevel* level);

struct DriftLevel {
  double translation_sigma_m_per_sqrt_m = 0.0;
  double yaw_sigma_rad_per_sqrt_m = 0.0;
  double scale_bias = 0.0;
};
// qsg_simulate's default (--drift M RAD): random walks only. The yaw walk dominates over a tour: the end-point
// error grows as distance^1.5 (about 2 % of 100 m, 3 % of 300 m).
inline constexpr DriftLevel kSimDrift{0.02, 0.003, 0.0};
// VIO-like: the end-point error on a 200 m straight walk is about 1 % of the distance (RMS over seeds, from
// E|e|^2 = (scale_bias D)^2 + 3 sigma_t^2 D + sigma_yaw^2 D^3 / 3 = 1.0 + 0.06 + 2.7 m^2 at D = 200 m: 1.9 m);
// 0.8 % at 100 m. A 0.5 % scale error is typical of a stereo-inertial estimator; it cancels on a closed loop.
inline constexpr DriftLevel kVioDrift{0.01, 0.001, 0.005};

// The DriftingOdometry configuration of a level (every parameter zero for kGroundTruth).
DriftingOdometry::Config drift_config(OdometryLevel level, std::uint64_t seed);

// The camera poses a pipeline is handed along a ground-truth body trajectory (sim::SimCamera's trajectory): the
// drifting odometry is played over the whole trajectory once, and a frame at time t gets the estimated body pose
// interpolated at t with the camera's true mounting. The estimate starts at the first true pose, so the map is
// built in a frame that coincides with the world at the start.
class OdometryPoses {
 public:
  OdometryPoses() = default;  // ground truth
  OdometryPoses(const replay::Trajectory& truth, OdometryLevel level, std::uint64_t seed);

  // The estimate of world_T_camera at t_ns for a camera whose true pose then is true_world_T_camera (times past
  // the trajectory's end take its last pose, as SimCamera does). kGroundTruth returns true_world_T_camera
  // unchanged. False when t_ns lies before the trajectory.
  bool estimate(std::int64_t t_ns, const Eigen::Isometry3d& true_world_T_camera,
                Eigen::Isometry3d* world_T_camera) const;

  OdometryLevel level() const { return level_; }
  std::uint64_t seed() const { return seed_; }
  // The estimated body trajectory (empty for kGroundTruth) and the truth it drifts from.
  const replay::Trajectory& estimated() const { return estimated_; }
  const replay::Trajectory& truth() const { return truth_; }

 private:
  OdometryLevel level_ = OdometryLevel::kGroundTruth;
  std::uint64_t seed_ = 0;
  replay::Trajectory truth_;
  replay::Trajectory estimated_;
};

}  // namespace qsg::sim
