// Drifting odometry: exact with zero noise, drift growing with the square root of distance, a covariance that
// matches the actual error, determinism per seed, and biases with their documented effect.
#include "drivers/sim/drifting_odometry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tests/support/allocation_counter.h"

namespace qsg::sim {
namespace {

using drivers::ReadStatus;
using replay::StampedPose;
using replay::Trajectory;

// Straight line along a slanted direction, step_m apart, 10 ms per step.
Trajectory straight_line(double length_m, double step_m) {
  Trajectory t;
  const Eigen::Vector3d dir = Eigen::Vector3d(1.0, 2.0, 0.5).normalized();
  const int steps = static_cast<int>(std::lround(length_m / step_m));
  for (int i = 0; i <= steps; ++i) {
    StampedPose p;
    p.time_ns = 1'000'000'000LL + i * 10'000'000LL;
    p.world_t_body_m = Eigen::Vector3d(3.0, -1.0, 0.4) + dir * (i * step_m);
    p.world_R_body = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
    t.push_back(p);
  }
  return t;
}

// A wavy planar path with changing heading and some roll/pitch, the kind a legged robot walks.
Trajectory wavy_path(int steps) {
  Trajectory t;
  for (int i = 0; i <= steps; ++i) {
    const double s = 0.05 * i;
    StampedPose p;
    p.time_ns = i * 20'000'000LL;
    p.world_t_body_m = Eigen::Vector3d(s, 0.8 * std::sin(0.7 * s), 0.02 * std::sin(5.0 * s));
    const double yaw = std::atan2(0.8 * 0.7 * std::cos(0.7 * s), 1.0);
    p.world_R_body = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                     Eigen::AngleAxisd(0.05 * std::sin(3.0 * s), Eigen::Vector3d::UnitX()) *
                     Eigen::AngleAxisd(0.03 * std::cos(2.0 * s), Eigen::Vector3d::UnitY());
    t.push_back(p);
  }
  return t;
}

Eigen::Isometry3d pose_of(const messages::OdometrySample& s) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = s.world_R_body.toRotationMatrix();
  t.translation() = s.world_t_body_m;
  return t;
}

// Runs to the end; returns the final position error and yaw error.
void run_to_end(DriftingOdometry& odom, Eigen::Vector3d* position_error, double* yaw_error) {
  messages::OdometrySample s;
  while (odom.read(s, 0) == ReadStatus::kOk) {
  }
  *position_error = odom.position_error_m();
  *yaw_error = odom.yaw_error_rad();
}

TEST(DriftingOdometry, ZeroNoiseReproducesGroundTruthExactly) {
  const Trajectory truth = wavy_path(200);
  DriftingOdometry odom(truth, DriftingOdometry::Config{});
  messages::OdometrySample s;
  std::size_t n = 0;
  Eigen::Isometry3d previous = Eigen::Isometry3d::Identity();
  while (odom.read(s, 0) == ReadStatus::kOk) {
    const StampedPose& gt = truth[n];
    EXPECT_EQ(s.sequence, n);
    EXPECT_EQ(s.sample_time_ns, gt.time_ns);
    EXPECT_EQ(s.world_t_body_m, gt.world_t_body_m) << n;  // bit for bit
    EXPECT_EQ(s.world_R_body.coeffs(), gt.world_R_body.coeffs()) << n;
    const Eigen::Isometry3d current = pose_of(s);
    if (n > 0) {  // relative motion between consecutive samples equals the ground truth's
      const Eigen::Isometry3d rel = previous.inverse() * current;
      const Eigen::Isometry3d rel_gt = truth[n - 1].world_T_body().inverse() * gt.world_T_body();
      EXPECT_LT((rel.matrix() - rel_gt.matrix()).cwiseAbs().maxCoeff(), 1e-12) << n;
    }
    previous = current;
    ++n;
  }
  EXPECT_EQ(n, truth.size());
  EXPECT_EQ(odom.position_error_m(), Eigen::Vector3d::Zero());
  EXPECT_EQ(odom.counters().delivered, truth.size());
}

TEST(DriftingOdometry, TranslationNoiseLeavesOrientationExact) {
  const Trajectory truth = wavy_path(50);
  DriftingOdometry::Config config;
  config.translation_sigma_m_per_sqrt_m = 0.05;
  DriftingOdometry odom(truth, config);
  messages::OdometrySample s;
  std::size_t n = 0;
  double max_error = 0.0;
  while (odom.read(s, 0) == ReadStatus::kOk) {
    EXPECT_EQ(s.world_R_body.coeffs(), truth[n].world_R_body.coeffs());
    max_error = std::max(max_error, (s.world_t_body_m - truth[n].world_t_body_m).norm());
    ++n;
  }
  EXPECT_GT(max_error, 1e-3);
  EXPECT_EQ(odom.ground_truth()[7].world_t_body_m, truth[7].world_t_body_m);  // ground truth kept apart
}

// Mean squared endpoint error over many seeds.
double mean_squared_translation_error(const Trajectory& truth, DriftingOdometry::Config config, int seeds) {
  double sum = 0.0;
  for (int k = 0; k < seeds; ++k) {
    config.seed = 1000 + k;
    DriftingOdometry odom(truth, config);
    Eigen::Vector3d e;
    double yaw;
    run_to_end(odom, &e, &yaw);
    sum += e.squaredNorm();
  }
  return sum / seeds;
}

TEST(DriftingOdometry, TranslationDriftGrowsWithTheSquareRootOfDistance) {
  DriftingOdometry::Config config;
  config.translation_sigma_m_per_sqrt_m = 0.02;
  const int seeds = 300;
  const double ms_1 = mean_squared_translation_error(straight_line(1.0, 0.05), config, seeds);
  const double ms_4 = mean_squared_translation_error(straight_line(4.0, 0.05), config, seeds);
  // Per axis variance sigma^2 * D: mean squared 3D error = 3 sigma^2 D.
  EXPECT_NEAR(ms_1, 3 * 0.02 * 0.02 * 1.0, 0.2 * 3 * 0.02 * 0.02 * 1.0);
  EXPECT_NEAR(ms_4, 3 * 0.02 * 0.02 * 4.0, 0.2 * 3 * 0.02 * 0.02 * 4.0);
  const double rms_ratio = std::sqrt(ms_4 / ms_1);
  EXPECT_NEAR(rms_ratio, 2.0, 0.25 * 2.0) << "4x the distance should give 2x the RMS drift";
}

TEST(DriftingOdometry, YawDriftGrowsWithTheSquareRootOfDistance) {
  DriftingOdometry::Config config;
  config.yaw_sigma_rad_per_sqrt_m = 0.01;
  const int seeds = 300;
  double var_1 = 0.0;
  double var_4 = 0.0;
  for (int k = 0; k < seeds; ++k) {
    config.seed = 77 + k;
    Eigen::Vector3d e;
    double yaw;
    DriftingOdometry a(straight_line(1.0, 0.05), config);
    run_to_end(a, &e, &yaw);
    var_1 += yaw * yaw / seeds;
    DriftingOdometry b(straight_line(4.0, 0.05), config);
    run_to_end(b, &e, &yaw);
    var_4 += yaw * yaw / seeds;
  }
  EXPECT_NEAR(var_1, 1e-4 * 1.0, 0.2e-4);
  EXPECT_NEAR(var_4, 1e-4 * 4.0, 0.8e-4);
  EXPECT_NEAR(std::sqrt(var_4 / var_1), 2.0, 0.5);
}

TEST(DriftingOdometry, ReportedCovarianceMatchesTheActualError) {
  const Trajectory truth = wavy_path(160);  // 8 m along x, about 9 m travelled
  DriftingOdometry::Config config;
  config.translation_sigma_m_per_sqrt_m = 0.02;
  config.yaw_sigma_rad_per_sqrt_m = 0.01;
  const int seeds = 300;
  double sum_sq_position = 0.0;
  double sum_sq_yaw = 0.0;
  Eigen::Matrix4d reported = Eigen::Matrix4d::Zero();
  for (int k = 0; k < seeds; ++k) {
    config.seed = 5000 + k;
    DriftingOdometry odom(truth, config);
    messages::OdometrySample s;
    double previous_trace = 0.0;
    while (odom.read(s, 0) == ReadStatus::kOk) {
      const double trace = s.covariance.trace();
      EXPECT_GE(trace, previous_trace) << "reported covariance must not shrink while moving";
      previous_trace = trace;
    }
    EXPECT_TRUE(s.covariance.isApprox(s.covariance.transpose()));
    sum_sq_position += odom.position_error_m().squaredNorm();
    sum_sq_yaw += odom.yaw_error_rad() * odom.yaw_error_rad();
    reported = odom.error_covariance();  // the same for every seed
    // Reported covariance [t; r]: position block and yaw entry are the propagated model plus the floors.
    EXPECT_NEAR(s.covariance(0, 0), reported(0, 0) + 1e-6, 1e-12);
    EXPECT_NEAR(s.covariance(5, 5), reported(3, 3) + 1e-6, 1e-12);
    EXPECT_NEAR(s.covariance(0, 5), reported(0, 3), 1e-12);
  }
  const double mean_sq_position = sum_sq_position / seeds;
  const double mean_sq_yaw = sum_sq_yaw / seeds;
  const double predicted_position = reported.topLeftCorner<3, 3>().trace();
  EXPECT_GT(predicted_position, 3 * 0.02 * 0.02 * 8.0) << "yaw drift must add lateral error to the prediction";
  EXPECT_NEAR(mean_sq_position / predicted_position, 1.0, 0.2);
  EXPECT_NEAR(mean_sq_yaw / reported(3, 3), 1.0, 0.2);
}

TEST(DriftingOdometry, DeterministicForASeed) {
  const Trajectory truth = wavy_path(40);
  DriftingOdometry::Config config;
  config.translation_sigma_m_per_sqrt_m = 0.05;
  config.yaw_sigma_rad_per_sqrt_m = 0.02;
  config.seed = 99;
  DriftingOdometry a(truth, config);
  DriftingOdometry b(truth, config);
  config.seed = 100;
  DriftingOdometry c(truth, config);
  messages::OdometrySample sa, sb, sc;
  std::vector<Eigen::Vector3d> first_run;
  bool any_different = false;
  while (a.read(sa, 0) == ReadStatus::kOk) {
    ASSERT_EQ(b.read(sb, 0), ReadStatus::kOk);
    ASSERT_EQ(c.read(sc, 0), ReadStatus::kOk);
    EXPECT_EQ(sa.world_t_body_m, sb.world_t_body_m);
    EXPECT_EQ(sa.world_R_body.coeffs(), sb.world_R_body.coeffs());
    any_different = any_different || sa.world_t_body_m != sc.world_t_body_m;
    first_run.push_back(sa.world_t_body_m);
  }
  EXPECT_TRUE(any_different);
  a.rewind();
  for (const Eigen::Vector3d& t : first_run) {
    ASSERT_EQ(a.read(sa, 0), ReadStatus::kOk);
    EXPECT_EQ(sa.world_t_body_m, t);
  }
}

TEST(DriftingOdometry, BiasesHaveTheirDocumentedEffect) {
  const Trajectory truth = straight_line(10.0, 0.1);
  const Eigen::Vector3d travel = truth.back().world_t_body_m - truth.front().world_t_body_m;
  DriftingOdometry::Config scale;
  scale.scale_bias = 0.01;
  DriftingOdometry a(truth, scale);
  Eigen::Vector3d e;
  double yaw;
  run_to_end(a, &e, &yaw);
  EXPECT_LT((e - 0.01 * travel).norm(), 1e-9);
  EXPECT_EQ(yaw, 0.0);

  DriftingOdometry::Config yaw_bias;
  yaw_bias.yaw_bias_rad_per_m = 0.002;
  DriftingOdometry b(truth, yaw_bias);
  run_to_end(b, &e, &yaw);
  EXPECT_NEAR(yaw, 0.002 * 10.0, 1e-9);
  EXPECT_NEAR(b.distance_m(), 10.0, 1e-9);
  EXPECT_GT(e.head<2>().norm(), 0.05);  // heading error bends the path sideways
  EXPECT_LT(std::abs(e.z()), 1e-9);     // about the gravity axis: no height error
}

TEST(DriftingOdometry, EndOfStreamIsStickyAndReadsDoNotAllocate) {
  DriftingOdometry::Config config;
  config.translation_sigma_m_per_sqrt_m = 0.05;
  config.yaw_sigma_rad_per_sqrt_m = 0.02;
  DriftingOdometry odom(wavy_path(30), config);
  messages::OdometrySample s;
  int ok = 0;
  EXPECT_NO_ALLOCATIONS(for (int i = 0; i < 40; ++i) ok += odom.read(s, 0) == ReadStatus::kOk ? 1 : 0);
  EXPECT_EQ(ok, 31);
  EXPECT_EQ(odom.read(s, 0), ReadStatus::kEndOfStream);
  EXPECT_LE(s.sample_time_ns, s.publish_time_ns);
}

TEST(DriftingOdometry, FlagsTimestampsGoingBackwards) {
  Trajectory truth = straight_line(1.0, 0.1);
  truth[4].time_ns = truth[2].time_ns;
  DriftingOdometry odom(truth, DriftingOdometry::Config{});
  messages::OdometrySample s;
  for (int i = 0; i < 5; ++i) ASSERT_EQ(odom.read(s, 0), ReadStatus::kOk);
  EXPECT_TRUE(s.flags & messages::kFrameTimestampBackwards);
  EXPECT_EQ(odom.counters().timestamps_backwards, 1u);
}

}  // namespace
}  // namespace qsg::sim
