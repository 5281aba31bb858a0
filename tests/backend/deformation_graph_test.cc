// The embedded deformation graph: a drifted square loop with its mesh control points and places; one true loop
// closure must pull agents, control points, places and any interpolated point back towards the truth, and a wrong
// loop closure next to it must switch itself off.
#include "core/backend/deformation_graph.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "core/backend/deformation_io.h"
#include "tests/backend/planar_pose.h"
#include "tests/scene_graph/test_graph.h"

namespace qsg::backend {
namespace {

using testing::planar;

// The map nodes' rotation prior of the tests below, and how far apart a loose and a tight stopping rule may land
// the hanging places without it (at least) and with it (at most).
constexpr double kPlaceSigmaRad = 0.3;
constexpr double kWithoutM = 0.05;
constexpr double kWithM = 0.02;

// A 6 m square walked once in 0.5 m steps; the odometry's yaw drifts 0.6 degree per step.
struct Walk {
  std::vector<Eigen::Isometry3d> truth, odometry;
};
Walk square_walk() {
  Walk w;
  Eigen::Isometry3d est = Eigen::Isometry3d::Identity(), prev = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d corner[4] = {{0, 0, 0}, {6, 0, 0}, {6, 6, 0}, {0, 6, 0}};
  for (int side = 0; side < 4; ++side)
    for (int k = 0; k < 12; ++k) {
      const double yaw = side * M_PI / 2;
      const Eigen::Vector3d p = corner[side] + 0.5 * k * (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::Vector3d::UnitX());
      const Eigen::Isometry3d t = planar(p.x(), p.y(), yaw);
      if (!w.truth.empty()) {
        Eigen::Isometry3d step = prev.inverse() * t;
        step.linear() = Eigen::AngleAxisd(0.6 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() * step.linear();
        est = est * step;
      }
      prev = t;
      w.truth.push_back(t);
      w.odometry.push_back(est);
    }
  return w;
}

class DeformationGraphTest : public ::testing::Test {
 protected:
  void SetUp() override {
    walk_ = square_walk();
    graph_ = scene_graph::testing::make_graph();
    agents::Config c;
    c.min_translation_m = 0.0;
    std::string error;
    ASSERT_TRUE(layer_.init(c, agents::Capacities{100}, &error)) << error;
    ASSERT_TRUE(control_.init(1000, 1.0, &error)) << error;
    for (std::size_t i = 0; i < walk_.odometry.size(); ++i) {
      Eigen::Matrix<double, 6, 1> variance;
      variance << 1e-4 * i, 1e-4 * i, 1e-6 * i, 1e-7 * i, 1e-7 * i, 1.2e-4 * i;  // yaw: the 0.6 degrees it drifts
      const std::uint64_t t = 1'000'000'000ull + 2'000'000'000ull * i;  // 0.25 m/s
      ASSERT_EQ(layer_.add_keyframe(graph_.get(), t, walk_.odometry[i], 0, variance), agents::AddResult::kAdded);
      // The wall 1.5 m to the robot's left, seen at this keyframe: a control point in the odometric frame.
      const Eigen::Vector3d wall(0.0, 1.5, 1.0);
      if (control_.offer(walk_.odometry[i] * wall, t))
        walls_.push_back({walk_.odometry[i] * wall, walk_.truth[i] * wall, t});
      // A place 0.7 m to the left every other keyframe, joined to the previous place and to the agent.
      if (i % 2 == 0) {
        scene_graph::PlaceAttributes p;
        p.position_m = walk_.odometry[i] * Eigen::Vector3d(0.0, 0.7, 0.0);
        p.last_update_time_ns = t;
        const scene_graph::NodeId id = scene_graph::make_node_id(scene_graph::kPlacePrefix, i);
        ASSERT_EQ(graph_->add_place(id, p), scene_graph::Status::kOk);
        places_.push_back({id, walk_.truth[i] * Eigen::Vector3d(0.0, 0.7, 0.0)});
        if (i > 0) graph_->add_edge(scene_graph::make_node_id(scene_graph::kPlacePrefix, i - 2), id);
        graph_->add_edge(layer_.chain(i).id, id);
      }
    }
    ASSERT_GT(walls_.size(), 10u);
  }
  ChainLoopClosure true_closure(std::uint32_t a, std::uint32_t b) const {
    const Eigen::Isometry3d a_T_b = walk_.truth[a].inverse() * walk_.truth[b];
    ChainLoopClosure c;
    c.a = a;
    c.b = b;
    c.a_T_b = Pose3{a_T_b.translation(), Eigen::Quaterniond(a_T_b.linear())};
    return c;
  }
  double agent_rmse(const DeformationGraph& d) const {
    double sum = 0.0;
    for (std::size_t k = 0; k < walk_.truth.size(); ++k) {
      const Eigen::Vector3d p = d.solved() ? d.agent_pose(k).t_m : walk_.odometry[k].translation();
      sum += (p - walk_.truth[k].translation()).squaredNorm();
    }
    return std::sqrt(sum / static_cast<double>(walk_.truth.size()));
  }
  double wall_rmse(const DeformationGraph& d) const {
    double sum = 0.0;
    for (const Wall& w : walls_) sum += (d.deform(w.odom, w.time_ns) - w.truth).squaredNorm();
    return std::sqrt(sum / static_cast<double>(walls_.size()));
  }

  Walk walk_;
  std::unique_ptr<scene_graph::SceneGraph> graph_;
  agents::AgentLayer layer_;
  ControlPoints control_;
  struct Wall {
    Eigen::Vector3d odom, truth;
    std::uint64_t time_ns;
  };
  std::vector<Wall> walls_;
  std::vector<std::pair<scene_graph::NodeId, Eigen::Vector3d>> places_;
};

// Both ways of deciding the loop closures (DeformationConfig::decide_on_agents) must pass every test below.
// The odometry edges' model is the walk's own: per 0.5 m step a variance of 1e-4 m^2 and 1.2e-4 rad^2 of yaw (the
// variance the fixture reports), i.e. 0.014 m and 0.0155 rad per sqrt(m) for the per-distance weighting.
DeformationConfig strategy(bool decide_on_agents) {
  DeformationConfig c;
  c.decide_on_agents = decide_on_agents;
  c.agents.sigma_t_m_per_sqrt_m = std::sqrt(1e-4 / 0.5);
  c.agents.sigma_yaw_rad_per_sqrt_m = std::sqrt(1.2e-4 / 0.5);
  return c;
}

TEST_F(DeformationGraphTest, ATrueLoopClosureCorrectsEveryLayer) {
  for (bool on_agents : {true, false}) {
  SCOPED_TRACE(on_agents ? "decided on the agent layer" : "GNC over the whole graph");
  DeformationGraph d(strategy(on_agents));
  const double agents_before = agent_rmse(d), walls_before = wall_rmse(d);
  ASSERT_GT(agents_before, 0.4) << "the test needs visible drift";
  const auto last = static_cast<std::uint32_t>(walk_.truth.size() - 1);
  const DeformationResult r = d.optimize(layer_, {true_closure(0, last)}, control_, *graph_);
  ASSERT_TRUE(r.solve.poses_updated()) << r.solve.message;
  EXPECT_EQ(r.agents, walk_.truth.size());
  EXPECT_EQ(r.control_points, walls_.size());
  EXPECT_EQ(r.places, places_.size());
  EXPECT_EQ(r.edges_am, walls_.size());
  EXPECT_EQ(r.edges_pp, places_.size() - 1) << "a spanning tree of the place chain";
  EXPECT_EQ(r.edges_ap, places_.size());
  EXPECT_GT(r.edges_mm, 0u);
  EXPECT_EQ(r.loop_closures_kept, 1u);
  EXPECT_LT(agent_rmse(d), 0.3 * agents_before);
  EXPECT_LT(wall_rmse(d), 0.3 * walls_before) << "control points and what they carry follow the agents";
  double places_before = 0.0, places_after = 0.0;
  for (const auto& [id, truth] : places_) {
    Eigen::Vector3d p;
    ASSERT_TRUE(d.place_position(id, &p));
    places_before += (graph_->place(id)->position_m - truth).squaredNorm();
    places_after += (p - truth).squaredNorm();
  }
  EXPECT_LT(places_after, 0.09 * places_before);
  }
}

TEST_F(DeformationGraphTest, AWrongLoopClosureSwitchesItselfOff) {
  for (bool on_agents : {true, false}) {
  SCOPED_TRACE(on_agents ? "decided on the agent layer" : "GNC over the whole graph");
  DeformationGraph d(strategy(on_agents));
  const double agents_before = agent_rmse(d);
  const auto last = static_cast<std::uint32_t>(walk_.truth.size() - 1);
  ChainLoopClosure wrong = true_closure(10, 30);
  wrong.a_T_b = Pose3{Eigen::Vector3d(0.5, 0.2, 0.0), Eigen::Quaterniond::Identity()};  // "the same place": it is not
  // Three views of the start from the end (a revisit proposes several), and one wrong closure among them.
  const DeformationResult r =
      d.optimize(layer_, {true_closure(0, last), true_closure(1, last), wrong, true_closure(0, last - 1)}, control_,
                 *graph_);
  ASSERT_TRUE(r.solve.poses_updated()) << r.solve.message;
  ASSERT_EQ(r.loop_closure_weight.size(), 4u);
  EXPECT_GT(r.loop_closure_weight[0], 0.5);
  EXPECT_GT(r.loop_closure_weight[1], 0.5);
  EXPECT_LT(r.loop_closure_weight[2], 0.5) << "the wrong one";
  EXPECT_GT(r.loop_closure_weight[3], 0.5);
  EXPECT_EQ(r.loop_closures_kept, 3u);
  EXPECT_LT(agent_rmse(d), 0.3 * agents_before);
  EXPECT_LT(wall_rmse(d), 0.3 * wall_rmse(DeformationGraph{})) << "the mesh follows, whichever way was decided";
  }
}

// A problem written to a file reads back equal, and solves to the same poses (bench/loop_closure/dg_solve).
TEST_F(DeformationGraphTest, AProblemFileReadsBackAndSolvesTheSame) {
  DeformationGraph d;
  const auto last = static_cast<std::uint32_t>(walk_.truth.size() - 1);
  ChainLoopClosure named = true_closure(0, last);
  named.id = 4'000'000'001ull;
  const DeformationProblem problem = d.build(layer_, {named}, control_, *graph_);
  std::vector<Eigen::Vector3d> truth;
  std::vector<Eigen::Quaterniond> truth_q;
  for (const Eigen::Isometry3d& t : walk_.truth) {
    truth.push_back(t.translation());
    truth_q.push_back(Eigen::Quaterniond(t.linear()));
  }
  const std::string path = ::testing::TempDir() + "/deformation_problem.txt";
  std::string error;
  ASSERT_TRUE(write_deformation_problem(path, problem, truth, &error)) << error;  // positions only
  DeformationProblemFile read;
  ASSERT_TRUE(read_deformation_problem(path, &read, &error)) << error;
  EXPECT_TRUE(read.truth_q.empty());
  ASSERT_TRUE(write_deformation_problem(path, problem, truth, &error, truth_q)) << error;  // and orientations
  ASSERT_TRUE(read_deformation_problem(path, &read, &error)) << error;
  ASSERT_EQ(read.truth_q.size(), truth.size());
  for (std::size_t k = 0; k < truth.size(); ++k) {
    EXPECT_EQ(read.truth_m[k], truth[k]) << k;
    EXPECT_LT(read.truth_q[k].angularDistance(truth_q[k]), 1e-12) << k;
  }
  ASSERT_EQ(read.problem.poses.size(), problem.poses.size());
  ASSERT_EQ(read.problem.edges.size(), problem.edges.size());
  ASSERT_FALSE(problem.place_ids.empty());
  EXPECT_EQ(read.problem.place_ids, problem.place_ids) << "places keep their node ids (dg_sequence matches by them)";
  // Agents keep their times and closures their ids: a sequence of solves read back carries decisions by them.
  ASSERT_EQ(problem.closure_ids, std::vector<std::uint64_t>{named.id});
  EXPECT_EQ(read.problem.closure_ids, problem.closure_ids);
  ASSERT_EQ(problem.agent_times_ns.size(), problem.result.agents);
  EXPECT_EQ(read.problem.agent_times_ns, problem.agent_times_ns);
  EXPECT_EQ(read.problem.first_closure, problem.first_closure);
  EXPECT_EQ(read.truth_m.size(), truth.size());
  for (std::size_t k = 0; k < problem.poses.size(); ++k) {
    EXPECT_EQ(read.problem.poses[k].t_m, problem.poses[k].t_m) << k;
    EXPECT_EQ(read.problem.poses[k].q.coeffs(), problem.poses[k].q.coeffs()) << k;
  }
  for (std::size_t k = 0; k < problem.edges.size(); ++k) {
    EXPECT_EQ(read.problem.edges[k].from, problem.edges[k].from);
    EXPECT_EQ(read.problem.edges[k].to, problem.edges[k].to);
    EXPECT_EQ(read.problem.edges[k].has_information, problem.edges[k].has_information);
    EXPECT_EQ(read.problem.edges[k].measured_from_T_to.t_m, problem.edges[k].measured_from_T_to.t_m);
    EXPECT_EQ(read.problem.edges[k].measured_from_T_to.q.coeffs(), problem.edges[k].measured_from_T_to.q.coeffs()) << k;
    EXPECT_EQ(read.problem.edges[k].is_loop_closure, problem.edges[k].is_loop_closure);
    EXPECT_EQ(read.problem.edges[k].information, problem.edges[k].information);
  }
  DeformationGraph a, b;
  const DeformationResult ra = a.solve(problem), rb = b.solve(read.problem);
  ASSERT_TRUE(ra.solve.poses_updated() && rb.solve.poses_updated());
  for (std::size_t k = 0; k < ra.agents; ++k) EXPECT_LT((a.agent_pose(k).t_m - b.agent_pose(k).t_m).norm(), 1e-9);

  // Malformed: named by line, never a crash.
  std::ofstream(path) << "qsg_deformation_problem 1\nsizes 2 0 0 1 5 1 0\n";
  EXPECT_FALSE(read_deformation_problem(path, &read, &error));
  EXPECT_NE(error.find(":2:"), std::string::npos) << error;
  std::ofstream(path) << "qsg_deformation_problem 1\nsizes 2 0 0 1 0 1 0\np 0 0 0 0 0 0 1\np 1 0 0 0 0 0 1\n"
                         "e 0 7 0 0 1 0 0 0 0 0 1 1 1 1 1 1 1\n";
  EXPECT_FALSE(read_deformation_problem(path, &read, &error));
  EXPECT_NE(error.find("in range"), std::string::npos) << error;
  std::ofstream(path) << "qsg_deformation_problem 1\nsizes 2 0 0 1 0 1 1\np 0 0 0 0 0 0 1\np 1 0 0 0 0 0 1\n"
                         "e 0 1 0 0 1 0 0 0 0 0 1 1 1 1 1 1 1\nt 0 0 0 0 0 0 1\nt 1 0 0\n";
  EXPECT_FALSE(read_deformation_problem(path, &read, &error));
  EXPECT_NE(error.find("every truth line or none"), std::string::npos) << error;
  std::ofstream(path) << "qsg_deformation_problem 1\nsizes 2 0 0 1 0 1 0\np 0 0 0 0 0 0 1 5\np 1 0 0 0 0 0 1\n"
                         "e 0 1 0 0 1 0 0 0 0 0 1 1 1 1 1 1 1\n";
  EXPECT_FALSE(read_deformation_problem(path, &read, &error));
  EXPECT_NE(error.find("every agent line or none"), std::string::npos) << error;
  std::ofstream(path) << "qsg_deformation_problem 1\nsizes 2 0 0 1 2 3 0\np 0 0 0 0 0 0 1\np 1 0 0 0 0 0 1\n"
                         "e 0 1 0 0 1 0 0 0 0 0 1 1 1 1 1 1 1\ne 0 1 1 0 1 0 0 0 0 0 1 1 1 1 1 1 1 7\n"
                         "e 0 1 1 0 1 0 0 0 0 0 1 1 1 1 1 1 1\n";
  EXPECT_FALSE(read_deformation_problem(path, &read, &error));
  EXPECT_NE(error.find("every loop closure line or none"), std::string::npos) << error;
}

// build() keeps the control-point edges of points past the time horizon from one build to the next: a graph that
// built before gives exactly the problem a fresh one builds, as the points grow, and when the set is replaced.
TEST_F(DeformationGraphTest, ABuildThatReusesTheLastOnesEdgesBuildsTheSameProblem) {
  const auto same = [](const DeformationProblem& a, const DeformationProblem& b) {
    ASSERT_EQ(a.edges.size(), b.edges.size());
    EXPECT_EQ(a.result.edges_mm, b.result.edges_mm);
    for (std::size_t e = 0; e < a.edges.size(); ++e) {
      EXPECT_EQ(a.edges[e].from, b.edges[e].from) << e;
      EXPECT_EQ(a.edges[e].to, b.edges[e].to) << e;
      EXPECT_EQ(a.edges[e].measured_from_T_to.t_m, b.edges[e].measured_from_T_to.t_m) << e;
    }
  };
  DeformationGraph reused;
  ControlPoints growing;
  std::string error;
  ASSERT_TRUE(growing.init(1000, 1.0, &error)) << error;
  std::size_t offered = 0, builds = 0;
  for (std::size_t until : {walls_.size() / 3, walls_.size() / 2, walls_.size()}) {
    for (; offered < until; ++offered) ASSERT_TRUE(growing.offer(walls_[offered].odom, walls_[offered].time_ns));
    const DeformationProblem a = reused.build(layer_, {true_closure(2, 40)}, growing, *graph_);
    const DeformationProblem b = DeformationGraph().build(layer_, {true_closure(2, 40)}, growing, *graph_);
    ASSERT_GT(a.result.edges_mm, 0u);
    same(a, b);
    ++builds;
  }
  // Another set of control points (the walls 0.3 m off): the kept edges do not apply, and are not used.
  ControlPoints other;
  ASSERT_TRUE(other.init(1000, 1.0, &error)) << error;
  for (const Wall& w : walls_) other.offer(w.odom + Eigen::Vector3d(0.3, 0.0, 0.0), w.time_ns);
  ASSERT_GT(other.size(), 10u);
  same(reused.build(layer_, {}, other, *graph_), DeformationGraph().build(layer_, {}, other, *graph_));
  EXPECT_EQ(builds, 3u);
}

// The app copies the chain, the control points and the places under the graph lock and builds from the copy
// without it: the copy must build the live state's problem, whatever the loop thread does to the live state after
// it, and must not allocate once reserved for the stores it copies.
TEST_F(DeformationGraphTest, AProblemBuiltFromACopyIsTheLiveStatesAtTheCopy) {
  const std::vector<ChainLoopClosure> closures = {true_closure(2, 40)};
  const DeformationProblem live = DeformationGraph().build(layer_, closures, control_, *graph_);
  DeformationInputs in;
  in.reserve(100, 1000, graph_->capacities().place_nodes, graph_->capacities().edges);
  in.copy(layer_, control_.view(), *graph_);
  EXPECT_EQ(in.grown, 0u);
  ASSERT_EQ(in.chain.size(), walk_.odometry.size());
  ASSERT_EQ(in.places.size(), places_.size());
  // The loop thread goes on: a keyframe, a control point, a new place and an old one moved.
  const std::uint64_t t = layer_.chain(layer_.chain_size() - 1).time_ns + 2'000'000'000ull;
  ASSERT_EQ(layer_.add_keyframe(graph_.get(), t, walk_.odometry.back() * planar(0.5, 0.0, 0.0)), agents::AddResult::kAdded);
  ASSERT_TRUE(control_.offer(Eigen::Vector3d(20.0, 20.0, 1.0), t));
  scene_graph::PlaceAttributes p;
  p.position_m = Eigen::Vector3d(3.0, 3.0, 0.0);
  p.last_update_time_ns = t;
  ASSERT_EQ(graph_->add_place(scene_graph::make_node_id(scene_graph::kPlacePrefix, 999), p), scene_graph::Status::kOk);
  graph_->place(places_.front().first)->position_m += Eigen::Vector3d(0.4, 0.0, 0.0);
  const DeformationProblem copied = DeformationGraph().build(in, closures);
  ASSERT_EQ(copied.poses.size(), live.poses.size());
  ASSERT_EQ(copied.edges.size(), live.edges.size());
  for (std::size_t i = 0; i < live.poses.size(); ++i) EXPECT_EQ(copied.poses[i].t_m, live.poses[i].t_m) << i;
  for (std::size_t e = 0; e < live.edges.size(); ++e) {
    EXPECT_EQ(copied.edges[e].from, live.edges[e].from) << e;
    EXPECT_EQ(copied.edges[e].to, live.edges[e].to) << e;
    EXPECT_EQ(copied.edges[e].measured_from_T_to.t_m, live.edges[e].measured_from_T_to.t_m) << e;
  }
  EXPECT_EQ(copied.originals, live.originals);
  EXPECT_EQ(copied.place_ids, live.place_ids);
  // The state after the changes differs (so the comparison above could fail), and a copy now, into buffers
  // reserved for the stores, still does not grow them.
  const DeformationProblem after = DeformationGraph().build(layer_, closures, control_, *graph_);
  EXPECT_GT(after.poses.size(), live.poses.size());
  in.copy(layer_, control_.view(), *graph_);
  EXPECT_EQ(in.grown, 0u);
  EXPECT_EQ(in.copies, 2u);
  DeformationInputs unreserved;
  unreserved.copy(layer_, control_.view(), *graph_);
  EXPECT_EQ(unreserved.grown, 1u);
}

// The agent chain folds when it fills (every second node of its older half goes), which shifts the indices of the
// nodes after the fold. The next solve must find its agents in the last one by time: the closure it decided is
// carried on the same two nodes, the solve starts from their last solution, and a node's pose is asked by time.
TEST_F(DeformationGraphTest, AfterAChainFoldTheNextSolveFindsItsAgentsByTime) {
  const auto last = static_cast<std::uint32_t>(walk_.truth.size() - 1);
  DeformationGraph d(strategy(true));
  ASSERT_TRUE(d.optimize(layer_, {true_closure(0, last)}, control_, *graph_).solve.poses_updated());
  std::vector<agents::ChainNode> folded;  // odd nodes of the first 20 folded away
  std::vector<std::uint32_t> original;    // each kept node's index in the full chain
  for (std::uint32_t k = 0; k < layer_.chain_size(); ++k)
    if (k >= 20 || k % 2 == 0) {
      folded.push_back(layer_.chain(k));
      original.push_back(k);
    }
  const agents::ChainView view(folded.data(), folded.size());
  const auto at = [&](std::uint32_t k) {
    return static_cast<std::uint32_t>(std::find(original.begin(), original.end(), k) - original.begin());
  };
  const auto moved = [&](ChainLoopClosure c) {  // the same closure on the folded chain's indices
    c.a = at(c.a);
    c.b = at(c.b);
    return c;
  };
  const std::vector<ChainLoopClosure> closures = {moved(true_closure(0, last)), moved(true_closure(24, 44))};
  const DeformationResult r = d.optimize(view, closures, control_, *graph_);
  ASSERT_TRUE(r.solve.poses_updated()) << r.solve.message;
  EXPECT_EQ(r.closures_carried, 1u) << "the first closure, on the same two nodes";
  EXPECT_EQ(r.loop_closures_kept, 2u);
  DeformationGraph fresh(strategy(true));
  ASSERT_TRUE(fresh.optimize(view, closures, control_, *graph_).solve.poses_updated());
  for (std::size_t k = 0; k < folded.size(); ++k) {
    EXPECT_LT((d.agent_pose(k).t_m - fresh.agent_pose(k).t_m).norm(), 0.01) << k;
    Pose3 p;
    ASSERT_TRUE(d.agent_pose_at(folded[k].time_ns, &p)) << k;
    EXPECT_EQ(p.t_m, d.agent_pose(k).t_m) << k;
  }
  Pose3 p;
  EXPECT_FALSE(d.agent_pose_at(layer_.chain(1).time_ns, &p)) << "folded away: not in the solve";
}

TEST_F(DeformationGraphTest, WithoutLoopClosuresNothingMoves) {
  DeformationGraph d;
  const DeformationResult r = d.optimize(layer_, {}, control_, *graph_);
  ASSERT_TRUE(r.solve.poses_updated()) << r.solve.message;
  for (const Wall& w : walls_) EXPECT_LT((d.deform(w.odom, w.time_ns) - w.odom).norm(), 1e-6);
  EXPECT_LT((d.agent_pose(5).t_m - walk_.odometry[5].translation()).norm(), 1e-6);
}

// DeformationConfig::agent_spacing_m: the solved graph keeps one agent per 1.5 m of path (every 3rd step, and the
// closure's two agents); the chain nodes between follow interpolated corrections. The result must be the full
// chain's within 5 cm everywhere along it, and the map must follow as before.
TEST_F(DeformationGraphTest, AThinnedAgentLayerSolvesToTheFullChainsPoses) {
  const auto last = static_cast<std::uint32_t>(walk_.truth.size() - 1);
  const std::vector<ChainLoopClosure> closures = {true_closure(0, last), true_closure(1, last - 1)};
  DeformationGraph full(strategy(true));
  const DeformationResult rf = full.optimize(layer_, closures, control_, *graph_);
  ASSERT_TRUE(rf.solve.poses_updated()) << rf.solve.message;
  EXPECT_EQ(rf.agents_solved, walk_.truth.size());
  DeformationConfig c = strategy(true);
  c.agent_spacing_m = 1.5;
  c.agent_turn_rad = 3.0;
  c.hold_agents = std::getenv("HOLD") != nullptr;  // the square's corners turn 90 degrees in one step: path alone decides here
  DeformationGraph thin(c);
  const DeformationResult rt = thin.optimize(layer_, closures, control_, *graph_);
  ASSERT_TRUE(rt.solve.poses_updated()) << rt.solve.message;
  EXPECT_EQ(rt.agents, walk_.truth.size());
  EXPECT_LT(rt.agents_solved, walk_.truth.size() / 2) << "one node per 1.5 m of 0.5 m steps";
  EXPECT_GE(rt.agents_solved, walk_.truth.size() / 3);
  EXPECT_EQ(rt.loop_closures_kept, 2u);
  ASSERT_EQ(thin.num_agent_poses(), walk_.truth.size()) << "every chain node gets a pose";
  for (std::size_t k = 0; k < walk_.truth.size(); ++k)
    EXPECT_LT((thin.agent_pose(k).t_m - full.agent_pose(k).t_m).norm(), 0.05) << "chain node " << k;
  // The walk drifts 0.6 degree a step and turns 90 degrees in one: the corrections interpolated over a spacing cost
  // a little (RMSE 0.037 against 0.017 m here, from 0.4 m before any correction).
  EXPECT_LT(agent_rmse(thin), agent_rmse(full) + 0.03);
  EXPECT_LT(wall_rmse(thin), wall_rmse(full) + 0.03);
}

// DeformationConfig::hold_agents: the map is solved around the agent layer's solution, which it does not move.
TEST_F(DeformationGraphTest, HeldAgentsKeepTheAgentLayersSolutionAndTheMapFollows) {
  const auto last = static_cast<std::uint32_t>(walk_.truth.size() - 1);
  const std::vector<ChainLoopClosure> closures = {true_closure(0, last)};
  // The agent layer alone, with the same closure and odometry model: what the held solve must keep.
  AgentGraphConfig agents = strategy(true).agents;
  std::vector<Pose3> alone;
  ASSERT_TRUE(optimize_agent_chain(layer_, closures, agents, &alone).solve.poses_updated());
  DeformationConfig c = strategy(true);
  c.hold_agents = true;
  c.reduced_decisions = false;  // the agent layer's own solve; reduced decisions re-solve it to a tolerance
  DeformationGraph d(c);
  const double walls_before = wall_rmse(d);
  const DeformationResult r = d.optimize(layer_, closures, control_, *graph_);
  ASSERT_TRUE(r.solve.poses_updated()) << r.solve.message;
  for (std::size_t k = 0; k < walk_.truth.size(); ++k)
    EXPECT_LT((d.agent_pose(k).t_m - alone[k].t_m).norm(), 1e-6) << "chain node " << k;
  EXPECT_LT(wall_rmse(d), 0.3 * walls_before) << "the control points follow the held agents";
}

// DeformationConfig::settle_tolerance_m: a second solve holds the control points its new closure did not move and
// solves the rest, to within a few centimetres of solving every node again; a tolerance too loose to tell shows why
// it must be small (the moved half then keeps its old pose).
TEST_F(DeformationGraphTest, ASecondSolveHoldsTheMapItsNewClosureDidNotMove) {
  const auto last = static_cast<std::uint32_t>(walk_.truth.size() - 1);
  const auto half = static_cast<std::uint32_t>(walk_.truth.size() / 2);
  DeformationConfig c = strategy(true);
  c.hold_agents = true;
  c.incremental_decisions = false;
  DeformationConfig tight = c, loose = c;
  c.settle_tolerance_m = 0.0;  // every node solved
  tight.settle_tolerance_m = 0.01;
  loose.settle_tolerance_m = 1.0;
  loose.settle_hops = 0;
  ASSERT_EQ(tight.check(), "");
  DeformationGraph full(c), settled(tight), careless(loose);
  // First solve: the first half corrected by a closure to its far corner; the second half drifts on.
  const std::vector<ChainLoopClosure> first = {true_closure(0, half)};
  for (DeformationGraph* d : {&full, &settled, &careless}) {
    const DeformationResult r = d->optimize(layer_, first, control_, *graph_);
    ASSERT_TRUE(r.solve.poses_updated()) << r.solve.message;
    EXPECT_EQ(r.map_settled, 0u) << "nothing to settle at: no solve before";
  }
  // Second: the loop's closure corrects the second half; the first half hardly moves.
  const std::vector<ChainLoopClosure> both = {true_closure(0, half), true_closure(0, last)};
  const DeformationResult a = full.optimize(layer_, both, control_, *graph_);
  const DeformationResult b = settled.optimize(layer_, both, control_, *graph_);
  const DeformationResult l = careless.optimize(layer_, both, control_, *graph_);
  ASSERT_TRUE(a.solve.poses_updated() && b.solve.poses_updated() && l.solve.poses_updated());
  const std::size_t nodes = a.control_points + a.places;
  EXPECT_EQ(a.map_settled, 0u);
  EXPECT_GE(b.map_settled, 3u) << "the first half settles";
  EXPECT_LT(b.map_settled, a.control_points / 2) << "the second half moves";
  EXPECT_EQ(l.map_settled, a.control_points) << "a metre of tolerance holds every control point (places never)";
  ASSERT_EQ(settled.num_map_nodes(), nodes);
  double worst = 0.0;
  for (std::size_t i = 0; i < nodes; ++i)
    worst = std::max(worst, (settled.map_node_pose(i).t_m - full.map_node_pose(i).t_m).norm());
  EXPECT_LT(worst, 0.05) << "held nodes are where solving them again puts them";
  EXPECT_LT(wall_rmse(settled), wall_rmse(full) + 0.01);
  EXPECT_GT(wall_rmse(careless), wall_rmse(full) + 0.05) << "the moved half left at its first-solve pose";
  for (std::size_t k = 0; k < walk_.truth.size(); ++k)
    EXPECT_EQ(settled.agent_pose(k).t_m, full.agent_pose(k).t_m) << "the agents are the agent layer's either way";
}

// DeformationConfig::incremental_decisions: a second solve keeps the first one's decisions and decides only its new
// closures (a wrong one among them switches off as before), to the full solve's agents; and when the new closures
// contradict a closure kept earlier, it decides them all again, which a carried decision alone could not.
TEST_F(DeformationGraphTest, IncrementalDecisionsKeepTheLastOnesAndDecideAgainWhenContradicted) {
  const auto last = static_cast<std::uint32_t>(walk_.truth.size() - 1);
  const auto half = static_cast<std::uint32_t>(walk_.truth.size() / 2);
  DeformationConfig c = strategy(true);
  c.incremental_decisions = false;  // every closure decided every time
  DeformationConfig inc = c;
  inc.incremental_decisions = true;
  ASSERT_EQ(inc.check(), "");
  ChainLoopClosure wrong = true_closure(10, 30);
  wrong.a_T_b = Pose3{Eigen::Vector3d(0.5, 0.2, 0.0), Eigen::Quaterniond::Identity()};  // "the same place": it is not
  {
    SCOPED_TRACE("new closures consistent with the old");
    DeformationGraph full(c), incremental(inc);
    const std::vector<ChainLoopClosure> first = {true_closure(0, half)};
    ASSERT_TRUE(full.optimize(layer_, first, control_, *graph_).solve.poses_updated());
    const DeformationResult r1 = incremental.optimize(layer_, first, control_, *graph_);
    ASSERT_TRUE(r1.solve.poses_updated());
    EXPECT_EQ(r1.closures_carried, 0u) << "nothing decided before";
    const std::vector<ChainLoopClosure> both = {true_closure(0, half), true_closure(0, last), wrong,
                                               true_closure(1, last)};
    const DeformationResult a = full.optimize(layer_, both, control_, *graph_);
    const DeformationResult b = incremental.optimize(layer_, both, control_, *graph_);
    ASSERT_TRUE(a.solve.poses_updated() && b.solve.poses_updated());
    EXPECT_EQ(b.closures_carried, 1u);
    EXPECT_FALSE(b.decided_again);
    ASSERT_EQ(b.loop_closure_weight.size(), 4u);
    EXPECT_EQ(b.loop_closure_weight, a.loop_closure_weight);
    EXPECT_LT(b.loop_closure_weight[2], 0.5) << "the wrong one";
    EXPECT_LT(std::abs(agent_rmse(incremental) - agent_rmse(full)), 0.01);
    EXPECT_LT(std::abs(wall_rmse(incremental) - wall_rmse(full)), 0.01);
  }
  {
    SCOPED_TRACE("a wrong closure kept alone, then contradicted");
    DeformationGraph full(c), incremental(inc);
    // The loop's closure, 0.6 m off. Alone, nothing contradicts it: the drifted walk bends to fit it, GNC keeps it.
    ChainLoopClosure off = true_closure(0, last);
    off.a_T_b.t_m += Eigen::Vector3d(0.0, 0.6, 0.0);
    const DeformationResult r1 = incremental.optimize(layer_, {off}, control_, *graph_);
    ASSERT_TRUE(r1.solve.poses_updated());
    ASSERT_EQ(r1.loop_closures_kept, 1u);
    const std::vector<ChainLoopClosure> more = {off, true_closure(1, last), true_closure(0, last - 1),
                                               true_closure(2, last), true_closure(0, last - 2)};
    const DeformationResult a = full.optimize(layer_, more, control_, *graph_);
    const DeformationResult b = incremental.optimize(layer_, more, control_, *graph_);
    ASSERT_TRUE(a.solve.poses_updated() && b.solve.poses_updated());
    EXPECT_LT(a.loop_closure_weight[0], 0.5) << "the full decision rejects it";
    EXPECT_TRUE(b.decided_again) << "its carried decision no longer fits";
    EXPECT_EQ(b.closures_carried, 0u);
    EXPECT_EQ(b.loop_closure_weight, a.loop_closure_weight);
    EXPECT_LT(std::abs(agent_rmse(incremental) - agent_rmse(full)), 1e-6);
  }
}

// The closure store folds when full (backend_stage.h: fold_loop_closures), which shifts every closure's index. A
// closure named by its id keeps its decision all the same; unnamed ones are known by index and lose theirs.
TEST_F(DeformationGraphTest, NamedClosuresKeepTheirDecisionsWhenTheStoreFolds) {
  const auto last = static_cast<std::uint32_t>(walk_.truth.size() - 1);
  const auto half = static_cast<std::uint32_t>(walk_.truth.size() / 2);
  DeformationConfig c = strategy(true);
  c.incremental_decisions = true;
  ASSERT_EQ(c.check(), "");
  ChainLoopClosure wrong = true_closure(10, 30);
  wrong.a_T_b = Pose3{Eigen::Vector3d(0.5, 0.2, 0.0), Eigen::Quaterniond::Identity()};
  std::vector<ChainLoopClosure> before = {true_closure(0, half), true_closure(0, last), wrong, true_closure(1, last)};
  std::vector<ChainLoopClosure> after = {true_closure(0, last), wrong, true_closure(1, last), true_closure(2, last)};
  for (const bool named : {true, false}) {
    SCOPED_TRACE(named ? "named" : "unnamed");
    for (std::size_t k = 0; k < before.size(); ++k) before[k].id = named ? 100 + k : 0;
    for (std::size_t k = 0; k < after.size(); ++k) after[k].id = named ? 101 + k : 0;  // the first one folded away
    DeformationGraph g(c);
    const DeformationResult r1 = g.optimize(layer_, before, control_, *graph_);
    ASSERT_TRUE(r1.solve.poses_updated());
    ASSERT_EQ(r1.loop_closure_weight.size(), 4u);
    ASSERT_LT(r1.loop_closure_weight[2], 0.5) << "the wrong one";
    double w = 1.0;
    EXPECT_EQ(g.closure_weight(102, &w), named);
    if (named) {
      EXPECT_LT(w, 0.5);
    }
    const DeformationResult r2 = g.optimize(layer_, after, control_, *graph_);
    ASSERT_TRUE(r2.solve.poses_updated());
    EXPECT_EQ(r2.closures_carried, named ? 3u : 0u);
    EXPECT_FALSE(r2.decided_again);
    ASSERT_EQ(r2.loop_closure_weight.size(), 4u);
    EXPECT_LT(r2.loop_closure_weight[1], 0.5) << "the wrong one stays out";
    EXPECT_GT(r2.loop_closure_weight[3], 0.5) << "the new one is decided";
  }
}

// reduced_decisions off: the agents are exactly GNC's over the whole agent layer (the current path, bit for bit);
// on: the same decisions, a wrong closure rejected, fresh and carried, and agents within millimetres of the off path.
TEST_F(DeformationGraphTest, ReducedDecisionsDecideAsTheWholeAgentLayer) {
  const auto last = static_cast<std::uint32_t>(walk_.truth.size() - 1);
  const auto half = static_cast<std::uint32_t>(walk_.truth.size() / 2);
  ChainLoopClosure wrong = true_closure(10, 30);
  wrong.a_T_b = Pose3{Eigen::Vector3d(0.5, 0.2, 0.0), Eigen::Quaterniond::Identity()};
  const std::vector<ChainLoopClosure> first = {true_closure(0, half), wrong};
  const std::vector<ChainLoopClosure> both = {true_closure(0, half), wrong, true_closure(0, last),
                                             true_closure(1, last), true_closure(2, last - 1)};
  DeformationConfig on = strategy(true);
  ASSERT_TRUE(on.reduced_decisions) << "on by default";
  DeformationConfig off = on;
  off.reduced_decisions = false;
  ASSERT_EQ(on.check(), "");
  for (const bool incremental : {false, true}) {
    SCOPED_TRACE(incremental ? "incremental decisions" : "every closure decided each time");
    off.incremental_decisions = on.incremental_decisions = incremental;
    DeformationGraph a(off), b(on);
    for (const std::vector<ChainLoopClosure>* closures : {&first, &both}) {
      const DeformationResult ra = a.optimize(layer_, *closures, control_, *graph_);
      const DeformationResult rb = b.optimize(layer_, *closures, control_, *graph_);
      ASSERT_TRUE(ra.solve.poses_updated() && rb.solve.poses_updated());
      EXPECT_EQ(ra.agents_decided, 0u);
      EXPECT_EQ(rb.agents_decided > 0, !incremental || closures == &first || rb.closures_carried < closures->size());
      EXPECT_EQ(rb.loop_closure_weight, ra.loop_closure_weight);
      EXPECT_LT(rb.loop_closure_weight[1], 0.5) << "the wrong closure";
      double worst = 0.0;
      for (std::size_t k = 0; k < walk_.truth.size(); ++k)
        worst = std::max(worst, (a.agent_pose(k).t_m - b.agent_pose(k).t_m).norm());
      EXPECT_LT(worst, 0.005);
      EXPECT_LT(std::abs(wall_rmse(a) - wall_rmse(b)), 0.005);
    }
  }
  // Off, from scratch: the agents are GNC's over the agent layer itself (odometry and closures), bit for bit.
  off.incremental_decisions = false;
  DeformationGraph fresh(off);
  ASSERT_TRUE(fresh.optimize(layer_, both, control_, *graph_).solve.poses_updated());
  std::vector<Pose3> agents;
  const AgentGraphResult chain = optimize_agent_chain(layer_, both, off.agents, &agents);
  ASSERT_TRUE(chain.solve.poses_updated());
  for (std::size_t k = 0; k < agents.size(); ++k) {
    EXPECT_EQ(fresh.agent_pose(k).t_m, agents[k].t_m) << k;
    // The whole solve holds the agents and writes them back normalized once more: the last bit may change.
    EXPECT_LT((fresh.agent_pose(k).q.coeffs() - agents[k].q.coeffs()).norm(), 1e-15) << k;
  }
}

// DeformationConfig::place_rotation_sigma_rad: places tied to the walk only by edges of their own (to the next place
// and to a wall's control point, no agent's) hold their rotation by those position-only edges alone; the last of
// the chain can swing about its control point at no cost. Without the prior, the whole solve's stopping rule
// decides where they land; with it, a loose and a tight rule land them together, and the closure still corrects
// them.
TEST_F(DeformationGraphTest, ARotationPriorLandsHangingPlacesWhereverTheSolveStops) {
  auto hanging = scene_graph::testing::make_graph();
  for (std::size_t p = 0; p < places_.size(); ++p) {
    ASSERT_EQ(hanging->add_place(places_[p].first, *graph_->place(places_[p].first)), scene_graph::Status::kOk);
    if (p > 0) hanging->add_edge(places_[p - 1].first, places_[p].first);
  }
  ASSERT_EQ(DeformationConfig{}.place_rotation_sigma_rad, kPlaceSigmaRad) << "on by default";
  const auto last = static_cast<std::uint32_t>(walk_.truth.size() - 1);
  const auto solve = [&](double sigma_rad, double tolerance, std::vector<Eigen::Vector3d>* out) {
    DeformationConfig c = strategy(true);
    c.place_rotation_sigma_rad = sigma_rad;
    c.whole_function_tolerance = tolerance;
    ASSERT_EQ(c.check(), "");
    DeformationGraph d(c);
    const DeformationResult r = d.optimize(layer_, {true_closure(0, last)}, control_, *hanging);
    ASSERT_TRUE(r.solve.poses_updated()) << r.solve.message;
    ASSERT_EQ(r.edges_ap, 0u);
    ASSERT_EQ(r.edges_mp, places_.size()) << "every place hangs from a wall's control point";
    out->clear();
    for (const auto& [id, truth] : places_) {
      out->emplace_back();
      ASSERT_TRUE(d.place_position(id, &out->back()));
    }
  };
  const auto apart = [](const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
    double worst = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, (a[i] - b[i]).norm());
    return worst;
  };
  std::vector<Eigen::Vector3d> loose, tight, loose_prior, tight_prior;
  solve(0.0, 1e-4, &loose);
  solve(0.0, 1e-10, &tight);
  solve(kPlaceSigmaRad, 1e-4, &loose_prior);
  solve(kPlaceSigmaRad, 1e-10, &tight_prior);
  std::printf("hanging places, loose against tight: %.4f m without the prior, %.4f m with it\n", apart(loose, tight),
              apart(loose_prior, tight_prior));
  EXPECT_GT(apart(loose, tight), kWithoutM) << "without the prior the stopping rule decides";
  EXPECT_LT(apart(loose_prior, tight_prior), kWithM);
  double before = 0.0, after = 0.0;
  for (std::size_t p = 0; p < places_.size(); ++p) {
    before += (graph_->place(places_[p].first)->position_m - places_[p].second).squaredNorm();
    after += (loose_prior[p] - places_[p].second).squaredNorm();
  }
  EXPECT_LT(after, 0.09 * before) << "the prior does not keep them from the correction";
}

// The priors do not keep the map from a real correction: with them on places and control points, the closures move
// the walk's places and walls as far towards the truth as without, in one solve and in a second one over settled
// control points and carried decisions. GNC over the whole graph has no prior (its map starts at identity, which
// would hold the map against the closures' rotation): the same solution with them or without.
TEST_F(DeformationGraphTest, RotationPriorsLetTheMapFollowACorrection) {
  const auto last = static_cast<std::uint32_t>(walk_.truth.size() - 1);
  const auto half = static_cast<std::uint32_t>(walk_.truth.size() / 2);
  const auto place_error = [&](const DeformationGraph& d) {
    double sum = 0.0;
    for (const auto& [id, truth] : places_) {
      Eigen::Vector3d p = graph_->place(id)->position_m;
      if (d.solved()) {
        EXPECT_TRUE(d.place_position(id, &p));
      }
      sum += (p - truth).squaredNorm();
    }
    return std::sqrt(sum / static_cast<double>(places_.size()));
  };
  const double places_before = place_error(DeformationGraph{}), walls_before = wall_rmse(DeformationGraph{});
  const std::vector<std::vector<ChainLoopClosure>> solves = {{true_closure(0, half)},
                                                             {true_closure(0, half), true_closure(0, last)}};
  for (const bool settle : {false, true}) {
    SCOPED_TRACE(settle ? "settled control points, carried decisions (the defaults)" : "every map node solved");
    DeformationConfig c = strategy(true);
    if (!settle) c.settle_tolerance_m = 0.0;
    c.incremental_decisions = settle;
    c.place_rotation_sigma_rad = c.control_rotation_sigma_rad = 0.0;
    DeformationConfig with = c;
    with.place_rotation_sigma_rad = with.control_rotation_sigma_rad = kPlaceSigmaRad;
    DeformationGraph a(c), b(with);
    DeformationResult r;
    for (const std::vector<ChainLoopClosure>& closures : solves) {
      ASSERT_TRUE(a.optimize(layer_, closures, control_, *graph_).solve.poses_updated());
      r = b.optimize(layer_, closures, control_, *graph_);
      ASSERT_TRUE(r.solve.poses_updated()) << r.solve.message;
    }
    std::printf("places %.4f -> %.4f without, %.4f with; walls %.4f -> %.4f without, %.4f with\n", places_before,
                place_error(a), place_error(b), walls_before, wall_rmse(a), wall_rmse(b));
    EXPECT_EQ(r.map_settled >= 3, settle);
    EXPECT_EQ(r.closures_carried, settle ? 1u : 0u);
    EXPECT_LT(place_error(b), 0.1 * places_before);
    EXPECT_LT(place_error(b), place_error(a) + 0.01);
    EXPECT_LT(wall_rmse(b), 0.2 * walls_before);
    EXPECT_LT(wall_rmse(b), wall_rmse(a) + 0.01);
  }
  DeformationConfig whole = strategy(false), with = whole;
  whole.place_rotation_sigma_rad = 0.0;
  with.place_rotation_sigma_rad = with.control_rotation_sigma_rad = kPlaceSigmaRad;
  DeformationGraph a(whole), b(with);
  ASSERT_TRUE(a.optimize(layer_, solves.back(), control_, *graph_).solve.poses_updated());
  ASSERT_TRUE(b.optimize(layer_, solves.back(), control_, *graph_).solve.poses_updated());
  EXPECT_EQ(place_error(a), place_error(b)) << "GNC over the whole graph: no prior";
}

TEST(ControlPointsTest, OnePerCellAndAFullStoreFoldsItsOlderHalf) {
  ControlPoints c;
  std::string error;
  ASSERT_TRUE(c.init(3, 1.0, &error)) << error;
  EXPECT_TRUE(c.offer(Eigen::Vector3d(0.2, 0.2, 0.2), 1));
  EXPECT_FALSE(c.offer(Eigen::Vector3d(0.8, 0.9, 0.1), 2)) << "same cell";
  EXPECT_TRUE(c.offer(Eigen::Vector3d(1.2, 0.2, 0.2), 3));
  EXPECT_TRUE(c.offer(Eigen::Vector3d(-0.2, 0.2, 0.2), 4));
  EXPECT_FALSE(c.offer(Eigen::Vector3d(1.5, 0.5, 0.5), 5)) << "full, but its cell has a recent point: not needed";
  EXPECT_EQ(c.folds(), 0u);
  // Full, a new cell: the oldest point goes, the new one is kept, nothing is refused.
  EXPECT_TRUE(c.offer(Eigen::Vector3d(5.0, 5.0, 5.0), 6));
  EXPECT_FALSE(c.offer(Eigen::Vector3d(std::nan(""), 0, 0), 7));
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(c.time_ns(0), 3u);
  EXPECT_EQ(c.time_ns(2), 6u);
  EXPECT_EQ(c.stats().failed, 0u);
  EXPECT_EQ(c.folds(), 1u);
  EXPECT_EQ(c.folded(), 1u);
  // The folded point's cell has no point any more: offered again, it gets one (the cells were re-indexed).
  EXPECT_TRUE(c.offer(Eigen::Vector3d(0.8, 0.9, 0.1), 8));
  EXPECT_EQ(c.time_ns(2), 8u);
  EXPECT_FALSE(c.offer(Eigen::Vector3d(5.1, 5.1, 5.1), 9)) << "the kept point's cell still has it";
}

// A long mission's revisits fill the store: folded, the walk's control points still carry the correction.
TEST_F(DeformationGraphTest, AFoldedStoreStillCorrectsTheWalk) {
  ControlPoints small;
  std::string error;
  ASSERT_TRUE(small.init(walls_.size() / 2, 1.0, &error)) << error;
  for (const Wall& w : walls_) ASSERT_TRUE(small.offer(w.odom, w.time_ns));
  EXPECT_GT(small.folds(), 0u);
  EXPECT_LE(small.size(), walls_.size() / 2);
  EXPECT_EQ(small.stats().failed, 0u);
  const auto last = static_cast<std::uint32_t>(walk_.truth.size() - 1);
  DeformationGraph full(strategy(true)), folded(strategy(true));
  ASSERT_TRUE(full.optimize(layer_, {true_closure(0, last)}, control_, *graph_).solve.poses_updated());
  ASSERT_TRUE(folded.optimize(layer_, {true_closure(0, last)}, small, *graph_).solve.poses_updated());
  const double odometry = wall_rmse(DeformationGraph());
  EXPECT_LT(wall_rmse(folded), 0.3 * odometry) << "folded " << small.folded() << " in " << small.folds();
  EXPECT_LT(wall_rmse(folded), 2.0 * wall_rmse(full)) << "coarser where folded, not lost; odometry " << odometry;
}

}  // namespace
}  // namespace qsg::backend

namespace qsg::backend {
namespace {

// LoopClosureConfig::map_in_corrected_frame: the frontend maps the keyframes after a solve at the odometric pose
// times the correction then in use. The same walk mapped so from node 20 or 21 on (a correction of 0.3 m and 4
// degrees, stamped on the nodes: AgentLayer::set_frame_correction) must solve to the odometry frame's agent poses:
// the odometry edges measure the odometry alone. Whole, to the solver's tolerance. Thinned, thinning keeps the node
// where the frame changes and composes the odometry into it from the edges; the kept set then differs from the
// odometry frame's by a node or two, and the poses interpolated between kept nodes by a few millimetres (the
// thinned test above allows 0.05 m against the whole chain). Without the stamp the edge into the node holds the
// correction as if it were motion, and the solution moves by a good part of it. (No control points: mesh edges
// across the change would join surfaces mapped in two frames, which is the mapping's own error, not the solve's.)
TEST_F(DeformationGraphTest, AWalkMappedInACorrectedFrameSolvesToTheOdometryFramesPoses) {
  const auto last = static_cast<std::uint32_t>(walk_.truth.size() - 1);
  const std::vector<ChainLoopClosure> closures = {true_closure(0, last), true_closure(1, last - 1)};
  const Eigen::Isometry3d correction = planar(0.3, -0.2, 4.0 * M_PI / 180.0);
  const auto mapped = [&](std::size_t from, const Eigen::Isometry3d& correction_from, bool stamp,
                          agents::AgentLayer* layer, ControlPoints* control,
                          std::unique_ptr<scene_graph::SceneGraph>* graph) {
    *graph = scene_graph::testing::make_graph();
    agents::Config c;
    c.min_translation_m = 0.0;
    std::string error;
    ASSERT_TRUE(layer->init(c, agents::Capacities{100}, &error)) << error;
    ASSERT_TRUE(control->init(1000, 1.0, &error)) << error;
    for (std::size_t i = 0; i < walk_.odometry.size(); ++i) {
      const Eigen::Isometry3d frame = i >= from ? correction_from : Eigen::Isometry3d::Identity();
      if (stamp) layer->set_frame_correction(frame);
      Eigen::Matrix<double, 6, 1> variance;
      variance << 1e-4 * i, 1e-4 * i, 1e-6 * i, 1e-7 * i, 1e-7 * i, 1.2e-4 * i;
      const std::uint64_t t = 1'000'000'000ull + 2'000'000'000ull * i;
      ASSERT_EQ(layer->add_keyframe(graph->get(), t, frame * walk_.odometry[i], 0, variance),
                agents::AddResult::kAdded);
    }
  };
  struct Case {
    std::size_t from;
    double spacing_m, within_m;
  };
  for (const Case& k : {Case{20, 0.0, 1e-4}, Case{21, 0.0, 1e-4}, Case{20, 1.5, 0.02}, Case{21, 1.5, 0.02}}) {
    SCOPED_TRACE("from node " + std::to_string(k.from) + (k.spacing_m > 0.0 ? ", thinned" : ", whole chain"));
    DeformationConfig c = strategy(true);
    c.agent_spacing_m = k.spacing_m;
    c.agent_turn_rad = 3.0;
    agents::AgentLayer odometric_layer;
    ControlPoints no_control;
    std::unique_ptr<scene_graph::SceneGraph> odometric_graph;
    mapped(k.from, Eigen::Isometry3d::Identity(), false, &odometric_layer, &no_control, &odometric_graph);
    DeformationGraph reference(c);
    ASSERT_TRUE(reference.optimize(odometric_layer, closures, no_control, *odometric_graph).solve.poses_updated());
    double moved_m[2] = {0.0, 0.0};
    for (int stamp = 0; stamp < 2; ++stamp) {
      agents::AgentLayer layer;
      ControlPoints control;
      std::unique_ptr<scene_graph::SceneGraph> graph;
      mapped(k.from, correction, stamp == 1, &layer, &control, &graph);
      if (stamp == 1) {
        EXPECT_NEAR(layer.chain(last).path_m, odometric_layer.chain(last).path_m, 1e-9)
            << "a change of frame is not path";
      }
      DeformationGraph d(c);
      const DeformationResult r = d.optimize(layer, closures, control, *graph);
      ASSERT_TRUE(r.solve.poses_updated()) << r.solve.message;
      if (k.spacing_m > 0.0) {
        EXPECT_LT(r.agents_solved, walk_.truth.size() / 2);
      }
      ASSERT_EQ(d.num_agent_poses(), walk_.truth.size());
      for (std::size_t n = 0; n < walk_.truth.size(); ++n)
        moved_m[stamp] = std::max(moved_m[stamp], (d.agent_pose(n).t_m - reference.agent_pose(n).t_m).norm());
    }
    EXPECT_LT(moved_m[1], k.within_m) << "stamped: the odometry frame's solution";
    EXPECT_GT(moved_m[0], 0.05) << "unstamped: the correction taken for motion";
  }
}

}  // namespace
}  // namespace qsg::backend
