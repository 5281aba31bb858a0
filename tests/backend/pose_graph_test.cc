// Tests of the SE(3) pose-graph optimizer on a synthetic square loop with known ground truth and seeded drift.
#include "core/backend/pose_graph.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace qsg::backend {
namespace {

// 4 sides x 10 poses of 0.5 m: big enough to drift visibly, small enough for qemu-aarch64.
constexpr std::uint32_t kPosesPerSide = 10;
constexpr std::uint32_t kNumPoses = 4 * kPosesPerSide;
constexpr double kStep_m = 0.5;
constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;

// Odometry drift: a yaw bias per step (the usual culprit of VIO on a turning quadruped) plus a scale bias. Kept
// small, because a closed loop cannot observe scale: it sets the floor of the corrected trajectory error.
constexpr double kYawBiasPerStep_rad = 0.4 * kDegToRad;
constexpr double kYawNoise_rad = 0.2 * kDegToRad;
constexpr double kScaleBias = 0.005;
constexpr double kTranslationNoise_m = 0.005;
constexpr unsigned kSeed = 20240611u;

const Eigen::Vector3d kOdomSigma_m = Eigen::Vector3d::Constant(0.02);
const Eigen::Vector3d kOdomSigma_rad = Eigen::Vector3d::Constant(0.01);
const Eigen::Vector3d kLoopSigma_m = Eigen::Vector3d::Constant(0.05);
const Eigen::Vector3d kLoopSigma_rad = Eigen::Vector3d::Constant(0.01);

Pose3 make_pose(const Eigen::Vector3d& t_m, const Eigen::Quaterniond& q) { return Pose3{t_m, q}; }

Eigen::Quaterniond yaw(double angle_rad) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitZ()));
}

// Counter-clockwise square starting at the origin facing +x; the step after pose 39 returns to pose 0. A little
// height and pitch bob (a walking gait) keeps the problem genuinely 3D.
std::vector<Pose3> square_ground_truth() {
  std::vector<Pose3> poses;
  Pose3 planar;
  for (std::uint32_t i = 0; i < kNumPoses; ++i) {
    Pose3 pose = planar;
    pose.t_m.z() += 0.03 * std::sin(0.7 * i);
    pose.q = pose.q * Eigen::Quaterniond(Eigen::AngleAxisd(0.02 * std::sin(0.5 * i), Eigen::Vector3d::UnitY()));
    poses.push_back(pose);
    planar = planar * make_pose(Eigen::Vector3d(kStep_m, 0.0, 0.0), Eigen::Quaterniond::Identity());
    if ((i + 1) % kPosesPerSide == 0) planar = planar * make_pose(Eigen::Vector3d::Zero(), yaw(kPi / 2.0));
  }
  return poses;
}

RelativePoseEdge make_edge(std::uint32_t from, std::uint32_t to, const Pose3& measured, bool is_loop_closure) {
  RelativePoseEdge edge;
  edge.from = from;
  edge.to = to;
  edge.measured_from_T_to = measured;
  edge.sigma_t_m = is_loop_closure ? kLoopSigma_m : kOdomSigma_m;
  edge.sigma_rot_rad = is_loop_closure ? kLoopSigma_rad : kOdomSigma_rad;
  edge.is_loop_closure = is_loop_closure;
  return edge;
}

// Odometry edges i -> i+1 from ground truth, corrupted by seeded yaw and scale drift.
std::vector<RelativePoseEdge> drifting_odometry(const std::vector<Pose3>& truth,
                                               double yaw_bias_per_step_rad = kYawBiasPerStep_rad) {
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> yaw_noise(0.0, kYawNoise_rad);
  std::normal_distribution<double> t_noise(0.0, kTranslationNoise_m);
  std::vector<RelativePoseEdge> edges;
  for (std::uint32_t i = 0; i + 1 < truth.size(); ++i) {
    Pose3 measured = between(truth[i], truth[i + 1]);
    // One draw per statement: argument evaluation order differs between GCC and clang.
    Eigen::Vector3d noise_m;
    for (int axis = 0; axis < 3; ++axis) noise_m[axis] = t_noise(rng);
    measured.t_m = (1.0 + kScaleBias) * measured.t_m + noise_m;
    measured.q = measured.q * yaw(yaw_bias_per_step_rad + yaw_noise(rng));
    edges.push_back(make_edge(i, i + 1, measured, false));
  }
  return edges;
}

// Dead reckoning: what the frontend hands the backend before any loop closure.
std::vector<Pose3> chain_odometry(const Pose3& start, const std::vector<RelativePoseEdge>& edges) {
  std::vector<Pose3> poses{start};
  for (const RelativePoseEdge& edge : edges) {
    if (!edge.is_loop_closure) poses.push_back(poses.back() * edge.measured_from_T_to);
  }
  return poses;
}

RelativePoseEdge true_loop_closure(const std::vector<Pose3>& truth, std::uint32_t from, std::uint32_t to) {
  return make_edge(from, to, between(truth[from], truth[to]), true);
}

// Absolute trajectory error, RMSE of positions. Pose 0 is fixed to ground truth, so no alignment is needed.
double ate_rmse_m(const std::vector<Pose3>& estimate, const std::vector<Pose3>& truth) {
  double sum_sq = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i) sum_sq += (estimate[i].t_m - truth[i].t_m).squaredNorm();
  return std::sqrt(sum_sq / static_cast<double>(truth.size()));
}

double translation_error_m(const Pose3& a, const Pose3& b) { return (a.t_m - b.t_m).norm(); }
double rotation_error_rad(const Pose3& a, const Pose3& b) { return a.q.angularDistance(b.q); }

TEST(PoseGraph, LoopClosureRemovesDriftOfSquareTrajectory) {
  const std::vector<Pose3> truth = square_ground_truth();
  std::vector<RelativePoseEdge> edges = drifting_odometry(truth);
  std::vector<Pose3> poses = chain_odometry(truth[0], edges);
  ASSERT_EQ(poses.size(), truth.size());
  edges.push_back(true_loop_closure(truth, kNumPoses - 1, 0));

  const double ate_before_m = ate_rmse_m(poses, truth);
  const Pose3 lc_measured = edges.back().measured_from_T_to;
  const double lc_error_before_m = translation_error_m(between(poses[kNumPoses - 1], poses[0]), lc_measured);

  const PoseGraphConfig config;
  const PoseGraphResult result = optimize_pose_graph(config, poses, edges);
  ASSERT_TRUE(result.poses_updated()) << result.message;
  EXPECT_TRUE(result.converged()) << result.message;
  EXPECT_GT(result.iterations, 0);
  EXPECT_LT(result.final_cost, result.initial_cost);

  const double ate_after_m = ate_rmse_m(poses, truth);
  const Pose3 lc_estimated = between(poses[kNumPoses - 1], poses[0]);
  std::printf("[ pose graph ] square loop: ATE before %.4f m, after %.4f m (%.1fx); loop-closure error before %.3f m, "
              "after %.4f m / %.3f deg; %d iterations\n",
              ate_before_m, ate_after_m, ate_before_m / ate_after_m, lc_error_before_m,
              translation_error_m(lc_estimated, lc_measured), rotation_error_rad(lc_estimated, lc_measured) / kDegToRad,
              result.iterations);
  ::testing::Test::RecordProperty("ate_before_mm", static_cast<int>(std::lround(ate_before_m * 1000.0)));
  ::testing::Test::RecordProperty("ate_after_mm", static_cast<int>(std::lround(ate_after_m * 1000.0)));

  // The drift must be real for the test to mean anything.
  EXPECT_GT(ate_before_m, 0.3);
  EXPECT_GT(lc_error_before_m, 0.5);
  EXPECT_LT(ate_after_m * 5.0, ate_before_m);
  // The closure is enforced to within its own noise model, not merely reduced.
  EXPECT_LT(translation_error_m(lc_estimated, lc_measured), 0.05);
  EXPECT_LT(rotation_error_rad(lc_estimated, lc_measured), 1.0 * kDegToRad);
  ASSERT_EQ(result.edge_residual_sigma.size(), edges.size());
  EXPECT_LT(result.edge_residual_sigma.back(), config.loop_closure_loss_scale_sigma);
  EXPECT_EQ(result.num_loop_closures_downweighted, 0u);
  // The gauge: pose 0 is held exactly.
  EXPECT_EQ(poses[0].t_m, truth[0].t_m);
  EXPECT_TRUE(poses[0].q.isApprox(truth[0].q, 1e-12));
}

// Several correct closures near the start plus one perceptual-aliasing closure that claims the far side of the
// square (5 m away) is 0.3 m ahead.
struct OutlierScenario {
  std::vector<Pose3> truth;
  std::vector<Pose3> initial;
  std::vector<RelativePoseEdge> edges;
  std::size_t wrong_edge = 0;
};

OutlierScenario outlier_scenario(double yaw_bias_per_step_rad = kYawBiasPerStep_rad) {
  OutlierScenario s;
  s.truth = square_ground_truth();
  s.edges = drifting_odometry(s.truth, yaw_bias_per_step_rad);
  s.initial = chain_odometry(s.truth[0], s.edges);
  const std::uint32_t last = kNumPoses - 1;
  s.edges.push_back(true_loop_closure(s.truth, last, 0));
  s.edges.push_back(true_loop_closure(s.truth, last, 1));
  s.edges.push_back(true_loop_closure(s.truth, last - 1, 0));
  s.edges.push_back(true_loop_closure(s.truth, last - 2, 0));
  s.wrong_edge = s.edges.size();
  s.edges.push_back(
      make_edge(2 * kPosesPerSide + 5, 5, make_pose(Eigen::Vector3d(0.3, 0.0, 0.0), yaw(kPi)), true));
  return s;
}

// The square walked twice (poses 40..79 retrace 0..39) with correct closures between the laps, then as many wrong
// closures again (random pairs, random relative poses): half the closures are outliers. GNC-TLS must switch every
// wrong one off and land on the outlier-free solution; plain least squares must not (else this tests nothing).
struct HalfOutliers {
  std::vector<Pose3> initial;
  std::vector<RelativePoseEdge> clean;    // odometry and the correct closures
  std::vector<RelativePoseEdge> corrupt;  // the same plus the wrong closures, appended
  std::size_t num_correct = 0;
};

HalfOutliers half_outliers() {
  HalfOutliers h;
  std::vector<Pose3> lap = square_ground_truth();
  std::vector<Pose3> truth = lap;
  const Pose3 back_to_start = between(lap.back(), lap.front());
  Pose3 second = lap.back() * back_to_start;
  for (std::size_t i = 0; i < lap.size(); ++i) truth.push_back(second * between(lap.front(), lap[i]));
  h.clean = drifting_odometry(truth);
  h.initial = chain_odometry(truth[0], h.clean);
  for (std::uint32_t i = 0; i < kNumPoses; i += 3) h.clean.push_back(true_loop_closure(truth, kNumPoses + i, i));
  h.num_correct = h.clean.size() - (truth.size() - 1);
  h.corrupt = h.clean;
  std::mt19937 rng(7u);
  std::uniform_int_distribution<std::uint32_t> pick(0, static_cast<std::uint32_t>(truth.size() - 1));
  std::uniform_real_distribution<double> offset(-3.0, 3.0), angle(-kPi, kPi);
  while (h.corrupt.size() < h.clean.size() + h.num_correct) {
    const std::uint32_t a = pick(rng), b = pick(rng);
    if (a + 1 >= b) continue;
    Eigen::Vector3d t;
    for (int k = 0; k < 3; ++k) t[k] = offset(rng);
    const double yaw_rad = angle(rng);
    h.corrupt.push_back(make_edge(a, b, make_pose(t, yaw(yaw_rad)), true));
  }
  return h;
}

// Least squares over the odometry and the correct closures only, from the odometry.
std::vector<Pose3> outlier_free_solution(const HalfOutliers& h) {
  PoseGraphConfig plain;
  plain.loop_closure_loss = RobustLoss::kNone;
  std::vector<Pose3> reference = h.initial;
  EXPECT_TRUE(optimize_pose_graph(plain, reference, h.clean).poses_updated());
  return reference;
}

// Every correct closure kept (weight 1), every wrong one off (0).
void expect_every_decision_right(const PoseGraphResult& r, const HalfOutliers& h) {
  ASSERT_EQ(r.edge_weight.size(), h.corrupt.size());
  for (std::size_t k = 0; k < h.corrupt.size(); ++k) {
    const double expected = k < h.clean.size() ? 1.0 : 0.0;
    EXPECT_EQ(r.edge_weight[k], expected) << "edge " << k;
  }
}

TEST(PoseGraph, GncTlsSwitchesOffHalfTheLoopClosuresWhenWrong) {
  const HalfOutliers h = half_outliers();
  const std::vector<Pose3> reference = outlier_free_solution(h);
  PoseGraphConfig plain;
  plain.loop_closure_loss = RobustLoss::kNone;
  std::vector<Pose3> least_squares = h.initial;
  ASSERT_TRUE(optimize_pose_graph(plain, least_squares, h.corrupt).poses_updated());
  PoseGraphConfig gnc;
  gnc.loop_closure_loss = RobustLoss::kGncTls;
  std::vector<Pose3> robust = h.initial;
  const PoseGraphResult r = optimize_pose_graph(gnc, robust, h.corrupt);
  ASSERT_TRUE(r.poses_updated()) << r.message;
  std::printf("[ pose graph ] %zu correct + %zu wrong closures: least squares %.3f m from the outlier-free solution, "
              "GNC-TLS %.5f m (%d outer iterations, %u closures off)\n",
              h.num_correct, h.corrupt.size() - h.clean.size(), ate_rmse_m(least_squares, reference),
              ate_rmse_m(robust, reference), r.gnc_outer_iterations, r.num_loop_closures_downweighted);
  EXPECT_GT(ate_rmse_m(least_squares, reference), 0.5) << "the wrong closures must bend a plain solution";
  EXPECT_LT(ate_rmse_m(robust, reference), 0.01);
  expect_every_decision_right(r, h);
  EXPECT_EQ(r.num_loop_closures_downweighted, h.corrupt.size() - h.clean.size());
  EXPECT_GT(r.gnc_outer_iterations, 0);
}

// GNC's weighted solves from the chordal estimate (PoseGraphConfig::gnc_chordal_solves) need no initial guess: from
// every pose at the origin they land on the outlier-free solution with the same decisions, where warm-started GNC
// from there does not.
TEST(PoseGraph, GncFromChordalEstimatesNeedsNoInitialGuess) {
  const HalfOutliers h = half_outliers();
  const std::vector<Pose3> reference = outlier_free_solution(h);
  std::vector<Pose3> origin(h.initial.size());
  origin[0] = h.initial[0];

  PoseGraphConfig gnc;
  gnc.loop_closure_loss = RobustLoss::kGncTls;
  std::vector<Pose3> warm = origin;
  ASSERT_TRUE(optimize_pose_graph(gnc, warm, h.corrupt).poses_updated());
  gnc.gnc_chordal_solves = true;
  std::vector<Pose3> chordal = origin;
  const PoseGraphResult r = optimize_pose_graph(gnc, chordal, h.corrupt);
  ASSERT_TRUE(r.poses_updated()) << r.message;
  std::printf(
      "[ pose graph ] from every pose at the origin: warm-started GNC %.3f m from the outlier-free solution, "
      "GNC from chordal estimates %.5f m\n",
      ate_rmse_m(warm, reference), ate_rmse_m(chordal, reference));
  EXPECT_GT(ate_rmse_m(warm, reference), 0.1) << "warm starts from the origin must fail, else this tests nothing";
  EXPECT_LT(ate_rmse_m(chordal, reference), 0.01);
  expect_every_decision_right(r, h);
}

// With gnc_chordal_solves, gnc_inner_iterations 0 makes each weighted solve the chordal estimate alone (a linear
// solve, no Ceres): GNC decides from those, and only its last solve runs Ceres. Without chordal solves 0 is refused.
TEST(PoseGraph, GncWithChordalEstimatesAloneAsItsWeightedSolves) {
  const HalfOutliers h = half_outliers();
  const std::vector<Pose3> reference = outlier_free_solution(h);
  PoseGraphConfig gnc;
  gnc.loop_closure_loss = RobustLoss::kGncTls;
  gnc.gnc_inner_iterations = 0;
  std::vector<Pose3> poses = h.initial;
  const PoseGraphResult refused = optimize_pose_graph(gnc, poses, h.corrupt);
  EXPECT_EQ(refused.status, PoseGraphStatus::kInvalidInput);
  EXPECT_NE(refused.message.find("gnc_inner_iterations"), std::string::npos) << refused.message;

  gnc.gnc_chordal_solves = true;
  const PoseGraphResult r = optimize_pose_graph(gnc, poses, h.corrupt);
  ASSERT_TRUE(r.poses_updated()) << r.message;
  EXPECT_GT(r.gnc_outer_iterations, 1);
  // Each weighted solve through Ceres would add at least one iteration per outer iteration.
  EXPECT_LE(r.iterations, gnc.max_iterations) << "only the last solve may run Ceres";
  EXPECT_LT(ate_rmse_m(poses, reference), 0.01);
  expect_every_decision_right(r, h);
}

// GNC-TLS stopped early: `outer` outer iterations of one Ceres iteration each.
PoseGraphConfig early_stopped_gnc(int outer) {
  PoseGraphConfig gnc;
  gnc.loop_closure_loss = RobustLoss::kGncTls;
  gnc.gnc_inner_iterations = 1;
  gnc.gnc_max_outer_iterations = outer;
  return gnc;
}

// GNC stopped early (one inner iteration, three outer ones) decides from a state that still bends under the wrong
// closures, and drops right ones that its final solve then fits. The TLS rounds keep what the solution fits and drop
// what it does not, until nothing changes: every right closure back, every wrong one off, and each decision agrees
// with its residual.
TEST(PoseGraph, TlsRoundsReadmitTheRightClosuresAnEarlyStoppedGncDropped) {
  const HalfOutliers h = half_outliers();
  PoseGraphConfig gnc = early_stopped_gnc(3);
  const auto right_dropped = [&h](const PoseGraphResult& r) {
    std::size_t n = 0;
    for (std::size_t k = 0; k < h.clean.size(); ++k) n += h.clean[k].is_loop_closure && r.edge_weight[k] == 0.0;
    return n;
  };
  std::vector<Pose3> early = h.initial;
  const PoseGraphResult without = optimize_pose_graph(gnc, early, h.corrupt);
  ASSERT_TRUE(without.poses_updated()) << without.message;
  ASSERT_GT(right_dropped(without), 0u) << "the early stop must drop a right closure, else this tests nothing";
  EXPECT_EQ(without.gnc_refine_rounds, 0);

  gnc.gnc_tls_refine_rounds = 10;
  std::vector<Pose3> refined = h.initial;
  const PoseGraphResult with = optimize_pose_graph(gnc, refined, h.corrupt);
  ASSERT_TRUE(with.poses_updated()) << with.message;
  EXPECT_GT(with.gnc_refine_rounds, 0);
  EXPECT_LT(with.gnc_refine_rounds, 10) << "the rounds stop when no decision changes";
  EXPECT_EQ(right_dropped(with), 0u);
  for (std::size_t k = 0; k < h.corrupt.size(); ++k) {
    if (!h.corrupt[k].is_loop_closure) continue;
    EXPECT_EQ(with.edge_weight[k] == 1.0, with.edge_residual_sigma[k] <= gnc.loop_closure_loss_scale_sigma)
        << "closure " << k << ": the decision must agree with the residual at the solution";
    if (k >= h.clean.size()) {
      EXPECT_EQ(with.edge_weight[k], 0.0) << "wrong closure " << k;
    }
  }
  std::printf("[ pose graph ] GNC stopped after 3 outer iterations: %zu right closures dropped; %d TLS rounds: %zu\n",
              right_dropped(without), with.gnc_refine_rounds, right_dropped(with));
}

// Four aliased closures that agree with each other: the second lap's third side claims to be where the first lap's
// second side is (every third pose, spaced as the right run).
void add_aliased_run(const std::vector<Pose3>& reference, HalfOutliers* h) {
  for (std::uint32_t j = 0; j < 4; ++j) {
    const std::uint32_t from = kNumPoses + 2 * kPosesPerSide + 5 + 3 * j, to = 5 + 3 * j;
    h->corrupt.push_back(make_edge(from, to, between(reference[from - kPosesPerSide], reference[to]), true));
  }
}

// GNC stopped after its first outer iteration decides from a state bent by every closure at once and drops the
// right closures with the wrong ones; the TLS rounds cannot bring them back (the solution without them does not fit
// them). The right closures form one run (every third pose of the second lap against the first). Beside them, a run
// of four aliased closures that agree with each other: the second lap's third side claims to be where the first
// lap's second side is. The cluster trials switch the right run back on and keep it (the TLS cost falls), and try
// the aliased run and reject it.
TEST(PoseGraph, ClusterTrialsReadmitARunOfRightClosuresTheTlsRoundsCannot) {
  HalfOutliers h = half_outliers();
  const std::vector<Pose3> reference = outlier_free_solution(h);
  add_aliased_run(reference, &h);
  PoseGraphConfig gnc = early_stopped_gnc(1);
  gnc.gnc_tls_refine_rounds = 10;
  gnc.gnc_cluster_gap_poses = 4;  // the runs' spacing is 3; at 10 the aliased run would join the right one
  const auto count = [&h](const PoseGraphResult& r, bool right, double weight) {
    std::size_t n = 0;
    for (std::size_t k = 0; k < h.corrupt.size(); ++k)
      n += h.corrupt[k].is_loop_closure && (k < h.clean.size()) == right && r.edge_weight[k] == weight;
    return n;
  };
  std::vector<Pose3> rounds_only = h.initial;
  const PoseGraphResult without = optimize_pose_graph(gnc, rounds_only, h.corrupt);
  ASSERT_TRUE(without.poses_updated()) << without.message;
  ASSERT_GT(count(without, true, 0.0), 3u) << "the early stop must drop the right run, else this tests nothing";
  EXPECT_EQ(without.gnc_cluster_trials, 0);

  gnc.gnc_cluster_trials = 32;
  std::vector<Pose3> searched = h.initial;
  const PoseGraphResult with = optimize_pose_graph(gnc, searched, h.corrupt);
  ASSERT_TRUE(with.poses_updated()) << with.message;
  std::printf(
      "[ pose graph ] GNC stopped after 1 outer iteration, then TLS rounds: %zu right closures dropped, %.3f m from "
      "the outlier-free solution; cluster trials (%d kept of %d): %zu dropped, %.5f m\n",
      count(without, true, 0.0), ate_rmse_m(rounds_only, reference), with.gnc_clusters_readmitted,
      with.gnc_cluster_trials, count(with, true, 0.0), ate_rmse_m(searched, reference));
  EXPECT_EQ(count(with, true, 0.0), 0u);
  EXPECT_EQ(count(with, false, 1.0), 0u) << "no wrong closure, aliased or random, may be kept";
  EXPECT_GE(with.gnc_cluster_trials, 2) << "the aliased run must be tried too";
  EXPECT_EQ(with.gnc_clusters_readmitted, 1);
  EXPECT_LT(ate_rmse_m(searched, reference), 0.01);
}

// The screen (gnc_cluster_screen) skips a cluster whose dropped closures do not agree with each other: beside the
// right run and the aliased run above, three wrong closures with ends next to each other but wildly different
// measurements. Unscreened, their cluster costs a trial that is rejected; screened, it is skipped and counted, and
// every decision is the same.
TEST(PoseGraph, TheClusterScreenSkipsRunsThatDisagreeWithThemselves) {
  HalfOutliers h = half_outliers();
  const std::vector<Pose3> reference = outlier_free_solution(h);
  add_aliased_run(reference, &h);
  const Eigen::Vector3d offsets[3] = {{3.0, 0.0, 0.0}, {-2.0, 2.5, 0.0}, {0.5, -3.0, 0.5}};
  for (std::uint32_t j = 0; j < 3; ++j)
    h.corrupt.push_back(
        make_edge(kNumPoses + kPosesPerSide + 25 + j, 25 + j, make_pose(offsets[j], yaw(2.0 * j)), true));
  PoseGraphConfig gnc = early_stopped_gnc(1);
  gnc.gnc_tls_refine_rounds = 10;
  gnc.gnc_cluster_gap_poses = 4;
  gnc.gnc_cluster_trials = 32;
  gnc.gnc_cluster_screen = false;
  std::vector<Pose3> unscreened_poses = h.initial, screened_poses = h.initial;
  const PoseGraphResult unscreened = optimize_pose_graph(gnc, unscreened_poses, h.corrupt);
  gnc.gnc_cluster_screen = true;
  const PoseGraphResult screened = optimize_pose_graph(gnc, screened_poses, h.corrupt);
  ASSERT_TRUE(unscreened.poses_updated() && screened.poses_updated()) << unscreened.message << screened.message;
  const std::size_t triple = h.corrupt.size() - 3;
  for (std::size_t k = triple; k < h.corrupt.size(); ++k)
    ASSERT_EQ(unscreened.edge_weight[k], 0.0) << "GNC must drop the disagreeing three, else this tests nothing";
  std::printf("[ pose graph ] cluster trials unscreened %d, screened %d (%d skipped)\n", unscreened.gnc_cluster_trials,
              screened.gnc_cluster_trials, screened.gnc_clusters_screened_out);
  EXPECT_EQ(unscreened.gnc_clusters_screened_out, 0);
  EXPECT_GE(screened.gnc_clusters_screened_out, 1);
  EXPECT_LT(screened.gnc_cluster_trials, unscreened.gnc_cluster_trials);
  EXPECT_EQ(screened.gnc_clusters_readmitted, unscreened.gnc_clusters_readmitted);
  EXPECT_EQ(screened.edge_weight, unscreened.edge_weight);
  EXPECT_LT(ate_rmse_m(screened_poses, reference), 0.01);
}

// A straight walk of 40 poses with exact odometry that holds rotation hard and translation loosely, and one wrong
// closure that claims pose 35 is 0.9 m (18 sigma) to the side of where pose 25 puts it. The odometry gives way to it
// (a quarter as stiff over the 10 steps): least squares leaves it 3.6 sigma, within the threshold of 5, so GNC
// (from the chordal estimate, which does not return before its rounding) and the TLS rounds keep it. Its truncated
// cost with the bend (about 32) is more than dropping it costs (12.5): the lone trial switches it off and the walk
// comes back straight.
TEST(PoseGraph, ClusterTrialsSwitchOffALoneClosureTheGraphBentToFit) {
  constexpr std::uint32_t kPoses = 40;
  const double loop_sigma_m = 0.05, odom_sigma_m = 0.632 * loop_sigma_m;
  std::vector<Pose3> truth;
  for (std::uint32_t i = 0; i < kPoses; ++i) truth.push_back(make_pose(Eigen::Vector3d(0.5 * i, 0.0, 0.0), yaw(0.0)));
  std::vector<RelativePoseEdge> edges;
  for (std::uint32_t i = 0; i + 1 < kPoses; ++i) {
    edges.push_back(make_edge(i, i + 1, between(truth[i], truth[i + 1]), false));
    edges.back().sigma_t_m = Eigen::Vector3d::Constant(odom_sigma_m);
    edges.back().sigma_rot_rad = Eigen::Vector3d::Constant(1e-4);
  }
  edges.push_back(
      make_edge(25, 35, between(truth[25], truth[35]) * make_pose(Eigen::Vector3d(0.0, 0.9, 0.0), yaw(0.0)), true));
  edges.back().sigma_t_m = Eigen::Vector3d::Constant(loop_sigma_m);
  PoseGraphConfig gnc;
  gnc.loop_closure_loss = RobustLoss::kGncTls;
  gnc.gnc_chordal_solves = true;
  gnc.gnc_tls_refine_rounds = 10;
  std::vector<Pose3> rounds_only = truth;
  const PoseGraphResult without = optimize_pose_graph(gnc, rounds_only, edges);
  ASSERT_TRUE(without.poses_updated()) << without.message;
  ASSERT_EQ(without.edge_weight.back(), 1.0) << "GNC must keep the wrong closure, else this tests nothing";
  EXPECT_NEAR(without.edge_residual_sigma.back(), 3.6, 0.2);
  EXPECT_GT(ate_rmse_m(rounds_only, truth), 0.1);

  gnc.gnc_cluster_trials = 32;
  std::vector<Pose3> searched = truth;
  const PoseGraphResult with = optimize_pose_graph(gnc, searched, edges);
  ASSERT_TRUE(with.poses_updated()) << with.message;
  std::printf(
      "[ pose graph ] a closure the walk bent to fit: kept at %.2f sigma, walk %.3f m off; lone trial: "
      "weight %.0f, %.6f m off (%d of %d trials)\n",
      without.edge_residual_sigma.back(), ate_rmse_m(rounds_only, truth), with.edge_weight.back(),
      ate_rmse_m(searched, truth), with.gnc_lone_dropped, with.gnc_cluster_trials);
  EXPECT_EQ(with.edge_weight.back(), 0.0);
  EXPECT_EQ(with.gnc_lone_dropped, 1);
  EXPECT_LT(ate_rmse_m(searched, truth), 1e-4);
}

// Cluster trials are bounded by gnc_cluster_trials and refused when negative.
TEST(PoseGraph, ClusterTrialsAreBoundedAndChecked) {
  const HalfOutliers h = half_outliers();
  PoseGraphConfig gnc = early_stopped_gnc(1);
  gnc.gnc_cluster_trials = -1;
  std::vector<Pose3> poses = h.initial;
  const PoseGraphResult refused = optimize_pose_graph(gnc, poses, h.corrupt);
  EXPECT_EQ(refused.status, PoseGraphStatus::kInvalidInput);
  EXPECT_NE(refused.message.find("gnc_cluster_trials"), std::string::npos) << refused.message;
  gnc.gnc_cluster_trials = 1;
  gnc.gnc_cluster_min_closures = 1;  // every dropped closure a candidate: many more than one trial's worth
  const PoseGraphResult r = optimize_pose_graph(gnc, poses, h.corrupt);
  ASSERT_TRUE(r.poses_updated()) << r.message;
  EXPECT_EQ(r.gnc_cluster_trials, 1);
  // A trial's two solves capped at one iteration each: the rejected trial adds four at most to GNC's count (Ceres
  // counts its initial evaluation among the successful steps).
  gnc.gnc_cluster_trial_iterations = -1;
  const PoseGraphResult refused_cap = optimize_pose_graph(gnc, poses, h.corrupt);
  EXPECT_EQ(refused_cap.status, PoseGraphStatus::kInvalidInput);
  EXPECT_NE(refused_cap.message.find("gnc_cluster_trial_iterations"), std::string::npos) << refused_cap.message;
  gnc.gnc_cluster_trial_iterations = 1;
  std::vector<Pose3> capped_poses = h.initial, none_poses = h.initial;  // poses holds r's solution
  const PoseGraphResult capped = optimize_pose_graph(gnc, capped_poses, h.corrupt);
  gnc.gnc_cluster_trials = 0;
  const PoseGraphResult none = optimize_pose_graph(gnc, none_poses, h.corrupt);
  ASSERT_TRUE(capped.poses_updated() && none.poses_updated()) << capped.message << none.message;
  ASSERT_EQ(capped.gnc_cluster_trials, 1);
  ASSERT_EQ(capped.gnc_clusters_readmitted + capped.gnc_lone_dropped, 0);
  EXPECT_LE(capped.iterations, none.iterations + 4);
  EXPECT_GT(r.iterations, none.iterations + 4);  // uncapped, the same trial solves longer
}

// An information matrix diag(1 / sigma^2) weighs as the sigmas do (translation in the `to` frame instead of the
// `from` frame changes nothing for an isotropic translation sigma).
TEST(PoseGraph, ADiagonalInformationMatrixEqualsItsSigmas) {
  const OutlierScenario s = outlier_scenario();
  std::vector<RelativePoseEdge> with_info = s.edges;
  for (RelativePoseEdge& e : with_info) {
    Eigen::Matrix<double, 6, 1> d;
    d << e.sigma_t_m.cwiseAbs2().cwiseInverse(), e.sigma_rot_rad.cwiseAbs2().cwiseInverse();
    e.information = d.asDiagonal();
    e.has_information = true;
  }
  std::vector<Pose3> a = s.initial, b = s.initial;
  const PoseGraphConfig config;
  ASSERT_TRUE(optimize_pose_graph(config, a, s.edges).poses_updated());
  ASSERT_TRUE(optimize_pose_graph(config, b, with_info).poses_updated());
  EXPECT_LT(ate_rmse_m(a, b), 1e-6);
  with_info[3].information(0, 0) = -1.0;
  std::vector<Pose3> c = s.initial;
  const PoseGraphResult bad = optimize_pose_graph(config, c, with_info);
  EXPECT_EQ(bad.status, PoseGraphStatus::kInvalidInput);
  EXPECT_NE(bad.message.find("positive definite"), std::string::npos) << bad.message;
}

TEST(PoseGraph, RobustLossDownweightsGrosslyWrongLoopClosure) {
  const OutlierScenario s = outlier_scenario();
  const RelativePoseEdge& wrong = s.edges[s.wrong_edge];
  ASSERT_GT(translation_error_m(between(s.truth[wrong.from], s.truth[wrong.to]), wrong.measured_from_T_to), 4.0);

  std::vector<Pose3> robust = s.initial;
  const PoseGraphConfig config;
  const PoseGraphResult result = optimize_pose_graph(config, robust, s.edges);
  ASSERT_TRUE(result.poses_updated()) << result.message;

  // The same graph without the robust loss: the outlier must visibly hurt, or this test proves nothing.
  std::vector<Pose3> least_squares = s.initial;
  PoseGraphConfig ls_config;
  ls_config.loop_closure_loss = RobustLoss::kNone;
  ASSERT_TRUE(optimize_pose_graph(ls_config, least_squares, s.edges).poses_updated());

  const double ate_initial_m = ate_rmse_m(s.initial, s.truth);
  const double ate_robust_m = ate_rmse_m(robust, s.truth);
  const double ate_least_squares_m = ate_rmse_m(least_squares, s.truth);
  std::printf("[ pose graph ] outlier closure: ATE initial %.4f m, robust (%s) %.4f m, least squares %.4f m; "
              "wrong closure at %.1f sigma\n",
              ate_initial_m, to_string(config.loop_closure_loss), ate_robust_m, ate_least_squares_m,
              result.edge_residual_sigma[s.wrong_edge]);

  EXPECT_LT(ate_robust_m, 0.1);
  EXPECT_LT(ate_robust_m * 5.0, ate_initial_m);
  EXPECT_GT(ate_least_squares_m, 3.0 * ate_robust_m);
  // Only the wrong closure is left outside the loss scale; the correct ones hold.
  EXPECT_EQ(result.num_loop_closures_downweighted, 1u);
  EXPECT_GT(result.edge_residual_sigma[s.wrong_edge], 10.0 * config.loop_closure_loss_scale_sigma);
  for (std::size_t k = s.wrong_edge - 4; k < s.wrong_edge; ++k) {
    EXPECT_LT(result.edge_residual_sigma[k], config.loop_closure_loss_scale_sigma) << "correct closure " << k;
  }
}

// 2 deg/step of yaw drift (80 deg around the loop): the correct closures start ~100 sigma away, where Cauchy alone
// would treat them as outliers. The Huber warm start must still close the loop and reject only the wrong closure.
TEST(PoseGraph, HuberWarmStartKeepsCorrectClosuresUnderStrongDrift) {
  const OutlierScenario s = outlier_scenario(2.0 * kDegToRad);
  const PoseGraphConfig config;
  ASSERT_TRUE(config.huber_warm_start);
  std::vector<Pose3> warm = s.initial;
  const PoseGraphResult result = optimize_pose_graph(config, warm, s.edges);
  ASSERT_TRUE(result.poses_updated()) << result.message;

  PoseGraphConfig cold_config;
  cold_config.huber_warm_start = false;
  std::vector<Pose3> cold = s.initial;
  ASSERT_TRUE(optimize_pose_graph(cold_config, cold, s.edges).poses_updated());

  const double ate_initial_m = ate_rmse_m(s.initial, s.truth);
  const double ate_warm_m = ate_rmse_m(warm, s.truth);
  const double ate_cold_m = ate_rmse_m(cold, s.truth);
  std::printf("[ pose graph ] strong drift: ATE initial %.4f m, Huber warm start %.4f m, Cauchy alone %.4f m; "
              "%d iterations\n",
              ate_initial_m, ate_warm_m, ate_cold_m, result.iterations);
  EXPECT_GT(ate_initial_m, 1.5);
  EXPECT_LT(ate_warm_m, 0.1);
  EXPECT_EQ(result.num_loop_closures_downweighted, 1u);
  EXPECT_GT(result.edge_residual_sigma[s.wrong_edge], 10.0 * config.loop_closure_loss_scale_sigma);
  // Why the warm start exists: from the drifted start Cauchy alone settles next to the odometry.
  EXPECT_GT(ate_cold_m, 5.0 * ate_warm_m);
}

std::vector<Pose3> two_pose_graph() { return {Pose3{}, make_pose(Eigen::Vector3d(1.0, 0.0, 0.0), yaw(0.1))}; }

std::vector<RelativePoseEdge> two_pose_edges() {
  const std::vector<Pose3> poses = two_pose_graph();
  return {make_edge(0, 1, between(poses[0], poses[1]), false)};
}

void expect_invalid(const PoseGraphConfig& config, std::vector<Pose3> poses, const std::vector<RelativePoseEdge>& edges,
                    const char* expected_text) {
  const std::vector<Pose3> before = poses;
  const PoseGraphResult result = optimize_pose_graph(config, poses, edges);
  EXPECT_EQ(result.status, PoseGraphStatus::kInvalidInput) << result.message;
  EXPECT_FALSE(result.poses_updated());
  EXPECT_NE(result.message.find(expected_text), std::string::npos)
      << "message '" << result.message << "' lacks '" << expected_text << "'";
  ASSERT_EQ(poses.size(), before.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    // Bitwise equality, NaN included: the caller's poses are never touched on bad input.
    EXPECT_EQ(0, std::memcmp(poses[i].t_m.data(), before[i].t_m.data(), sizeof(double) * 3)) << "pose " << i;
    EXPECT_EQ(0, std::memcmp(poses[i].q.coeffs().data(), before[i].q.coeffs().data(), sizeof(double) * 4))
        << "pose " << i;
  }
}

TEST(PoseGraph, InvalidInputIsReportedNotCrashed) {
  const PoseGraphConfig config;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();

  expect_invalid(config, {}, {}, "empty graph");

  std::vector<RelativePoseEdge> edges = two_pose_edges();
  edges.push_back(make_edge(1, 7, Pose3{}, true));
  expect_invalid(config, two_pose_graph(), edges, "edge 1 (loop closure 1 -> 7): pose index out of range");

  edges = two_pose_edges();
  edges[0].to = 0;
  expect_invalid(config, two_pose_graph(), edges, "connects pose 0 to itself");

  std::vector<Pose3> poses = two_pose_graph();
  poses[1].t_m.y() = nan;
  expect_invalid(config, poses, two_pose_edges(), "pose 1 is not finite");

  poses = two_pose_graph();
  poses[1].q.coeffs().setZero();
  expect_invalid(config, poses, two_pose_edges(), "pose 1 has a zero-norm quaternion");

  edges = two_pose_edges();
  edges[0].measured_from_T_to.q.w() = inf;
  expect_invalid(config, two_pose_graph(), edges, "measurement is not finite");

  edges = two_pose_edges();
  edges[0].sigma_rot_rad.z() = 0.0;
  expect_invalid(config, two_pose_graph(), edges, "sigmas must be finite and > 0");

  PoseGraphConfig bad_config;
  bad_config.max_iterations = 0;
  expect_invalid(bad_config, two_pose_graph(), two_pose_edges(), "max_iterations");
  bad_config = PoseGraphConfig{};
  bad_config.loop_closure_loss_scale_sigma = -1.0;
  expect_invalid(bad_config, two_pose_graph(), two_pose_edges(), "loop_closure_loss_scale_sigma");
}

TEST(PoseGraph, ExactOdometryWithoutLoopClosureLeavesPosesUnchanged) {
  const std::vector<Pose3> truth = square_ground_truth();
  std::vector<RelativePoseEdge> edges;
  for (std::uint32_t i = 0; i + 1 < kNumPoses; ++i) {
    edges.push_back(make_edge(i, i + 1, between(truth[i], truth[i + 1]), false));
  }
  std::vector<Pose3> poses = chain_odometry(truth[0], edges);

  const std::vector<Pose3> before = poses;
  const PoseGraphResult result = optimize_pose_graph(PoseGraphConfig{}, poses, edges);
  ASSERT_TRUE(result.converged()) << result.message;
  EXPECT_LT(result.final_cost, 1e-20);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    EXPECT_LT(translation_error_m(poses[i], before[i]), 1e-9) << "pose " << i;
    EXPECT_LT(rotation_error_rad(poses[i], before[i]), 1e-9) << "pose " << i;
  }
}

// q and -q are the same rotation: a measurement handed over with w < 0 must cost nothing (a residual built on
// coefficient differences would read it as a large error).
TEST(PoseGraph, NegatedMeasurementQuaternionIsTheSameRotation) {
  std::vector<Pose3> poses = two_pose_graph();
  std::vector<RelativePoseEdge> edges = two_pose_edges();
  edges[0].measured_from_T_to.q.coeffs() *= -1.0;
  const std::vector<Pose3> before = poses;
  const PoseGraphResult result = optimize_pose_graph(PoseGraphConfig{}, poses, edges);
  ASSERT_TRUE(result.converged()) << result.message;
  EXPECT_LT(result.initial_cost, 1e-20);
  EXPECT_LT(translation_error_m(poses[1], before[1]), 1e-9);
  EXPECT_LT(rotation_error_rad(poses[1], before[1]), 1e-9);
}

TEST(PoseGraph, NonUnitQuaternionsAreNormalized) {
  std::vector<Pose3> poses = two_pose_graph();
  std::vector<RelativePoseEdge> edges = two_pose_edges();
  // The measurement disagrees by 0.02 rad of yaw, so its weight (which a non-unit quaternion would scale) shows in
  // the cost: 2 sin(0.01) / sigma whitened, in yaw only.
  constexpr double kYawOffset_rad = 0.02;
  edges[0].measured_from_T_to.q = edges[0].measured_from_T_to.q * yaw(kYawOffset_rad);
  edges[0].measured_from_T_to.q.coeffs() *= 0.5;
  poses[1].q.coeffs() *= 3.0;
  const double whitened = 2.0 * std::sin(kYawOffset_rad / 2.0) / kOdomSigma_rad.z();
  const PoseGraphResult result = optimize_pose_graph(PoseGraphConfig{}, poses, edges);
  ASSERT_TRUE(result.converged()) << result.message;
  EXPECT_NEAR(result.initial_cost, 0.5 * whitened * whitened, 1e-9);
  EXPECT_NEAR(poses[1].q.norm(), 1.0, 1e-12);
  EXPECT_LT(rotation_error_rad(poses[1], make_pose(Eigen::Vector3d::Zero(), yaw(0.1 + kYawOffset_rad))), 1e-6);
}

// A second, unconnected trajectory keeps its own gauge: its first pose is held, so it cannot drift off.
TEST(PoseGraph, EachDisconnectedComponentKeepsItsFirstPose) {
  std::vector<Pose3> poses = two_pose_graph();
  const Pose3 far_start = make_pose(Eigen::Vector3d(10.0, 5.0, 0.0), yaw(1.0));
  poses.push_back(far_start);
  poses.push_back(far_start * make_pose(Eigen::Vector3d(1.0, 0.0, 0.0), yaw(0.0)));
  std::vector<RelativePoseEdge> edges = two_pose_edges();
  // The measurement disagrees with the initial guess, so pose 3 must move and pose 2 must not.
  edges.push_back(make_edge(2, 3, make_pose(Eigen::Vector3d(2.0, 0.0, 0.0), yaw(0.0)), false));
  const PoseGraphResult result = optimize_pose_graph(PoseGraphConfig{}, poses, edges);
  ASSERT_TRUE(result.converged()) << result.message;
  EXPECT_EQ(poses[2].t_m, far_start.t_m);
  EXPECT_NEAR(translation_error_m(poses[3], far_start * make_pose(Eigen::Vector3d(2.0, 0.0, 0.0), yaw(0.0))), 0.0,
              1e-6);
}

std::string print_to_string(const std::function<void(std::FILE*)>& print) {
  std::FILE* out = std::tmpfile();
  if (out == nullptr) return "tmpfile failed";
  print(out);
  std::rewind(out);
  char buffer[1024] = {};
  const std::size_t length = std::fread(buffer, 1, sizeof(buffer) - 1, out);
  std::fclose(out);
  return std::string(buffer, length);
}

TEST(PoseGraph, PrintShowsEffectiveParametersAndOutcome) {
  const PoseGraphConfig config;
  const std::string config_text = print_to_string([&](std::FILE* out) { config.print(out); });
  for (const char* field : {"loop_closure_loss=cauchy", "loop_closure_loss_scale_sigma=5", "huber_warm_start=true",
                            "max_iterations=50", "fix_first_pose=true", "num_threads=1"}) {
    EXPECT_NE(config_text.find(field), std::string::npos) << config_text;
  }
  std::vector<Pose3> poses;
  const PoseGraphResult result = optimize_pose_graph(config, poses, {});
  const std::string result_text = print_to_string([&](std::FILE* out) { result.print(out); });
  EXPECT_NE(result_text.find("status=invalid_input"), std::string::npos) << result_text;
  EXPECT_NE(result_text.find("empty graph"), std::string::npos) << result_text;
}

TEST(PoseGraph, NoEdgesLeavesPosesAsTheyAre) {
  std::vector<Pose3> poses = two_pose_graph();
  const PoseGraphResult result = optimize_pose_graph(PoseGraphConfig{}, poses, {});
  EXPECT_TRUE(result.converged()) << result.message;
  EXPECT_EQ(result.iterations, 0);
  EXPECT_EQ(poses[1].t_m, two_pose_graph()[1].t_m);
  EXPECT_LT(rotation_error_rad(poses[1], two_pose_graph()[1]), 1e-12);
}

// RotationPrior: a pose's rotation between its edge's (identity) and its prior's (30 degrees), as sure of either,
// lands halfway, its position untouched; without the prior, on the edge's. A held pose ignores its prior; a bad
// prior is named, not solved.
TEST(PoseGraph, ARotationPriorPullsARotationTowardsItsOwn) {
  const Eigen::Quaterniond prior_q(Eigen::AngleAxisd(30.0 * kDegToRad, Eigen::Vector3d::UnitZ()));
  const std::vector<Pose3> initial = {make_pose(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity()),
                                      make_pose(Eigen::Vector3d(1.1, 0.1, 0.0), prior_q)};
  RelativePoseEdge e;
  e.from = 0;
  e.to = 1;
  e.measured_from_T_to = make_pose(Eigen::Vector3d(1.0, 0.0, 0.0), Eigen::Quaterniond::Identity());
  e.sigma_t_m = Eigen::Vector3d::Constant(0.1);
  e.sigma_rot_rad = Eigen::Vector3d::Constant(0.2);
  std::vector<Pose3> without = initial, with = initial;
  ASSERT_TRUE(optimize_pose_graph(PoseGraphConfig{}, without, {e}).converged());
  EXPECT_LT(without[1].q.angularDistance(Eigen::Quaterniond::Identity()), 1e-4);
  const Eigen::Quaterniond held_at(Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitX()));
  const std::vector<RotationPrior> priors = {RotationPrior{1, prior_q, 0.2}, RotationPrior{0, held_at, 0.01}};
  const PoseGraphResult r = optimize_pose_graph(PoseGraphConfig{}, with, {e}, priors);
  ASSERT_TRUE(r.converged()) << r.message;
  const Eigen::Quaterniond halfway(Eigen::AngleAxisd(15.0 * kDegToRad, Eigen::Vector3d::UnitZ()));
  EXPECT_LT(with[1].q.angularDistance(halfway), 1e-4);
  EXPECT_LT((with[1].t_m - Eigen::Vector3d(1.0, 0.0, 0.0)).norm(), 1e-6);
  EXPECT_LT(with[0].q.angularDistance(Eigen::Quaterniond::Identity()), 1e-12) << "the gauge pose is held";
  std::vector<Pose3> bad = initial;
  const PoseGraphResult invalid = optimize_pose_graph(PoseGraphConfig{}, bad, {e}, {RotationPrior{1, prior_q, 0.0}});
  EXPECT_EQ(invalid.status, PoseGraphStatus::kInvalidInput);
  EXPECT_NE(invalid.message.find("rotation prior 0"), std::string::npos) << invalid.message;
  EXPECT_EQ(optimize_pose_graph(PoseGraphConfig{}, bad, {e}, {RotationPrior{2, prior_q, 1.0}}).status,
            PoseGraphStatus::kInvalidInput);
}

}  // namespace
}  // namespace qsg::backend
