// Tests of the pairwise-consistency prefilter (PCM) on three laps of a square with noisy odometry, right loop
// closures between the laps and as many wrong ones (random pairs, random relative poses, the same sigmas).
#include "core/backend/pairwise_consistency.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "core/backend/pose_graph.h"

namespace qsg::backend {
namespace {

constexpr std::uint32_t kPerLap = 40;  // 4 sides x 10 steps of 1 m
constexpr std::uint32_t kLaps = 3;
constexpr double kPi = 3.14159265358979323846;
const Eigen::Vector3d kOdomSigma_m = Eigen::Vector3d::Constant(0.02);
const Eigen::Vector3d kOdomSigma_rad = Eigen::Vector3d::Constant(0.005);
const Eigen::Vector3d kLoopSigma_m = Eigen::Vector3d::Constant(0.05);
const Eigen::Vector3d kLoopSigma_rad = Eigen::Vector3d::Constant(0.01);

std::vector<Pose3> truth() {
  std::vector<Pose3> poses;
  Pose3 p;
  for (std::uint32_t i = 0; i < kPerLap * kLaps; ++i) {
    poses.push_back(p);
    p = p * Pose3{Eigen::Vector3d(1.0, 0.0, 0.0), Eigen::Quaterniond::Identity()};
    if ((i + 1) % 10 == 0) p = p * Pose3{Eigen::Vector3d::Zero(), Eigen::Quaterniond(Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitZ()))};
  }
  return poses;
}

Pose3 perturb(const Pose3& x, const Eigen::Vector3d& sigma_t, const Eigen::Vector3d& sigma_r, std::mt19937* rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  const Eigen::Vector3d dt(sigma_t.x() * g(*rng), sigma_t.y() * g(*rng), sigma_t.z() * g(*rng));
  const Eigen::Vector3d dr(sigma_r.x() * g(*rng), sigma_r.y() * g(*rng), sigma_r.z() * g(*rng));
  const Eigen::Quaterniond dq(Eigen::AngleAxisd(dr.norm(), dr.norm() > 0 ? dr.normalized() : Eigen::Vector3d::UnitZ()));
  return Pose3{x.t_m + dt, x.q * dq};
}

RelativePoseEdge edge(std::uint32_t a, std::uint32_t b, const Pose3& z, bool closure) {
  RelativePoseEdge e;
  e.from = a;
  e.to = b;
  e.measured_from_T_to = z;
  e.sigma_t_m = closure ? kLoopSigma_m : kOdomSigma_m;
  e.sigma_rot_rad = closure ? kLoopSigma_rad : kOdomSigma_rad;
  e.is_loop_closure = closure;
  return e;
}

// Odometry edges, then `right` true closures (lap 2 and 3 against lap 1 at the same corner index), then `wrong`
// random ones.
std::vector<RelativePoseEdge> make_graph(const std::vector<Pose3>& gt, std::size_t wrong, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<RelativePoseEdge> edges;
  for (std::uint32_t i = 0; i + 1 < gt.size(); ++i)
    edges.push_back(edge(i, i + 1, perturb(between(gt[i], gt[i + 1]), kOdomSigma_m, kOdomSigma_rad, &rng), false));
  for (std::uint32_t lap = 1; lap < kLaps; ++lap) {
    for (std::uint32_t k = 0; k < kPerLap; k += 4) {
      const std::uint32_t a = k, b = lap * kPerLap + k;
      edges.push_back(edge(a, b, perturb(between(gt[a], gt[b]), 0.5 * kLoopSigma_m, 0.5 * kLoopSigma_rad, &rng), true));
    }
  }
  std::uniform_int_distribution<std::uint32_t> pick(0, static_cast<std::uint32_t>(gt.size() - 1));
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  std::normal_distribution<double> g(0.0, 1.0);
  for (std::size_t n = 0; n < wrong;) {
    std::uint32_t a = pick(rng), b = pick(rng);
    if (a > b) std::swap(a, b);
    if (b - a < 2) continue;
    Eigen::Quaterniond q;
    q.coeffs() << g(rng), g(rng), g(rng), g(rng);
    edges.push_back(edge(a, b, Pose3{Eigen::Vector3d(u(rng), u(rng), 0.2 * u(rng)), q.normalized()}, true));
    ++n;
  }
  return edges;
}

constexpr std::size_t kRight = (kLaps - 1) * (kPerLap / 4);

TEST(PairwiseConsistencyTest, KeepsTheRightClosuresAndRejectsHalfWrongOnes) {
  const std::vector<Pose3> gt = truth();
  for (const unsigned seed : {1u, 2u, 3u}) {
    const std::vector<RelativePoseEdge> edges = make_graph(gt, kRight, seed);
    const PairwiseConsistencyResult r = select_consistent_loop_closures({}, gt.size(), edges);
    ASSERT_TRUE(r.message.empty()) << r.message;
    EXPECT_EQ(r.loop_closures, 2 * kRight);
    std::size_t right_rejected = 0, wrong_kept = 0;
    const std::size_t first_closure = gt.size() - 1;
    for (std::size_t k = first_closure; k < edges.size(); ++k) {
      const bool right = k < first_closure + kRight;
      if (right && r.rejected[k]) ++right_rejected;
      if (!right && !r.rejected[k]) ++wrong_kept;
    }
    EXPECT_EQ(right_rejected, 0u) << "seed " << seed;
    EXPECT_EQ(wrong_kept, 0u) << "seed " << seed;
    EXPECT_EQ(r.kept, kRight);
    EXPECT_FALSE(r.clique_truncated);
    for (std::size_t k = 0; k < first_closure; ++k) EXPECT_FALSE(r.rejected[k]) << "odometry edge " << k;
  }
}

TEST(PairwiseConsistencyTest, AGapInTheOdometryMakesPairsUntestableNotWrong) {
  const std::vector<Pose3> gt = truth();
  std::vector<RelativePoseEdge> edges = make_graph(gt, 0, 4);
  edges.erase(edges.begin() + 50);  // no odometry between poses 50 and 51
  const PairwiseConsistencyResult r = select_consistent_loop_closures({}, gt.size(), edges);
  EXPECT_GT(r.pairs_untestable, 0u);
  EXPECT_EQ(r.kept, r.loop_closures);
}

TEST(PairwiseConsistencyTest, BadInputRejectsNothingAndSaysWhy) {
  const std::vector<Pose3> gt = truth();
  std::vector<RelativePoseEdge> edges = make_graph(gt, 5, 5);
  PairwiseConsistencyConfig bad;
  bad.threshold_sigma = -1.0;
  PairwiseConsistencyResult r = select_consistent_loop_closures(bad, gt.size(), edges);
  EXPECT_NE(r.message.find("threshold_sigma"), std::string::npos);
  for (const bool rej : r.rejected) EXPECT_FALSE(rej);
  r = select_consistent_loop_closures({}, 10, edges);  // indices beyond 10 poses
  EXPECT_NE(r.message.find("out of range"), std::string::npos);
  for (const bool rej : r.rejected) EXPECT_FALSE(rej);
}

TEST(PairwiseConsistencyTest, TheCliqueBudgetStillGivesTheGreedyClique) {
  const std::vector<Pose3> gt = truth();
  const std::vector<RelativePoseEdge> edges = make_graph(gt, kRight, 6);
  PairwiseConsistencyConfig tight;
  tight.max_clique_nodes = 1;
  const PairwiseConsistencyResult r = select_consistent_loop_closures(tight, gt.size(), edges);
  EXPECT_GE(r.kept, kRight * 9 / 10);  // the greedy start alone finds nearly every right closure here
}

// The screen answers for any group: the right closures agree with each other, a wrong one added to them does not
// join their subset, two wrong ones agree with neither each other nor the right ones, and a group with an index
// beyond the edges comes back whole (nothing to screen it with).
TEST(PairwiseConsistencyTest, TheScreenFindsTheAgreeingSubsetOfAGroup) {
  const std::vector<Pose3> gt = truth();
  const std::vector<RelativePoseEdge> edges = make_graph(gt, 8, 7);
  const PairwiseConsistencyScreen screen({}, gt.size(), edges);
  const std::size_t first_closure = gt.size() - 1, first_wrong = first_closure + kRight;
  std::vector<std::size_t> right;
  for (std::size_t k = first_closure; k < first_wrong; ++k) right.push_back(k);
  EXPECT_EQ(screen.largest_consistent_subset(right), kRight);
  std::vector<std::size_t> mixed = right;
  mixed.push_back(first_wrong);
  EXPECT_EQ(screen.largest_consistent_subset(mixed), kRight);
  EXPECT_EQ(screen.largest_consistent_subset({first_wrong, first_wrong + 1}), 1u);
  EXPECT_EQ(screen.largest_consistent_subset({first_wrong, first_wrong + 1, first_wrong + 2, first_closure}), 1u);
  EXPECT_EQ(screen.largest_consistent_subset({first_closure}), 1u);
  EXPECT_EQ(screen.largest_consistent_subset({}), 0u);
  EXPECT_EQ(screen.largest_consistent_subset({first_wrong, edges.size()}), 2u);
}

// Through the optimizer: with the prefilter, GNC-TLS on the half-wrong graph ends where the outlier-free solve does.
TEST(PairwiseConsistencyTest, PrefilterThenGncMatchesTheOutlierFreeSolution) {
  const std::vector<Pose3> gt = truth();
  const std::vector<RelativePoseEdge> clean = make_graph(gt, 0, 7);
  const std::vector<RelativePoseEdge> dirty = make_graph(gt, kRight, 7);
  std::vector<Pose3> init(gt.size());
  for (std::uint32_t i = 0; i + 1 < gt.size(); ++i) init[i + 1] = init[i] * clean[i].measured_from_T_to;

  PoseGraphConfig ls;
  ls.loop_closure_loss = RobustLoss::kNone;
  std::vector<Pose3> reference = init;
  ASSERT_TRUE(optimize_pose_graph(ls, reference, clean).poses_updated());

  PoseGraphConfig robust;
  robust.loop_closure_loss = RobustLoss::kGncTls;
  robust.prefilter_pairwise_consistency = true;
  std::vector<Pose3> poses = init;
  const PoseGraphResult r = optimize_pose_graph(robust, poses, dirty);
  ASSERT_TRUE(r.poses_updated()) << r.message;
  EXPECT_EQ(r.pairwise.kept, kRight);
  EXPECT_GE(r.num_loop_closures_downweighted, kRight);
  double s = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) s += (poses[i].t_m - reference[i].t_m).squaredNorm();
  EXPECT_LT(std::sqrt(s / poses.size()), 0.01);
}

}  // namespace
}  // namespace qsg::backend
