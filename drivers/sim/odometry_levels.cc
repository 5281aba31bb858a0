// Odometry levels and the estimated camera poses along a ground-truth trajectory.
#include "drivers/sim/odometry_levels.h"

#include <algorithm>
#include <cstdint>

namespace qsg::sim {

const char* to_string(OdometryLevel level) {
  switch (level) {
    case OdometryLevel::kGroundTruth: return "gt";
    case OdometryLevel::kSim: return "sim";
    case OdometryLevel::kVio: return "vio";
  }
  return "?";
}

bool parse_odometry_level(const std::string& name, OdometryLevel* level) {
  for (const OdometryLevel l : {OdometryLevel::kGroundTruth, OdometryLevel::kSim, OdometryLevel::kVio})
    if (name == to_string(l)) return *level = l, true;
  return false;
}

DriftingOdometry::Config drift_config(OdometryLevel level, std::uint64_t seed) {
  DriftingOdometry::Config c;
  c.seed = seed;
  DriftLevel d;
  if (level == OdometryLevel::kSim) d = kSimDrift;
  if (level == OdometryLevel::kVio) d = kVioDrift;
  c.translation_sigma_m_per_sqrt_m = d.translation_sigma_m_per_sqrt_m;
  c.yaw_sigma_rad_per_sqrt_m = d.yaw_sigma_rad_per_sqrt_m;
  c.scale_bias = d.scale_bias;
  return c;
}

OdometryPoses::OdometryPoses(const replay::Trajectory& truth, OdometryLevel level, std::uint64_t seed)
    : level_(level), seed_(seed), truth_(truth) {
  if (level_ == OdometryLevel::kGroundTruth) return;
  estimated_ = drifted_trajectory(truth_, drift_config(level_, seed_));
}

bool OdometryPoses::estimate(std::int64_t t_ns, const Eigen::Isometry3d& true_world_T_camera,
                             Eigen::Isometry3d* world_T_camera) const {
  if (level_ == OdometryLevel::kGroundTruth) return *world_T_camera = true_world_T_camera, true;
  if (truth_.empty()) return false;
  const std::int64_t t = std::min(t_ns, truth_.back().time_ns);
  replay::StampedPose truth_body, estimated_body;
  if (!replay::interpolate_pose(truth_, t, INT64_MAX, &truth_body) ||
      !replay::interpolate_pose(estimated_, t, INT64_MAX, &estimated_body))
    return false;
  // The camera's mounting on the body, from the truth at the same time: exact for a rigid mount.
  const Eigen::Isometry3d body_T_camera = truth_body.world_T_body().inverse() * true_world_T_camera;
  *world_T_camera = estimated_body.world_T_body() * body_T_camera;
  return true;
}

}  // namespace qsg::sim
