// Drifting odometry over a ground-truth trajectory.
#include "drivers/sim/drifting_odometry.h"

#include <Eigen/Geometry>
#include <cinttypes>
#include <cmath>

namespace qsg::sim {
namespace {

std::uint64_t splitmix64(std::uint64_t* state) {
  std::uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

constexpr double kPi = 3.14159265358979323846;

Eigen::Matrix3d rot_z(double psi) {
  return Eigen::AngleAxisd(psi, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

}  // namespace

void DriftingOdometry::Config::print(std::FILE* out) const {
  std::fprintf(out,
               "DriftingOdometry: translation_sigma_m_per_sqrt_m=%g yaw_sigma_rad_per_sqrt_m=%g scale_bias=%g "
               "yaw_bias_rad_per_m=%g seed=%" PRIu64 " publish_latency_ns=%" PRId64
               " translation_floor_m=%g rotation_floor_rad=%g\n",
               translation_sigma_m_per_sqrt_m, yaw_sigma_rad_per_sqrt_m, scale_bias, yaw_bias_rad_per_m, seed,
               publish_latency_ns, translation_floor_m, rotation_floor_rad);
}

DriftingOdometry::DriftingOdometry(replay::Trajectory ground_truth, const Config& config)
    : ground_truth_(std::move(ground_truth)), config_(config) {
  rewind();
}

void DriftingOdometry::rewind() {
  next_ = 0;
  rng_state_ = config_.seed;
  have_spare_ = false;
  psi_rad_ = 0.0;
  offset_m_.setZero();
  distance_m_ = 0.0;
  error_cov_.setZero();
  have_last_time_ = false;
}

double DriftingOdometry::gaussian() {
  // Box-Muller on our own generator: the same numbers on every platform and standard library.
  if (have_spare_) {
    have_spare_ = false;
    return spare_;
  }
  const double u1 = (static_cast<double>(splitmix64(&rng_state_) >> 11) + 1.0) * 0x1.0p-53;  // (0, 1]
  const double u2 = static_cast<double>(splitmix64(&rng_state_) >> 11) * 0x1.0p-53;
  const double r = std::sqrt(-2.0 * std::log(u1));
  const double theta = 2.0 * kPi * u2;
  spare_ = r * std::sin(theta);
  have_spare_ = true;
  return r * std::cos(theta);
}

drivers::ReadStatus DriftingOdometry::read(messages::OdometrySample& sample, std::int64_t /*timeout_ns*/) {
  if (next_ >= ground_truth_.size()) return drivers::ReadStatus::kEndOfStream;
  const std::size_t i = next_++;
  const replay::StampedPose& truth = ground_truth_[i];
  if (i > 0) {
    const Eigen::Vector3d step_m = truth.world_t_body_m - ground_truth_[i - 1].world_t_body_m;
    const double d = step_m.norm();
    distance_m_ += d;
    // Noise is drawn on every step, moving or not, so a sample's noise depends only on the seed and its index.
    const double sqrt_d = std::sqrt(d);
    const double yaw_step = config_.yaw_sigma_rad_per_sqrt_m * sqrt_d * gaussian() + config_.yaw_bias_rad_per_m * d;
    const Eigen::Vector3d noise_m(gaussian(), gaussian(), gaussian());
    const double psi_prev = psi_rad_;
    psi_rad_ += yaw_step;
    if (psi_prev != 0.0 || psi_rad_ != 0.0 || config_.scale_bias != 0.0 || config_.translation_sigma_m_per_sqrt_m != 0.0) {
      const Eigen::Matrix3d r_prev = rot_z(psi_prev);
      // Yaw error pivots about the current position, so a new yaw error does not teleport the estimate.
      offset_m_ += r_prev * truth.world_t_body_m - rot_z(psi_rad_) * truth.world_t_body_m +
                   config_.scale_bias * (r_prev * step_m) + config_.translation_sigma_m_per_sqrt_m * sqrt_d * noise_m;
    }
    // Covariance of [p; psi], p = estimate - truth: p += (Rz(psi) - I) step + n ~ p + psi * (z x step) + n.
    Eigen::Matrix4d f = Eigen::Matrix4d::Identity();
    f(0, 3) = -step_m.y();
    f(1, 3) = step_m.x();
    const double vt = config_.translation_sigma_m_per_sqrt_m * config_.translation_sigma_m_per_sqrt_m * d;
    const double vy = config_.yaw_sigma_rad_per_sqrt_m * config_.yaw_sigma_rad_per_sqrt_m * d;
    error_cov_ = f * error_cov_ * f.transpose();
    error_cov_.diagonal() += Eigen::Vector4d(vt, vt, vt, vy);
  }
  if (psi_rad_ == 0.0) {
    last_est_t_m_ = truth.world_t_body_m + offset_m_;
    sample.world_R_body = truth.world_R_body;
  } else {
    last_est_t_m_ = rot_z(psi_rad_) * truth.world_t_body_m + offset_m_;
    sample.world_R_body = Eigen::Quaterniond(Eigen::AngleAxisd(psi_rad_, Eigen::Vector3d::UnitZ())) * truth.world_R_body;
  }
  sample.world_t_body_m = last_est_t_m_;
  sample.sequence = i;
  sample.sample_time_ns = truth.time_ns;
  sample.publish_time_ns = truth.time_ns + config_.publish_latency_ns;
  sample.flags = 0;
  if (have_last_time_ && truth.time_ns <= last_time_ns_) {
    sample.flags |= messages::kFrameTimestampBackwards;
    ++counters_.timestamps_backwards;
  }
  have_last_time_ = true;
  last_time_ns_ = truth.time_ns;

  const double ft = config_.translation_floor_m * config_.translation_floor_m;
  const double fr = config_.rotation_floor_rad * config_.rotation_floor_rad;
  sample.covariance.setZero();
  sample.covariance.topLeftCorner<3, 3>() = error_cov_.topLeftCorner<3, 3>();
  sample.covariance.block<3, 1>(0, 5) = error_cov_.block<3, 1>(0, 3);
  sample.covariance.block<1, 3>(5, 0) = error_cov_.block<1, 3>(3, 0);
  sample.covariance(5, 5) = error_cov_(3, 3);
  sample.covariance.diagonal() += (Eigen::Matrix<double, 6, 1>() << ft, ft, ft, fr, fr, fr).finished();
  ++counters_.delivered;
  return drivers::ReadStatus::kOk;
}

replay::Trajectory drifted_trajectory(const replay::Trajectory& truth, const DriftingOdometry::Config& config) {
  DriftingOdometry odometry(truth, config);
  replay::Trajectory estimate;
  estimate.reserve(truth.size());
  messages::OdometrySample sample;
  while (odometry.read(sample, 0) == drivers::ReadStatus::kOk) {
    replay::StampedPose p;
    p.time_ns = sample.sample_time_ns;
    p.world_t_body_m = sample.world_t_body_m;
    p.world_R_body = sample.world_R_body;
    estimate.push_back(p);
  }
  return estimate;
}

}  // namespace qsg::sim
