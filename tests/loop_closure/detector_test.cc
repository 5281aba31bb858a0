#include "core/loop_closure/detector.h"

#include <gtest/gtest.h>

#include <random>

#include "tests/scene_graph/test_graph.h"

namespace qsg::loop_closure {
namespace {

constexpr LocalMapCapacities kLocalMap{16, 4096};  // the local-map pass's buffers, as host_sim's table

using scene_graph::NodeId;
using scene_graph::make_node_id;

struct Furniture {
  Eigen::Vector2d xy;
  std::uint32_t label;
};

// One room of the building drawn into the graph through `world_T_room`: a 6 x 5 grid of places 1 m apart (clearance
// smaller near the walls), each object a child of its nearest place. Returns the centre place.
NodeId draw_room(scene_graph::SceneGraph* g, std::uint64_t* next_place, std::uint64_t* next_object,
                 const Eigen::Isometry3d& world_T_room, const std::vector<Furniture>& furniture) {
  const std::uint64_t first = *next_place;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 5; ++j) {
      scene_graph::PlaceAttributes p;
      p.position_m = world_T_room * Eigen::Vector3d(i, j, 1.0);
      p.distance_m = 0.3 + 0.25 * std::min(std::min(i, 5 - i), std::min(j, 4 - j));
      const NodeId id = make_node_id(scene_graph::kPlacePrefix, (*next_place)++);
      EXPECT_EQ(g->add_place(id, p), scene_graph::Status::kOk);
      if (i > 0) g->add_edge(id, make_node_id(scene_graph::kPlacePrefix, first + (i - 1) * 5 + j));
      if (j > 0) g->add_edge(id, make_node_id(scene_graph::kPlacePrefix, first + i * 5 + j - 1));
    }
  for (const Furniture& f : furniture) {
    scene_graph::ObjectAttributes o;
    o.position_m = world_T_room * Eigen::Vector3d(f.xy.x(), f.xy.y(), 0.5);
    o.semantic_label = f.label;
    const NodeId id = make_node_id(scene_graph::kObjectPrefix, (*next_object)++);
    EXPECT_EQ(g->add_object(id, o), scene_graph::Status::kOk);
    const int i = std::clamp(static_cast<int>(std::lround(f.xy.x())), 0, 5);
    const int j = std::clamp(static_cast<int>(std::lround(f.xy.y())), 0, 4);
    g->add_edge(make_node_id(scene_graph::kPlacePrefix, first + i * 5 + j), id);
  }
  return make_node_id(scene_graph::kPlacePrefix, first + 2 * 5 + 2);
}

const std::vector<Furniture> kLiving = {{{0.5, 0.5}, 10}, {{1.5, 3.5}, 10}, {{4.5, 0.8}, 5},
                                        {{3.0, 2.0}, 3},  {{2.2, 2.1}, 3},  {{4.8, 3.9}, 14}};
const std::vector<Furniture> kKitchen = {{{0.3, 0.3}, 7}, {{1.3, 0.3}, 7}, {{2.3, 0.3}, 7},
                                         {{4.5, 3.5}, 5}, {{3.5, 3.6}, 3}, {{0.4, 4.0}, 37}};

Eigen::Isometry3d pose(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  return T;
}

AgentEntry describe(DescriptorBuilder* b, const scene_graph::SceneGraph& g, NodeId place, std::uint64_t index,
                    double time_s, double path_m, const Eigen::Isometry3d& world_T_agent) {
  AgentEntry e;
  e.agent = make_node_id('a', index);
  e.time_ns = static_cast<std::uint64_t>(time_s * 1e9);
  e.path_m = path_m;
  e.world_T_agent = world_T_agent;
  EXPECT_TRUE(b->describe(g, place, world_T_agent.translation(), &e.descriptor));
  return e;
}

class DetectorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    graph_ = scene_graph::testing::make_graph();
    std::string error;
    ASSERT_TRUE(builder_.init(DescriptorConfig{}, &error)) << error;
    // These agents carry no depth (nothing for ICP): object registrations are proposed unrefined.
    DetectorConfig config;
    config.propose_unrefined_objects = true;
    ASSERT_TRUE(detector_.init(64, kLocalMap, config, &error)) << error;
  }
  std::unique_ptr<scene_graph::SceneGraph> graph_;
  std::uint64_t places_ = 0, objects_ = 0;
  DescriptorBuilder builder_;
  LoopClosureDetector detector_;
};

TEST_F(DetectorTest, DescriptorsCountThePlacesAndObjectsAroundTheAgent) {
  const NodeId centre = draw_room(graph_.get(), &places_, &objects_, pose(0, 0, 0), kLiving);
  AgentDescriptor d;
  ASSERT_TRUE(builder_.describe(*graph_, centre, Eigen::Vector3d(2, 2, 1), &d));
  EXPECT_EQ(d.num_places, 30u);
  EXPECT_EQ(d.num_objects, 6u);
  EXPECT_FLOAT_EQ(d.objects[10], 2.0f / 6.0f);
  float sum = 0.0f;
  for (float v : d.places) sum += v;
  EXPECT_NEAR(sum, 1.0f, 1e-6f);
  EXPECT_FALSE(builder_.describe(*graph_, make_node_id(scene_graph::kObjectPrefix, 0), Eigen::Vector3d::Zero(), &d))
      << "an object is not a place to start from";
}

// The robot maps the living room, the kitchen 20 m away, then comes back; its odometry has drifted by 0.6 m and 4
// degrees, so the revisit maps a shifted copy of the living room. The detector must propose the closure with the
// true relative pose between the two agents.
TEST_F(DetectorTest, ARevisitWithDriftIsDetectedWithTheTrueRelativePose) {
  const Eigen::Isometry3d living = pose(0, 0, 0), kitchen = pose(20, 0, 0.3);
  const Eigen::Isometry3d drift = pose(0.6, -0.4, 0.07);
  const NodeId a = draw_room(graph_.get(), &places_, &objects_, living, kLiving);
  const NodeId b = draw_room(graph_.get(), &places_, &objects_, kitchen, kKitchen);
  const NodeId c = draw_room(graph_.get(), &places_, &objects_, drift * living, kLiving);
  const Eigen::Isometry3d true_a = pose(2, 2, 0.1), true_c = pose(2.5, 1.5, 2.0);
  LoopClosure lc;
  EXPECT_FALSE(detector_.add_and_detect(describe(&builder_, *graph_, a, 0, 0, 0, true_a), &lc));
  EXPECT_FALSE(detector_.add_and_detect(describe(&builder_, *graph_, b, 1, 60, 25, kitchen * pose(2, 2, 0)), &lc));
  ASSERT_TRUE(detector_.add_and_detect(describe(&builder_, *graph_, c, 2, 120, 50, drift * true_c), &lc));
  EXPECT_EQ(lc.match, make_node_id('a', 0));
  EXPECT_EQ(lc.query, make_node_id('a', 2));
  const Eigen::Isometry3d truth = true_a.inverse() * true_c;
  EXPECT_LT((lc.match_T_query.translation() - truth.translation()).norm(), 0.02);
  EXPECT_LT(Eigen::AngleAxisd(lc.match_T_query.linear().transpose() * truth.linear()).angle(), 0.01);
  EXPECT_EQ(detector_.counters().proposed, 1u);
}

// By default an object registration ICP could not refine (here: no depth at all) is verified, counted and kept out.
TEST_F(DetectorTest, AnUnrefinedObjectRegistrationIsNotProposedByDefault) {
  LoopClosureDetector detector;
  std::string error;
  ASSERT_TRUE(detector.init(64, kLocalMap, DetectorConfig{}, &error)) << error;
  const NodeId a = draw_room(graph_.get(), &places_, &objects_, pose(0, 0, 0), kLiving);
  const NodeId c = draw_room(graph_.get(), &places_, &objects_, pose(0.6, -0.4, 0.07), kLiving);
  LoopClosure lc;
  EXPECT_FALSE(detector.add_and_detect(describe(&builder_, *graph_, a, 0, 0, 0, pose(2, 2, 0.1)), &lc));
  EXPECT_FALSE(detector.add_and_detect(describe(&builder_, *graph_, c, 1, 120, 50, pose(2.5, 1.5, 2.0)), &lc));
  EXPECT_EQ(detector.counters().verifications, 1u);
  EXPECT_EQ(detector.counters().registration_failures, 0u);
  EXPECT_EQ(detector.counters().objects_unrefined, 1u);
  EXPECT_EQ(detector.counters().proposed, 0u);
}

// Three agents described one after another in a room whose objects have the query's labels but not its layout
// rank above the true match (one object more, so a lower objects similarity). The verification of the first
// covers its stretch of the trajectory; the budget of two goes to the next stretch, where the true match is.
// Verified by rank only, both verifications go to the look-alike and nothing is found.
TEST_F(DetectorTest, VerificationsGoToDistinctStretchesOfTheTrajectory) {
  const std::vector<Furniture> look_alike = {{{0.5, 4.0}, 10}, {{4.0, 0.5}, 10}, {{2.5, 2.5}, 5},
                                             {{0.8, 1.9}, 3},  {{5.0, 2.2}, 3},  {{1.0, 0.3}, 14}};
  std::vector<Furniture> living_plus = kLiving;
  living_plus.push_back({{3.8, 3.0}, 7});
  const NodeId a = draw_room(graph_.get(), &places_, &objects_, pose(0, 0, 0), living_plus);
  const NodeId d = draw_room(graph_.get(), &places_, &objects_, pose(30, 0, 0.5), look_alike);
  const NodeId c = draw_room(graph_.get(), &places_, &objects_, pose(0.6, -0.4, 0.07), kLiving);
  for (const double distinct_m : {3.0, 0.0}) {
    SCOPED_TRACE(distinct_m);
    DetectorConfig config;
    config.propose_unrefined_objects = true;  // no depth here: registrations are proposed unrefined
    config.ratio = 1.0;                       // the look-alike would make the place ambiguous
    config.max_verifications = 2;
    config.distinct_verification_m = distinct_m;
    LoopClosureDetector detector;
    std::string error;
    ASSERT_TRUE(detector.init(64, kLocalMap, config, &error)) << error;
    LoopClosure lc;
    EXPECT_FALSE(detector.add_and_detect(describe(&builder_, *graph_, a, 0, 0, 0, pose(2, 2, 0.1)), &lc));
    for (std::uint64_t i = 1; i <= 3; ++i) {
      const Eigen::Isometry3d at = pose(30, 0, 0.5) * pose(1.5 + 0.5 * i, 2, 0);
      EXPECT_FALSE(detector.add_and_detect(describe(&builder_, *graph_, d, i, 30 + i, 10 + i, at), &lc));
    }
    const DetectorCounters before = detector.counters();  // the look-alike's agents were queries too
    const bool found = detector.add_and_detect(describe(&builder_, *graph_, c, 4, 120, 50, pose(2.5, 1.5, 2.0)), &lc);
    const DetectorCounters& after = detector.counters();
    EXPECT_EQ(after.objects_candidates - before.objects_candidates, 4u);
    EXPECT_EQ(after.verifications - before.verifications, 2u);
    const std::uint64_t skipped = after.verifications_skipped - before.verifications_skipped;
    const std::uint64_t failed = after.registration_failures - before.registration_failures;
    if (distinct_m > 0.0) {
      ASSERT_TRUE(found);
      EXPECT_EQ(lc.match, make_node_id('a', 0));
      EXPECT_EQ(skipped, 2u);
      EXPECT_EQ(failed, 1u);
    } else {
      EXPECT_FALSE(found);
      EXPECT_EQ(skipped, 0u);
      EXPECT_EQ(failed, 2u);
    }
  }
}

TEST_F(DetectorTest, TheRecentPastIsNotACandidate) {
  const NodeId a = draw_room(graph_.get(), &places_, &objects_, pose(0, 0, 0), kLiving);
  LoopClosure lc;
  EXPECT_FALSE(detector_.add_and_detect(describe(&builder_, *graph_, a, 0, 0, 0, pose(2, 2, 0)), &lc));
  // The same room 10 s and 3 m later: the robot has not left, this is not a loop.
  EXPECT_FALSE(detector_.add_and_detect(describe(&builder_, *graph_, a, 1, 10, 3, pose(2, 2, 0)), &lc));
  EXPECT_EQ(detector_.counters().places_candidates, 0u);
}

// Three identical rooms (same furniture, same layout) 12 m apart: the third's view matches both earlier ones equally
// well, so the ratio test must refuse to pick one.
TEST_F(DetectorTest, IdenticalRoomsAreAmbiguousAndProposeNothing) {
  NodeId rooms[3];
  for (int r = 0; r < 3; ++r) rooms[r] = draw_room(graph_.get(), &places_, &objects_, pose(12.0 * r, 0, 0), kLiving);
  LoopClosure lc;
  EXPECT_FALSE(detector_.add_and_detect(describe(&builder_, *graph_, rooms[0], 0, 0, 0, pose(2, 2, 0)), &lc));
  // The second room alone matches the first: proposed (a false loop closure the optimizer must reject).
  EXPECT_TRUE(detector_.add_and_detect(describe(&builder_, *graph_, rooms[1], 1, 60, 20, pose(14, 2, 0)), &lc));
  EXPECT_FALSE(detector_.add_and_detect(describe(&builder_, *graph_, rooms[2], 2, 120, 40, pose(26, 2, 0)), &lc));
  EXPECT_GE(detector_.counters().ratio_rejections, 1u);
  EXPECT_EQ(detector_.counters().proposed, 1u);
}

// The tree search must return exactly what a scan would, over hundreds of agents and several rebuilds.
TEST_F(DetectorTest, TreeSearchFindsWhatALinearScanFinds) {
  std::string error;
  DetectorConfig config;
  config.rebuild_batch = 16;
  config.min_objects = 0;
  config.objects_threshold = 1.0;  // empty object histograms score 0: nothing is verified
  LoopClosureDetector tree, scan;
  ASSERT_TRUE(tree.init(600, kLocalMap, config, &error));
  config.rebuild_batch = 100000;  // never rebuilt: every query scans
  ASSERT_TRUE(scan.init(600, kLocalMap, config, &error));
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  LoopClosure lc;
  for (int i = 0; i < 500; ++i) {
    AgentEntry e;
    e.agent = make_node_id('a', static_cast<std::uint64_t>(i));
    e.time_ns = static_cast<std::uint64_t>(i) * 10'000'000'000ull;
    e.path_m = 10.0 * i;
    float sum = 0.0f;
    for (float& v : e.descriptor.places) sum += (v = u(rng) < 0.5f ? 0.0f : u(rng));
    for (float& v : e.descriptor.places) v /= sum;
    e.descriptor.num_places = 10;
    tree.add_and_detect(e, &lc);
    scan.add_and_detect(e, &lc);
  }
  EXPECT_GT(tree.counters().tree_rebuilds, 20u);
  EXPECT_GT(scan.counters().places_candidates, 0u);
  EXPECT_EQ(tree.counters().places_candidates, scan.counters().places_candidates);
}

TEST_F(DetectorTest, AFullDatabaseFoldsItsOlderHalf) {
  std::string error;
  LoopClosureDetector small;
  ASSERT_TRUE(small.init(8, kLocalMap, DetectorConfig{}, &error));
  LoopClosure lc;
  for (int i = 0; i < 9; ++i) {
    AgentEntry e;
    e.agent = make_node_id('a', static_cast<std::uint64_t>(i));
    small.add_and_detect(e, &lc);
  }
  // At the 9th: entries 0..7 fold to 0, 2, 4..7, then 8 joins.
  ASSERT_EQ(small.size(), 7u);
  EXPECT_EQ(small.counters().folds, 1u);
  EXPECT_EQ(small.counters().refused, 0u);
  EXPECT_EQ(small.entry(1).agent, make_node_id('a', 2));
  EXPECT_EQ(small.entry(6).agent, make_node_id('a', 8));
  EXPECT_EQ(small.stats().high_water, 8u);
}

TEST_F(DetectorTest, BadConfigIsRefusedWithTheField) {
  std::string error;
  DetectorConfig c;
  c.places_threshold = 1.5;
  LoopClosureDetector d;
  EXPECT_FALSE(d.init(8, kLocalMap, c, &error));
  EXPECT_NE(error.find("places_threshold"), std::string::npos) << error;
}

}  // namespace
}  // namespace qsg::loop_closure
