#include "core/loop_closure/appearance.h"

#include <Eigen/SVD>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include <algorithm>
#include <cstring>
#include <cmath>
#include <vector>

namespace qsg::loop_closure {

std::string AppearanceConfig::check() const {
  if (max_features < 8 || max_features > kMaxAppearanceFeatures) return "max_features must be in [8, 128]";
  if (!(min_depth_m >= 0.0 && max_depth_m > min_depth_m && max_depth_m <= 100.0))
    return "depth range must satisfy 0 <= min_depth_m < max_depth_m <= 100 m";
  if (!(ratio > 0.0 && ratio <= 1.0)) return "ratio must be in (0, 1]";
  if (max_hamming < 1 || max_hamming > 256) return "max_hamming must be in [1, 256]";
  if (!(inlier_m > 0.0 && inlier_m <= 1.0)) return "inlier_m must be in (0, 1] m";
  if (iterations < 1 || iterations > 100000) return "iterations must be in [1, 100000]";
  if (min_inliers < 3 || min_inliers > kMaxAppearanceFeatures) return "min_inliers must be in [3, 128]";
  return "";
}

void AppearanceConfig::print(std::FILE* out) const {
  std::fprintf(out,
               "appearance: %u ORB features with depth in [%.1f, %.1f] m; matches at ratio %.2f, Hamming <= %u; RANSAC "
               "%u iterations, inliers within %.3f m, at least %u; %s\n",
               max_features, min_depth_m, max_depth_m, ratio, max_hamming, iterations, inlier_m, min_inliers,
               gravity_aligned ? "yaw + translation (gravity aligned)" : "full SE(3)");
}

struct AppearanceExtractor::Impl {
  cv::Ptr<cv::ORB> orb;
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
};

AppearanceExtractor::AppearanceExtractor() = default;
AppearanceExtractor::~AppearanceExtractor() = default;

bool AppearanceExtractor::init(const AppearanceConfig& config, std::string* error) {
  if (const std::string why = config.check(); !why.empty()) return *error = "loop_closure.appearance: " + why, false;
  config_ = config;
  impl_ = std::make_unique<Impl>();
  // More candidates than kept: those without a depth are dropped.
  impl_->orb = cv::ORB::create(static_cast<int>(2 * config.max_features));
  return true;
}

bool AppearanceExtractor::extract(const GreyDepthView& v, AppearanceFeatures* out) {
  out->count = 0;
  if (impl_ == nullptr || v.grey == nullptr || v.depth_m == nullptr || v.width < 32 || v.height < 32 || v.fx <= 0.0 ||
      v.fy <= 0.0)
    return false;
  const cv::Mat grey(v.height, v.width, CV_8UC1, const_cast<std::uint8_t*>(v.grey));
  impl_->keypoints.clear();
  impl_->orb->detectAndCompute(grey, cv::noArray(), impl_->keypoints, impl_->descriptors);
  // Strongest first.
  std::vector<int> order(impl_->keypoints.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return impl_->keypoints[a].response > impl_->keypoints[b].response; });
  for (int i : order) {
    if (out->count == config_.max_features) break;
    const cv::KeyPoint& k = impl_->keypoints[static_cast<std::size_t>(i)];
    const int u = static_cast<int>(std::lround(k.pt.x)), w = static_cast<int>(std::lround(k.pt.y));
    if (u < 0 || w < 0 || u >= v.width || w >= v.height) continue;
    const float d = v.depth_m[w * v.width + u];
    if (!(d >= config_.min_depth_m && d <= config_.max_depth_m)) continue;
    out->points_m[out->count] = Eigen::Vector3f(static_cast<float>((k.pt.x - v.cx) / v.fx * d),
                                                static_cast<float>((k.pt.y - v.cy) / v.fy * d), d);
    std::copy_n(impl_->descriptors.ptr<std::uint8_t>(i), 32, out->descriptors[out->count].data());
    ++out->count;
  }
  return out->count > 0;
}

namespace {

int hamming(const std::array<std::uint8_t, 32>& a, const std::array<std::uint8_t, 32>& b) {
  int d = 0;
  for (int i = 0; i < 32; i += 8) {
    std::uint64_t x, y;
    std::memcpy(&x, a.data() + i, 8);
    std::memcpy(&y, b.data() + i, 8);
    d += __builtin_popcountll(x ^ y);
  }
  return d;
}

// The means of the given pairs' sources and destinations.
void centroids(const Eigen::Vector3d* src, const Eigen::Vector3d* dst, const std::uint32_t* idx, std::size_t n,
               Eigen::Vector3d* cs, Eigen::Vector3d* cd) {
  *cs = Eigen::Vector3d::Zero();
  *cd = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    *cs += src[idx[i]];
    *cd += dst[idx[i]];
  }
  *cs /= static_cast<double>(n);
  *cd /= static_cast<double>(n);
}

// Least-squares rigid transform dst = T * src over the given pairs (Kabsch).
Eigen::Isometry3d kabsch(const Eigen::Vector3d* src, const Eigen::Vector3d* dst, const std::uint32_t* idx,
                         std::size_t n) {
  Eigen::Vector3d cs, cd;
  centroids(src, dst, idx, n, &cs, &cd);
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < n; ++i) H += (src[idx[i]] - cs) * (dst[idx[i]] - cd).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = svd.matrixV() * D * svd.matrixU().transpose();
  T.translation() = cd - T.linear() * cs;
  return T;
}

// The same with the tilt fixed: dst = T * src with T's rotation Rot(up, theta) * tilt, the angle about `up` (the
// match's vertical) by least squares on the pairs' components across it.
Eigen::Isometry3d kabsch_about(const Eigen::Vector3d* src, const Eigen::Vector3d* dst, const std::uint32_t* idx,
                               std::size_t n, const Eigen::Quaterniond& tilt, const Eigen::Vector3d& up) {
  Eigen::Vector3d cs, cd;
  centroids(src, dst, idx, n, &cs, &cd);
  // Maximise sum b . Rot(up, theta) a over the centred pairs projected across up (a from the tilted source):
  // cos(theta) sum a.b + sin(theta) sum up.(a x b).
  double c = 0.0, s = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Vector3d a = tilt * (src[idx[i]] - cs), b = dst[idx[i]] - cd;
    a -= up * up.dot(a);
    b -= up * up.dot(b);
    c += a.dot(b);
    s += up.dot(a.cross(b));
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(std::atan2(s, c), up) * tilt).toRotationMatrix();
  T.translation() = cd - T.linear() * cs;
  return T;
}

}  // namespace

AppearanceRegistration register_appearance(const AppearanceFeatures& query, const AppearanceFeatures& match,
                                           const AppearanceConfig& config, std::uint32_t seed,
                                           const GravityPrior* gravity) {
  AppearanceRegistration r;
  Eigen::Vector3d src[kMaxAppearanceFeatures], dst[kMaxAppearanceFeatures];
  std::uint32_t n = 0;
  for (std::uint32_t i = 0; i < query.count; ++i) {
    int best = 257, second = 257;
    std::uint32_t best_j = 0;
    for (std::uint32_t j = 0; j < match.count; ++j) {
      const int d = hamming(query.descriptors[i], match.descriptors[j]);
      if (d < best) {
        second = best;
        best = d;
        best_j = j;
      } else if (d < second) {
        second = d;
      }
    }
    if (best > static_cast<int>(config.max_hamming) || best >= config.ratio * second) continue;
    src[n] = query.points_m[i].cast<double>();
    dst[n++] = match.points_m[best_j].cast<double>();
  }
  r.matches = n;
  if (n < config.min_inliers) return r;
  const bool four_dof = gravity != nullptr && config.gravity_aligned;
  const Eigen::Vector3d up = four_dof ? gravity->match_up.normalized() : Eigen::Vector3d::UnitZ();
  const Eigen::Quaterniond tilt = four_dof ? gravity->tilt() : Eigen::Quaterniond::Identity();
  const auto fit = [&](const std::uint32_t* idx, std::size_t count) {
    return four_dof ? kabsch_about(src, dst, idx, count, tilt, up) : kabsch(src, dst, idx, count);
  };
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::uint32_t> pick(0, n - 1);
  std::uint32_t best_inliers[kMaxAppearanceFeatures], inliers[kMaxAppearanceFeatures];
  std::uint32_t best_count = 0;
  const double tol2 = config.inlier_m * config.inlier_m;
  for (std::uint32_t it = 0; it < config.iterations; ++it) {
    std::uint32_t s[3] = {pick(rng), pick(rng), pick(rng)};
    if (s[0] == s[1] || s[1] == s[2] || s[0] == s[2]) continue;
    // A rigid motion preserves the sample's side lengths.
    bool rigid = true;
    for (int a = 0; a < 3 && rigid; ++a) {
      const int b = (a + 1) % 3;
      rigid = std::abs((src[s[a]] - src[s[b]]).norm() - (dst[s[a]] - dst[s[b]]).norm()) <= 2.0 * config.inlier_m &&
              (src[s[a]] - src[s[b]]).norm() > 0.1;
    }
    if (!rigid) continue;
    const Eigen::Isometry3d T = fit(s, 3);
    std::uint32_t count = 0;
    for (std::uint32_t k = 0; k < n; ++k)
      if ((T * src[k] - dst[k]).squaredNorm() <= tol2) inliers[count++] = k;
    if (count > best_count) {
      best_count = count;
      std::copy_n(inliers, count, best_inliers);
    }
  }
  if (best_count < config.min_inliers) {
    r.inliers = best_count;
    return r;
  }
  // Refine on the inliers, then take the inliers of the refined transform once more.
  Eigen::Isometry3d T = fit(best_inliers, best_count);
  std::uint32_t count = 0;
  for (std::uint32_t k = 0; k < n; ++k)
    if ((T * src[k] - dst[k]).squaredNorm() <= tol2) inliers[count++] = k;
  if (count >= 3) T = fit(inliers, count);
  double sum = 0.0;
  for (std::uint32_t k = 0; k < count; ++k) sum += (T * src[inliers[k]] - dst[inliers[k]]).squaredNorm();
  r.inliers = count;
  r.inlier_rmse_m = count > 0 ? std::sqrt(sum / count) : 0.0;
  r.match_T_query = T;
  r.ok = count >= config.min_inliers;
  return r;
}

}  // namespace qsg::loop_closure
