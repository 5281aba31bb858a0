// Trajectory error: clean the inputs, associate stamps, align with Umeyama's closed form, then ATE and RPE.
#include "core/metrics/trajectory_error.h"

#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <tuple>
#include <utility>

namespace qsg::metrics {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRadToDeg = 180.0 / kPi;
// Below this quaternion norm the direction is noise, not a rotation.
constexpr double kMinQuaternionNorm = 1e-9;
// Positions whose mean squared distance to their centroid is below (1 um)^2 define no rotation.
constexpr double kMinSpread_m2 = 1e-12;
// A window wide enough to give more candidate pairs than this is a wrong unit, not a trajectory; refusing it keeps
// the candidate list from exhausting memory.
constexpr std::size_t kMaxCandidatePairs = 50'000'000;
constexpr std::size_t kMinAssociated = 3;

bool finite(const TimedPose& pose) {
  return pose.t_m.allFinite() && pose.q.coeffs().allFinite();
}

// Valid poses, quaternions normalised, sorted by time; of equal stamps the first given is kept.
std::vector<TimedPose> clean(const std::vector<TimedPose>& input, std::size_t* dropped) {
  std::vector<TimedPose> out;
  out.reserve(input.size());
  for (const TimedPose& pose : input) {
    if (!finite(pose)) continue;
    const double norm = pose.q.norm();
    if (!(norm > kMinQuaternionNorm)) continue;
    TimedPose p = pose;
    p.q.coeffs() /= norm;
    out.push_back(p);
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const TimedPose& a, const TimedPose& b) { return a.time_ns < b.time_ns; });
  const auto last = std::unique(out.begin(), out.end(),
                                [](const TimedPose& a, const TimedPose& b) { return a.time_ns == b.time_ns; });
  out.erase(last, out.end());
  *dropped = input.size() - out.size();
  return out;
}

// |a - b| without signed overflow: the true difference always fits in 64 unsigned bits.
std::uint64_t abs_difference(std::int64_t a, std::int64_t b) {
  return a > b ? static_cast<std::uint64_t>(a) - static_cast<std::uint64_t>(b)
               : static_cast<std::uint64_t>(b) - static_cast<std::uint64_t>(a);
}

std::int64_t saturating_add(std::int64_t a, std::int64_t b) {  // b >= 0
  return a > std::numeric_limits<std::int64_t>::max() - b ? std::numeric_limits<std::int64_t>::max() : a + b;
}

std::int64_t saturating_sub(std::int64_t a, std::int64_t b) {  // b >= 0
  return a < std::numeric_limits<std::int64_t>::min() + b ? std::numeric_limits<std::int64_t>::min() : a - b;
}

struct Match {
  std::size_t reference = 0;
  std::size_t estimate = 0;
};

struct Candidate {
  std::uint64_t dt_ns = 0;
  std::size_t reference = 0;
  std::size_t estimate = 0;
};

// Greedy matching by increasing |dt| (ties by reference then estimate index, so the result is deterministic), each
// pose used at most once; matches come out in reference order. Both inputs are sorted by time.
bool associate(const std::vector<TimedPose>& reference, const std::vector<TimedPose>& estimate,
               std::int64_t window_ns, std::vector<Match>* matches, std::string* error) {
  const auto by_time = [](const TimedPose& pose, std::int64_t t) { return pose.time_ns < t; };
  const auto time_before = [](std::int64_t t, const TimedPose& pose) { return t < pose.time_ns; };
  std::vector<std::pair<std::size_t, std::size_t>> ranges(reference.size());
  std::size_t count = 0;
  for (std::size_t r = 0; r < reference.size(); ++r) {
    const std::int64_t t = reference[r].time_ns;
    const auto lo = std::lower_bound(estimate.begin(), estimate.end(), saturating_sub(t, window_ns), by_time);
    const auto hi = std::upper_bound(lo, estimate.end(), saturating_add(t, window_ns), time_before);
    ranges[r] = {static_cast<std::size_t>(lo - estimate.begin()), static_cast<std::size_t>(hi - estimate.begin())};
    count += ranges[r].second - ranges[r].first;
  }
  if (count > kMaxCandidatePairs) {
    *error = "association window of " + std::to_string(window_ns) + " ns gives " + std::to_string(count) +
             " candidate pairs (more than " + std::to_string(kMaxCandidatePairs) + "): is the unit right?";
    return false;
  }
  std::vector<Candidate> candidates;
  candidates.reserve(count);
  for (std::size_t r = 0; r < reference.size(); ++r) {
    for (std::size_t e = ranges[r].first; e < ranges[r].second; ++e) {
      candidates.push_back({abs_difference(reference[r].time_ns, estimate[e].time_ns), r, e});
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return std::tie(a.dt_ns, a.reference, a.estimate) < std::tie(b.dt_ns, b.reference, b.estimate);
  });
  std::vector<bool> reference_used(reference.size(), false);
  std::vector<bool> estimate_used(estimate.size(), false);
  matches->clear();
  for (const Candidate& c : candidates) {
    if (reference_used[c.reference] || estimate_used[c.estimate]) continue;
    reference_used[c.reference] = true;
    estimate_used[c.estimate] = true;
    matches->push_back({c.reference, c.estimate});
  }
  std::sort(matches->begin(), matches->end(),
            [](const Match& a, const Match& b) { return a.reference < b.reference; });
  return true;
}

struct Similarity {
  double scale = 1.0;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_m = Eigen::Vector3d::Zero();
  bool degenerate = false;
};

// Least-squares y ~ s R x + t (Umeyama 1991): R from the SVD of the cross-covariance, its last axis flipped when
// the best orthogonal matrix would be a reflection; s = trace(D S) / var(x) only for Sim(3).
Similarity umeyama(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& y, Alignment alignment) {
  Similarity out;
  if (alignment == Alignment::kNone) return out;
  const double n = static_cast<double>(x.size());
  Eigen::Vector3d mean_x = Eigen::Vector3d::Zero(), mean_y = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < x.size(); ++i) {
    mean_x += x[i];
    mean_y += y[i];
  }
  mean_x /= n;
  mean_y /= n;
  double var_x = 0.0, var_y = 0.0;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < x.size(); ++i) {
    const Eigen::Vector3d dx = x[i] - mean_x, dy = y[i] - mean_y;
    var_x += dx.squaredNorm();
    var_y += dy.squaredNorm();
    cov += dy * dx.transpose();
  }
  var_x /= n;
  var_y /= n;
  cov /= n;
  if (var_x < kMinSpread_m2 || var_y < kMinSpread_m2) {
    out.degenerate = true;
    out.t_m = mean_y - mean_x;
    return out;
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d s = Eigen::Vector3d::Ones();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) s.z() = -1.0;
  out.R = svd.matrixU() * s.asDiagonal() * svd.matrixV().transpose();
  if (alignment == Alignment::kSim3) out.scale = svd.singularValues().dot(s) / var_x;
  out.t_m = mean_y - out.scale * out.R * mean_x;
  return out;
}

double rotation_angle_rad(const Eigen::Quaterniond& q) {
  return 2.0 * std::atan2(q.vec().norm(), std::abs(q.w()));
}

}  // namespace

const char* to_string(Alignment a) {
  switch (a) {
    case Alignment::kNone:
      return "none";
    case Alignment::kSE3:
      return "se3";
    case Alignment::kSim3:
      return "sim3";
  }
  return "unknown";
}

void TrajectoryErrorConfig::print(std::FILE* out) const {
  std::fprintf(out, "trajectory_error: max_time_difference_ns=%lld alignment=%s rpe_delta_m=%g\n",
               static_cast<long long>(max_time_difference_ns), to_string(alignment), rpe_delta_m);
}

void TrajectoryError::print(std::FILE* out) const {
  if (!ok) {
    std::fprintf(out, "trajectory_error: failed: %s\n", error.c_str());
    return;
  }
  std::fprintf(out,
               "trajectory_error: poses reference=%zu estimate=%zu (dropped %zu, %zu) associated=%zu "
               "path_length_m=%.4f\n",
               reference_poses, estimate_poses, reference_dropped, estimate_dropped, associated, path_length_m);
  std::fprintf(out, "  ATE m: rmse=%.6f mean=%.6f median=%.6f max=%.6f\n", ate_rmse_m, ate_mean_m, ate_median_m,
               ate_max_m);
  std::fprintf(out,
               "  alignment: scale=%.6f%s t_m=(%.6f %.6f %.6f) "
               "R=[%.6f %.6f %.6f; %.6f %.6f %.6f; %.6f %.6f %.6f]\n",
               scale, alignment_degenerate ? " (degenerate: translation only)" : "", t_m.x(), t_m.y(), t_m.z(),
               R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2));
  std::fprintf(out, "  RPE: pairs=%zu translation_rmse=%.6f m/m rotation_rmse=%.6f deg/m\n", rpe_pairs,
               rpe_translation_rmse_m_per_m, rpe_rotation_rmse_deg_per_m);
}

TrajectoryError evaluate_trajectory(const std::vector<TimedPose>& reference, const std::vector<TimedPose>& estimate,
                                    const TrajectoryErrorConfig& config) {
  TrajectoryError result;
  result.reference_poses = reference.size();
  result.estimate_poses = estimate.size();
  if (config.max_time_difference_ns < 0) {
    result.error = "max_time_difference_ns is negative";
    return result;
  }
  if (!std::isfinite(config.rpe_delta_m) || !(config.rpe_delta_m > 0.0)) {
    result.error = "rpe_delta_m must be positive and finite";
    return result;
  }
  if (config.alignment != Alignment::kNone && config.alignment != Alignment::kSE3 &&
      config.alignment != Alignment::kSim3) {
    result.error = "unknown alignment";
    return result;
  }

  const std::vector<TimedPose> ref = clean(reference, &result.reference_dropped);
  const std::vector<TimedPose> est = clean(estimate, &result.estimate_dropped);
  std::vector<Match> matches;
  if (!associate(ref, est, config.max_time_difference_ns, &matches, &result.error)) return result;
  result.associated = matches.size();
  if (matches.size() < kMinAssociated) {
    result.error = "fewer than 3 associated poses (" + std::to_string(matches.size()) + " of " +
                   std::to_string(ref.size()) + " valid reference and " + std::to_string(est.size()) +
                   " valid estimate poses within " + std::to_string(config.max_time_difference_ns) + " ns)";
    return result;
  }

  const std::size_t n = matches.size();
  std::vector<Eigen::Vector3d> x(n), y(n);
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = est[matches[i].estimate].t_m;
    y[i] = ref[matches[i].reference].t_m;
  }
  const Similarity sim = umeyama(x, y, config.alignment);
  result.scale = sim.scale;
  result.R = sim.R;
  result.t_m = sim.t_m;
  result.alignment_degenerate = sim.degenerate;

  // ATE on positions.
  std::vector<Eigen::Vector3d> aligned(n);
  std::vector<double> errors(n);
  double sum = 0.0, sum_sq = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    aligned[i] = sim.scale * (sim.R * x[i]) + sim.t_m;
    errors[i] = (y[i] - aligned[i]).norm();
    sum += errors[i];
    sum_sq += errors[i] * errors[i];
    result.ate_max_m = std::max(result.ate_max_m, errors[i]);
  }
  result.ate_mean_m = sum / static_cast<double>(n);
  result.ate_rmse_m = std::sqrt(sum_sq / static_cast<double>(n));
  std::sort(errors.begin(), errors.end());
  result.ate_median_m = n % 2 == 1 ? errors[n / 2] : 0.5 * (errors[n / 2 - 1] + errors[n / 2]);

  // Distance along the associated reference, which picks the RPE pairs and normalises their errors.
  std::vector<double> along_m(n, 0.0);
  for (std::size_t i = 1; i < n; ++i) along_m[i] = along_m[i - 1] + (y[i] - y[i - 1]).norm();
  result.path_length_m = along_m[n - 1];

  // RPE: for each pose i, the first later pose j at least rpe_delta_m further along. The rigid part of the
  // alignment cancels in a relative pose; the Sim(3) scale does not, so the estimate is compared aligned.
  const Eigen::Quaterniond q_align(sim.R);
  double rpe_t_sq = 0.0, rpe_r_sq = 0.0;
  std::size_t j = 1;
  for (std::size_t i = 0; i + 1 < n; ++i) {
    j = std::max(j, i + 1);
    while (j < n && along_m[j] - along_m[i] < config.rpe_delta_m) ++j;
    if (j == n) break;
    const double distance_m = along_m[j] - along_m[i];
    const Eigen::Quaterniond& qr_i = ref[matches[i].reference].q;
    const Eigen::Quaterniond& qr_j = ref[matches[j].reference].q;
    const Eigen::Quaterniond qe_i = q_align * est[matches[i].estimate].q;
    const Eigen::Quaterniond qe_j = q_align * est[matches[j].estimate].q;
    // Relative motions i -> j in frame i; the error motion's translation has the norm of their difference.
    const Eigen::Vector3d ref_t_m = qr_i.conjugate() * (y[j] - y[i]);
    const Eigen::Vector3d est_t_m = qe_i.conjugate() * (aligned[j] - aligned[i]);
    const Eigen::Quaterniond ref_q = qr_i.conjugate() * qr_j;
    const Eigen::Quaterniond est_q = qe_i.conjugate() * qe_j;
    const double t_per_m = (est_t_m - ref_t_m).norm() / distance_m;
    const double r_deg_per_m = rotation_angle_rad(ref_q.conjugate() * est_q) * kRadToDeg / distance_m;
    rpe_t_sq += t_per_m * t_per_m;
    rpe_r_sq += r_deg_per_m * r_deg_per_m;
    ++result.rpe_pairs;
  }
  if (result.rpe_pairs > 0) {
    result.rpe_translation_rmse_m_per_m = std::sqrt(rpe_t_sq / static_cast<double>(result.rpe_pairs));
    result.rpe_rotation_rmse_deg_per_m = std::sqrt(rpe_r_sq / static_cast<double>(result.rpe_pairs));
  }
  result.ok = true;
  return result;
}

}  // namespace qsg::metrics
