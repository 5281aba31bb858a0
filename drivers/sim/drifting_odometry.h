// Odometry with drift: plays a ground-truth trajectory back with a seeded random walk per metre travelled (3D
// translation and yaw) plus optional scale and yaw bias, so loop closure has something to correct.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <cstdio>

#include "drivers/replay/trajectory.h"
#include "drivers/sources.h"

namespace qsg::sim {

// Error model, per step between consecutive ground-truth poses that moves the body by d metres:
//   yaw error     psi += N(0, yaw_sigma^2 d) + yaw_bias d            (about the world z axis)
//   position      est_t += Rz(psi_prev) dt (1 + scale_bias) + N(0, translation_sigma^2 d I3)
//   orientation   est_R = Rz(psi) gt_R
// The estimate starts at the first ground-truth pose; with every parameter zero it equals ground truth bit for
// bit. Roll and pitch do not drift (gravity makes them observable to a legged robot's estimator).
//
// The reported covariance is the first-order propagation of this model for the error [position (m); rotation
// vector (rad)] in the world frame: it grows with distance since the start (position faster than linearly once
// yaw error turns into lateral error). Biases are deterministic and not part of it.
class DriftingOdometry : public drivers::OdometrySource {
 public:
  struct Config {
    double translation_sigma_m_per_sqrt_m = 0.0;  // position random walk: sigma after 1 m of travel
    double yaw_sigma_rad_per_sqrt_m = 0.0;        // yaw random walk: sigma after 1 m of travel
    double scale_bias = 0.0;                      // 0.01: reports 1 % more motion than travelled
    double yaw_bias_rad_per_m = 0.0;
    std::uint64_t seed = 1;
    std::int64_t publish_latency_ns = 0;
    // Standard deviations added to the reported covariance so it stays invertible at the start.
    double translation_floor_m = 1e-3;
    double rotation_floor_rad = 1e-3;  // also the (non-drifting) roll and pitch
    void print(std::FILE* out) const;
  };

  DriftingOdometry(replay::Trajectory ground_truth, const Config& config);

  const char* name() const override { return "drifting_odometry"; }
  // One sample per ground-truth pose (sequence = index), then kEndOfStream. Never waits; never allocates.
  drivers::ReadStatus read(messages::OdometrySample& sample, std::int64_t timeout_ns) override;
  const drivers::DriverCounters& counters() const override { return counters_; }

  // Starts over; the same seed gives the same samples.
  void rewind();
  const Config& config() const { return config_; }
  // Ground truth, kept apart from what the source publishes.
  const replay::Trajectory& ground_truth() const { return ground_truth_; }
  // Index of the last delivered sample in ground_truth() (valid after the first kOk read).
  std::size_t last_index() const { return next_ == 0 ? 0 : next_ - 1; }
  // Distance travelled along the ground truth up to the last delivered sample.
  double distance_m() const { return distance_m_; }
  // Error of the last delivered sample: estimate position - true position, and yaw error.
  Eigen::Vector3d position_error_m() const { return last_est_t_m_ - ground_truth_[last_index()].world_t_body_m; }
  double yaw_error_rad() const { return psi_rad_; }
  // First-order covariance of [position error (3); yaw error] at the last delivered sample (without floors).
  const Eigen::Matrix4d& error_covariance() const { return error_cov_; }

 private:
  double gaussian();

  replay::Trajectory ground_truth_;
  Config config_;
  std::size_t next_ = 0;
  std::uint64_t rng_state_ = 0;
  bool have_spare_ = false;
  double spare_ = 0.0;
  double psi_rad_ = 0.0;                                  // yaw error
  Eigen::Vector3d offset_m_ = Eigen::Vector3d::Zero();    // estimate = Rz(psi) * truth + offset (exact when 0)
  Eigen::Vector3d last_est_t_m_ = Eigen::Vector3d::Zero();
  bool have_last_time_ = false;
  std::int64_t last_time_ns_ = 0;
  double distance_m_ = 0.0;
  Eigen::Matrix4d error_cov_ = Eigen::Matrix4d::Zero();
  drivers::DriverCounters counters_;
};

// The whole estimate DriftingOdometry(truth, config) publishes, as a trajectory (allocates: set-up, not a read).
replay::Trajectory drifted_trajectory(const replay::Trajectory& truth, const DriftingOdometry::Config& config);

}  // namespace qsg::sim
