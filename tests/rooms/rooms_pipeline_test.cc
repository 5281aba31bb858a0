// Rooms from a real pipeline run: a rendered two-room world (door 0.9 m) scanned by the simulated camera,
// integrated into the TSDF, places and objects by the frontend, then the room finder: two rooms, each holding
// the places of its side, joined by a room-room edge, below one building.
#include <gtest/gtest.h>

#include <memory>

#include "core/frontend/frontend.h"
#include "core/rooms/room_finder.h"
#include "core/scene_graph/scene_graph.h"
#include "tests/places/places_test_world.h"
#include "tests/support/allocation_counter.h"

namespace qsg::rooms {
namespace {

namespace sg = scene_graph;
using places::testing::camera_pose;
using places::testing::kPi;

TEST(RoomsPipelineTest, TwoRenderedRoomsBecomeTwoRoomNodes) {
  // Rooms [0, 4] x [0, 4] and [4.1, 8.1] x [0, 4], a 0.9 m door between them.
  const world::World w = places::testing::rooms_world({4.0, 4.0}, 4.0, /*doors=*/true);
  auto renderer = std::make_unique<render::Renderer>();
  auto tsdf = std::make_unique<reconstruction::SemanticTsdf>();
  auto frame = std::make_unique<messages::RgbdFrame>();
  auto graph = std::make_unique<sg::SceneGraph>();
  auto frontend = std::make_unique<frontend::Frontend>();
  auto finder = std::make_unique<RoomFinder>();
  std::string error;
  const reconstruction::Capacities caps = places::testing::small_tsdf_capacities();
  ASSERT_TRUE(renderer->init(render::Renderer::Config{}, w, &error)) << error;
  ASSERT_TRUE(tsdf->init(reconstruction::Config{}, caps, reconstruction::SemanticTsdf::plan(caps).total_bytes(), &error))
      << error;
  ASSERT_TRUE(graph->init(sg::capacities_from_budget(), sg::arena_bytes_from_budget(), &error)) << error;
  ASSERT_TRUE(frontend->init(frontend::Config{}, &error)) << error;
  ASSERT_TRUE(finder->init(Config{}, Capacities::from_scene_graph(graph->capacities()), 0, &error)) << error;

  const messages::CameraIntrinsics camera{160, 120, 100.0, 100.0, 79.5, 59.5};
  std::uint64_t seq = 0, time_ns = 0;
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(2.0, 2.0, 1.0), Eigen::Vector3d(6.1, 2.0, 1.0)}) {
    for (double pitch : {-0.6, 0.0, 0.6})
      for (int k = 0; k < 8; ++k) {
        const Eigen::Isometry3d T = camera_pose(p, 2 * kPi * k / 8, pitch);
        ASSERT_TRUE(renderer->render(T, camera, seq++, *frame, &error)) << error;
        ASSERT_TRUE(tsdf->process(*frame, T));
        frontend->observe(*tsdf, T);  // as the app does per keyframe: the places carve from every view
        time_ns += 100000000;
        frontend->add_keyframe(graph.get(), time_ns, T);
      }
    ASSERT_TRUE(frontend->update(*tsdf, p, time_ns, graph.get(), frontend::Deadline{}).places_complete);
  }
  ASSERT_GT(graph->num_nodes(sg::NodeKind::kPlace), 0u);


  UpdateResult r;
  EXPECT_NO_ALLOCATIONS(r = finder->update(graph.get(), time_ns));
  ASSERT_EQ(r.outcome, Outcome::kOk) << to_string(r.outcome) << " with " << r.places << " places";
  EXPECT_EQ(r.rooms, 2u) << "places " << r.places << ", dilation " << r.dilation_m;
  EXPECT_EQ(r.places_unassigned, 0u);
  // Each room's places lie on its side of the wall at x = 4.05 (a place in the doorway may go either way).
  for (std::size_t k = 0; k < finder->num_rooms(); ++k) {
    const sg::NodeId room = finder->room_id(k);
    const bool west = graph->room(room)->position_m.x() < 4.05;
    std::size_t wrong = 0, total = 0;
    graph->for_each_child(room, [&](sg::NodeId place) {
      const double x = graph->place(place)->position_m.x();
      ++total;
      wrong += (west ? x > 4.6 : x < 3.5) ? 1 : 0;
    });
    EXPECT_EQ(wrong, 0u) << "room " << sg::node_label(room) << " has " << wrong << " of " << total
                         << " places on the other side";
    EXPECT_EQ(graph->parent(room), finder->building_id());
  }
  if (finder->num_rooms() == 2) {
    EXPECT_TRUE(graph->has_edge(finder->room_id(0), finder->room_id(1)));
  }
}

}  // namespace
}  // namespace qsg::rooms
