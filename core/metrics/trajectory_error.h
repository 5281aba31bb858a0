// Absolute and relative trajectory error (ATE, RPE) of an estimated trajectory against a reference, as in Sturm et
// al., "A Benchmark for the Evaluation of RGB-D SLAM Systems" (IROS 2012), with Umeyama's closed-form alignment.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace qsg::metrics {

// world_T_body at a time: translation and rotation (normalised on use; a zero or non-finite one is dropped).
struct TimedPose {
  std::int64_t time_ns = 0;
  Eigen::Vector3d t_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
};

enum class Alignment : std::uint8_t {
  kNone,  // the estimate is already in the reference frame
  kSE3,   // rotation and translation: what a stereo, RGB-D or visual-inertial estimate leaves unobservable
  kSim3,  // plus scale: monocular estimates
};
const char* to_string(Alignment a);

struct TrajectoryErrorConfig {
  std::int64_t max_time_difference_ns = 20'000'000;  // association window (TUM associate tool's default 0.02 s)
  Alignment alignment = Alignment::kSE3;
  double rpe_delta_m = 1.0;  // RPE over pose pairs this far apart along the reference path

  void print(std::FILE* out) const;
};

struct TrajectoryError {
  bool ok = false;
  std::string error;  // why not ok, e.g. "fewer than 3 associated poses"
  std::size_t reference_poses = 0, estimate_poses = 0, associated = 0;  // poses given, pairs associated
  // Poses left out before association: non-finite values, a zero-norm quaternion, or a stamp seen before.
  std::size_t reference_dropped = 0, estimate_dropped = 0;
  double ate_rmse_m = 0, ate_mean_m = 0, ate_median_m = 0, ate_max_m = 0;
  double path_length_m = 0;  // of the associated reference
  double scale = 1.0;        // Sim(3) scale (1 otherwise)
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_m = Eigen::Vector3d::Zero();  // reference = s R est + t
  // The associated positions of one side (nearly) coincide, so no rotation is defined: the alignment fell back to
  // a translation (centroid onto centroid, R = I, scale 1).
  bool alignment_degenerate = false;
  std::size_t rpe_pairs = 0;
  double rpe_translation_rmse_m_per_m = 0;  // translational RPE divided by the pair's reference distance, RMSE
  double rpe_rotation_rmse_deg_per_m = 0;

  void print(std::FILE* out) const;
};

// Associates by timestamp (greedy by increasing |dt| within the window, inclusive, each stamp at most once, like
// the TUM associate tool), aligns (Umeyama least squares over positions), computes ATE on positions and RPE over
// pairs rpe_delta_m apart along the associated reference path (the pair's distance is that path length). Inputs
// may be unsorted; never throws; on bad input returns ok = false with a reason.
TrajectoryError evaluate_trajectory(const std::vector<TimedPose>& reference, const std::vector<TimedPose>& estimate,
                                    const TrajectoryErrorConfig& config);

}  // namespace qsg::metrics
