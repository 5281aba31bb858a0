// Tests of the weighted chordal initialization: a global estimate of a pose graph from its measurements alone.
#include "core/backend/chordal_init.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include "core/backend/pose_graph.h"

namespace qsg::backend {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A helix of poses turning 30 degrees a step, rolling and pitching a little: nothing planar for the estimate to lean
// on.
std::vector<Pose3> helix(std::uint32_t n) {
  std::vector<Pose3> poses;
  for (std::uint32_t i = 0; i < n; ++i) {
    const double a = kPi / 6.0 * i;
    Pose3 p;
    p.t_m = Eigen::Vector3d(3.0 * std::cos(a), 3.0 * std::sin(a), 0.2 * i);
    p.q = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(0.1 * std::sin(i), Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(0.05 * i, Eigen::Vector3d::UnitY());
    poses.push_back(p);
  }
  return poses;
}

RelativePoseEdge edge(const std::vector<Pose3>& truth, std::uint32_t from, std::uint32_t to, bool loop_closure) {
  RelativePoseEdge e;
  e.from = from;
  e.to = to;
  e.measured_from_T_to = between(truth[from], truth[to]);
  e.is_loop_closure = loop_closure;
  return e;
}

// Odometry along the helix and a closure every fifth pose back to three before (a ring of constraints).
std::vector<RelativePoseEdge> helix_edges(const std::vector<Pose3>& truth) {
  std::vector<RelativePoseEdge> edges;
  for (std::uint32_t i = 0; i + 1 < truth.size(); ++i) edges.push_back(edge(truth, i, i + 1, false));
  for (std::uint32_t i = 5; i < truth.size(); i += 5) edges.push_back(edge(truth, i - 3, i, true));
  return edges;
}

// Every pose at the origin, unrotated, except the anchor: nothing to start from.
std::vector<Pose3> no_guess(const std::vector<Pose3>& truth) {
  std::vector<Pose3> poses(truth.size());
  poses[0] = truth[0];
  return poses;
}

double max_error_m(const std::vector<Pose3>& a, const std::vector<Pose3>& b) {
  double e = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) e = std::max(e, (a[i].t_m - b[i].t_m).norm());
  return e;
}
double max_error_rad(const std::vector<Pose3>& a, const std::vector<Pose3>& b) {
  double e = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) e = std::max(e, a[i].q.angularDistance(b[i].q));
  return e;
}

// Gaussian noise of `sigma` (metres and radians) on every axis of every measurement.
void add_noise(double sigma, std::mt19937* rng, std::vector<RelativePoseEdge>* edges) {
  std::normal_distribution<double> noise(0.0, sigma);
  for (RelativePoseEdge& e : *edges) {
    // One draw per statement: argument evaluation order differs between GCC and clang.
    Eigen::Vector3d dt, w;
    for (int k = 0; k < 3; ++k) dt[k] = noise(*rng);
    for (int k = 0; k < 3; ++k) w[k] = noise(*rng);
    e.measured_from_T_to.t_m += dt;
    e.measured_from_T_to.q = e.measured_from_T_to.q * Eigen::AngleAxisd(w.norm(), w.normalized());
  }
}

TEST(ChordalInit, RecoversAConsistentGraphWithoutAGuess) {
  const std::vector<Pose3> truth = helix(40);
  const std::vector<RelativePoseEdge> edges = helix_edges(truth);
  std::vector<Pose3> poses = no_guess(truth);
  std::vector<bool> anchored(truth.size(), false);
  anchored[0] = true;
  ASSERT_TRUE(chordal_initialize(edges, std::vector<double>(edges.size(), 1.0), anchored, &poses));
  EXPECT_LT(max_error_m(poses, truth), 1e-6);
  EXPECT_LT(max_error_rad(poses, truth), 1e-6);
}

// A wrong closure at weight 0 changes nothing; at weight 1 it bends the estimate (else this tests nothing).
TEST(ChordalInit, AnEdgeAtWeightZeroIsIgnored) {
  const std::vector<Pose3> truth = helix(40);
  std::vector<RelativePoseEdge> edges = helix_edges(truth);
  RelativePoseEdge wrong = edge(truth, 4, 30, true);
  wrong.measured_from_T_to.t_m += Eigen::Vector3d(2.0, -1.0, 0.5);
  wrong.measured_from_T_to.q = wrong.measured_from_T_to.q * Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitX());
  edges.push_back(wrong);
  std::vector<bool> anchored(truth.size(), false);
  anchored[0] = true;
  std::vector<double> weights(edges.size(), 1.0);
  std::vector<Pose3> bent = no_guess(truth);
  ASSERT_TRUE(chordal_initialize(edges, weights, anchored, &bent));
  EXPECT_GT(max_error_m(bent, truth), 0.1);
  weights.back() = 0.0;
  std::vector<Pose3> poses = no_guess(truth);
  ASSERT_TRUE(chordal_initialize(edges, weights, anchored, &poses));
  EXPECT_LT(max_error_m(poses, truth), 1e-6);
}

// Anchors keep their values; a pose that only a switched-off edge reaches stays where it was; without any anchor the
// gauge is free and the call refuses, leaving the poses as they were.
TEST(ChordalInit, AnchorsHoldAndUnreachedPosesStay) {
  const std::vector<Pose3> truth = helix(12);
  std::vector<RelativePoseEdge> edges = helix_edges(truth);
  std::vector<double> weights(edges.size(), 1.0);
  weights[10] = 0.0;  // odometry 10 -> 11: pose 11 is reached by nothing else
  std::vector<bool> anchored(truth.size(), false);
  anchored[0] = true;
  anchored[6] = true;
  std::vector<Pose3> poses = no_guess(truth);
  poses[6] = truth[6];
  poses[11].t_m = Eigen::Vector3d(7.0, 8.0, 9.0);
  ASSERT_TRUE(chordal_initialize(edges, weights, anchored, &poses));
  EXPECT_LT((poses[6].t_m - truth[6].t_m).norm(), 1e-12);
  EXPECT_LT((poses[5].t_m - truth[5].t_m).norm(), 1e-6);
  EXPECT_LT((poses[11].t_m - Eigen::Vector3d(7.0, 8.0, 9.0)).norm(), 1e-6);

  std::vector<Pose3> free_gauge = no_guess(truth);
  const std::vector<Pose3> before = free_gauge;
  EXPECT_FALSE(chordal_initialize(edges, weights, std::vector<bool>(truth.size(), false), &free_gauge));
  EXPECT_EQ(max_error_m(free_gauge, before), 0.0);
  EXPECT_FALSE(chordal_initialize(edges, std::vector<double>(3, 1.0), anchored, &free_gauge)) << "weights per edge";
}

// Noisy measurements (1 cm and 0.6 degrees a step on every axis): the estimate lands near the least-squares solution,
// a start for the nonlinear solve in its basin.
TEST(ChordalInit, NoisyMeasurementsLandNearTheLeastSquaresSolution) {
  const std::vector<Pose3> truth = helix(40);
  std::vector<RelativePoseEdge> edges = helix_edges(truth);
  std::mt19937 rng(5u);
  add_noise(0.01, &rng, &edges);
  PoseGraphConfig plain;
  plain.loop_closure_loss = RobustLoss::kNone;
  plain.function_tolerance = 1e-12;
  std::vector<Pose3> solution = truth;
  ASSERT_TRUE(optimize_pose_graph(plain, solution, edges).poses_updated());
  std::vector<Pose3> poses = no_guess(truth);
  std::vector<bool> anchored(truth.size(), false);
  anchored[0] = true;
  ASSERT_TRUE(chordal_initialize(edges, std::vector<double>(edges.size(), 1.0), anchored, &poses));
  std::printf(
      "[ chordal ] noisy helix: estimate %.4f m, %.4f rad from the least-squares solution, which is %.3f m "
      "from the truth\n",
      max_error_m(poses, solution), max_error_rad(poses, solution), max_error_m(solution, truth));
  EXPECT_GT(max_error_m(solution, truth), 0.1) << "the noise must move the solution, else this tests nothing";
  EXPECT_LT(max_error_m(poses, solution), 0.05);
  EXPECT_LT(max_error_rad(poses, solution), 0.01);
}

// The iterative solver lands where the direct one does, on the noisy helix with as many random wrong closures
// weighted as right edges (the case it is for) and on the helix alone, both weightings.
TEST(ChordalInit, ConjugateGradientsMatchTheDirectSolve) {
  const std::vector<Pose3> truth = helix(60);
  std::vector<RelativePoseEdge> edges = helix_edges(truth);
  std::mt19937 rng(9u);
  add_noise(0.01, &rng, &edges);
  std::vector<RelativePoseEdge> corrupt = edges;
  std::uniform_int_distribution<std::uint32_t> pick(0, static_cast<std::uint32_t>(truth.size() - 1));
  std::uniform_real_distribution<double> offset(-5.0, 5.0);
  while (corrupt.size() < 2 * edges.size()) {
    std::uint32_t a = pick(rng), b = pick(rng);
    if (a > b) std::swap(a, b);
    if (b - a < 2) continue;
    RelativePoseEdge e;
    e.from = a;
    e.to = b;
    e.is_loop_closure = true;
    e.measured_from_T_to.t_m = Eigen::Vector3d(offset(rng), offset(rng), offset(rng));
    e.measured_from_T_to.q =
        Eigen::AngleAxisd(offset(rng), Eigen::Vector3d(offset(rng), offset(rng), 1.0).normalized());
    corrupt.push_back(e);
  }
  std::vector<bool> anchored(truth.size(), false);
  anchored[0] = true;
  for (const std::vector<RelativePoseEdge>* graph : {&edges, &corrupt}) {
    for (const ChordalWeighting weighting : {ChordalWeighting::kIsotropic, ChordalWeighting::kAnisotropic}) {
      const std::vector<double> weights(graph->size(), 1.0);
      std::vector<Pose3> direct = no_guess(truth), iterative = no_guess(truth);
      ASSERT_TRUE(chordal_initialize(*graph, weights, anchored, &direct, weighting, ChordalSolver::kDirect));
      ChordalStats stats;
      ASSERT_TRUE(
          chordal_initialize(*graph, weights, anchored, &iterative, weighting, ChordalSolver::kIterative, &stats));
      EXPECT_GT(stats.systems, 1);
      EXPECT_EQ(stats.iterative, stats.systems) << "conjugate gradients must converge here, else this tests nothing";
      EXPECT_EQ(stats.direct_fallbacks, 0);
      EXPECT_LT(max_error_m(direct, iterative), 1e-6) << graph->size() << " edges";
      EXPECT_LT(max_error_rad(direct, iterative), 1e-7) << graph->size() << " edges";
      EXPECT_GT(max_error_m(direct, no_guess(truth)), 1.0) << "the estimate must move the poses";
    }
  }
}

// The iterative solver's preconditioner keeps whole the edges between poses near each other in the numbering and a
// spanning tree. On a graph that is a tree (odometry alone, each edge sure of some axes and vague on others, as
// cubicle's) it is the system itself: conjugate gradients stop after an iteration or two a column, where a
// diagonal preconditioner needs about as many as the chain is long. So too when the poses are numbered out of
// the trajectory's order (the spanning tree finds the chain), and one closure more across the chain costs only a
// few iterations.
TEST(ChordalInit, OnATreeTheIterativeSolversPreconditionerIsTheSystem) {
  const std::vector<Pose3> truth = helix(400);
  std::vector<RelativePoseEdge> chain;
  for (std::uint32_t i = 0; i + 1 < truth.size(); ++i) {
    RelativePoseEdge e = edge(truth, i, i + 1, false);
    e.sigma_t_m = Eigen::Vector3d(0.5, 0.5, 0.001);
    e.sigma_rot_rad = Eigen::Vector3d(0.001, 0.001, 0.2);
    chain.push_back(e);
  }
  std::mt19937 rng(4u);
  add_noise(0.01, &rng, &chain);
  std::vector<RelativePoseEdge> closed = chain;
  closed.push_back(edge(truth, 10, 390, true));
  // The chain renumbered at random (pose 0, the anchor, kept).
  std::vector<std::uint32_t> order(truth.size());
  for (std::uint32_t i = 0; i < order.size(); ++i) order[i] = i;
  std::shuffle(order.begin() + 1, order.end(), rng);
  std::vector<RelativePoseEdge> shuffled = chain;
  for (RelativePoseEdge& e : shuffled) {
    e.from = order[e.from];
    e.to = order[e.to];
  }
  std::vector<bool> anchored(truth.size(), false);
  anchored[0] = true;
  for (const std::vector<RelativePoseEdge>* graph : {&chain, &closed, &shuffled}) {
    const std::vector<double> weights(graph->size(), 1.0);
    std::vector<Pose3> direct = no_guess(truth), iterative = no_guess(truth);
    ASSERT_TRUE(chordal_initialize(*graph, weights, anchored, &direct));
    ChordalStats stats;
    ASSERT_TRUE(chordal_initialize(*graph, weights, anchored, &iterative, ChordalWeighting::kAnisotropic,
                                   ChordalSolver::kIterative, &stats));
    const long long columns = stats.systems + 2;  // the rotation relaxation solves 3 columns
    std::printf("[ chordal ] %zu edges: %d systems, %lld conjugate-gradient iterations\n", graph->size(), stats.systems,
                stats.iterations);
    EXPECT_EQ(stats.iterative, stats.systems);
    EXPECT_LE(stats.iterations, (graph == &closed ? 12 : 2) * columns);
    // Poses up to 80 m from the anchor: a relative residual of 1e-10 leaves micrometres.
    EXPECT_LT(max_error_m(direct, iterative), 1e-5);
    EXPECT_LT(max_error_rad(direct, iterative), 1e-7);
  }
}

// A planar robot in the way cubicle.g2o states its edges: odometry sure of height, roll and pitch (it knows it drives
// on a floor) and vague in x, y and heading; closures (scan matches) the reverse. Noise drawn to match, at a fifth of
// the stated sigma as cubicle's residuals are (bench/results/pose_graph.md). The anisotropic estimate weighs each
// axis by the edge that knows it and lands near the least-squares solution (not on it: rotations and translations
// are solved apart); the isotropic one (each edge's mean precision) lets the odometry's sure axes lend it a heading
// it does not have.
TEST(ChordalInit, AnisotropicWeightsFollowEachAxisToTheEdgeThatKnowsIt) {
  using Vector6d = Eigen::Matrix<double, 6, 1>;
  std::vector<Pose3> truth;
  for (std::uint32_t i = 0; i < 48; ++i) {  // two laps of a 6 m square, 1 m steps, turning at the corners
    const std::uint32_t k = i % 24, side = k / 6, along = k % 6;
    const Eigen::Vector2d corner[4] = {{0, 0}, {6, 0}, {6, 6}, {0, 6}};
    const Eigen::Vector2d dir[4] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
    Pose3 p;
    const Eigen::Vector2d xy = corner[side] + static_cast<double>(along) * dir[side];
    p.t_m = Eigen::Vector3d(xy.x(), xy.y(), 0.0);
    p.q = Eigen::Quaterniond(Eigen::AngleAxisd(kPi / 2.0 * side, Eigen::Vector3d::UnitZ()));
    truth.push_back(p);
  }
  std::vector<RelativePoseEdge> edges;
  const auto add = [&](std::uint32_t a, std::uint32_t b, const Vector6d& info) {
    RelativePoseEdge e = edge(truth, a, b, b != a + 1);
    e.has_information = true;
    e.information = info.asDiagonal();
    edges.push_back(e);
  };
  Vector6d odometry, closure;
  odometry << 100, 100, 4e6, 1e6, 1e6, 6.25;
  closure << 1e6, 1e6, 10, 10, 10, 2.6e4;
  for (std::uint32_t i = 0; i + 1 < truth.size(); ++i) add(i, i + 1, odometry);
  for (std::uint32_t i = 0; i + 3 < truth.size(); ++i) {
    add(i, i + 2, closure);
    add(i, i + 3, closure);
  }
  for (std::uint32_t i = 24; i < truth.size(); i += 2) add(i - 24, i, closure);
  std::mt19937 rng(11u);
  std::normal_distribution<double> unit(0.0, 1.0);
  for (RelativePoseEdge& e : edges) {
    Vector6d n;
    for (int k = 0; k < 6; ++k) n[k] = 0.2 * unit(rng) / std::sqrt(e.information(k, k));
    const Eigen::Vector3d w = n.tail<3>();
    e.measured_from_T_to.t_m += e.measured_from_T_to.q * n.head<3>();  // the translation error is in the to frame
    e.measured_from_T_to.q = e.measured_from_T_to.q * Eigen::AngleAxisd(w.norm(), w.normalized());
  }
  PoseGraphConfig plain;
  plain.loop_closure_loss = RobustLoss::kNone;
  plain.function_tolerance = 1e-12;
  plain.max_iterations = 200;
  std::vector<Pose3> solution = truth;
  ASSERT_TRUE(optimize_pose_graph(plain, solution, edges).poses_updated());
  std::vector<bool> anchored(truth.size(), false);
  anchored[0] = true;
  const std::vector<double> weights(edges.size(), 1.0);
  std::vector<Pose3> anisotropic = no_guess(truth), isotropic = no_guess(truth);
  ASSERT_TRUE(chordal_initialize(edges, weights, anchored, &anisotropic, ChordalWeighting::kAnisotropic));
  ASSERT_TRUE(chordal_initialize(edges, weights, anchored, &isotropic, ChordalWeighting::kIsotropic));
  std::printf(
      "[ chordal ] planar, anisotropic edges: from the least-squares solution (%.4f m from the truth) the "
      "anisotropic estimate is %.4f m, %.4f rad, the isotropic one %.4f m, %.4f rad\n",
      max_error_m(solution, truth), max_error_m(anisotropic, solution), max_error_rad(anisotropic, solution),
      max_error_m(isotropic, solution), max_error_rad(isotropic, solution));
  EXPECT_LT(max_error_m(anisotropic, solution), 0.15);
  EXPECT_LT(max_error_rad(anisotropic, solution), 0.03);
  EXPECT_GT(max_error_m(isotropic, solution), 5.0 * max_error_m(anisotropic, solution));
  EXPECT_GT(max_error_rad(isotropic, solution), 5.0 * max_error_rad(anisotropic, solution));
}

}  // namespace
}  // namespace qsg::backend
