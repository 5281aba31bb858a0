// The backend stage driven on its own, as the app and the evaluations drive it: rooms and labels in one call, its
// stores and counters, loop closure off and on, and a clear error when its stores exceed their arena.
#include "core/backend/backend_stage.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "budgets/budget_table.h"
#include "tests/rooms/synthetic_places.h"

namespace qsg::backend {
namespace {

namespace sg = scene_graph;

sg::Capacities graph_capacities() { return rooms::testing::small_graph_capacities(); }

std::unique_ptr<sg::SceneGraph> make_graph() {
  auto g = std::make_unique<sg::SceneGraph>();
  std::string error;
  EXPECT_TRUE(g->init(graph_capacities(), sg::SceneGraph::plan(graph_capacities()).total_bytes(), &error)) << error;
  return g;
}

// Two rooms joined by a door, with an object hanging from a place of each.
std::unique_ptr<sg::SceneGraph> two_rooms_with_objects(rooms::testing::SyntheticPlaces* s) {
  rooms::testing::two_rooms_plan().add_to(s, 1.0);
  auto g = make_graph();
  EXPECT_TRUE(s->write(g.get()));
  const sg::NodeId first = s->places.front().id, last = s->places.back().id;
  std::uint64_t k = 0;
  for (const auto& [place, label] : {std::pair{first, semantics::kBed}, std::pair{last, semantics::kToilet}}) {
    sg::ObjectAttributes o;
    o.semantic_label = label;
    o.position_m = g->place(place)->position_m;
    o.bounding_box = sg::BoundingBox::aabb(o.position_m - Eigen::Vector3d::Constant(0.4),
                                           o.position_m + Eigen::Vector3d::Constant(0.4));
    const sg::NodeId id = sg::make_node_id(sg::kObjectPrefix, k++);
    EXPECT_EQ(g->add_object(id, o), sg::Status::kOk);
    EXPECT_EQ(g->add_edge(place, id), sg::Status::kOk);
  }
  return g;
}

std::set<std::string> store_names(const BackendStage& stage, bool with_door_set = true) {
  std::set<std::string> names;
  stage.for_each_resource([&](const memory::ResourceStats& s) { names.insert(s.name); }, with_door_set);
  return names;
}

TEST(BackendStageTest, LocalMapClosuresCarryTheOdometryWalkOfTheirStitching) {
  LoopClosureConfig config;
  config.deformation.agents.sigma_t_m_per_sqrt_m = 0.02;
  config.deformation.agents.sigma_yaw_rad_per_sqrt_m = 0.003;
  config.detector.local_map.path_m = 4.0;
  loop_closure::LoopClosure keyframe;
  keyframe.source = loop_closure::ClosureSource::kObjects;
  keyframe.refined = true;
  keyframe.icp.rmse_m = 0.01;
  Eigen::Vector3d t_kf, r_kf, t_lm, r_lm;
  closure_sigmas(keyframe, config, &t_kf, &r_kf);
  EXPECT_DOUBLE_EQ(t_kf.x(), 0.02);  // the ICP's floor
  EXPECT_DOUBLE_EQ(r_kf.x(), 0.005);
  loop_closure::LoopClosure local = keyframe;
  local.local_map = true;
  closure_sigmas(local, config, &t_lm, &r_lm);
  // Walk over 4 m: 0.02 * 2 = 0.04 m and 0.003 * 2 = 0.006 rad, in quadrature with the keyframe ICP's sigmas.
  EXPECT_NEAR(t_lm.x(), std::hypot(0.02, 0.04), 1e-12);
  EXPECT_NEAR(r_lm.z(), std::hypot(0.005, 0.006), 1e-12);
  config.detector.local_map.path_m = 1.0;
  closure_sigmas(local, config, &t_lm, &r_lm);
  EXPECT_NEAR(t_lm.y(), std::hypot(0.02, 0.02), 1e-12);
}

// A closure whose agent the chain folded away joins the nearest chain node through the odometry between them: an
// exact closure between two keyframes gives the exact relative pose of the two chain nodes it lands on.
TEST(BackendStageTest, AClosureToAFoldedAgentJoinsItsNodeThroughTheOdometry) {
  auto g = make_graph();
  agents::AgentLayer agents;
  std::string error;
  ASSERT_TRUE(agents.init(agents::Config{}, agents::Capacities{10}, &error)) << error;
  std::vector<Eigen::Isometry3d> poses;
  std::vector<std::uint64_t> times;
  for (int k = 0; k < 30; ++k) {  // a 1 m step and a 12 degree turn per keyframe: a curling walk
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    if (!poses.empty()) pose = poses.back() * Eigen::Translation3d(1.0, 0.0, 0.0) *
                               Eigen::AngleAxisd(0.2094, Eigen::Vector3d::UnitZ());
    poses.push_back(pose);
    times.push_back(1'000'000'000ull * (k + 1));
    ASSERT_NE(agents.add_keyframe(g.get(), times.back(), pose), agents::AddResult::kFull);
  }
  ASSERT_GT(agents.counters().folded, 0u) << "the test needs a folded chain";
  const auto node_of = [&](std::uint64_t t) {
    for (std::size_t i = 0; i < agents.chain_size(); ++i)
      if (agents.chain(i).time_ns == t) return static_cast<int>(i);
    return -1;
  };
  int folded = -1;
  for (int k = 1; k < 10 && folded < 0; ++k)
    if (node_of(times[k]) < 0) folded = k;
  ASSERT_GE(folded, 0);
  const auto closure = [&](int m, int q) {
    loop_closure::LoopClosure lc;
    lc.match_time_ns = times[m];
    lc.query_time_ns = times[q];
    lc.world_T_match = poses[m];
    lc.world_T_query = poses[q];
    lc.match_T_query = poses[m].inverse() * poses[q];  // exact
    return lc;
  };
  const auto iso = [](const agents::ChainNode& n) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = n.q.toRotationMatrix();
    T.translation() = n.t_m;
    return T;
  };
  ChainLoopClosure cc;
  ASSERT_TRUE(chain_closure(agents, closure(folded, 29), LoopClosureConfig{}, &cc));
  ASSERT_NE(agents.chain(cc.a).time_ns, times[folded]);
  const Eigen::Isometry3d nodes = iso(agents.chain(cc.a)).inverse() * iso(agents.chain(cc.b));
  EXPECT_LT((cc.a_T_b.t_m - nodes.translation()).norm(), 1e-9);
  EXPECT_LT(Eigen::AngleAxisd(cc.a_T_b.q.toRotationMatrix().transpose() * nodes.linear()).angle(), 1e-9);
  const Eigen::Isometry3d raw = closure(folded, 29).match_T_query;
  EXPECT_GT((raw.translation() - nodes.translation()).norm(), 0.5) << "taken as it was, it would be off";
  // The join adds the odometry's walk over the distance joined to the closure's own sigmas.
  const LoopClosureConfig config;
  Eigen::Vector3d own_t, own_rot;
  closure_sigmas(closure(folded, 29), config, &own_t, &own_rot);
  const double joined = (agents.chain(cc.a).t_m - poses[folded].translation()).norm() +
                        (agents.chain(cc.b).t_m - poses[29].translation()).norm();
  ASSERT_GT(joined, 0.5);
  const AgentGraphConfig& walk = config.deformation.agents;
  EXPECT_NEAR(cc.sigma_t_m.x(), std::hypot(own_t.x(), walk.sigma_t_m_per_sqrt_m * std::sqrt(joined)), 1e-12);
  EXPECT_NEAR(cc.sigma_rot_rad.z(), std::hypot(own_rot.z(), walk.sigma_yaw_rad_per_sqrt_m * std::sqrt(joined)), 1e-12);
  // Both agents still in the chain: the measured pose as it is.
  const int kept = node_of(times[28]) >= 0 ? 28 : 27;
  ASSERT_GE(node_of(times[kept]), 0);
  const int first_kept = node_of(times[0]) >= 0 ? 0 : -1;
  if (first_kept == 0) {
    ASSERT_TRUE(chain_closure(agents, closure(0, kept), LoopClosureConfig{}, &cc));
    EXPECT_EQ(cc.a_T_b.t_m, closure(0, kept).match_T_query.translation());
    closure_sigmas(closure(0, kept), config, &own_t, &own_rot);
    EXPECT_EQ(cc.sigma_t_m, own_t) << "nothing joined, nothing added";
  }
  EXPECT_FALSE(chain_closure(agents, closure(kept, kept), LoopClosureConfig{}, &cc)) << "one node";
}

// A full closure store folds its older half: the last solve's outliers first; when they free less than a quarter of
// the store, every second closure left there too. The newer half stays whole, outliers and all.
TEST(BackendStageTest, AFullClosureStoreFoldsItsOlderHalfOutliersFirst) {
  using Closures = std::vector<loop_closure::LoopClosure>;
  const auto store = [](std::size_t n) {
    Closures v(n);
    for (std::size_t k = 0; k < n; ++k) v[k].query_time_ns = k + 1;
    return v;
  };
  const auto times = [](const Closures& v) {
    std::vector<std::uint64_t> t;
    for (const auto& lc : v) t.push_back(lc.query_time_ns);
    return t;
  };
  {
    SCOPED_TRACE("enough outliers in the older half");
    Closures v = store(8);
    const auto* data = v.data();
    const std::set<std::uint64_t> outliers = {2, 3, 7};
    const auto rejected = [&](const loop_closure::LoopClosure& lc) { return outliers.count(lc.query_time_ns) > 0; };
    EXPECT_EQ(fold_loop_closures(&v, rejected), 2u);
    EXPECT_EQ(times(v), (std::vector<std::uint64_t>{1, 4, 5, 6, 7, 8})) << "the newer half's outlier stays";
    EXPECT_EQ(v.data(), data) << "in place";
  }
  {
    SCOPED_TRACE("no outliers: every second closure of the older half");
    Closures v = store(8);
    EXPECT_EQ(fold_loop_closures(&v, [](const loop_closure::LoopClosure&) { return false; }), 2u);
    EXPECT_EQ(times(v), (std::vector<std::uint64_t>{1, 3, 5, 6, 7, 8}));
  }
  {
    SCOPED_TRACE("one outlier is too few: it goes, then every second closure left");
    Closures v = store(8);
    EXPECT_EQ(fold_loop_closures(&v, [](const loop_closure::LoopClosure& lc) { return lc.query_time_ns == 1; }), 2u);
    EXPECT_EQ(times(v), (std::vector<std::uint64_t>{2, 4, 5, 6, 7, 8}));
  }
}

TEST(BackendStageTest, RoomsAndTheirLabelsInOneUpdate) {
  rooms::testing::SyntheticPlaces s;
  auto g = two_rooms_with_objects(&s);
  BackendStage stage;
  BackendStage::Config c;
  c.doors_online = false;
  c.loop_closure.enabled = false;
  std::string error, warning;
  ASSERT_TRUE(stage.init(c, graph_capacities(), 0, 0, &error, &warning)) << error;
  EXPECT_TRUE(warning.empty()) << warning;  // the shipped weights load
  const rooms::UpdateResult r = stage.update_rooms(g.get(), 1'000'000'000);
  ASSERT_EQ(r.outcome, rooms::Outcome::kOk) << rooms::to_string(r.outcome);
  EXPECT_EQ(r.rooms, 2u);
  EXPECT_EQ(stage.counters().updates.load(), 1u);
  EXPECT_EQ(stage.counters().rooms.load(), 2u);
  // Each room holds one informative object: both get a label, and the stage says so.
  std::size_t labelled = 0;
  g->for_each_node([&](const sg::NodeRecord& n) {
    if (n.kind != sg::NodeKind::kRoom) return;
    const sg::RoomAttributes* a = g->room(n.id);
    labelled += a->semantic_label != semantics::kRoomUnknown ? 1 : 0;
    EXPECT_FALSE(a->class_probabilities.empty());
  });
  EXPECT_EQ(labelled, 2u);
  EXPECT_EQ(stage.counters().rooms_labelled.load(), 2u);
  // Loop closure off: no loop-closure store, and nothing to solve or correct.
  const std::set<std::string> names = store_names(stage);
  EXPECT_EQ(names.count("loop_closure.closures"), 0u);
  EXPECT_FALSE(stage.solve_due(1'000'000'000));
  EXPECT_FALSE(stage.solved());
}

// After a window update only the rooms it wrote are classified; a room away from the robot keeps its label until
// the final update classifies every room.
TEST(BackendStageTest, WindowUpdateLabelsOnlyTheRoomsItWrote) {
  rooms::testing::SyntheticPlaces s;
  auto g = two_rooms_with_objects(&s);
  BackendStage stage;
  BackendStage::Config c;
  c.doors_online = false;
  std::string error, warning;
  ASSERT_TRUE(stage.init(c, graph_capacities(), 0, 0, &error, &warning)) << error;
  ASSERT_EQ(stage.update_rooms(g.get(), 1'000'000'000).rooms, 2u);
  const sg::NodeId a = g->parent(s.places.front().id), b = g->parent(s.places.back().id);
  ASSERT_NE(a, sg::kNoNode);
  ASSERT_NE(b, sg::kNoNode);
  ASSERT_NE(a, b);
  const semantics::RoomLabel predicted = g->room(b)->semantic_label;
  ASSERT_NE(predicted, semantics::kRoomUnknown);
  // The robot in room a: b holds no active place, and carries a label the classifier did not give it.
  for (const auto& p : s.places) g->place(p.id)->is_active = g->parent(p.id) == a;
  const auto other = static_cast<semantics::RoomLabel>(predicted == 1 ? 2 : 1);
  g->room(b)->semantic_label = other;
  const rooms::UpdateResult r = stage.update_rooms(g.get(), 2'000'000'000);
  ASSERT_TRUE(r.window);
  EXPECT_EQ(g->room(b)->last_update_time_ns, 1'000'000'000u) << "room b was rewritten";
  EXPECT_EQ(g->room(b)->semantic_label, other) << "a room the window update did not write was classified";
  EXPECT_EQ(g->room(a)->last_update_time_ns, 2'000'000'000u);
  EXPECT_NE(g->room(a)->semantic_label, semantics::kRoomUnknown);
  EXPECT_EQ(stage.counters().rooms_labelled.load(), 2u);  // a classified, b's kept label
  stage.update_rooms(g.get(), 3'000'000'000, /*final=*/true);
  EXPECT_EQ(g->room(b)->semantic_label, predicted) << "the final update classifies every room";
}

TEST(BackendStageTest, MissingWeightsAreAWarningAndRoomsStayUnknown) {
  rooms::testing::SyntheticPlaces s;
  auto g = two_rooms_with_objects(&s);
  BackendStage stage;
  BackendStage::Config c;
  c.doors_online = false;
  c.room_weights_path = "/nonexistent/room_classifier.json";
  std::string error, warning;
  ASSERT_TRUE(stage.init(c, graph_capacities(), 0, 0, &error, &warning)) << error;
  EXPECT_NE(warning.find("room labels off"), std::string::npos) << warning;
  EXPECT_EQ(stage.update_rooms(g.get(), 0).rooms, 2u);
  EXPECT_EQ(stage.counters().rooms_labelled.load(), 0u);
}

TEST(BackendStageTest, LoopClosureStoresAreCarvedAndReported) {
  BackendStage stage;
  BackendStage::Config c;
  c.loop_closure.enabled = true;
  std::string error, warning;
  ASSERT_TRUE(stage.init(c, graph_capacities(), 64, 0, &error, &warning)) << error;
  const std::set<std::string> names = store_names(stage);
  EXPECT_EQ(names.count("loop_closure.closures"), 1u);
  EXPECT_EQ(names.count(stage.control_points().stats().name), 1u);
  // The door set is left out for a reader on another thread; the online doors' arena is still reported.
  EXPECT_LT(store_names(stage, false).size(), names.size());
  // No agents yet: nothing described, nothing detected, nothing to solve.
  auto g = make_graph();
  agents::AgentLayer agents;
  EXPECT_FALSE(stage.detect_loop_closures(*g, agents, 100'000'000'000ull));
  EXPECT_FALSE(stage.solve_due(100'000'000'000ull));
  EXPECT_EQ(stage.counters().agents_described.load(), 0u);
  // The closure store's capacity: the budget's by default, a smaller one when configured, never a larger one.
  const auto closures_capacity = [](const BackendStage& s) {
    std::size_t capacity = 0;
    s.for_each_resource([&](const memory::ResourceStats& r) {
      if (std::string(r.name) == "loop_closure.closures") capacity = r.capacity;
    });
    return capacity;
  };
  EXPECT_EQ(closures_capacity(stage), budgets::active::loop_closure::kLoopClosures);
  for (const std::uint32_t capacity :
       {2u, static_cast<std::uint32_t>(budgets::active::loop_closure::kLoopClosures + 1)}) {
    BackendStage small;
    c.loop_closure.closure_capacity = capacity;
    EXPECT_FALSE(small.init(c, graph_capacities(), 64, 0, &error, &warning));
    EXPECT_NE(error.find("loop_closure.closure_capacity"), std::string::npos) << error;
  }
  BackendStage small;
  c.loop_closure.closure_capacity = 16;
  ASSERT_TRUE(small.init(c, graph_capacities(), 64, 0, &error, &warning)) << error;
  EXPECT_EQ(closures_capacity(small), 16u);
}

// The detect hook (the app's stage markers) brackets each described agent's lookup and verification: the agents
// whose keyframe appearance the stage holds and that have a place, once each, in chain order.
TEST(BackendStageTest, DetectHookBracketsEachDescribedAgentsLookup) {
  BackendStage stage;
  BackendStage::Config c;
  c.loop_closure.enabled = true;
  std::string error, warning;
  ASSERT_TRUE(stage.init(c, graph_capacities(), 64, 0, &error, &warning)) << error;
  auto g = make_graph();
  agents::AgentLayer agents;
  ASSERT_TRUE(agents.init(agents::Config{}, agents::Capacities{64}, &error)) << error;
  for (int k = 0; k < 6; ++k) {
    const Eigen::Isometry3d pose(Eigen::Translation3d(1.0 * k, 0.0, 0.0));
    ASSERT_EQ(agents.add_keyframe(g.get(), 1'000'000'000ull * (k + 1), pose), agents::AddResult::kAdded);
  }
  const int w = 32, h = 24;
  std::vector<std::uint8_t> grey(w * h, 128);
  std::vector<float> depth(w * h, 2.0f);
  loop_closure::GreyDepthView view{grey.data(), depth.data(), w, h, 30.0, 30.0, 15.5, 11.5};
  for (std::size_t k : {1u, 3u, 4u}) stage.add_appearance(agents.chain(k).id, agents.chain(k).time_ns, view);
  struct Calls {
    std::vector<std::pair<bool, std::uint64_t>> seen;
  } calls;
  stage.set_detect_hook(
      [](void* user, bool begin, std::uint64_t t) { static_cast<Calls*>(user)->seen.emplace_back(begin, t); },
      &calls);
  // Agent 1 has no place: it is not described. Agents 3 and 4 each hang from a place.
  for (std::size_t k : {3u, 4u}) {
    const sg::NodeId place = sg::make_node_id(sg::kPlacePrefix, k);
    sg::PlaceAttributes a;
    a.position_m = agents.chain(k).t_m;
    ASSERT_EQ(g->add_place(place, a), sg::Status::kOk);
    ASSERT_EQ(g->add_edge(agents.chain(k).id, place), sg::Status::kOk);
  }
  EXPECT_EQ(stage.describe_agents(*g, agents, 1000'000'000'000ull), 2u);
  EXPECT_TRUE(calls.seen.empty());  // described under the lock; looked up after it
  EXPECT_FALSE(stage.detect_described());  // nothing earlier to match
  ASSERT_EQ(calls.seen.size(), 4u);
  EXPECT_EQ(stage.counters().agents_described.load(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const std::uint64_t t = agents.chain(std::vector<std::size_t>{3, 4}[i]).time_ns;
    EXPECT_EQ(calls.seen[2 * i], std::make_pair(true, t));
    EXPECT_EQ(calls.seen[2 * i + 1], std::make_pair(false, t));
  }
  // Described already: a later call looks at nobody.
  EXPECT_FALSE(stage.detect_loop_closures(*g, agents, 1001'000'000'000ull));
  EXPECT_EQ(calls.seen.size(), 4u);
}

// Adds a keyframe agent at `pose` and `time_ns` with a flat grey keyframe for its appearance and a place it hangs
// from (index `k`): an agent describe_agents() describes once it is past the horizon.
void add_described_agent(BackendStage* stage, sg::SceneGraph* g, agents::AgentLayer* agents, std::uint64_t time_ns,
                         const Eigen::Isometry3d& pose, std::uint64_t k) {
  constexpr int w = 32, h = 24;
  static const std::vector<std::uint8_t> grey(w * h, 128);
  static const std::vector<float> depth(w * h, 2.0f);
  const loop_closure::GreyDepthView view{grey.data(), depth.data(), w, h, 30.0, 30.0, 15.5, 11.5};
  ASSERT_EQ(agents->add_keyframe(g, time_ns, pose), agents::AddResult::kAdded);
  const agents::ChainNode& n = agents->chain(agents->chain_size() - 1);
  stage->add_appearance(n.id, n.time_ns, view);
  const sg::NodeId place = sg::make_node_id(sg::kPlacePrefix, k);
  sg::PlaceAttributes a;
  a.position_m = n.t_m;
  ASSERT_EQ(g->add_place(place, a), sg::Status::kOk);
  ASSERT_EQ(g->add_edge(n.id, place), sg::Status::kOk);
}

// While mapping, an agent is described once the robot is horizon_s past it; at the finish the map is final and the
// last horizon_s's agents are described too (a tour's return to its start is among them).
TEST(BackendStageTest, TheFinishDescribesTheAgentsOfTheLastHorizon) {
  BackendStage stage;
  BackendStage::Config c;
  c.loop_closure.enabled = true;
  c.loop_closure.horizon_s = 15.0;
  std::string error, warning;
  ASSERT_TRUE(stage.init(c, graph_capacities(), 64, 0, &error, &warning)) << error;
  auto g = make_graph();
  agents::AgentLayer agents;
  ASSERT_TRUE(agents.init(agents::Config{}, agents::Capacities{64}, &error)) << error;
  for (int k = 0; k < 4; ++k) {  // agents at 20, 25, 30 and 35 s, each with its keyframe and a place
    const Eigen::Isometry3d pose(Eigen::Translation3d(1.0 * k, 0.0, 0.0));
    add_described_agent(&stage, g.get(), &agents, 5'000'000'000ull * (k + 4), pose, static_cast<std::uint64_t>(k));
    ASSERT_FALSE(::testing::Test::HasFatalFailure());
  }
  const std::uint64_t last_ns = 35'000'000'000ull;
  EXPECT_EQ(stage.describe_agents(*g, agents, last_ns), 1u) << "only the agent 15 s behind the robot";
  stage.detect_described();
  stage.detect_at_finish(*g, agents, last_ns);
  EXPECT_EQ(stage.counters().agents_described.load(), 4u) << "the finish describes the last 15 s too";
}

// The path an agent is described at is the odometry's: when the frontend changes frame (a solve's correction,
// map_in_corrected_frame) the mapped positions jump, and the jump is not travel. Agents 1 m apart along x, the
// last two mapped in a frame moved 5 m sideways: the path to the last is 3 m, not 3 + 5.
TEST(BackendStageTest, TheDescribedPathIsTheOdometrysNotTheMappedJump) {
  BackendStage stage;
  BackendStage::Config c;
  c.loop_closure.enabled = true;
  c.loop_closure.horizon_s = 1.0;
  std::string error, warning;
  ASSERT_TRUE(stage.init(c, graph_capacities(), 64, 0, &error, &warning)) << error;
  auto g = make_graph();
  agents::AgentLayer agents;
  ASSERT_TRUE(agents.init(agents::Config{}, agents::Capacities{64}, &error)) << error;
  const Eigen::Isometry3d shifted(Eigen::Translation3d(0.0, 5.0, 0.0));
  for (int k = 0; k < 4; ++k) {
    if (k == 2) agents.set_frame_correction(shifted);
    const Eigen::Isometry3d odometric(Eigen::Translation3d(1.0 * k, 0.0, 0.0));
    const Eigen::Isometry3d mapped = k >= 2 ? shifted * odometric : odometric;
    add_described_agent(&stage, g.get(), &agents, 5'000'000'000ull * (k + 1), mapped, static_cast<std::uint64_t>(k));
    ASSERT_FALSE(::testing::Test::HasFatalFailure());
  }
  ASSERT_NEAR(agents.chain(3).t_m.y(), 5.0, 1e-12) << "the last agents are mapped in the shifted frame";
  EXPECT_EQ(stage.describe_agents(*g, agents, 100'000'000'000ull), 4u);
  stage.detect_described();
  ASSERT_EQ(stage.detector().size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(stage.detector().entry(i).path_m, 1.0 * i, 1e-9) << i;
}

TEST(BackendStageTest, StoresOverTheirArenaAreAClearError) {
  BackendStage stage;
  BackendStage::Config c;
  c.loop_closure.enabled = true;
  std::string error, warning;
  EXPECT_FALSE(stage.init(c, graph_capacities(), 0, budgets::active::loop_closure::kArenaBytes + 1, &error, &warning));
  EXPECT_NE(error.find("loop_closure"), std::string::npos) << error;
}

// The reconciliation after a correction: revisited places merged, objects boxed from the mesh.
TEST(BackendStageTest, ReconciliationMergesRevisitedPlacesAndBoxesObjectsFromTheMesh) {
  auto g = make_graph();
  const auto place = [&](std::uint64_t k, const Eigen::Vector3d& p, double clearance_m) {
    sg::PlaceAttributes a;
    a.position_m = p;
    a.distance_m = clearance_m;
    const sg::NodeId id = sg::make_node_id(sg::kPlacePrefix, k);
    EXPECT_EQ(g->add_place(id, a), sg::Status::kOk);
    return id;
  };
  // A place and its revisit 0.3 m away in the same free space (1 m clearance): one place. Two places 0.3 m apart
  // either side of a wall (0.2 m clearance each): both stay. A place 2 m away: stays.
  const sg::NodeId first = place(0, {0, 0, 1}, 1.0), revisit = place(1, {0.3, 0, 1}, 1.0);
  const sg::NodeId wall_a = place(2, {5, 0, 1}, 0.2), wall_b = place(3, {5.3, 0, 1}, 0.2);
  const sg::NodeId far = place(4, {0, 2, 1}, 1.0);
  ASSERT_EQ(g->add_edge(revisit, far), sg::Status::kOk);
  // Two chairs, one centred in the other's box; a table at the same spot; a chair elsewhere.
  const auto object = [&](std::uint64_t k, semantics::Label label, const Eigen::Vector3d& c, double half_m) {
    sg::ObjectAttributes o;
    o.semantic_label = label;
    o.position_m = c;
    o.bounding_box = sg::BoundingBox::aabb(c - Eigen::Vector3d::Constant(half_m), c + Eigen::Vector3d::Constant(half_m));
    const sg::NodeId id = sg::make_node_id(sg::kObjectPrefix, k);
    EXPECT_EQ(g->add_object(id, o), sg::Status::kOk);
    return id;
  };
  const sg::NodeId chair = object(0, semantics::kChair, {1, 1, 0.5}, 0.3);
  const sg::NodeId chair_again = object(1, semantics::kChair, {1.2, 1, 0.5}, 0.3);
  const sg::NodeId table = object(2, semantics::kTable, {1.1, 1, 0.5}, 0.3);
  const sg::NodeId other_chair = object(3, semantics::kChair, {4, 4, 0.5}, 0.3);
  // The corrected mesh: the first chair's vertices span x 0.8 .. 1.6, y 0.8 .. 1.3, z 0.3 .. 0.8; the second chair
  // has fewer, inside that box; the table none.
  reconstruction::Mesh mesh;
  for (double x : {0.8, 1.0, 1.2, 1.4, 1.6}) mesh.vertices.push_back({static_cast<float>(x), 1.0f, 0.5f});
  mesh.vertices.push_back({1.2f, 0.8f, 0.3f});
  mesh.vertices.push_back({1.2f, 1.3f, 0.8f});
  mesh.vertices.push_back({1.3f, 1.2f, 0.6f});
  std::unordered_map<sg::NodeId, std::vector<std::uint32_t>> indices;
  indices[chair] = {0, 1, 2, 3, 4, 5, 6};
  indices[chair_again] = {7};

  BackendStage stage;
  BackendStage::Config c;
  c.doors_online = false;
  std::string error, warning;
  ASSERT_TRUE(stage.init(c, graph_capacities(), 0, 0, &error, &warning)) << error;
  const BackendStage::Reconciliation r = stage.reconcile(mesh, indices, g.get());
  EXPECT_EQ(r.objects_from_mesh, 2u);
  EXPECT_EQ(r.places_merged, 1u);
  EXPECT_EQ(g->place(revisit), nullptr) << "the revisit merged into the older place";
  EXPECT_TRUE(g->has_edge(first, far)) << "its edges moved with it";
  EXPECT_NE(g->place(wall_a), nullptr);
  EXPECT_NE(g->place(wall_b), nullptr) << "places that do not share free space stay apart";
  // Objects are re-boxed, not merged (objects::merge_revisits does that next, tests/objects/revisit_merge_test.cc).
  ASSERT_NE(g->object(chair), nullptr);
  ASSERT_NE(g->object(chair_again), nullptr);
  EXPECT_NE(g->object(table), nullptr) << "no vertices: keeps its box";
  EXPECT_NE(g->object(other_chair), nullptr);
  // Each chair: centre and box from its own vertices in the corrected mesh.
  const sg::ObjectAttributes* kept = g->object(chair);
  EXPECT_NEAR(kept->position_m.x(), (0.8 + 1.0 + 1.2 + 1.4 + 1.6 + 1.2 + 1.2) / 7.0, 1e-6);
  EXPECT_NEAR(kept->bounding_box.min_m.x(), 0.8, 1e-6);
  EXPECT_NEAR(kept->bounding_box.max_m.x(), 1.6, 1e-6);
  EXPECT_NEAR(kept->bounding_box.max_m.y(), 1.3, 1e-6);
  EXPECT_NEAR(g->object(chair_again)->position_m.x(), 1.3, 1e-6);
  EXPECT_NEAR(g->object(table)->position_m.x(), 1.1, 1e-6);

  // Place merging off: nothing merges, objects are still boxed from the mesh.
  auto g2 = make_graph();
  g.swap(g2);
  place(0, {0, 0, 1}, 1.0);
  place(1, {0.3, 0, 1}, 1.0);
  BackendStage off;
  c.loop_closure.merge_places_within_m = 0.0;
  ASSERT_TRUE(off.init(c, graph_capacities(), 0, 0, &error, &warning)) << error;
  const BackendStage::Reconciliation r2 = off.reconcile(mesh, {}, g.get());
  EXPECT_EQ(r2.places_merged, 0u);
  EXPECT_EQ(r2.objects_from_mesh, 0u);
}

}  // namespace
}  // namespace qsg::backend
