// Appearance at an agent node and its geometric verification (the paper's visual level, as Kimera's RANSAC check):
// ORB features (OpenCV features2d) of the agent's keyframe, each with its 3D point from the depth image in the
// camera frame. Two agents register by matching descriptors (Hamming distance, Lowe's ratio test) and a RANSAC over
// 3D-3D correspondences (3-point minimal samples, Kabsch), refined on the inliers: precise to the depth's noise
// where object centroids are not. Extraction allocates (OpenCV) and runs on the backend thread; the features are
// stored inline, fixed size.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <random>
#include <string>

#include "core/loop_closure/gravity.h"

namespace qsg::loop_closure {

inline constexpr std::size_t kMaxAppearanceFeatures = 128;

struct AppearanceConfig {
  std::uint32_t max_features = 128;  // ORB features kept per agent (<= kMaxAppearanceFeatures)
  double min_depth_m = 0.2;          // features without a depth in [min, max] are dropped
  double max_depth_m = 4.0;
  double ratio = 0.8;                // Lowe's ratio on Hamming distances (the paper's SG-LC: 0.8)
  std::uint32_t max_hamming = 64;    // of 256 bits
  double inlier_m = 0.05;            // RANSAC: a correspondence agrees within this distance
  std::uint32_t iterations = 300;
  std::uint32_t min_inliers = 12;
  // Given the two agents' verticals (a GravityPrior), RANSAC and its refit estimate yaw and translation only and
  // keep the odometry's relative roll and pitch (as ICP does, IcpConfig::gravity_aligned): a pose from a dozen
  // features is otherwise off by up to a degree or two in tilt, which no ICP corrects when the views do not
  // constrain it.
  bool gravity_aligned = true;

  std::string check() const;
  void print(std::FILE* out) const;
};

struct AppearanceFeatures {
  std::uint32_t count = 0;
  std::array<std::array<std::uint8_t, 32>, kMaxAppearanceFeatures> descriptors;
  std::array<Eigen::Vector3f, kMaxAppearanceFeatures> points_m;  // camera frame
};

struct AppearanceRegistration {
  bool ok = false;
  Eigen::Isometry3d match_T_query = Eigen::Isometry3d::Identity();  // camera frames
  std::uint32_t matches = 0;
  std::uint32_t inliers = 0;
  double inlier_rmse_m = 0.0;
};

// A grey image and its depth (metres along the optical axis, 0 or NaN: none), pinhole intrinsics.
struct GreyDepthView {
  const std::uint8_t* grey = nullptr;
  const float* depth_m = nullptr;
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

class AppearanceExtractor {
 public:
  AppearanceExtractor();
  ~AppearanceExtractor();
  bool init(const AppearanceConfig& config, std::string* error);
  // False (count 0) for an empty or malformed view.
  bool extract(const GreyDepthView& view, AppearanceFeatures* out);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  AppearanceConfig config_;
};

// Registers the query's features onto the match's: match_T_query maps a point of the query camera's frame into the
// match camera's. 4 DOF about `gravity` when given and config.gravity_aligned, else 6 DOF. Deterministic for a seed.
AppearanceRegistration register_appearance(const AppearanceFeatures& query, const AppearanceFeatures& match,
                                           const AppearanceConfig& config, std::uint32_t seed = 1,
                                           const GravityPrior* gravity = nullptr);

}  // namespace qsg::loop_closure
