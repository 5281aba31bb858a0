// The simulated robot in a world: exploration tours, ground-truth skeleton and rooms, the simulated camera.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <memory>
#include <set>

#include "drivers/replay/tum_replay.h"
#include "drivers/sim/drifting_odometry.h"
#include "drivers/sim/exploration.h"
#include "drivers/sim/fault_plan.h"
#include "drivers/sim/ground_truth.h"
#include "drivers/sim/sim_camera.h"
#include "drivers/world/building_generator.h"
#include "drivers/world/floor_plan_import.h"
#include "drivers/world/world_query.h"
#include "tests/drivers/rgbd_source_contract.h"
#include "tests/support/allocation_counter.h"

namespace qsg::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A closed box room [0, 4] x [0, 3] x [0, 2.5] with 0.1 m thick walls outside that volume.
world::World box_room() {
  world::World w;
  w.name = "box_room";
  world::Material wall;
  wall.label = semantics::kWall;
  const auto add = [&](Eigen::Vector3d c, Eigen::Vector3d half, semantics::Label label) {
    world::BoxShape b;
    b.center_m = c;
    b.half_extents_m = half;
    world::Material m = wall;
    m.label = label;
    w.add_box(b, m, -1, 0);
  };
  add({2, 1.5, -0.05}, {2.2, 1.7, 0.05}, semantics::kFloor);
  add({2, 1.5, 2.55}, {2.2, 1.7, 0.05}, semantics::kCeiling);
  add({-0.05, 1.5, 1.25}, {0.05, 1.7, 1.3}, semantics::kWall);
  add({4.05, 1.5, 1.25}, {0.05, 1.7, 1.3}, semantics::kWall);
  add({2, -0.05, 1.25}, {2.2, 0.05, 1.3}, semantics::kWall);
  add({2, 3.05, 1.25}, {2.2, 0.05, 1.3}, semantics::kWall);
  world::Room room;
  room.id = 0;
  room.label = semantics::kOffice;
  room.footprint_m = {{{0, 0}, {4, 0}, {4, 3}, {0, 3}}};
  room.height_m = 2.5;
  w.rooms.push_back(room);
  return w;
}

struct Prepared {
  world::World world;
  render::RayScene scene;
  std::unique_ptr<world::FreeSpaceIndex> free_space;
};

std::unique_ptr<Prepared> prepare(world::World w) {
  auto p = std::make_unique<Prepared>();
  p->world = std::move(w);
  std::string error;
  EXPECT_TRUE(p->scene.build(p->world, &error)) << error;
  p->free_space = std::make_unique<world::FreeSpaceIndex>(p->world);
  return p;
}

world::World small_building(bool two_floors, std::uint64_t seed) {
  world::BuildingConfig config;
  config.num_rooms = two_floors ? 8 : 6;
  config.two_floors = two_floors;
  config.seed = seed;
  return world::generate_building(config);
}

// Every property a tour must have, whatever the world.
void expect_valid_tour(const Prepared& p, const ExplorationConfig& config, const ExplorationResult& r) {
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_GT(r.trajectory.size(), 2u);
  const double dt = 1.0 / config.rate_hz;
  for (std::size_t k = 1; k < r.trajectory.size(); ++k) {
    const auto& a = r.trajectory[k - 1];
    const auto& b = r.trajectory[k];
    ASSERT_GT(b.time_ns, a.time_ns);
    EXPECT_LE((b.world_t_body_m - a.world_t_body_m).norm(), config.speed_m_s * dt * 1.01 + 1e-9) << "pose " << k;
    EXPECT_LE(a.world_R_body.angularDistance(b.world_R_body), config.yaw_rate_rad_s * dt * 1.01 + 1e-9) << "pose " << k;
  }
  // The body never comes closer to a surface than its radius (less a grid cell of planning slack).
  for (std::size_t k = 0; k < r.trajectory.size(); k += 5) {
    const Eigen::Vector3d cam = r.trajectory[k].world_t_body_m;
    EXPECT_TRUE(p.free_space->is_free(cam, config.robot_radius_m - config.resolution_m))
        << "pose " << k << " at " << cam.transpose() << " collides";
  }
  if (config.return_to_start) {
    EXPECT_LT((r.trajectory.front().world_t_body_m - r.trajectory.back().world_t_body_m).norm(), 1e-6);
  }
}

TEST(ExplorationTest, VisitsEveryRoomOfAGeneratedBuildingThroughItsDoors) {
  auto p = prepare(small_building(false, 3));
  ExplorationConfig config;
  const ExplorationResult r = plan_exploration(p->world, p->scene, *p->free_space, config);
  expect_valid_tour(*p, config, r);
  EXPECT_TRUE(r.unreachable_rooms.empty());
  std::set<std::int32_t> visited(r.room_order.begin(), r.room_order.end());
  EXPECT_EQ(visited.size(), p->world.rooms.size());
  // Room changes happen at doors: where consecutive poses lie in two different rooms, a door joins them nearby.
  int crossings = 0;
  for (std::size_t k = 1; k < r.trajectory.size(); ++k) {
    const Eigen::Vector3d a = r.trajectory[k - 1].world_t_body_m, b = r.trajectory[k].world_t_body_m;
    const std::int32_t ra = world::room_at(p->world, a.x(), a.y(), a.z()), rb = world::room_at(p->world, b.x(), b.y(), b.z());
    if (ra < 0 || rb < 0 || ra == rb) continue;
    ++crossings;
    double nearest = 1e9;
    for (const world::Door& d : p->world.doors) {
      if (!((d.room_a == ra && d.room_b == rb) || (d.room_a == rb && d.room_b == ra))) continue;
      nearest = std::min(nearest, (0.5 * (d.a_m + d.b_m) - b.head<2>()).norm());
    }
    EXPECT_LT(nearest, 0.7) << "room " << ra << " -> " << rb << " away from their doors at " << b.transpose();
  }
  EXPECT_GE(crossings, static_cast<int>(p->world.rooms.size()) - 1);
  // Quadruped camera height above the floor.
  EXPECT_NEAR(r.trajectory.front().world_t_body_m.z() - p->world.rooms[0].floor_z_m, config.camera_height_m, 0.06);
}

TEST(ExplorationTest, ReachesBothFloorsByTheStairs) {
  auto p = prepare(small_building(true, 5));
  ExplorationConfig config;
  config.spin_in_rooms = false;
  const ExplorationResult r = plan_exploration(p->world, p->scene, *p->free_space, config);
  expect_valid_tour(*p, config, r);
  std::set<std::int32_t> floors;
  for (std::int32_t id : r.room_order)
    for (const world::Room& room : p->world.rooms)
      if (room.id == id) floors.insert(room.floor_index);
  EXPECT_EQ(floors.size(), 2u) << "rooms visited on " << floors.size() << " floor(s)";
  EXPECT_TRUE(r.unreachable_rooms.empty());
}

TEST(ExplorationTest, HandHeldHeightAndConfigErrors) {
  auto p = prepare(box_room());
  ExplorationConfig config;
  config.camera_height_m = 1.2;
  const ExplorationResult r = plan_exploration(p->world, p->scene, *p->free_space, config);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_NEAR(r.trajectory.front().world_t_body_m.z(), 1.2, 0.06);
  EXPECT_NEAR(r.duration_s, 2 * kPi / config.yaw_rate_rad_s, 0.2) << "one room: a spin in place";
  config.speed_m_s = -1;
  EXPECT_NE(plan_exploration(p->world, p->scene, *p->free_space, config).error.find("speed_m_s"), std::string::npos);
  config = ExplorationConfig{};
  config.start_room = 42;
  EXPECT_NE(plan_exploration(p->world, p->scene, *p->free_space, config).error.find("start room 42"), std::string::npos);
}

// Regression (issue 36): a world shape of 2^31 m aborted the planner (its grid's size overflowed) and 1e6 m took
// 11 GB. A world wider than the grid budget is refused by name before the grid exists.
TEST(ExplorationTest, AWorldWiderThanTheGridBudgetIsRefusedByName) {
  world::World w = box_room();
  world::BoxShape far;
  far.center_m = {900.0, 900.0, 0.5};  // 900 m away: 9,000 x 9,000 cells at 0.1 m, past 4 Mi
  far.half_extents_m = {0.5, 0.5, 0.5};
  world::Material m;
  m.label = semantics::kWall;
  w.add_box(far, m);
  auto p = prepare(w);
  ExplorationConfig config;
  const ExplorationResult r = plan_exploration(p->world, p->scene, *p->free_space, config);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("exploration: the world's x-y extent (900.7 m x 900.7 m) needs"), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("more than max_grid_cells (4194304)"), std::string::npos) << r.error;
  EXPECT_TRUE(r.trajectory.empty());
  // The budget is the config's: a coarser grid fits the same world.
  config.resolution_m = 0.5;
  EXPECT_EQ(plan_exploration(p->world, p->scene, *p->free_space, config).error.find("max_grid_cells"), std::string::npos);
  config = ExplorationConfig{};
  config.max_grid_cells = 0;
  EXPECT_NE(plan_exploration(p->world, p->scene, *p->free_space, config).error.find("max_grid_cells must be in"),
            std::string::npos);
}

// A 10 x 8 m floor plan: a ring corridor around a walled 4 x 3 m block (x 3-7 m, y 2.5-5.5 m) whose room opens by a
// door door_px pixels (5 cm each) wide in its bottom wall, centred at x 5 m; the ground truth closes the doorway.
world::World ring_plan(int door_px) {
  cv::Mat occupancy(160, 200, CV_8UC1, cv::Scalar(0));
  occupancy(cv::Rect(4, 4, 192, 152)).setTo(255);
  occupancy(cv::Rect(60, 50, 80, 60)).setTo(0);
  occupancy(cv::Rect(64, 54, 72, 52)).setTo(255);
  occupancy(cv::Rect(100 - door_px / 2, 106, door_px, 4)).setTo(255);
  cv::Mat ground_truth = occupancy.clone();
  ground_truth(cv::Rect(86, 107, 28, 1)).setTo(0);
  world::WorldResult r = world::import_floor_plan(occupancy, ground_truth, world::FloorPlanConfig(), "ring");
  EXPECT_TRUE(r.ok) << r.error;
  return r.world;
}

// The room inside the ring is entered and spun in: its ground is its own, not the corridor's (whose footprint has
// the block cut out).
TEST(ExplorationTest, EntersTheRoomInsideARingCorridor) {
  auto p = prepare(ring_plan(20));
  ASSERT_EQ(p->world.rooms.size(), 2u);
  ExplorationConfig config;
  const ExplorationResult r = plan_exploration(p->world, p->scene, *p->free_space, config);
  expect_valid_tour(*p, config, r);
  EXPECT_TRUE(r.unreachable_rooms.empty());
  EXPECT_TRUE(r.peeked_rooms.empty());
  EXPECT_EQ(std::set<std::int32_t>(r.room_order.begin(), r.room_order.end()).size(), 2u);
  const std::int32_t inner = world::room_at(p->world, 5.0, 4.0, 1.0);
  std::size_t inside = 0;
  for (const auto& pose : r.trajectory) {
    const Eigen::Vector3d t = pose.world_t_body_m;
    inside += world::room_at(p->world, t.x(), t.y(), t.z()) == inner ? 1 : 0;
  }
  EXPECT_GT(inside, static_cast<std::size_t>(2 * kPi / config.yaw_rate_rad_s * config.rate_hz)) << "no spin inside";
}

// A door narrower than the robot: the room cannot be entered, so the tour looks into it from in front of its door
// (facing it, sweeping), or, with look_into_unreachable_rooms off, only passes by.
TEST(ExplorationTest, LooksIntoARoomItCannotEnter) {
  auto p = prepare(ring_plan(8));  // 0.4 m: the robot needs 2 x 0.25 m
  const std::int32_t inner = world::room_at(p->world, 5.0, 4.0, 1.0);
  ExplorationConfig config;
  const ExplorationResult r = plan_exploration(p->world, p->scene, *p->free_space, config);
  expect_valid_tour(*p, config, r);
  ASSERT_EQ(r.unreachable_rooms, std::vector<std::int32_t>{inner});
  EXPECT_EQ(r.peeked_rooms, std::vector<std::int32_t>{inner});
  // Some pose stands within 1.5 m of the door, below it, looking into the room (+y) within the sweep.
  const Eigen::Vector2d door(5.0, 2.6);
  std::size_t looking = 0;
  for (const auto& pose : r.trajectory) {
    const Eigen::Vector3d forward = pose.world_R_body * Eigen::Vector3d::UnitX();
    const Eigen::Vector2d to_door = door - pose.world_t_body_m.head<2>();
    if (to_door.norm() < 1.5 && to_door.y() > 0.0 && forward.y() > std::cos(0.25 * kPi) - 1e-6) ++looking;
  }
  EXPECT_GT(looking, 0u) << "no pose looks through the door";
  config.look_into_unreachable_rooms = false;
  const ExplorationResult passing = plan_exploration(p->world, p->scene, *p->free_space, config);
  expect_valid_tour(*p, config, passing);
  EXPECT_TRUE(passing.peeked_rooms.empty());
  EXPECT_LT(passing.duration_s, r.duration_s);
  config.peek_range_m = 0.0;
  EXPECT_NE(plan_exploration(p->world, p->scene, *p->free_space, config).error.find("peek_range_m"), std::string::npos);
}

TEST(ScriptedTrajectoryTest, FollowsWaypointsAtTheConfiguredSpeed) {
  ExplorationConfig config;
  config.rate_hz = 20;
  const ExplorationResult r = scripted_trajectory({{0, 0, 0.5}, {2, 0, 0.5}, {2, 1, 0.5}}, config);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_NEAR(r.length_m, 3.0, 1e-9);
  EXPECT_NEAR((r.trajectory.back().world_t_body_m - Eigen::Vector3d(2, 1, 0.5)).norm(), 0.0, 1e-9);
  EXPECT_GE(r.duration_s, 3.0 / config.speed_m_s);
  EXPECT_FALSE(scripted_trajectory({}, config).ok);
}

TEST(GroundTruthTest, ClearanceMatchesABruteForceTransform) {
  auto p = prepare(box_room());
  GroundTruthConfig config;
  config.voxel_size_m = 0.2;
  GroundTruth t;
  std::string error;
  ASSERT_TRUE(compute_ground_truth(p->world, *p->free_space, config, &t, &error)) << error;
  std::vector<Eigen::Vector3i> occupied;
  for (int z = 0; z < t.dims.z(); ++z)
    for (int y = 0; y < t.dims.y(); ++y)
      for (int x = 0; x < t.dims.x(); ++x)
        if (t.voxel_room[t.index(x, y, z)] == kVoxelOccupied) occupied.emplace_back(x, y, z);
  ASSERT_FALSE(occupied.empty());
  int checked = 0;
  for (int z = 0; z < t.dims.z(); ++z)
    for (int y = 0; y < t.dims.y(); ++y)
      for (int x = 0; x < t.dims.x(); x += 2) {
        const std::size_t i = t.index(x, y, z);
        if (t.voxel_room[i] == kVoxelOccupied) continue;
        double best = 1e30;
        for (const Eigen::Vector3i& o : occupied) best = std::min(best, (o - Eigen::Vector3i(x, y, z)).cast<double>().squaredNorm());
        const double expected = std::min(config.max_clearance_m, std::max(0.0, (std::sqrt(best) - 0.5) * config.voxel_size_m));
        ASSERT_NEAR(t.clearance_m[i], expected, 1e-5) << x << " " << y << " " << z;
        ++checked;
      }
  EXPECT_GT(checked, 100);
}

TEST(GroundTruthTest, RoomVoxelsAndSkeletonOfABoxRoom) {
  auto p = prepare(box_room());
  GroundTruthConfig config;
  config.voxel_size_m = 0.1;
  GroundTruth t;
  std::string error;
  ASSERT_TRUE(compute_ground_truth(p->world, *p->free_space, config, &t, &error)) << error;
  // The room's interior volume: the grid's voxel faces fall on the room's surfaces here, so every interior
  // voxel is free and no other is.
  const double interior_voxels = 4.0 * 3.0 * 2.5 / 1e-3;
  ASSERT_EQ(t.room_free_voxels.size(), 1u);
  EXPECT_NEAR(static_cast<double>(t.room_free_voxels[0]), interior_voxels, 0.01 * interior_voxels);
  ASSERT_GT(t.gvd.size(), 100u);
  for (const GvdVoxel& g : t.gvd) {
    const Eigen::Vector3d c = g.position_m.cast<double>();
    double d[6] = {c.x(), 4.0 - c.x(), c.y(), 3.0 - c.y(), c.z(), 2.5 - c.z()};
    std::sort(d, d + 6);
    // On the medial axis of a box: the clearance is the distance to the nearest face, and the two nearest
    // faces are (nearly) equally far.
    EXPECT_NEAR(g.clearance_m, d[0], 0.02) << c.transpose();
    EXPECT_LE(d[1] - d[0], config.voxel_size_m + 1e-6) << c.transpose();
    EXPECT_GE(g.num_basis_points, 2);
  }
  EXPECT_LT(t.distance_to_gvd({2.0, 1.5, 1.25}), 0.11) << "the room's centre lies on its skeleton";
}

TEST(GroundTruthTest, WritesFilesOthersCanRead) {
  auto p = prepare(box_room());
  GroundTruthConfig config;
  config.voxel_size_m = 0.2;
  GroundTruth t;
  std::string error;
  ASSERT_TRUE(compute_ground_truth(p->world, *p->free_space, config, &t, &error)) << error;
  const std::string dir = ::testing::TempDir();
  replay::Trajectory trajectory(2);
  trajectory[1].time_ns = 1000000;
  ASSERT_TRUE(write_ground_truth(dir, p->world, t, trajectory, &error)) << error;
  std::ifstream ply(dir + "/gvd.ply", std::ios::binary);
  std::string line;
  std::size_t vertices = 0;
  while (std::getline(ply, line) && line != "end_header")
    if (line.rfind("element vertex ", 0) == 0) vertices = std::stoul(line.substr(15));
  EXPECT_EQ(vertices, t.gvd.size());
  std::ifstream bin(dir + "/free_space.bin", std::ios::binary | std::ios::ate);
  EXPECT_EQ(static_cast<std::size_t>(bin.tellg()), 2 * t.voxel_room.size());
  std::ifstream objects(dir + "/objects.json");
  EXPECT_TRUE(objects.good());
  std::ifstream traj(dir + "/trajectory.txt");
  EXPECT_TRUE(traj.good());
  EXPECT_FALSE(compute_ground_truth(p->world, *p->free_space, config, &t, &error, 1000));
  EXPECT_NE(error.find("coarser"), std::string::npos);
}

// Through box_room facing +x from x = 1, 1.5 m from each side wall: the wall at x = 4 is 3 m ahead, then 2 m at
// the end.
ExplorationResult towards_the_far_wall() {
  ExplorationConfig tc;
  tc.rate_hz = 10;
  tc.speed_m_s = 0.5;
  return scripted_trajectory({{1, 1.5, 1.0}, {2, 1.5, 1.0}}, tc);
}

TEST(SimCameraTest, RendersTheWallAheadAtItsDistance) {
  const world::World w = box_room();
  const ExplorationResult r = towards_the_far_wall();
  ASSERT_TRUE(r.ok);
  SimCamera camera;
  SimCamera::Config config;
  config.rate_hz = 5;
  std::string error;
  ASSERT_TRUE(camera.init(config, render::Renderer::Config{}, w, r.trajectory, &error)) << error;
  auto frame = std::make_unique<messages::RgbdFrame>();
  std::size_t frames = 0;
  while (camera.read(*frame, 0) == drivers::ReadStatus::kOk) {
    Eigen::Isometry3d pose;
    ASSERT_TRUE(camera.camera_pose(frame->sequence, &pose, nullptr));
    const int cx = config.intrinsics.width / 2, cy = config.intrinsics.height / 2;
    const float depth = frame->depth_m[static_cast<std::size_t>(cy * config.intrinsics.width + cx)];
    // The principal point is half a pixel off the image centre, so allow a millimetre.
    EXPECT_NEAR(depth, 4.0 - pose.translation().x(), 1e-3) << "frame " << frame->sequence;
    EXPECT_EQ(frame->labels[static_cast<std::size_t>(cy * config.intrinsics.width + cx)], semantics::kWall);
    EXPECT_EQ(frame->publish_time_ns - frame->sample_time_ns, config.latency_ns);
    ++frames;
  }
  EXPECT_EQ(frames, camera.num_frames());
  EXPECT_EQ(camera.read(*frame, 0), drivers::ReadStatus::kEndOfStream);
}

// The field of view sets the focal length: the wall beside the camera enters the image's left edge where a ray at
// that angle meets it (1.5 m to the side: 1.5 f / 159.5 m ahead), and the frames carry the intrinsics rendered with.
TEST(SimCameraTest, TheFieldOfViewSetsTheFocalLength) {
  const world::World w = box_room();
  const ExplorationResult r = towards_the_far_wall();
  ASSERT_TRUE(r.ok);
  for (const double hfov_deg : {0.0, 90.0}) {
    SCOPED_TRACE(::testing::Message() << "hfov_deg " << hfov_deg);
    SimCamera camera;
    SimCamera::Config config;  // 320 x 240, f 262.5 as given
    config.hfov_deg = hfov_deg;
    const double f = hfov_deg > 0.0 ? 160.0 : 262.5;
    std::string error;
    ASSERT_TRUE(camera.init(config, render::Renderer::Config{}, w, r.trajectory, &error)) << error;
    EXPECT_NEAR(camera.intrinsics().fx, f, 1e-9);
    EXPECT_NEAR(camera.intrinsics().fy, f, 1e-9);
    EXPECT_NEAR(camera.intrinsics().cx, 159.5, 1e-12);
    auto frame = std::make_unique<messages::RgbdFrame>();
    ASSERT_EQ(camera.read(*frame, 0), drivers::ReadStatus::kOk);
    EXPECT_NEAR(frame->intrinsics.fx, f, 1e-9);
    const int row = config.intrinsics.height / 2;
    const float edge = frame->depth_m[static_cast<std::size_t>(row * config.intrinsics.width)];
    EXPECT_NEAR(edge, 1.5 * f / 159.5, 0.01);
  }
  SimCamera::Config bad;
  for (const double hfov_deg : {5.0, 175.0, -30.0}) {
    bad.hfov_deg = hfov_deg;
    EXPECT_NE(bad.check().find("hfov_deg"), std::string::npos) << hfov_deg;
  }
}

TEST(SimCameraTest, IsDeterministicAndDoesNotAllocatePerFrame) {
  const world::World w = small_building(false, 4);
  auto p = prepare(w);
  ExplorationConfig tc;
  const ExplorationResult r = plan_exploration(p->world, p->scene, *p->free_space, tc);
  ASSERT_TRUE(r.ok) << r.error;
  SimCamera a, b;
  SimCamera::Config config;
  config.intrinsics = {160, 120, 131.25, 131.25, 79.5, 59.5};
  std::string error;
  ASSERT_TRUE(a.init(config, render::Renderer::Config{}, w, r.trajectory, &error)) << error;
  ASSERT_TRUE(b.init(config, render::Renderer::Config{}, w, r.trajectory, &error)) << error;
  auto fa = std::make_unique<messages::RgbdFrame>();
  auto fb = std::make_unique<messages::RgbdFrame>();
  ASSERT_EQ(a.read(*fa, 0), drivers::ReadStatus::kOk);  // warm-up
  EXPECT_NO_ALLOCATIONS({
    for (int k = 0; k < 5; ++k) a.read(*fa, 0);
  });
  for (int k = 0; k < 6; ++k) ASSERT_EQ(b.read(*fb, 0), drivers::ReadStatus::kOk);
  EXPECT_EQ(fa->sequence, fb->sequence);
  const std::size_t n = static_cast<std::size_t>(fa->pixels());
  EXPECT_TRUE(std::equal(fa->depth_m.begin(), fa->depth_m.begin() + n, fb->depth_m.begin()));
  EXPECT_TRUE(std::equal(fa->rgb.begin(), fa->rgb.begin() + 3 * n, fb->rgb.begin()));
}

TEST(SimCameraTest, TumReplayOfARenderedSequenceReproducesItsFrames) {
  const world::World w = small_building(false, 6);
  auto p = prepare(w);
  const ExplorationResult r = plan_exploration(p->world, p->scene, *p->free_space, ExplorationConfig{});
  ASSERT_TRUE(r.ok) << r.error;
  SimCamera camera;
  SimCamera::Config config;
  config.intrinsics = {160, 120, 131.25, 131.25, 79.5, 59.5};
  config.depth_scale_m = 1.0f / 5000.0f;  // what the TUM format stores
  std::string error;
  ASSERT_TRUE(camera.init(config, render::Renderer::Config{}, w, r.trajectory, &error)) << error;
  const std::string dir = ::testing::TempDir() + "/tum_roundtrip";
  replay::TumWriter writer;
  ASSERT_TRUE(writer.open(dir, replay::TumWriter::Config{}, &error)) << error;
  constexpr int kFrames = 6;
  std::vector<std::unique_ptr<messages::RgbdFrame>> rendered;
  for (int k = 0; k < kFrames; ++k) {
    rendered.push_back(std::make_unique<messages::RgbdFrame>());
    ASSERT_EQ(camera.read(*rendered.back(), 0), drivers::ReadStatus::kOk);
    Eigen::Isometry3d pose;
    ASSERT_TRUE(camera.camera_pose(rendered.back()->sequence, &pose, nullptr));
    ASSERT_TRUE(writer.write_frame(*rendered.back(), &error)) << error;
    ASSERT_TRUE(writer.write_pose(replay::StampedPose::from_isometry(rendered.back()->sample_time_ns, pose), &error));
  }
  ASSERT_TRUE(writer.close(&error)) << error;

  replay::TumReplay replay;
  replay::TumReplay::Config rc;
  rc.intrinsics = config.intrinsics;
  ASSERT_TRUE(replay.open(dir, rc, &error)) << error;
  auto back = std::make_unique<messages::RgbdFrame>();
  for (int k = 0; k < kFrames; ++k) {
    ASSERT_EQ(replay.read(*back, 0), drivers::ReadStatus::kOk) << "frame " << k;
    const messages::RgbdFrame& f = *rendered[static_cast<std::size_t>(k)];
    EXPECT_EQ(back->sample_time_ns, f.sample_time_ns);
    ASSERT_EQ(back->pixels(), f.pixels());
    const std::size_t n = static_cast<std::size_t>(f.pixels());
    // Depth comes back as the TUM writer's 16-bit quantisation of the rendered value, exactly.
    for (std::size_t i = 0; i < n; ++i) {
      const float expected =
          static_cast<float>(std::llround(static_cast<double>(f.depth_m[i]) / static_cast<double>(rc.depth_scale_m))) *
          rc.depth_scale_m;
      ASSERT_EQ(back->depth_m[i], expected) << "frame " << k << " pixel " << i << " rendered " << f.depth_m[i];
    }
    EXPECT_TRUE(std::equal(f.rgb.begin(), f.rgb.begin() + 3 * n, back->rgb.begin())) << "frame " << k;
    ASSERT_TRUE(back->has_labels);
    EXPECT_TRUE(std::equal(f.labels.begin(), f.labels.begin() + n, back->labels.begin())) << "frame " << k;
  }
  EXPECT_EQ(replay.read(*back, 0), drivers::ReadStatus::kEndOfStream);
}

TEST(SimCameraTest, FaultPlanOnTheSimulatedCameraAndOdometry) {
  const world::World w = box_room();
  ExplorationConfig tc;
  const ExplorationResult r = scripted_trajectory({{1, 1.5, 1.0}, {3, 1.5, 1.0}}, tc);
  ASSERT_TRUE(r.ok);
  SimCamera camera;
  SimCamera::Config config;
  config.intrinsics = {80, 60, 65.6, 65.6, 39.5, 29.5};
  std::string error;
  ASSERT_TRUE(camera.init(config, render::Renderer::Config{}, w, r.trajectory, &error)) << error;
  FaultPlan plan;
  ASSERT_TRUE(parse_fault_plan_text("at 2 drop\nat 4 depth_nan rect=10,10,20,20\nat 6 unplug reads=2\n", "plan", &plan,
                                    &error))
      << error;
  FaultInjectingRgbdSource faulty(camera, plan);
  auto frame = std::make_unique<messages::RgbdFrame>();
  int delivered = 0, disconnected = 0;
  bool saw_nan_frame = false, saw_reconnect = false;
  for (int k = 0; k < 40; ++k) {
    const drivers::ReadStatus s = faulty.read(*frame, 0);
    if (s == drivers::ReadStatus::kEndOfStream) break;
    if (s == drivers::ReadStatus::kDisconnected) ++disconnected;
    if (s != drivers::ReadStatus::kOk) continue;
    ++delivered;
    EXPECT_NE(frame->sequence, 2u) << "frame 2 was to be dropped";
    if (frame->flags & messages::kFrameInvalidDepthRegion) {
      saw_nan_frame = true;
      EXPECT_TRUE(std::isnan(frame->depth_m[static_cast<std::size_t>(15 * 80 + 15)]));
    }
    if (frame->flags & messages::kFrameAfterReconnect) saw_reconnect = true;
  }
  EXPECT_TRUE(saw_nan_frame);
  EXPECT_TRUE(saw_reconnect);
  EXPECT_EQ(disconnected, 2);
  EXPECT_EQ(delivered, static_cast<int>(camera.num_frames()) - 1);
  EXPECT_EQ(faulty.counters().dropped, 1u);
  EXPECT_EQ(faulty.counters().disconnects, 1u);

  DriftingOdometry odometry(r.trajectory, DriftingOdometry::Config{});
  FaultPlan odo_plan;
  ASSERT_TRUE(parse_fault_plan_text("at 3 backwards back_ms=5\n", "odo", &odo_plan, &error)) << error;
  FaultInjectingOdometrySource faulty_odometry(odometry, odo_plan);
  messages::OdometrySample sample;
  bool flagged = false;
  while (faulty_odometry.read(sample, 0) == drivers::ReadStatus::kOk) {
    flagged |= (sample.flags & messages::kFrameTimestampBackwards) != 0;
  }
  EXPECT_TRUE(flagged);
  EXPECT_EQ(faulty_odometry.counters().timestamps_backwards, 1u);
}

}  // namespace
}  // namespace qsg::sim

namespace qsg::testing {
namespace {
std::shared_ptr<drivers::RgbdSource> make_sim_camera(std::string*) {
  struct Holder {
    sim::SimCamera camera;
  };
  auto holder = std::make_shared<Holder>();
  sim::ExplorationConfig tc;
  const sim::ExplorationResult r = sim::scripted_trajectory({{1, 1.5, 1.0}, {3, 1.5, 1.0}}, tc);
  world::World w;
  world::BoxShape wall;
  wall.center_m = {5, 0, 1};
  wall.half_extents_m = {0.1, 5, 2};
  w.add_box(wall, world::Material{});
  sim::SimCamera::Config config;
  config.intrinsics = {64, 48, 52.5, 52.5, 31.5, 23.5};
  std::string error;
  if (!r.ok || !holder->camera.init(config, render::Renderer::Config{}, w, r.trajectory, &error)) return nullptr;
  return std::shared_ptr<drivers::RgbdSource>(holder, &holder->camera);
}
}  // namespace
INSTANTIATE_TEST_SUITE_P(SimCamera, RgbdSourceContract,
                         ::testing::Values(RgbdContractCase{"sim_camera", make_sim_camera, true, 400, false}),
                         rgbd_contract_case_name);
}  // namespace qsg::testing
