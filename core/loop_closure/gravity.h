// The world's vertical as two agents' cameras see it, for registrations that keep the odometry's tilt: odometry
// with an IMU observes roll and pitch, so two agents' relative tilt is the odometry's, and a registration need only
// estimate the yaw about the vertical and the translation (4 DOF: the appearance RANSAC, ICP).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace qsg::loop_closure {

// The world's vertical in the match's and the query's camera frames (from their odometric poses).
struct GravityPrior {
  Eigen::Vector3d match_up = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d query_up = Eigen::Vector3d::UnitZ();
  static GravityPrior from_poses(const Eigen::Isometry3d& world_T_match, const Eigen::Isometry3d& world_T_query) {
    GravityPrior g;
    g.match_up = world_T_match.linear().transpose() * Eigen::Vector3d::UnitZ();
    g.query_up = world_T_query.linear().transpose() * Eigen::Vector3d::UnitZ();
    return g;
  }
  // The smallest rotation that takes the query's vertical onto the match's: any match_T_query with the odometry's
  // tilt is a rotation about match_up after it.
  Eigen::Quaterniond tilt() const { return Eigen::Quaterniond::FromTwoVectors(query_up, match_up); }
};

}  // namespace qsg::loop_closure
