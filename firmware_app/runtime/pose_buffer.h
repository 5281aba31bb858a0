// Time alignment of odometry and frames: a fixed-capacity, time-ordered ring of pose samples, and the pose at a
// frame's sample time interpolated on SE(3) between the two samples around it. Samples a consumer must not trust
// (non-finite, off-unit quaternion, out of order, duplicated, jumping in time or space) are rejected and counted.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "core/memory/resource_stats.h"
#include "core/messages/sensor_types.h"

namespace qsg::runtime {

struct PoseBufferConfig {
  // Two accepted samples further apart than this are a gap (a logged fault): no pose is interpolated across it.
  double max_gap_s = 0.5;
  // A sample this far past the previous one is held, not accepted, until the next sample follows it within
  // max_gap_s (the source was silent and came back); a lone one is a clock fault, rejected.
  double max_time_jump_s = 10.0;
  // Faster than this between two samples is a pose jump (a reset or a corrupt message), rejected. A quadruped
  // walks at about 1 m/s; a wheeled platform or a vehicle would raise it.
  double max_speed_m_per_s = 10.0;
  double unit_quaternion_tolerance = 1e-3;  // | |q| - 1 | above this: rejected (below: normalised)

  std::string check() const;  // empty when usable
  void print(std::FILE* out) const;
};

// Why a sample was not taken. Every value but kAccepted and kHeld is a rejection, counted by kind.
enum class PoseSampleResult : std::uint8_t {
  kAccepted,
  kHeld,          // past max_time_jump_s: waits for the next sample to confirm the new time
  kNonFinite,     // NaN or infinite time, position, orientation or covariance
  kBadQuaternion, // not within unit_quaternion_tolerance of unit norm
  kOutOfOrder,    // sample time before the newest accepted one
  kDuplicate,     // the newest accepted sample's time or sequence number again
  kTimeJump,      // a held sample the next one did not confirm
  kPoseJump,      // implies a speed above max_speed_m_per_s
};
const char* to_string(PoseSampleResult r);

enum class PoseLookup : std::uint8_t {
  kOk,
  kNotYet,  // after the newest sample: the pose has not arrived (wait, up to the budget's bound)
  kTooOld,  // before the oldest sample still held
  kInGap,   // the two samples around it are further apart than max_gap_s
  kEmpty,
};
const char* to_string(PoseLookup r);

struct PoseBufferCounters {
  std::uint64_t accepted = 0;
  std::uint64_t non_finite = 0;
  std::uint64_t bad_quaternion = 0;
  std::uint64_t out_of_order = 0;
  std::uint64_t duplicates = 0;
  std::uint64_t time_jumps = 0;
  std::uint64_t pose_jumps = 0;
  std::uint64_t resyncs = 0;      // held samples confirmed by the next (accepted with a gap)
  // The source moved faster than max_speed_m_per_s and stayed there (a relocalization or a reset): after samples
  // refused as pose jumps, one was accepted nearer the refused ones than the pose before them. The map on either
  // side is then joined by that step (logged; a fault, not a rejection).
  std::uint64_t steps = 0;
  std::uint64_t gaps = 0;         // accepted samples more than max_gap_s after the previous one (logged faults)
  std::uint64_t overwritten = 0;  // oldest samples dropped because the ring was full (normal in a long run)
  std::uint64_t rejected() const {
    return non_finite + bad_quaternion + out_of_order + duplicates + time_jumps + pose_jumps;
  }
  void print(std::FILE* out) const;
};

// One accepted sample: world_T_body with the diagonal of its covariance ([t (m^2); r (rad^2)]).
struct BufferedPose {
  std::int64_t time_ns = 0;
  std::uint64_t sequence = 0;
  Eigen::Vector3d t_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  Eigen::Matrix<double, 6, 1> variance = Eigen::Matrix<double, 6, 1>::Zero();
};

// a * Exp(alpha * Log(a^-1 b)): the constant-twist (screw) path from a (alpha 0) to b (alpha 1).
Eigen::Isometry3d interpolate_se3(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double alpha);

// Single-threaded: the loop's odometry task pushes, its camera task looks up. Allocates only in init().
class PoseBuffer {
 public:
  bool init(std::uint32_t capacity, const PoseBufferConfig& config, std::string* error);

  PoseSampleResult push(const messages::OdometrySample& sample);
  // world_T_body at time_ns (and the interpolated covariance diagonal when `variance` is given).
  PoseLookup lookup(std::int64_t time_ns, Eigen::Isometry3d* world_T_body,
                    Eigen::Matrix<double, 6, 1>* variance = nullptr) const;

  std::uint32_t size() const { return size_; }
  std::uint32_t capacity() const { return capacity_; }
  bool empty() const { return size_ == 0; }
  const BufferedPose& newest() const { return at(size_ - 1); }  // size() > 0
  const BufferedPose& oldest() const { return at(0); }          // size() > 0
  const PoseBufferCounters& counters() const { return counters_; }
  const PoseBufferConfig& config() const { return config_; }
  // capacity, in use, high-water mark; `failed` counts rejected samples.
  memory::ResourceStats stats() const;

 private:
  const BufferedPose& at(std::uint32_t i) const { return ring_[(head_ + i) % capacity_]; }
  PoseSampleResult validate(const messages::OdometrySample& sample, BufferedPose* out);
  PoseSampleResult check_against_newest(const BufferedPose& pose) const;
  void append(const BufferedPose& pose);
  PoseSampleResult count(PoseSampleResult r);

  PoseBufferConfig config_;
  std::unique_ptr<BufferedPose[]> ring_;
  std::uint32_t capacity_ = 0;
  std::uint32_t head_ = 0;
  std::uint32_t size_ = 0;
  std::uint32_t high_water_ = 0;
  bool have_held_ = false;
  // Samples refused as pose jumps since the last accepted one, and where the last of them was.
  std::uint32_t jump_run_ = 0;
  Eigen::Vector3d last_jump_t_m_ = Eigen::Vector3d::Zero();
  BufferedPose held_;
  PoseBufferCounters counters_;
};

}  // namespace qsg::runtime
