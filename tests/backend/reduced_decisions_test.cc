// Decisions on the reduced agent graph (reduced_decisions.h): a composed edge is the chain's composition with the
// covariance its first-order (Jacobian) propagation gives; the reduced graph keeps the closures' agents and the
// ends; on a drifted three-lap walk with a wrong closure among right ones, GNC on the reduced graph rejects the
// wrong one and keeps the right ones, as GNC over the whole chain does, and the chain solved with those decisions
// lands where the whole chain's GNC does.
#include "core/backend/reduced_decisions.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "core/backend/agent_pose_graph.h"
#include "core/backend/deformation_graph.h"
#include "tests/backend/planar_pose.h"

namespace qsg::backend {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;

Eigen::Quaterniond exp_rotation(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  if (angle < 1e-15) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, phi / angle));
}

// The residual's convention (pose_graph.cc): [R_m^T (t - t_m); 2 vec(q_m^-1 q)], both in the `to` frame.
Vector6d residual(const Pose3& measured, const Pose3& estimate) {
  Vector6d r;
  r.head<3>() = measured.q.conjugate() * (estimate.t_m - measured.t_m);
  r.tail<3>() = 2.0 * (measured.q.conjugate() * estimate.q).vec();
  return r;
}

// A step perturbed the way the residual measures it: (t + R rho, R Exp(phi)).
Pose3 perturbed(const Pose3& p, const Vector6d& x) {
  return Pose3{p.t_m + p.q * x.head<3>(), p.q * exp_rotation(x.tail<3>())};
}

TEST(ReducedDecisionsTest, AComposedEdgeIsTheChainsCompositionWithItsFirstOrderCovariance) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<RelativePoseEdge> steps;
  std::vector<Matrix6d> covariances;
  for (std::uint32_t k = 0; k < 6; ++k) {
    RelativePoseEdge e;
    e.from = k;
    e.to = k + 1;
    e.measured_from_T_to.t_m = Eigen::Vector3d(0.8 + 0.3 * n01(rng), 0.4 * n01(rng), 0.2 * n01(rng));
    e.measured_from_T_to.q = exp_rotation(0.4 * Eigen::Vector3d(n01(rng), n01(rng), n01(rng)));
    if (k == 2) {  // sigmas: translation in the `from` frame
      e.sigma_t_m = Eigen::Vector3d(0.02, 0.03, 0.01);
      e.sigma_rot_rad = Eigen::Vector3d(0.004, 0.002, 0.006);
    } else {
      Matrix6d l;
      for (int i = 0; i < 36; ++i) l.data()[i] = 0.01 * n01(rng);
      const Matrix6d cov = l * l.transpose() + 1e-5 * Matrix6d::Identity();
      e.has_information = true;
      e.information = cov.inverse();
      e.information = 0.5 * (e.information + e.information.transpose()).eval();
    }
    covariances.push_back(covariance_in_to_frame(e));
    steps.push_back(e);
  }
  // The sigma-form step's covariance in its `to` frame: the translation's rotated by the step's rotation.
  const Eigen::Matrix3d to_R_from = steps[2].measured_from_T_to.q.conjugate().toRotationMatrix();
  EXPECT_TRUE((covariances[2].topLeftCorner<3, 3>() -
               to_R_from * steps[2].sigma_t_m.cwiseAbs2().asDiagonal() * to_R_from.transpose())
                  .isZero(1e-15));

  const RelativePoseEdge composed = compose_steps(steps.data(), steps.size());
  EXPECT_EQ(composed.from, 0u);
  EXPECT_EQ(composed.to, 6u);
  EXPECT_FALSE(composed.is_loop_closure);
  ASSERT_TRUE(composed.has_information);
  Pose3 product;
  for (const RelativePoseEdge& e : steps) product = product * e.measured_from_T_to;
  EXPECT_LT((composed.measured_from_T_to.t_m - product.t_m).norm(), 1e-12);
  EXPECT_LT(composed.measured_from_T_to.q.angularDistance(product.q), 1e-12);

  // The covariance against first-order propagation with Jacobians by central differences: sum_k J_k C_k J_k^T.
  Matrix6d expected = Matrix6d::Zero();
  constexpr double kStep = 1e-6;
  for (std::size_t k = 0; k < steps.size(); ++k) {
    Matrix6d jacobian;
    for (int i = 0; i < 6; ++i) {
      Vector6d plus = Vector6d::Zero(), minus = Vector6d::Zero();
      plus[i] = kStep;
      minus[i] = -kStep;
      Pose3 a, b;
      for (std::size_t j = 0; j < steps.size(); ++j) {
        a = a * (j == k ? perturbed(steps[j].measured_from_T_to, plus) : steps[j].measured_from_T_to);
        b = b * (j == k ? perturbed(steps[j].measured_from_T_to, minus) : steps[j].measured_from_T_to);
      }
      jacobian.col(i) = (residual(product, a) - residual(product, b)) / (2.0 * kStep);
    }
    expected += jacobian * covariances[k] * jacobian.transpose();
  }
  const Matrix6d got = composed.information.inverse();
  EXPECT_LT((got - expected).norm(), 1e-6 * expected.norm()) << "got\n" << got << "\nexpected\n" << expected;
  // Summing the covariances without the adjoint (no lever arm) is far off: the check can fail.
  Matrix6d summed = Matrix6d::Zero();
  for (const Matrix6d& c : covariances) summed += c;
  EXPECT_GT((summed - expected).norm(), 0.1 * expected.norm());
}

// Three laps of a 6 m square in 0.5 m steps; the odometry's yaw drifts 0.5 degree per step.
struct Laps {
  std::vector<Eigen::Isometry3d> truth;
  std::vector<Pose3> odometry;
};
Laps three_laps() {
  Laps l;
  Eigen::Isometry3d est = Eigen::Isometry3d::Identity(), prev = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d corner[4] = {{0, 0, 0}, {6, 0, 0}, {6, 6, 0}, {0, 6, 0}};
  for (int lap = 0; lap < 3; ++lap)
    for (int side = 0; side < 4; ++side)
      for (int k = 0; k < 12; ++k) {
        const double yaw = side * M_PI / 2;
        const Eigen::Vector3d p =
            corner[side] + 0.5 * k * (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::Vector3d::UnitX());
        const Eigen::Isometry3d t = testing::planar(p.x(), p.y(), yaw);
        if (!l.truth.empty()) {
          Eigen::Isometry3d step = prev.inverse() * t;
          step.linear() =
              Eigen::AngleAxisd(0.5 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() * step.linear();
          est = est * step;
        }
        prev = t;
        l.truth.push_back(t);
        l.odometry.push_back(Pose3{est.translation(), Eigen::Quaterniond(est.linear())});
      }
  return l;
}

RelativePoseEdge closure(const Laps& l, std::uint32_t a, std::uint32_t b) {
  const Eigen::Isometry3d a_T_b = l.truth[a].inverse() * l.truth[b];
  RelativePoseEdge e;
  e.from = a;
  e.to = b;
  e.measured_from_T_to = Pose3{a_T_b.translation(), Eigen::Quaterniond(a_T_b.linear())};
  e.is_loop_closure = true;
  return e;
}

// The walk's own noise model: per 0.5 m step 0.01 m and 0.011 rad of yaw (the drift is half a sigma per step).
DeformationConfig laps_config() {
  DeformationConfig c;
  c.agents.sigma_t_m_per_sqrt_m = std::sqrt(1e-4 / 0.5);
  c.agents.sigma_yaw_rad_per_sqrt_m = std::sqrt(1.2e-4 / 0.5);
  return c;
}

// The chain's odometry (per distance, the walk's own noise) then the closures: right ones from the second and third
// laps to the first, and one wrong one (two places 1.5 m apart taken for the same).
std::vector<RelativePoseEdge> laps_edges(const Laps& l, const AgentGraphConfig& config, std::size_t* wrong) {
  std::vector<RelativePoseEdge> edges;
  for (std::uint32_t k = 0; k + 1 < l.odometry.size(); ++k)
    edges.push_back(per_distance_odometry_edge(k, k + 1, l.odometry[k], l.odometry[k + 1], 0.5, config));
  for (std::uint32_t b = 50; b < l.odometry.size(); b += 7) edges.push_back(closure(l, b % 48, b));
  *wrong = edges.size();
  RelativePoseEdge bad = closure(l, 20, 70);
  bad.measured_from_T_to.t_m += Eigen::Vector3d(1.2, -0.9, 0.0);
  edges.push_back(bad);
  for (std::uint32_t b = 53; b < l.odometry.size(); b += 11) edges.push_back(closure(l, b % 48, b));
  return edges;
}

TEST(ReducedDecisionsTest, TheReducedGraphKeepsTheClosuresAgentsAndTheEnds) {
  const Laps l = three_laps();
  const DeformationConfig config = laps_config();
  std::size_t wrong = 0;
  const std::vector<RelativePoseEdge> edges = laps_edges(l, config.agents, &wrong);
  const std::size_t chain = l.odometry.size() - 1;
  ReducedAgentGraph g;
  ASSERT_TRUE(reduce_agent_graph(l.odometry.size(), edges, chain, &g));
  std::vector<char> expect(l.odometry.size(), 0);
  expect.front() = expect.back() = 1;
  for (std::size_t k = chain; k < edges.size(); ++k) expect[edges[k].from] = expect[edges[k].to] = 1;
  std::vector<std::uint32_t> kept;
  for (std::uint32_t k = 0; k < expect.size(); ++k)
    if (expect[k]) kept.push_back(k);
  EXPECT_EQ(g.kept, kept);
  EXPECT_LT(g.kept.size(), l.odometry.size() / 2);
  ASSERT_EQ(g.edges.size(), kept.size() - 1 + edges.size() - chain);
  for (std::size_t j = 0; j + 1 < kept.size(); ++j) {  // the composed odometry spans consecutive kept agents
    EXPECT_EQ(g.edges[j].from, j);
    EXPECT_EQ(g.edges[j].to, j + 1);
    const Pose3 odometric = between(l.odometry[kept[j]], l.odometry[kept[j + 1]]);
    EXPECT_LT((g.edges[j].measured_from_T_to.t_m - odometric.t_m).norm(), 1e-9);
  }
  for (std::size_t k = chain; k < edges.size(); ++k) {  // every closure, between its agents' reduced nodes
    ASSERT_GE(g.edge_index[k], 0);
    const RelativePoseEdge& e = g.edges[static_cast<std::size_t>(g.edge_index[k])];
    EXPECT_EQ(kept[e.from], edges[k].from);
    EXPECT_EQ(kept[e.to], edges[k].to);
  }
  // Not a chain: the first edges must join k and k + 1.
  std::vector<RelativePoseEdge> broken = edges;
  broken[3].to = 5;
  EXPECT_FALSE(reduce_agent_graph(l.odometry.size(), broken, chain, &g));
}

TEST(ReducedDecisionsTest, AWrongClosureAmongRightOnesIsRejectedAsOnTheWholeChain) {
  const Laps l = three_laps();
  const DeformationConfig config = laps_config();  // the shipped solver: GNC-TLS at 5 sigma
  const PoseGraphConfig& solver = config.agents.solver;
  std::size_t wrong = 0;
  const std::vector<RelativePoseEdge> edges = laps_edges(l, config.agents, &wrong);
  const std::size_t chain = l.odometry.size() - 1;

  std::vector<Pose3> whole = l.odometry;
  const PoseGraphResult full = optimize_pose_graph(solver, whole, edges);
  ASSERT_TRUE(full.poses_updated()) << full.message;

  ReducedDecision d;
  ASSERT_TRUE(decide_on_reduced_graph(solver, l.odometry, edges, chain, &d));
  ASSERT_TRUE(d.decide.poses_updated()) << d.decide.message;
  EXPECT_GT(d.decide.gnc_outer_iterations, 0) << "the wrong closure must make GNC anneal";
  ASSERT_EQ(d.decide.edge_weight.size(), edges.size());
  std::size_t right = 0;
  for (std::size_t k = chain; k < edges.size(); ++k) {
    EXPECT_EQ(d.decide.edge_weight[k], full.edge_weight[k]) << "closure " << k - chain;
    if (k == wrong) EXPECT_EQ(d.decide.edge_weight[k], 0.0) << "the wrong closure";
    else right += d.decide.edge_weight[k] == 1.0 ? 1 : 0;
  }
  EXPECT_EQ(right, edges.size() - chain - 1) << "every right closure kept";

  std::vector<Pose3> agents = l.odometry;
  chain_with_decisions(solver, edges, &d, &agents);
  ASSERT_TRUE(d.chain.poses_updated()) << d.chain.message;
  double worst = 0.0, error = 0.0, drift = 0.0;
  for (std::size_t k = 0; k < agents.size(); ++k) {
    worst = std::max(worst, (agents[k].t_m - whole[k].t_m).norm());
    error = std::max(error, (agents[k].t_m - l.truth[k].translation()).norm());
    drift = std::max(drift, (l.odometry[k].t_m - l.truth[k].translation()).norm());
  }
  EXPECT_LT(worst, 1e-3) << "the chain with the decisions lands where the whole chain's GNC does";
  EXPECT_LT(error, 0.1 * drift);
}

}  // namespace
}  // namespace qsg::backend
