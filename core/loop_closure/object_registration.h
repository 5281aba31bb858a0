// Object-based geometric verification of a loop closure (the paper's bottom-up step, TEASER-style): two sets of
// labelled object centroids, the one around the query agent and the one around the matched agent, are registered
// without an initial guess.
//
//  1. Putative correspondences: every pair of objects with the same semantic label.
//  2. Pairwise-consistency pruning: two correspondences are consistent when they preserve the distance between
//     their objects to within 2 * noise_bound_m (rigid motions preserve distances); the largest set of mutually
//     consistent correspondences is a maximum clique of that graph, searched exactly by branch and bound with a
//     node budget (the best clique found so far when the budget runs out, counted).
//  3. A truncated-least-squares estimate on the clique by graduated non-convexity around a closed-form weighted
//     alignment (yaw + translation for gravity-aligned odometry, or full 3D rotation).
// Yang, Shi, Carlone, "TEASER: Fast and Certifiable Point Cloud Registration", T-RO 2020, steps 1-3 in spirit;
// written here from the paper. Runs on the backend thread; the workspace is sized at init, nothing allocates after.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <bitset>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace qsg::loop_closure {

struct LabelledPoint {
  Eigen::Vector3d p_m = Eigen::Vector3d::Zero();
  std::uint32_t label = 0;
};

inline constexpr std::size_t kMaxCorrespondences = 256;  // the consistency graph's nodes (bitset rows)

struct RegistrationConfig {
  double noise_bound_m = 0.3;          // bound on one object centroid's error (partial views move a centroid)
  std::uint32_t min_inliers = 4;       // the paper's "object minimum inliers" is 5 with denser object layers
  double min_spread_m = 1.0;           // inliers must span this much (second principal extent): no line fits
  bool gravity_aligned = true;         // odometry with an IMU observes roll and pitch: estimate yaw only
  std::uint32_t max_clique_nodes = 200000;  // branch-and-bound nodes per registration (bounded time)
  int gnc_iterations = 20;

  std::string check() const;
  void print(std::FILE* out) const;
};

enum class RegistrationFailure : std::uint8_t {
  kNone,
  kTooFewCorrespondences,
  kTooFewInliers,
  kDegenerate,  // inliers on a line (or a point): rotation about it unobservable
};
const char* to_string(RegistrationFailure f);

struct Registration {
  RegistrationFailure failure = RegistrationFailure::kTooFewCorrespondences;
  // Maps a point of the query set onto the match set: p_match = target_T_source * p_query.
  Eigen::Isometry3d target_T_source = Eigen::Isometry3d::Identity();
  std::uint32_t correspondences = 0;
  std::uint32_t correspondences_dropped = 0;  // beyond kMaxCorrespondences (counted, not used)
  std::uint32_t clique = 0;
  std::uint32_t inliers = 0;
  double inlier_rmse_m = 0.0;
  bool clique_search_truncated = false;  // node budget reached: the clique may not be maximum
  bool ok() const { return failure == RegistrationFailure::kNone; }
};

class ObjectRegistration {
 public:
  explicit ObjectRegistration(const RegistrationConfig& config = {}) : config_(config) {}
  // Registers `source` (query) onto `target` (match). Bounded: at most kMaxCorrespondences correspondences.
  Registration register_sets(const LabelledPoint* source, std::size_t num_source, const LabelledPoint* target,
                             std::size_t num_target);
  const RegistrationConfig& config() const { return config_; }

 private:
  using Row = std::bitset<kMaxCorrespondences>;
  void expand(Row candidates, std::uint32_t size);
  Eigen::Isometry3d align(const Eigen::Vector3d* src, const Eigen::Vector3d* dst, const double* w, std::size_t n) const;

  RegistrationConfig config_;
  // The clique's points (source, target) for the estimate: members, not 12 KB of stack per registration.
  Eigen::Vector3d clique_source_[kMaxCorrespondences];
  Eigen::Vector3d clique_target_[kMaxCorrespondences];
  std::uint32_t src_[kMaxCorrespondences];
  std::uint32_t dst_[kMaxCorrespondences];
  Row adjacency_[kMaxCorrespondences];
  std::uint32_t n_ = 0;
  // Branch and bound state.
  std::uint32_t stack_[kMaxCorrespondences];
  std::uint32_t best_[kMaxCorrespondences];
  std::uint32_t best_size_ = 0;
  std::uint32_t nodes_visited_ = 0;
  bool truncated_ = false;
};

}  // namespace qsg::loop_closure
