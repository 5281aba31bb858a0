// Rigid transforms and relative-pose measurements between them: the vocabulary of the backend's pose graphs
// (pose_graph.h, pairwise_consistency.h, agent_pose_graph.h). Eigen only.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>

namespace qsg::backend {

// Rigid transform a_T_b: maps a point from frame b into frame a, p_a = q * p_b + t_m.
struct Pose3 {
  Eigen::Vector3d t_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();

  Pose3 inverse() const {
    const Eigen::Quaterniond q_inv = q.conjugate();
    return {q_inv * -t_m, q_inv};
  }
  Pose3 operator*(const Pose3& rhs) const { return {t_m + q * rhs.t_m, q * rhs.q}; }
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return t_m + q * p; }
};

// a_T_b from world_T_a and world_T_b: the quantity an edge from a to b measures.
inline Pose3 between(const Pose3& world_T_a, const Pose3& world_T_b) { return world_T_a.inverse() * world_T_b; }

// One relative-pose measurement. The translation error is expressed in the `from` frame, the rotation error
// (2 * vec(q_measured^-1 * q_estimated), the rotation vector for small angles) in the `to` frame.
struct RelativePoseEdge {
  std::uint32_t from = 0;
  std::uint32_t to = 0;
  Pose3 measured_from_T_to;
  Eigen::Vector3d sigma_t_m = Eigen::Vector3d::Constant(0.05);
  Eigen::Vector3d sigma_rot_rad = Eigen::Vector3d::Constant(0.01);
  bool is_loop_closure = false;
  // A full information matrix (inverse covariance) of the residual [translation; rotation], used instead of the
  // sigmas when set (e.g. from a g2o file, read_g2o_pose_graph). Then the translation error is expressed in the
  // measurement's `to` frame, as g2o does; rotation in this residual's 2 vec(q_err) units (radians, small angles).
  bool has_information = false;
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity();
};

}  // namespace qsg::backend
