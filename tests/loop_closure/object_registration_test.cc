#include "core/loop_closure/object_registration.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace qsg::loop_closure {
namespace {

// A furnished room: labelled object centroids spread over a few metres.
std::vector<LabelledPoint> room(std::mt19937* rng, int n, int labels) {
  std::uniform_real_distribution<double> xy(-3.0, 3.0), z(0.2, 1.5);
  std::vector<LabelledPoint> out;
  for (int i = 0; i < n; ++i) out.push_back({Eigen::Vector3d(xy(*rng), xy(*rng), z(*rng)), static_cast<std::uint32_t>(3 + i % labels)});
  return out;
}

Eigen::Isometry3d yaw_pose(double yaw, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = t;
  return T;
}

TEST(ObjectRegistrationTest, RecoversAYawAndTranslationUnderNoise) {
  std::mt19937 rng(7);
  const std::vector<LabelledPoint> target = room(&rng, 12, 5);
  const Eigen::Isometry3d truth = yaw_pose(0.4, Eigen::Vector3d(1.5, -0.7, 0.0));  // target_T_source
  std::normal_distribution<double> noise(0.0, 0.05);
  std::vector<LabelledPoint> source;
  for (const LabelledPoint& p : target)
    source.push_back({truth.inverse() * p.p_m + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)), p.label});
  ObjectRegistration reg;
  const Registration r = reg.register_sets(source.data(), source.size(), target.data(), target.size());
  ASSERT_TRUE(r.ok()) << to_string(r.failure);
  EXPECT_EQ(r.inliers, 12u);
  EXPECT_LT((r.target_T_source.translation() - truth.translation()).norm(), 0.1);
  EXPECT_LT(Eigen::AngleAxisd(r.target_T_source.linear().transpose() * truth.linear()).angle(), 0.03);
}

TEST(ObjectRegistrationTest, OutliersAndExtraObjectsDoNotMoveTheEstimate) {
  std::mt19937 rng(11);
  const std::vector<LabelledPoint> target = room(&rng, 10, 4);
  const Eigen::Isometry3d truth = yaw_pose(-1.2, Eigen::Vector3d(-2.0, 0.5, 0.0));
  std::vector<LabelledPoint> source;
  for (std::size_t i = 0; i < target.size(); ++i) {
    Eigen::Vector3d p = truth.inverse() * target[i].p_m;
    if (i % 3 == 0) p += Eigen::Vector3d(1.5, -1.0, 0.0);  // a third of the objects moved (or mis-segmented)
    source.push_back({p, target[i].label});
  }
  std::vector<LabelledPoint> clutter = room(&rng, 6, 4);  // objects only one side saw
  source.insert(source.end(), clutter.begin(), clutter.end());
  ObjectRegistration reg;
  const Registration r = reg.register_sets(source.data(), source.size(), target.data(), target.size());
  ASSERT_TRUE(r.ok()) << to_string(r.failure);
  EXPECT_GE(r.inliers, 6u);
  EXPECT_LT((r.target_T_source.translation() - truth.translation()).norm(), 0.05);
}

TEST(ObjectRegistrationTest, UnrelatedRoomsFailToRegister) {
  std::mt19937 rng(3);
  int accepted = 0;
  for (int trial = 0; trial < 50; ++trial) {
    const std::vector<LabelledPoint> a = room(&rng, 8, 4), b = room(&rng, 8, 4);
    ObjectRegistration reg;
    accepted += reg.register_sets(a.data(), a.size(), b.data(), b.size()).ok() ? 1 : 0;
  }
  EXPECT_LE(accepted, 1) << "random rooms must (almost) never register with 4 consistent inliers";
}

TEST(ObjectRegistrationTest, CollinearInliersAreDegenerate) {
  std::vector<LabelledPoint> target;
  for (int i = 0; i < 6; ++i) target.push_back({Eigen::Vector3d(0.1 * i, 0.0, 0.5), 5u});  // a row within 0.5 m
  std::vector<LabelledPoint> source = target;
  ObjectRegistration reg;
  const Registration r = reg.register_sets(source.data(), source.size(), target.data(), target.size());
  EXPECT_EQ(r.failure, RegistrationFailure::kDegenerate);
}

TEST(ObjectRegistrationTest, TooFewCorrespondencesIsAClearFailure) {
  const LabelledPoint a[2] = {{Eigen::Vector3d(0, 0, 0), 3}, {Eigen::Vector3d(1, 0, 0), 4}};
  const LabelledPoint b[2] = {{Eigen::Vector3d(0, 0, 0), 5}, {Eigen::Vector3d(1, 0, 0), 6}};
  ObjectRegistration reg;
  const Registration r = reg.register_sets(a, 2, b, 2);
  EXPECT_EQ(r.failure, RegistrationFailure::kTooFewCorrespondences);
  EXPECT_EQ(r.correspondences, 0u);
}

TEST(ObjectRegistrationTest, CorrespondencesBeyondTheBoundAreCountedNotUsed) {
  std::vector<LabelledPoint> many(20, LabelledPoint{Eigen::Vector3d::Zero(), 7u});
  for (std::size_t i = 0; i < many.size(); ++i) many[i].p_m = Eigen::Vector3d(0.5 * i, 0.3 * (i % 4), 0.0);
  RegistrationConfig config;
  config.max_clique_nodes = 1000;
  ObjectRegistration reg(config);
  const Registration r = reg.register_sets(many.data(), many.size(), many.data(), many.size());
  EXPECT_EQ(r.correspondences, 400u);
  EXPECT_EQ(r.correspondences_dropped, 400u - kMaxCorrespondences);
}

TEST(ObjectRegistrationTest, FullRotationWhenNotGravityAligned) {
  std::mt19937 rng(5);
  const std::vector<LabelledPoint> target = room(&rng, 10, 5);
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  truth.linear() = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()))
                       .toRotationMatrix();
  truth.translation() = Eigen::Vector3d(0.5, 1.0, -0.3);
  std::vector<LabelledPoint> source;
  for (const LabelledPoint& p : target) source.push_back({truth.inverse() * p.p_m, p.label});
  RegistrationConfig config;
  config.gravity_aligned = false;
  ObjectRegistration reg(config);
  const Registration r = reg.register_sets(source.data(), source.size(), target.data(), target.size());
  ASSERT_TRUE(r.ok());
  EXPECT_LT((r.target_T_source.matrix() - truth.matrix()).norm(), 1e-6);
}

}  // namespace
}  // namespace qsg::loop_closure
