// The pipeline's steps (core/pipeline/pipeline_steps.h) on a small rendered building, through a host that records
// every call: the order inside each step, which shared state is held where (the app's locks), the wall painting
// skipped while the wall map is busy and done with the next keyframe, a refused keyframe stopping its step, the
// door pass's cadence, and Host::after_rooms releasing the graph early.
#include "core/pipeline/pipeline_steps.h"

#include <gtest/gtest.h>

#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "bench/sim_tour.h"
#include "budgets/budget_table.h"
#include "drivers/world/building_generator.h"

namespace qsg::pipeline {
namespace {

// Records each call as a word; checks that no shared state is taken twice or given back unheld.
class RecordingHost : public Host {
 public:
  void lock(Shared what) override {
    EXPECT_FALSE(held(what)) << name(what) << " locked twice";
    held(what) = true;
    events.push_back("lock " + name(what));
  }
  void unlock(Shared what) override {
    EXPECT_TRUE(held(what)) << name(what) << " unlocked but not held";
    held(what) = false;
    events.push_back("unlock " + name(what));
  }
  bool try_lock(Shared what) override {
    if (walls_busy && what == Shared::kWallMap) return false;
    lock(what);
    return true;
  }
  void begin(Step step) override { events.push_back("begin " + name(step)); }
  void end(Step step, bool ran) override { events.push_back("end " + name(step) + (ran ? "" : " (did not run)")); }
  void integrated(const messages::RgbdFrame&, const Eigen::Isometry3d&) override { events.push_back("integrated"); }
  void after_rooms(std::uint64_t, Held* graph) override {
    events.push_back(std::string("after_rooms") + (graph_held ? " (graph held)" : ""));
    if (release_in_after_rooms) graph->release();
  }

  std::vector<std::string> take() { return std::exchange(events, {}); }

  std::vector<std::string> events;
  bool walls_busy = false;
  bool release_in_after_rooms = false;
  bool graph_held = false, walls_held = false;

 private:
  bool& held(Shared what) { return what == Shared::kGraph ? graph_held : walls_held; }
  static std::string name(Shared what) { return what == Shared::kGraph ? "graph" : "walls"; }
  static std::string name(Step step) {
    switch (step) {
      case Step::kIntegrate:
        return "integrate";
      case Step::kObserve:
        return "observe";
      case Step::kFrontendUpdate:
        return "frontend";
      case Step::kDoorPass:
        return "door_pass";
      case Step::kFinalStage:
        return "final";
    }
    return "?";
  }
};

struct Fixture {
  world::World world;
  bench::SimTour tour;
  reconstruction::SemanticTsdf tsdf;
  frontend::Frontend frontend;
  backend::BackendStage backend;
  std::unique_ptr<scene_graph::SceneGraph> graph = std::make_unique<scene_graph::SceneGraph>();
  Stages stages() { return {&tsdf, &frontend, &backend, graph.get()}; }
};

std::unique_ptr<Fixture> small_building(std::uint32_t door_pass_every_n) {
  auto f = std::make_unique<Fixture>();
  world::BuildingConfig bc;
  bc.num_rooms = 3;
  bc.seed = 3;
  bc.room_size_max_m = 4.0;
  f->world = world::generate_building(bc);
  sim::ExplorationConfig ec;
  sim::SimCamera::Config cc;
  cc.intrinsics = bench::camera_of_fov(160, 120, 90.0);
  cc.rate_hz = ec.speed_m_s / 0.5;  // a keyframe every 0.5 m
  std::string error, warning;
  EXPECT_TRUE(bench::make_sim_tour(f->world, ec, cc, render::Renderer::Config{}, &f->tour, &error)) << error;
  EXPECT_TRUE(f->graph->init(scene_graph::capacities_from_budget(), scene_graph::arena_bytes_from_budget(), &error))
      << error;
  EXPECT_TRUE(f->tsdf.init(reconstruction::Config{}, reconstruction::capacities_from_budget(),
                           budgets::active::reconstruction::kArenaBytes, &error))
      << error;
  EXPECT_TRUE(f->frontend.init(frontend::Config{}, &error)) << error;
  backend::BackendStage::Config b;
  b.doors_online = true;
  b.doors_online_every_n = door_pass_every_n;
  EXPECT_TRUE(f->backend.init(b, f->graph->capacities(), f->tsdf.block_slots(), 0, &error, &warning)) << error;
  return f;
}

const std::vector<std::string> kKeyframe = {"begin integrate", "end integrate", "integrated",
                                            "lock walls",      "unlock walls",  "begin observe",
                                            "end observe",     "lock graph",    "unlock graph"};

TEST(PipelineStepsTest, EachStepRunsInItsOrderHoldingWhatItTouches) {
  std::unique_ptr<Fixture> f = small_building(2);
  ASSERT_TRUE(f->tour.camera != nullptr);
  RecordingHost host;
  std::size_t keyframes = 0, updates = 0, passes = 0, painted = 0;
  auto frame = std::make_unique<messages::RgbdFrame>();
  bench::for_each_posed_frame(
      f->tour, *frame,
      [&](const messages::RgbdFrame& fr, const Eigen::Isometry3d& T, std::int64_t t_ns, const Eigen::Isometry3d&) {
        const auto t = static_cast<std::uint64_t>(t_ns);
        const KeyframeResult k = integrate_keyframe(f->stages(), host, fr, T, t);
        ASSERT_TRUE(k.integrated);
        EXPECT_FALSE(k.walls_deferred);
        painted += k.blocks_painted;
        EXPECT_EQ(host.take(), kKeyframe) << "keyframe " << keyframes;
        if (keyframes++ % 3 != 0) return;
        const frontend::UpdateSummary s = frontend_update(f->stages(), host, T.translation(), t, frontend::Deadline{});
        EXPECT_EQ(host.take(),
                  (std::vector<std::string>{"lock graph", "begin frontend", "end frontend", "unlock graph"}));
        ASSERT_TRUE(backend_update_due(s));  // no deadline: every update completes its places cycle
        const BackendResult b = backend_update(f->stages(), host, T.translation(), t);
        std::vector<std::string> expected;
        if (updates++ % 2 == 0) {  // a door pass on every 2nd backend update, from the first
          expected = {"begin door_pass", "lock graph",
                      "unlock graph",    "lock walls",
                      "unlock walls",    std::string("end door_pass") + (b.pass.ran ? "" : " (did not run)")};
          passes += b.door_pass ? 1 : 0;
        } else {
          EXPECT_FALSE(b.door_pass);
        }
        for (const char* e : {"lock graph", "after_rooms (graph held)", "unlock graph"}) expected.push_back(e);
        EXPECT_EQ(host.take(), expected) << "update " << updates;
      });
  ASSERT_GT(keyframes, 20u);
  EXPECT_GT(painted, 0u);
  EXPECT_GT(passes, 0u);
  EXPECT_GT(f->backend.counters().updates.load(), 0u);

  // After rooms, the host may release the graph (the app's loop closure solves without it): released once.
  host.release_in_after_rooms = true;
  backend_update(f->stages(), host, Eigen::Vector3d::Zero(), 0, /*rooms=*/true);
  const std::vector<std::string> e = host.take();
  ASSERT_GE(e.size(), 2u);
  EXPECT_EQ(e[e.size() - 2], "after_rooms (graph held)");
  EXPECT_EQ(e.back(), "unlock graph");
  // Without rooms (the evaluations), no room update and no after_rooms.
  const std::uint64_t room_updates = f->backend.counters().updates.load();
  backend_update(f->stages(), host, Eigen::Vector3d::Zero(), 0, /*rooms=*/false);
  EXPECT_EQ(f->backend.counters().updates.load(), room_updates);  // the room updates
  for (const std::string& s : host.take()) EXPECT_EQ(s.find("after_rooms"), std::string::npos);

  // The final stage: doors on the final surface, then the rooms on the whole map, inside its bracket.
  reconstruction::Mesh mesh;
  f->tsdf.extract_full_mesh(&mesh);
  const FinalResult r = final_stage(f->stages(), host, &mesh, 0);
  EXPECT_TRUE(r.doors.ok) << r.doors.error;
  EXPECT_GT(r.rooms.rooms, 0u);
  EXPECT_EQ(host.take(), (std::vector<std::string>{"begin final", "lock graph", "unlock graph", "lock graph",
                                                   "unlock graph", "end final"}));
  EXPECT_FALSE(host.graph_held);
  EXPECT_FALSE(host.walls_held);
}

TEST(PipelineStepsTest, BusyWallMapIsPaintedWithTheNextKeyframeAndARefusedFrameStopsItsStep) {
  std::unique_ptr<Fixture> f = small_building(4);
  ASSERT_TRUE(f->tour.camera != nullptr);
  RecordingHost host;
  std::vector<KeyframeResult> results;
  auto frame = std::make_unique<messages::RgbdFrame>();
  bench::for_each_posed_frame(
      f->tour, *frame,
      [&](const messages::RgbdFrame& fr, const Eigen::Isometry3d& T, std::int64_t t_ns, const Eigen::Isometry3d&) {
        if (results.size() >= 4) return;
        host.walls_busy = results.size() < 2;  // a door pass holds the map for the first two keyframes
        results.push_back(integrate_keyframe(f->stages(), host, fr, T, static_cast<std::uint64_t>(t_ns)));
        if (results.size() == 4) {
          // A frame the reconstruction refuses (a non-finite pose): nothing after the integration runs.
          host.take();
          Eigen::Isometry3d bad = T;
          bad.translation().x() = std::numeric_limits<double>::quiet_NaN();
          const std::size_t agents = f->frontend.agents().num_keyframes();
          const KeyframeResult refused =
              integrate_keyframe(f->stages(), host, fr, bad, static_cast<std::uint64_t>(t_ns) + 1);
          EXPECT_FALSE(refused.integrated);
          EXPECT_EQ(host.take(), (std::vector<std::string>{"begin integrate", "end integrate (did not run)"}));
          EXPECT_EQ(f->frontend.agents().num_keyframes(), agents);
        }
      });
  ASSERT_EQ(results.size(), 4u);
  for (int i = 0; i < 2; ++i) {
    EXPECT_TRUE(results[i].walls_deferred) << i;
    EXPECT_EQ(results[i].blocks_painted, 0u) << i;
  }
  EXPECT_FALSE(results[2].walls_deferred);
  EXPECT_GT(results[2].blocks_painted, 0u);  // the two skipped keyframes' blocks and its own
  EXPECT_FALSE(host.graph_held);
  EXPECT_FALSE(host.walls_held);
}

}  // namespace
}  // namespace qsg::pipeline
