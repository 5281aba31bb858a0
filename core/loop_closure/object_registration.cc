#include "core/loop_closure/object_registration.h"

#include "core/loop_closure/detector_params.h"

#include <Eigen/SVD>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>

namespace qsg::loop_closure {

std::string RegistrationConfig::check() const {
  // Each field the app exposes within its declared range (detector_params.cc).
  if (std::string why = params::check(registration_params_table(), *this); !why.empty()) return why;
  if (!(min_spread_m >= 0.0 && min_spread_m <= 100.0)) return "min_spread_m must be in [0, 100] m";
  if (max_clique_nodes < 1) return "max_clique_nodes must be at least 1";
  if (gnc_iterations < 1 || gnc_iterations > 1000) return "gnc_iterations must be in [1, 1000]";
  return "";
}

void RegistrationConfig::print(std::FILE* out) const {
  std::fprintf(out,
               "object registration: noise bound %.2f m, at least %u inliers spanning %.2f m, %s, clique search "
               "<= %u nodes, GNC <= %d iterations\n",
               noise_bound_m, min_inliers, min_spread_m, gravity_aligned ? "yaw + translation" : "full SE(3)",
               max_clique_nodes, gnc_iterations);
}

const char* to_string(RegistrationFailure f) {
  switch (f) {
    case RegistrationFailure::kNone: return "ok";
    case RegistrationFailure::kTooFewCorrespondences: return "too few label-consistent correspondences";
    case RegistrationFailure::kTooFewInliers: return "too few inliers";
    case RegistrationFailure::kDegenerate: return "inliers degenerate (on a line)";
  }
  return "?";
}

// Branch and bound over the consistency graph: `candidates` can extend the clique stack_[0, size).
void ObjectRegistration::expand(Row candidates, std::uint32_t size) {
  if (++nodes_visited_ > config_.max_clique_nodes) {
    truncated_ = true;
    return;
  }
  if (candidates.none()) {
    if (size > best_size_) {
      best_size_ = size;
      std::copy(stack_, stack_ + size, best_);
    }
    return;
  }
  for (std::uint32_t v = 0; v < n_; ++v) {
    if (size + candidates.count() <= best_size_ || truncated_) return;  // cannot beat the best any more
    if (!candidates.test(v)) continue;
    stack_[size] = v;
    expand(candidates & adjacency_[v], size + 1);
    candidates.reset(v);
  }
}

Eigen::Isometry3d ObjectRegistration::align(const Eigen::Vector3d* src, const Eigen::Vector3d* dst, const double* w,
                                            std::size_t n) const {
  double sw = 0.0;
  Eigen::Vector3d cs = Eigen::Vector3d::Zero(), cd = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    sw += w[i];
    cs += w[i] * src[i];
    cd += w[i] * dst[i];
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (sw <= 0.0) return T;
  cs /= sw;
  cd /= sw;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  if (config_.gravity_aligned) {
    double s = 0.0, c = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d a = src[i] - cs, b = dst[i] - cd;
      s += w[i] * (a.x() * b.y() - a.y() * b.x());
      c += w[i] * (a.x() * b.x() + a.y() * b.y());
    }
    R = Eigen::AngleAxisd(std::atan2(s, c), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  } else {
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    for (std::size_t i = 0; i < n; ++i) H += w[i] * (src[i] - cs) * (dst[i] - cd).transpose();
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
    D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
    R = svd.matrixV() * D * svd.matrixU().transpose();
  }
  T.linear() = R;
  T.translation() = cd - R * cs;
  return T;
}

Registration ObjectRegistration::register_sets(const LabelledPoint* source, std::size_t num_source,
                                               const LabelledPoint* target, std::size_t num_target) {
  Registration out;
  n_ = 0;
  for (std::size_t i = 0; i < num_source; ++i)
    for (std::size_t j = 0; j < num_target; ++j) {
      if (source[i].label != target[j].label) continue;
      ++out.correspondences;
      if (n_ == kMaxCorrespondences) {
        ++out.correspondences_dropped;
        continue;
      }
      src_[n_] = static_cast<std::uint32_t>(i);
      dst_[n_++] = static_cast<std::uint32_t>(j);
    }
  if (n_ < config_.min_inliers) return out;

  // Consistency graph: rigid motions preserve distances, each endpoint off by at most the noise bound.
  const double tolerance = 2.0 * config_.noise_bound_m;
  for (std::uint32_t a = 0; a < n_; ++a) adjacency_[a].reset();
  for (std::uint32_t a = 0; a < n_; ++a)
    for (std::uint32_t b = a + 1; b < n_; ++b) {
      if (src_[a] == src_[b] || dst_[a] == dst_[b]) continue;  // one object cannot match two
      const double ds = (source[src_[a]].p_m - source[src_[b]].p_m).norm();
      const double dd = (target[dst_[a]].p_m - target[dst_[b]].p_m).norm();
      if (std::abs(ds - dd) > tolerance) continue;
      adjacency_[a].set(b);
      adjacency_[b].set(a);
    }
  best_size_ = 0;
  nodes_visited_ = 0;
  truncated_ = false;
  Row all;
  for (std::uint32_t a = 0; a < n_; ++a) all.set(a);
  expand(all, 0);
  out.clique = best_size_;
  out.clique_search_truncated = truncated_;
  if (best_size_ < config_.min_inliers) {
    out.failure = RegistrationFailure::kTooFewInliers;
    return out;
  }

  // Truncated least squares on the clique by graduated non-convexity (Yang et al., RA-L 2020).
  Eigen::Vector3d* ps = clique_source_;
  Eigen::Vector3d* pd = clique_target_;
  double w[kMaxCorrespondences] = {}, r2[kMaxCorrespondences] = {};
  const std::uint32_t m = best_size_;
  for (std::uint32_t k = 0; k < m; ++k) {
    ps[k] = source[src_[best_[k]]].p_m;
    pd[k] = target[dst_[best_[k]]].p_m;
    w[k] = 1.0;
  }
  const double c2 = tolerance * tolerance;
  Eigen::Isometry3d T = align(ps, pd, w, m);
  double max_r2 = 0.0;
  for (std::uint32_t k = 0; k < m; ++k) max_r2 = std::max(max_r2, (T * ps[k] - pd[k]).squaredNorm());
  double mu = max_r2 > 0.5 * c2 ? c2 / (2.0 * max_r2 - c2) : 1e6;
  for (int it = 0; it < config_.gnc_iterations && mu < 1e6; ++it) {
    bool binary = true;
    for (std::uint32_t k = 0; k < m; ++k) {
      r2[k] = (T * ps[k] - pd[k]).squaredNorm();
      if (r2[k] >= (mu + 1.0) / mu * c2) w[k] = 0.0;
      else if (r2[k] <= mu / (mu + 1.0) * c2) w[k] = 1.0;
      else {
        w[k] = std::sqrt(c2 / r2[k]) * std::sqrt(mu * (mu + 1.0)) - mu;
        binary = false;
      }
    }
    T = align(ps, pd, w, m);
    if (binary) break;
    mu *= 1.4;
  }

  // Inliers of the final estimate, their residual and their spread.
  double sum_r2 = 0.0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::uint32_t inliers = 0;
  for (std::uint32_t k = 0; k < m; ++k) {
    const double e2 = (T * ps[k] - pd[k]).squaredNorm();
    if (e2 > c2) continue;
    ++inliers;
    sum_r2 += e2;
    mean += pd[k];
  }
  out.inliers = inliers;
  out.target_T_source = T;
  if (inliers < config_.min_inliers) {
    out.failure = RegistrationFailure::kTooFewInliers;
    return out;
  }
  out.inlier_rmse_m = std::sqrt(sum_r2 / inliers);
  mean /= inliers;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::uint32_t k = 0; k < m; ++k) {
    if ((T * ps[k] - pd[k]).squaredNorm() > c2) continue;
    Eigen::Vector3d d = pd[k] - mean;
    if (config_.gravity_aligned) d.z() = 0.0;  // yaw needs horizontal extent
    cov += d * d.transpose() / inliers;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);  // ascending eigenvalues
  const double extent = 2.0 * std::sqrt(std::max(0.0, config_.gravity_aligned ? eig.eigenvalues()(2)
                                                                              : eig.eigenvalues()(1)));
  out.failure = extent < config_.min_spread_m ? RegistrationFailure::kDegenerate : RegistrationFailure::kNone;
  return out;
}

}  // namespace qsg::loop_closure
