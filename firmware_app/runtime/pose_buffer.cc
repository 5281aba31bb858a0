// Pose buffer: validation of odometry samples, the ring, and SE(3) interpolation at frame times.
#include "firmware_app/runtime/pose_buffer.h"

#include <cinttypes>
#include <cmath>

namespace qsg::runtime {

namespace {

Eigen::Matrix3d hat(const Eigen::Vector3d& w) {
  Eigen::Matrix3d m;
  m << 0.0, -w.z(), w.y(), w.z(), 0.0, -w.x(), -w.y(), w.x(), 0.0;
  return m;
}

// The left Jacobian V of SO(3) (t = V rho in Exp of a twist (rho, w)), and its inverse; series near w = 0.
Eigen::Matrix3d left_jacobian(const Eigen::Vector3d& w) {
  const double theta = w.norm();
  const Eigen::Matrix3d W = hat(w);
  if (theta < 1e-6) return Eigen::Matrix3d::Identity() + 0.5 * W + (1.0 / 6.0) * W * W;
  const double t2 = theta * theta;
  return Eigen::Matrix3d::Identity() + (1.0 - std::cos(theta)) / t2 * W + (theta - std::sin(theta)) / (t2 * theta) * W * W;
}

Eigen::Matrix3d left_jacobian_inverse(const Eigen::Vector3d& w) {
  const double theta = w.norm();
  const Eigen::Matrix3d W = hat(w);
  if (theta < 1e-6) return Eigen::Matrix3d::Identity() - 0.5 * W + (1.0 / 12.0) * W * W;
  const double half = 0.5 * theta;
  const double coefficient = (1.0 - half * std::cos(half) / std::sin(half)) / (theta * theta);
  return Eigen::Matrix3d::Identity() - 0.5 * W + coefficient * W * W;
}

void log_rejection(PoseSampleResult r, std::uint64_t count) {
  if ((count & (count - 1)) == 0)
    std::fprintf(stderr, "qsg: warning: odometry: sample rejected (%s); %" PRIu64 " so far\n", to_string(r), count);
}

}  // namespace

Eigen::Isometry3d interpolate_se3(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double alpha) {
  const Eigen::Isometry3d delta = a.inverse() * b;
  const Eigen::AngleAxisd aa(Eigen::Quaterniond(delta.linear()).normalized());
  Eigen::Vector3d w = aa.angle() * aa.axis();
  if (aa.angle() > M_PI) w = (aa.angle() - 2.0 * M_PI) * aa.axis();  // the short way round
  const Eigen::Vector3d rho = left_jacobian_inverse(w) * delta.translation();
  const Eigen::Vector3d w_a = alpha * w;
  Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
  const double angle = w_a.norm();
  if (angle > 0.0) step.linear() = Eigen::AngleAxisd(angle, w_a / angle).toRotationMatrix();
  step.translation() = left_jacobian(w_a) * (alpha * rho);
  return a * step;
}

const char* to_string(PoseSampleResult r) {
  switch (r) {
    case PoseSampleResult::kAccepted: return "accepted";
    case PoseSampleResult::kHeld: return "held: time jump, waiting for confirmation";
    case PoseSampleResult::kNonFinite: return "non-finite value";
    case PoseSampleResult::kBadQuaternion: return "quaternion not unit";
    case PoseSampleResult::kOutOfOrder: return "out of order";
    case PoseSampleResult::kDuplicate: return "duplicate";
    case PoseSampleResult::kTimeJump: return "time jump";
    case PoseSampleResult::kPoseJump: return "pose jump";
  }
  return "?";
}

const char* to_string(PoseLookup r) {
  switch (r) {
    case PoseLookup::kOk: return "ok";
    case PoseLookup::kNotYet: return "not yet";
    case PoseLookup::kTooOld: return "too old";
    case PoseLookup::kInGap: return "in a gap";
    case PoseLookup::kEmpty: return "empty";
  }
  return "?";
}

std::string PoseBufferConfig::check() const {
  if (!(max_gap_s > 0.0 && max_gap_s <= 60.0)) return "max_gap_s must be in (0, 60]";
  if (!(max_time_jump_s >= max_gap_s && max_time_jump_s <= 3600.0))
    return "max_time_jump_s must be in [max_gap_s, 3600]";
  if (!(max_speed_m_per_s > 0.0 && max_speed_m_per_s <= 1000.0)) return "max_speed_m_per_s must be in (0, 1000]";
  if (!(unit_quaternion_tolerance > 0.0 && unit_quaternion_tolerance <= 0.1))
    return "unit_quaternion_tolerance must be in (0, 0.1]";
  return {};
}

void PoseBufferConfig::print(std::FILE* out) const {
  std::fprintf(out, "pose buffer: max_gap_s=%g max_time_jump_s=%g max_speed_m_per_s=%g unit_quaternion_tolerance=%g\n",
               max_gap_s, max_time_jump_s, max_speed_m_per_s, unit_quaternion_tolerance);
}

void PoseBufferCounters::print(std::FILE* out) const {
  std::fprintf(out,
               "odometry samples: accepted=%" PRIu64 " rejected=%" PRIu64 " (non_finite=%" PRIu64
               " bad_quaternion=%" PRIu64 " out_of_order=%" PRIu64 " duplicates=%" PRIu64 " time_jumps=%" PRIu64
               " pose_jumps=%" PRIu64 ") gaps=%" PRIu64 " resyncs=%" PRIu64 " steps=%" PRIu64 " overwritten=%" PRIu64 "\n",
               accepted, rejected(), non_finite, bad_quaternion, out_of_order, duplicates, time_jumps, pose_jumps, gaps,
               resyncs, steps, overwritten);
}

bool PoseBuffer::init(std::uint32_t capacity, const PoseBufferConfig& config, std::string* error) {
  const std::string why = config.check();
  if (!why.empty()) return *error = "pose buffer config: " + why, false;
  if (capacity < 2) return *error = "pose buffer: capacity must be at least 2 (the budget's 'odometry' queue depth)", false;
  config_ = config;
  ring_ = std::make_unique<BufferedPose[]>(capacity);
  capacity_ = capacity;
  head_ = size_ = high_water_ = 0;
  have_held_ = false;
  jump_run_ = 0;
  counters_ = {};
  return true;
}

PoseSampleResult PoseBuffer::count(PoseSampleResult r) {
  std::uint64_t* c = nullptr;
  switch (r) {
    case PoseSampleResult::kNonFinite: c = &counters_.non_finite; break;
    case PoseSampleResult::kBadQuaternion: c = &counters_.bad_quaternion; break;
    case PoseSampleResult::kOutOfOrder: c = &counters_.out_of_order; break;
    case PoseSampleResult::kDuplicate: c = &counters_.duplicates; break;
    case PoseSampleResult::kTimeJump: c = &counters_.time_jumps; break;
    case PoseSampleResult::kPoseJump: c = &counters_.pose_jumps; break;
    case PoseSampleResult::kAccepted:
    case PoseSampleResult::kHeld: return r;
  }
  log_rejection(r, ++*c);
  return r;
}

PoseSampleResult PoseBuffer::validate(const messages::OdometrySample& s, BufferedPose* out) {
  const Eigen::Vector4d q = s.world_R_body.coeffs();
  if (!s.world_t_body_m.allFinite() || !q.allFinite() || !s.covariance.allFinite()) return PoseSampleResult::kNonFinite;
  if (std::abs(q.norm() - 1.0) > config_.unit_quaternion_tolerance) return PoseSampleResult::kBadQuaternion;
  out->time_ns = s.sample_time_ns;
  out->sequence = s.sequence;
  out->t_m = s.world_t_body_m;
  out->q = s.world_R_body.normalized();
  out->variance = s.covariance.diagonal().cwiseMax(0.0);
  return PoseSampleResult::kAccepted;
}

PoseSampleResult PoseBuffer::check_against_newest(const BufferedPose& pose) const {
  if (size_ == 0) return PoseSampleResult::kAccepted;
  const BufferedPose& last = newest();
  if (pose.time_ns == last.time_ns || pose.sequence == last.sequence) return PoseSampleResult::kDuplicate;
  if (pose.time_ns < last.time_ns) return PoseSampleResult::kOutOfOrder;
  const double dt_s = 1e-9 * static_cast<double>(pose.time_ns - last.time_ns);
  if ((pose.t_m - last.t_m).norm() > config_.max_speed_m_per_s * dt_s) return PoseSampleResult::kPoseJump;
  if (dt_s > config_.max_time_jump_s) return PoseSampleResult::kHeld;
  return PoseSampleResult::kAccepted;
}

void PoseBuffer::append(const BufferedPose& pose) {
  if (size_ > 0 && pose.time_ns - newest().time_ns > static_cast<std::int64_t>(config_.max_gap_s * 1e9)) {
    ++counters_.gaps;
    if ((counters_.gaps & (counters_.gaps - 1)) == 0)
      std::fprintf(stderr, "qsg: warning: odometry: %.3f s without a pose (fault); %" PRIu64 " gaps so far\n",
                   1e-9 * static_cast<double>(pose.time_ns - newest().time_ns), counters_.gaps);
  }
  if (size_ == capacity_) {
    head_ = (head_ + 1) % capacity_;
    --size_;
    ++counters_.overwritten;
  }
  ring_[(head_ + size_) % capacity_] = pose;
  ++size_;
  if (size_ > high_water_) high_water_ = size_;
  ++counters_.accepted;
}

PoseSampleResult PoseBuffer::push(const messages::OdometrySample& sample) {
  BufferedPose pose;
  const PoseSampleResult valid = validate(sample, &pose);
  if (valid != PoseSampleResult::kAccepted) return count(valid);
  if (have_held_) {
    // The held sample is confirmed when this one follows it closely; otherwise it was a clock fault.
    const std::int64_t dt_ns = pose.time_ns - held_.time_ns;
    have_held_ = false;
    if (dt_ns > 0 && dt_ns <= static_cast<std::int64_t>(config_.max_gap_s * 1e9) && pose.sequence != held_.sequence &&
        (pose.t_m - held_.t_m).norm() <= config_.max_speed_m_per_s * 1e-9 * static_cast<double>(dt_ns)) {
      ++counters_.resyncs;
      jump_run_ = 0;
      append(held_);
      append(pose);
      return PoseSampleResult::kAccepted;
    }
    count(PoseSampleResult::kTimeJump);
  }
  const PoseSampleResult order = check_against_newest(pose);
  if (order == PoseSampleResult::kHeld) {
    held_ = pose;
    have_held_ = true;
    return order;
  }
  if (order == PoseSampleResult::kPoseJump) {
    ++jump_run_;
    last_jump_t_m_ = pose.t_m;
  }
  if (order != PoseSampleResult::kAccepted) return count(order);
  // After refused jumps: a sample back where the stream was ends a glitch; one where the refused samples went is a
  // step the source kept (its speed from the newest is now under the limit only because time has passed).
  if (jump_run_ > 0 && size_ > 0) {
    const double from_newest_m = (pose.t_m - newest().t_m).norm();
    if ((pose.t_m - last_jump_t_m_).norm() < from_newest_m) {
      ++counters_.steps;
      if ((counters_.steps & (counters_.steps - 1)) == 0)
        std::fprintf(stderr,
                     "qsg: warning: odometry: the source stepped %.2f m and stayed there (%u samples refused as jumps "
                     "first): a relocalization or a reset; %" PRIu64 " steps so far\n",
                     from_newest_m, jump_run_, counters_.steps);
    }
  }
  jump_run_ = 0;
  append(pose);
  return PoseSampleResult::kAccepted;
}

PoseLookup PoseBuffer::lookup(std::int64_t time_ns, Eigen::Isometry3d* world_T_body,
                              Eigen::Matrix<double, 6, 1>* variance) const {
  if (size_ == 0) return PoseLookup::kEmpty;
  if (time_ns > newest().time_ns) return PoseLookup::kNotYet;
  if (time_ns < oldest().time_ns) return PoseLookup::kTooOld;
  // The first sample at or after time_ns (binary search over the ring's logical order).
  std::uint32_t lo = 0, hi = size_ - 1;
  while (lo < hi) {
    const std::uint32_t mid = lo + (hi - lo) / 2;
    if (at(mid).time_ns < time_ns) lo = mid + 1;
    else hi = mid;
  }
  const BufferedPose& b = at(lo);
  const auto to_isometry = [](const BufferedPose& p) {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.linear() = p.q.toRotationMatrix();
    t.translation() = p.t_m;
    return t;
  };
  if (b.time_ns == time_ns) {
    *world_T_body = to_isometry(b);
    if (variance != nullptr) *variance = b.variance;
    return PoseLookup::kOk;
  }
  const BufferedPose& a = at(lo - 1);  // lo > 0: time_ns > oldest
  const std::int64_t span_ns = b.time_ns - a.time_ns;
  if (span_ns > static_cast<std::int64_t>(config_.max_gap_s * 1e9)) return PoseLookup::kInGap;
  const double alpha = static_cast<double>(time_ns - a.time_ns) / static_cast<double>(span_ns);
  *world_T_body = interpolate_se3(to_isometry(a), to_isometry(b), alpha);
  if (variance != nullptr) *variance = (1.0 - alpha) * a.variance + alpha * b.variance;
  return PoseLookup::kOk;
}

memory::ResourceStats PoseBuffer::stats() const {
  memory::ResourceStats s;
  s.name = "odometry.pose_buffer";
  s.unit = "samples";
  s.capacity = capacity_;
  s.in_use = size_;
  s.high_water = high_water_;
  s.failed = counters_.rejected();
  return s;
}

}  // namespace qsg::runtime
