// The evaluations' shared harness (bench/eval_harness.h) on a small rendered building: it must build the same graph
// as the frontend driven by hand in the app's order (integrate, observe, agent node, a frontend update every Nth
// keyframe, updates until a places cycle completes), keep its cadences (frontend updates, online door passes), and
// end with the final door stage and rooms on the whole map.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "bench/eval_harness.h"
#include "bench/sim_tour.h"
#include "core/frontend/frontend.h"
#include "core/reconstruction/semantic_tsdf.h"
#include "core/scene_graph/scene_graph.h"
#include "drivers/world/building_generator.h"

namespace qsg::bench {
namespace {

struct Tour {
  world::World world;
  SimTour tour;
};

std::unique_ptr<Tour> small_tour() {
  auto t = std::make_unique<Tour>();
  world::BuildingConfig bc;
  bc.num_rooms = 3;
  bc.seed = 3;
  bc.room_size_max_m = 4.0;
  t->world = world::generate_building(bc);
  sim::ExplorationConfig ec;
  sim::SimCamera::Config cc;
  cc.intrinsics = camera_of_fov(160, 120, 90.0);
  cc.rate_hz = ec.speed_m_s / 0.5;  // a keyframe every 0.5 m
  std::string error;
  EXPECT_TRUE(make_sim_tour(t->world, ec, cc, render::Renderer::Config{}, &t->tour, &error)) << error;
  return t;
}

std::unique_ptr<scene_graph::SceneGraph> budget_graph() {
  auto g = std::make_unique<scene_graph::SceneGraph>();
  std::string error;
  EXPECT_TRUE(g->init(scene_graph::capacities_from_budget(), scene_graph::arena_bytes_from_budget(), &error)) << error;
  return g;
}

struct GraphCounts {
  std::size_t places = 0, objects = 0, agents = 0, edges = 0;
};

GraphCounts counts(const scene_graph::SceneGraph& g) {
  return {g.num_nodes(scene_graph::NodeKind::kPlace), g.num_nodes(scene_graph::NodeKind::kObject),
          g.num_nodes(scene_graph::NodeKind::kAgent), g.num_edges()};
}

TEST(EvalHarnessTest, BuildsTheGraphOfTheFrontendDrivenInTheAppsOrder) {
  constexpr std::uint32_t kEvery = 3;
  std::unique_ptr<Tour> t = small_tour();
  ASSERT_TRUE(t->tour.camera != nullptr);

  PipelineConfig config;
  config.frontend_every_n = kEvery;
  auto graph = budget_graph();
  EvalPipeline pipeline;
  std::string error;
  ASSERT_TRUE(pipeline.init(config, graph.get(), &error)) << error;
  std::vector<std::size_t> stepped;
  Eigen::Vector3d last = Eigen::Vector3d::Zero();
  std::uint64_t t_last = 0;
  const std::size_t keyframes = pipeline.explore(t->tour, [&](const FrontendStep& step) {
    stepped.push_back(step.keyframe);
    last = step.world_T_camera.translation();
    t_last = step.time_ns;
  });
  pipeline.finish(last, t_last);
  ASSERT_GT(keyframes, 20u);
  ASSERT_EQ(stepped.size(), (keyframes + kEvery - 1) / kEvery);
  for (std::size_t i = 0; i < stepped.size(); ++i) EXPECT_EQ(stepped[i], 1 + i * kEvery);
  EXPECT_EQ(pipeline.integrate_ms().size(), keyframes);

  // The same frames through a frontend wired by hand in the app's order.
  std::unique_ptr<Tour> again = small_tour();
  auto hand_graph = budget_graph();
  reconstruction::SemanticTsdf tsdf;
  ASSERT_TRUE(tsdf.init(reconstruction::Config{}, reconstruction::capacities_from_budget(),
                        budgets::active::reconstruction::kArenaBytes, &error))
      << error;
  frontend::Frontend fe;
  ASSERT_TRUE(fe.init(frontend::Config{}, &error)) << error;
  std::size_t n = 0;
  auto frame = std::make_unique<messages::RgbdFrame>();
  for_each_posed_frame(again->tour, *frame,
                       [&](const messages::RgbdFrame& f, const Eigen::Isometry3d& T, std::int64_t t_ns,
                           const Eigen::Isometry3d&) {
                         tsdf.process(f, T);
                         fe.observe(tsdf, T);
                         fe.add_keyframe(hand_graph.get(), static_cast<std::uint64_t>(t_ns), T);
                         if (n++ % kEvery == 0)
                           fe.update(tsdf, T.translation(), static_cast<std::uint64_t>(t_ns), hand_graph.get(),
                                     frontend::Deadline{});
                       });
  for (int i = 0; i < 100; ++i)
    if (fe.update(tsdf, last, t_last, hand_graph.get(), frontend::Deadline{}).places_complete) break;
  const GraphCounts a = counts(*graph), b = counts(*hand_graph);
  EXPECT_GT(a.places, 10u);
  EXPECT_EQ(a.places, b.places);
  EXPECT_EQ(a.objects, b.objects);
  EXPECT_EQ(a.agents, b.agents);
  EXPECT_LE(a.agents, keyframes);  // keyframes that did not move fold into the previous node
  EXPECT_GT(a.agents, keyframes / 2);
  EXPECT_EQ(a.edges, b.edges);
}

TEST(EvalHarnessTest, RunsTheDoorPassesAndTheFinalRooms) {
  std::unique_ptr<Tour> t = small_tour();
  ASSERT_TRUE(t->tour.camera != nullptr);
  PipelineConfig config;
  config.backend = true;
  config.backend_stage.doors_online = true;
  config.backend_stage.doors_online_every_n = 4;
  auto graph = budget_graph();
  EvalPipeline pipeline;
  std::string error;
  ASSERT_TRUE(pipeline.init(config, graph.get(), &error)) << error;
  std::size_t steps = 0, passes = 0;
  Eigen::Vector3d last = Eigen::Vector3d::Zero();
  pipeline.explore(t->tour, [&](const FrontendStep& step) {
    passes += step.door_pass ? 1 : 0;
    // A pass runs only on the updates it is due on (every 4th, from the first).
    if (step.door_pass) {
      EXPECT_EQ(steps % 4, 0u) << "update " << steps;
    }
    ++steps;
    last = step.world_T_camera.translation();
  });
  const FrontendStep end = pipeline.finish(last, 0);
  passes += end.door_pass ? 1 : 0;
  EXPECT_GT(passes, 0u);
  EXPECT_EQ(passes, pipeline.backend().counters().door_passes.load());

  reconstruction::Mesh mesh;
  pipeline.tsdf().extract_full_mesh(&mesh);
  std::vector<EdgeBefore> changed;
  const backend::BackendStage::FinalDoors doors = pipeline.close_doors(mesh, &changed);
  ASSERT_TRUE(doors.ok) << doors.error;
  EXPECT_EQ(doors.found.size(), doors.doors);
  EXPECT_LE(changed.size(), doors.edges_closed + doors.edges_through_walls);
  EXPECT_EQ(changed.empty(), doors.edges_closed + doors.edges_through_walls == 0);
  EXPECT_TRUE(pipeline.has_sight());
  const rooms::UpdateResult r = pipeline.update_rooms();
  EXPECT_EQ(r.outcome, rooms::Outcome::kOk);
  EXPECT_GT(r.rooms, 0u);
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kRoom), r.rooms);
}

}  // namespace
}  // namespace qsg::bench
