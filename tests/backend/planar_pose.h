// A pose in the plane (x, y, yaw about z) for the backend's tests.
#pragma once

#include <Eigen/Geometry>

namespace qsg::backend::testing {

inline Eigen::Isometry3d planar(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  return T;
}

}  // namespace qsg::backend::testing
