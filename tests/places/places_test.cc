// Layer 3 places: ESDF distances, GVD on the medial axis, incremental removal, places graph components, edge
// weights, inactive nodes, the anytime split and the allocation-free update, on rendered box-room worlds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "core/places/places.h"
#include "core/scene_graph/scene_graph.h"
#include "drivers/sim/ground_truth.h"
#include "drivers/world/world_query.h"
#include "tests/places/places_test_support.h"
#include "tests/places/places_test_world.h"
#include "tests/support/allocation_counter.h"

namespace qsg::places {
namespace {

using testing::kHeight;
using testing::Scanner;
using testing::make_graph;
using testing::make_places;
using testing::place_components;
using testing::run_to_completion;
using testing::small_capacities;

// The places update of every keyframe, with the robot at the camera.
Scanner::Hook every_frame(Places* p, Scanner* scanner) {
  return [p, scanner](const Eigen::Vector3d& camera) { run_to_completion(p, scanner->tsdf(), camera); };
}

// Connected components of the places layer of a scene graph (all place nodes, all place-place edges).
// Distance from p to the nearest wall, floor or ceiling of the box room [0, 4] x [0, 3] x [0, kHeight].
double box_distance(const Eigen::Vector3d& p) {
  return std::min({p.x(), 4.0 - p.x(), p.y(), 3.0 - p.y(), p.z(), kHeight - p.z()});
}

struct Mapped {
  Scanner scanner;
  std::unique_ptr<Places> places;
};

// One box room, scanned from two viewpoints, with places updated to completion.
std::unique_ptr<Mapped> map_box_room(const Config& config = Config{}) {
  auto m = std::make_unique<Mapped>();
  std::string error;
  EXPECT_TRUE(m->scanner.init(testing::rooms_world({4.0}, 3.0, false), 100.0, &error)) << error;
  m->places = make_places(config);
  EXPECT_TRUE(m->scanner.spin({1.3, 1.5, 1.2}, 8, every_frame(m->places.get(), &m->scanner)));
  EXPECT_TRUE(m->scanner.spin({2.7, 1.5, 1.2}, 8, every_frame(m->places.get(), &m->scanner)));
  return m;
}

TEST(PlacesTest, EsdfDistancesInABoxRoomMatchTheWalls) {
  auto m = map_box_room();
  const double s = m->places->voxel_size_m();
  std::size_t checked = 0, within = 0;
  double worst = 0.0;
  for (double x = 0.1; x < 4.0; x += s)
    for (double y = 0.1; y < 3.0; y += s)
      for (double z = 0.1; z < kHeight; z += s) {
        const Eigen::Vector3d p(x, y, z);
        const Eigen::Vector3d c = ((p / s).array().floor() + 0.5).matrix() * s;  // the voxel's centre
        const double truth = box_distance(c);
        if (truth < 0.35) continue;  // inside the truncation band the TSDF's own distance is used
        float d = 0.0f;
        ASSERT_TRUE(m->places->distance_at(p, &d)) << "no distance at " << p.transpose();
        ++checked;
        const double err = std::fabs(d - truth);
        worst = std::max(worst, err);
        within += err <= s ? 1 : 0;
      }
  ASSERT_GT(checked, 500u);
  EXPECT_EQ(within, checked) << "worst error " << worst << " m";
  EXPECT_LE(worst, s);
}

TEST(PlacesTest, GvdOfABoxRoomLiesOnTheMedialAxis) {
  auto m = map_box_room();
  std::vector<GvdVoxelInfo> gvd;
  m->places->gvd_voxels(&gvd);
  ASSERT_GT(gvd.size(), 50u);
  const world::World w = testing::rooms_world({4.0}, 3.0, false);
  const world::FreeSpaceIndex free_space(w);
  sim::GroundTruth truth;
  std::string error;
  ASSERT_TRUE(sim::compute_ground_truth(w, free_space, sim::GroundTruthConfig{}, &truth, &error)) << error;
  ASSERT_GT(truth.gvd.size(), 100u);
  double sum = 0.0, worst = 0.0;
  for (const GvdVoxelInfo& v : gvd) {
    const double d = truth.distance_to_gvd(v.position_m);
    sum += d;
    worst = std::max(worst, d);
    EXPECT_GE(v.num_basis_points, 2);
    EXPECT_NEAR(v.clearance_m, box_distance(v.position_m), m->places->voxel_size_m());
  }
  const double mean = sum / static_cast<double>(gvd.size());
  if (std::getenv("QSG_PLACES_DEBUG") != nullptr)
    for (const GvdVoxelInfo& v : gvd)
      if (truth.distance_to_gvd(v.position_m) > 0.25)
        std::printf("far: %.2f %.2f %.2f clear %.2f basis %d true %.2f\n", v.position_m.x(), v.position_m.y(),
                    v.position_m.z(), v.clearance_m, v.num_basis_points, truth.distance_to_gvd(v.position_m));
  std::printf("box room: %zu GVD voxels, distance to the true theta-SMA mean %.3f m, max %.3f m (%zu true voxels)\n",
              gvd.size(), mean, worst, truth.gvd.size());
  // Half a GVD voxel of discretisation on each side of a sheet lying between voxel centres, and within one voxel.
  EXPECT_LE(mean, 0.12);
  EXPECT_LE(worst, m->places->voxel_size_m());
  // The centre of the room's skeleton is found: the mid-height sheet above the room centre.
  double nearest = 1e9;
  for (const GvdVoxelInfo& v : gvd) nearest = std::min(nearest, (v.position_m - Eigen::Vector3d(2.0, 1.5, 1.25)).norm());
  EXPECT_LE(nearest, 0.35);
}

// A level camera 0.5 m above the floor (a quadruped's) never sees the floor beneath it or the ceiling above it.
// With unobserved space as an obstacle at every height, no voxel claims more clearance than the room has and no
// GVD sheet forms between a wall and the unseen ceiling; with it off (or, the default, only below the camera),
// voxels under the unseen ceiling overclaim. Below the camera nothing overclaims in any mode.
struct LevelScan {
  std::size_t gvd_voxels = 0;
  std::size_t overclaimed = 0;  // ESDF distance above the true clearance by more than a voxel
  std::size_t overclaimed_below_camera = 0;
  double mean_gvd_distance_m = 0.0;
  std::uint64_t frontier_seeds = 0;
};
// A closed 6 m x 4 m room seen by a level camera 0.5 m high, from two spins.
world::World level_room() { return testing::rooms_world({6.0}, 4.0, false); }
std::unique_ptr<Places> map_level_room(const Config& config) {
  Scanner scanner;
  std::string error;
  EXPECT_TRUE(scanner.init(level_room(), 100.0, &error)) << error;
  auto places = make_places(config);
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(1.5, 1.0, 0.5), Eigen::Vector3d(4.5, 3.0, 0.5)})
    EXPECT_TRUE(scanner.spin_at_pitches(p, 8, {0.0}, every_frame(places.get(), &scanner)));
  return places;
}

LevelScan scan_level(bool unobserved_is_obstacle, double above_m) {
  Config config;
  config.unobserved_is_obstacle = unobserved_is_obstacle;
  config.unobserved_obstacle_above_m = above_m;
  const auto places = map_level_room(config);
  std::string error;
  const world::World w = level_room();
  const world::FreeSpaceIndex free_space(w);
  sim::GroundTruth truth;
  EXPECT_TRUE(sim::compute_ground_truth(w, free_space, sim::GroundTruthConfig{}, &truth, &error)) << error;
  LevelScan out;
  std::vector<GvdVoxelInfo> gvd;
  places->gvd_voxels(&gvd);
  out.gvd_voxels = gvd.size();
  double sum = 0.0;
  for (const GvdVoxelInfo& v : gvd) {
    sum += truth.distance_to_gvd(v.position_m);
    const double true_clearance = std::min({v.position_m.x(), 6.0 - v.position_m.x(), v.position_m.y(),
                                            4.0 - v.position_m.y(), v.position_m.z(), kHeight - v.position_m.z()});
    if (v.clearance_m > true_clearance + places->voxel_size_m()) {
      ++out.overclaimed;
      out.overclaimed_below_camera += v.position_m.z() < 0.5 ? 1 : 0;
      if (std::getenv("QSG_PLACES_DEBUG") != nullptr)
        std::printf("overclaimed: %.2f %.2f %.2f clearance %.2f true %.2f\n", v.position_m.x(), v.position_m.y(),
                    v.position_m.z(), v.clearance_m, true_clearance);
    }
  }
  out.mean_gvd_distance_m = gvd.empty() ? 0.0 : sum / static_cast<double>(gvd.size());
  out.frontier_seeds = places->counters().frontier_seeds;
  return out;
}

TEST(PlacesTest, UnobservedSpaceBoundsDistancesAndMakesNoGvd) {
  const LevelScan all = scan_level(true, 100.0);  // unobserved space is an obstacle at every height
  const LevelScan below = scan_level(true, Config{}.unobserved_obstacle_above_m);  // the default: below the camera
  const LevelScan off = scan_level(false, 0.0);
  std::printf("level camera: unobserved as obstacle everywhere %zu GVD voxels, %zu overclaimed, mean distance to the "
              "true GVD %.3f m, %llu frontier seeds; below the camera %zu, %zu (%zu below it), %.3f m; off %zu, %zu "
              "(%zu below the camera), %.3f m\n",
              all.gvd_voxels, all.overclaimed, all.mean_gvd_distance_m, (unsigned long long)all.frontier_seeds,
              below.gvd_voxels, below.overclaimed, below.overclaimed_below_camera, below.mean_gvd_distance_m,
              off.gvd_voxels, off.overclaimed, off.overclaimed_below_camera, off.mean_gvd_distance_m);
  EXPECT_GT(all.frontier_seeds, 0u);
  EXPECT_GT(below.frontier_seeds, 0u);
  EXPECT_EQ(off.frontier_seeds, 0u);
  EXPECT_GT(off.overclaimed, 0u) << "the scene must leave the ceiling unseen";
  EXPECT_EQ(all.overclaimed, 0u);
  // Below the camera nothing overclaims in any mode (an unseen floor under seen free space is an occupied seed or
  // a frontier); above it, the default leaves unseen space open, as the off mode does.
  EXPECT_EQ(below.overclaimed_below_camera, 0u);
  EXPECT_EQ(off.overclaimed_below_camera, 0u);
  EXPECT_GT(all.gvd_voxels, 20u);
  EXPECT_LT(all.mean_gvd_distance_m, off.mean_gvd_distance_m);
}

// A level camera 0.5 m above the floor sees most of the floor at a grazing angle, where the TSDF's projective
// distances overestimate (by 1/sin(angle), up to the truncation). Seeds measured from the TSDF's zero crossings
// give ESDF distances near the floor that match the true clearance; seeds at the TSDF's values overclaim.
struct FloorError {
  double mean_abs_m = 0.0;
  std::size_t samples = 0, overclaimed = 0;
};
FloorError floor_distance_error(bool corrected) {
  Config config;
  config.correct_projective_distance = corrected;
  config.signed_surface_seeds = corrected;
  const auto places = map_level_room(config);
  FloorError out;
  double sum = 0.0;
  const double s = places->voxel_size_m();
  // Voxel centres 0.1-0.5 m above the floor, at least 1 m from every wall (the floor is the nearest surface).
  for (double z = 0.5 * s; z < 0.6; z += s)
    for (double y = 1.0 + 0.5 * s; y < 3.0; y += s)
      for (double x = 1.0 + 0.5 * s; x < 5.0; x += s) {
        float d = 0.0f;
        if (!places->distance_at({x, y, z}, &d)) continue;
        const double err = static_cast<double>(d) - z;
        sum += std::fabs(err);
        ++out.samples;
        out.overclaimed += err > 0.5 * s ? 1 : 0;
      }
  out.mean_abs_m = out.samples > 0 ? sum / static_cast<double>(out.samples) : 0.0;
  return out;
}

TEST(PlacesTest, SeedsFromZeroCrossingsUndoTheProjectiveOverestimate) {
  const FloorError on = floor_distance_error(true), off = floor_distance_error(false);
  std::printf("ESDF near the floor vs true clearance: zero-crossing seeds mean |error| %.3f m, %zu of %zu overclaim "
              "by > half a voxel; TSDF-value seeds %.3f m, %zu of %zu\n",
              on.mean_abs_m, on.overclaimed, on.samples, off.mean_abs_m, off.overclaimed, off.samples);
  ASSERT_GT(on.samples, 100u);
  ASSERT_GT(off.samples, 100u);
  EXPECT_GT(off.overclaimed, off.samples / 4) << "the scene must show the projective overestimate";
  EXPECT_LT(on.mean_abs_m, 0.5 * off.mean_abs_m);
  EXPECT_LT(on.overclaimed, on.samples / 20);
}

// Two rooms joined by a door: one connected free-space region, so one connected places graph. Two closed rooms:
// two regions, two components.
std::size_t components_of_two_rooms(bool door, std::size_t* num_places) {
  Scanner scanner;
  std::string error;
  EXPECT_TRUE(scanner.init(testing::rooms_world({3.0, 3.0}, 3.0, door), 100.0, &error)) << error;
  auto places = make_places();
  EXPECT_TRUE(scanner.spin({1.5, 1.5, 1.2}, 8, every_frame(places.get(), &scanner)));
  EXPECT_TRUE(scanner.spin({4.6, 1.5, 1.2}, 8, every_frame(places.get(), &scanner)));
  if (door) {
    EXPECT_TRUE(scanner.spin({3.05, 1.5, 1.2}, 4, every_frame(places.get(), &scanner)));
  }
  auto graph = make_graph();
  const SyncResult r = places->sync(graph.get());
  EXPECT_EQ(r.status, scene_graph::Status::kOk);
  EXPECT_EQ(r.nodes_added, places->num_places());
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kPlace), places->num_places());
  EXPECT_EQ(graph->num_edges(), places->num_place_edges());
  *num_places = places->num_places();
  return place_components(*graph);
}

TEST(PlacesTest, TwoRoomsAndADoorFormOneConnectedPlacesGraph) {
  std::size_t n = 0;
  EXPECT_EQ(components_of_two_rooms(true, &n), 1u);
  EXPECT_GE(n, 6u);
}

TEST(PlacesTest, TwoClosedRoomsFormTwoPlacesComponents) {
  std::size_t n = 0;
  EXPECT_EQ(components_of_two_rooms(false, &n), 2u);
  EXPECT_GE(n, 6u);
}

// The sparsified graph follows the paper's rules: every place is one connected piece of GVD inside one hash
// cell; two places are joined exactly when their voxels touch, with the smallest clearance of the touching
// voxels as weight; the node takes the clearance of its voxel with the most basis points.
TEST(PlacesTest, SparsificationClustersAndEdgeWeightsFollowTheGvd) {
  auto m = map_box_room();
  const double s = m->places->voxel_size_m();
  const double cell = m->places->config().place_resolution_m;
  std::vector<PlaceInfo> places;
  m->places->places(&places);
  ASSERT_GT(places.size(), 4u);
  const auto touch = [s](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return (a - b).cwiseAbs().maxCoeff() < 1.5 * s;
  };
  const auto cell_of = [cell](const Eigen::Vector3d& p) { return (p / cell).array().floor().cast<int>().eval(); };
  std::size_t edges = 0;
  for (const PlaceInfo& p : places) {
    ASSERT_GT(p.num_voxels, 0u);
    ASSERT_EQ(p.voxel_positions_m.size(), p.num_voxels);
    // One hash cell, one connected piece of the GVD graph.
    std::vector<bool> reached(p.num_voxels, false);
    std::vector<std::size_t> stack{0};
    reached[0] = true;
    while (!stack.empty()) {
      const std::size_t i = stack.back();
      stack.pop_back();
      for (std::size_t j = 0; j < p.num_voxels; ++j)
        if (!reached[j] && touch(p.voxel_positions_m[i], p.voxel_positions_m[j])) {
          reached[j] = true;
          stack.push_back(j);
        }
    }
    EXPECT_TRUE(std::all_of(reached.begin(), reached.end(), [](bool b) { return b; })) << "cluster not connected";
    for (const Eigen::Vector3d& v : p.voxel_positions_m) EXPECT_TRUE((cell_of(v) == cell_of(p.voxel_positions_m[0])).all());
    // Node from the voxel with the most basis points.
    const std::uint32_t most = *std::max_element(p.voxel_basis_points.begin(), p.voxel_basis_points.end());
    EXPECT_EQ(p.num_basis_points, most);
    EXPECT_GE(p.num_basis_points, 2u);
    bool rep_found = false;
    for (std::size_t i = 0; i < p.num_voxels; ++i)
      rep_found = rep_found || (p.voxel_positions_m[i] == p.position_m && p.voxel_basis_points[i] == most &&
                                std::fabs(p.voxel_clearances_m[i] - p.clearance_m) < 1e-6);
    EXPECT_TRUE(rep_found);
    // Edges: exactly the places whose voxels touch, weighted by the smallest clearance of the touching voxels.
    for (const PlaceInfo& q : places) {
      if (q.id == p.id) continue;
      double expected = 1e9;
      for (std::size_t i = 0; i < p.num_voxels; ++i)
        for (std::size_t j = 0; j < q.num_voxels; ++j)
          if (touch(p.voxel_positions_m[i], q.voxel_positions_m[j]))
            expected = std::min({expected, p.voxel_clearances_m[i], q.voxel_clearances_m[j]});
      const auto it = std::find_if(p.edges.begin(), p.edges.end(), [&](const auto& e) { return e.first == q.id; });
      if (expected == 1e9) {
        EXPECT_TRUE(it == p.edges.end()) << "edge between places that do not touch";
        continue;
      }
      // Touching places of one cell would have been merged.
      EXPECT_FALSE((cell_of(p.voxel_positions_m[0]) == cell_of(q.voxel_positions_m[0])).all());
      ASSERT_TRUE(it != p.edges.end()) << "touching places without an edge";
      EXPECT_NEAR(it->second, expected, 1e-6);
      ++edges;
    }
  }
  EXPECT_GT(edges, 0u);
  // The scene graph mirror carries the same weights.
  auto graph = make_graph();
  m->places->sync(graph.get());
  for (const PlaceInfo& p : places) {
    const scene_graph::PlaceAttributes* a = graph->place(p.id);
    ASSERT_NE(a, nullptr);
    EXPECT_TRUE(a->is_active);
    EXPECT_NEAR(a->distance_m, p.clearance_m, 1e-6);
    EXPECT_EQ(a->num_basis_points, p.num_basis_points);
    EXPECT_GE(a->mesh_connections.size(), 1u);  // basis points on observed surfaces reach a mesh vertex
    for (const auto& [other, weight] : p.edges) {
      const scene_graph::EdgeRecord* e = graph->edge(p.id, other);
      ASSERT_NE(e, nullptr);
      EXPECT_NEAR(e->info.weight, weight, 1e-6);
    }
  }
}

// Adding a partition wall later: GVD voxels and places that are no longer valid disappear, and the incremental
// result matches a from-scratch run on the final TSDF.
TEST(PlacesTest, AnObstacleAddedLaterRemovesInvalidGvdVoxelsAndPlaces) {
  world::World w = testing::rooms_world({4.0}, 3.0, false);
  Scanner scanner;
  std::string error;
  ASSERT_TRUE(scanner.init(w, 4.0, &error)) << error;  // low max weight: the map follows the change quickly
  auto places = make_places();
  const auto hook = every_frame(places.get(), &scanner);
  ASSERT_TRUE(scanner.spin({1.0, 1.5, 1.2}, 8, hook));
  ASSERT_TRUE(scanner.spin({3.0, 1.5, 1.2}, 8, hook));
  auto graph = make_graph();
  places->sync(graph.get());
  std::vector<GvdVoxelInfo> before;
  places->gvd_voxels(&before);
  // A 0.2 m partition across the room at x = 2, from y = 0 to 2 m, full height.
  const Eigen::Vector3d lo(1.9, 0.0, 0.0), hi(2.1, 2.0, kHeight);
  std::size_t inside_before = 0;
  for (const GvdVoxelInfo& v : before)
    inside_before += (v.position_m.array() >= lo.array() - 0.1).all() && (v.position_m.array() <= hi.array() + 0.1).all();
  ASSERT_GT(inside_before, 0u) << "the old skeleton must cross the new wall's place";
  testing::add_box(&w, lo, hi);
  ASSERT_TRUE(scanner.set_world(w, &error)) << error;
  for (int pass = 0; pass < 2; ++pass) {  // from where the partition's end face is seen too
    ASSERT_TRUE(scanner.spin({1.0, 2.4, 1.2}, 8, hook));
    ASSERT_TRUE(scanner.spin({3.0, 2.4, 1.2}, 8, hook));
  }
  const SyncResult r = places->sync(graph.get());
  EXPECT_GT(r.nodes_removed, 0u);
  EXPECT_GT(places->counters().voxels_raised, 0u);
  std::vector<GvdVoxelInfo> after;
  places->gvd_voxels(&after);
  for (const GvdVoxelInfo& v : after) {
    const bool inside = (v.position_m.array() >= lo.array()).all() && (v.position_m.array() <= hi.array()).all();
    EXPECT_FALSE(inside) << "GVD voxel inside the new wall at " << v.position_m.transpose();
  }
  std::vector<PlaceInfo> now;
  places->places(&now);
  for (const PlaceInfo& p : now) {
    const bool inside = (p.position_m.array() >= lo.array()).all() && (p.position_m.array() <= hi.array()).all();
    EXPECT_FALSE(inside) << "place inside the new wall at " << p.position_m.transpose();
    EXPECT_TRUE(graph->has_node(p.id));
  }
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kPlace), now.size());
  // Against the truth of the changed room: distances as good as in the untouched test, the skeleton on the
  // new medial axis.
  const auto truth_distance = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d q = (p - 0.5 * (lo + hi)).cwiseAbs() - 0.5 * (hi - lo);
    const double box = q.maxCoeff() > 0 ? q.cwiseMax(0.0).norm() : -q.maxCoeff();
    return std::min(box_distance(p), box);
  };
  const double s = places->voxel_size_m();
  std::size_t checked = 0, bad = 0;
  for (double x = 0.1; x < 4.0; x += s)
    for (double y = 0.1; y < 3.0; y += s)
      for (double z = 0.1; z < kHeight; z += s) {
        const Eigen::Vector3d c(x, y, z);
        const double t = truth_distance(c);
        if (t < 0.35) continue;
        float d = 0.0f;
        if (!places->distance_at(c, &d)) {
          ++bad;
          continue;
        }
        ++checked;
        if (std::fabs(d - t) > s) {
          ++bad;
          if (std::getenv("QSG_PLACES_DEBUG") != nullptr)
            std::printf("bad %.1f %.1f %.1f esdf %.2f truth %.2f\n", x, y, z, d, t);
        }
      }
  EXPECT_GT(checked, 400u);
  EXPECT_LE(bad, checked / 100) << "ESDF voxels off by more than one voxel after the change";
  const world::FreeSpaceIndex free_space(w);
  sim::GroundTruth truth;
  ASSERT_TRUE(sim::compute_ground_truth(w, free_space, sim::GroundTruthConfig{}, &truth, &error)) << error;
  double sum = 0.0;
  for (const GvdVoxelInfo& v : after) sum += truth.distance_to_gvd(v.position_m);
  const double mean = sum / static_cast<double>(std::max<std::size_t>(1, after.size()));
  std::printf("after the change: %zu GVD voxels (%zu before), mean distance to the true theta-SMA %.3f m\n",
              after.size(), before.size(), mean);
  EXPECT_LE(mean, 0.12);
}

TEST(PlacesTest, PlacesThatLeaveTheWindowStayInTheGraphInactive) {
  Scanner scanner;
  std::string error;
  ASSERT_TRUE(scanner.init(testing::rooms_world({3.0, 3.0}, 3.0, true), 100.0, &error)) << error;
  auto places = make_places();
  ASSERT_TRUE(scanner.spin({1.5, 1.5, 1.2}, 8, every_frame(places.get(), &scanner)));
  ASSERT_TRUE(scanner.spin({4.6, 1.5, 1.2}, 8, every_frame(places.get(), &scanner)));
  auto graph = make_graph();
  places->sync(graph.get());
  const std::size_t nodes = graph->num_nodes(scene_graph::NodeKind::kPlace);
  const std::size_t edges = graph->num_edges();
  ASSERT_GT(nodes, 4u);
  // The robot walks 30 m away: every ESDF block leaves the window.
  run_to_completion(places.get(), scanner.tsdf(), {33.0, 1.5, 1.2});
  EXPECT_EQ(places->num_places(), 0u);
  EXPECT_GT(places->counters().blocks_freed, 0u);
  const SyncResult r = places->sync(graph.get());
  EXPECT_EQ(r.nodes_deactivated, nodes);
  EXPECT_EQ(r.nodes_removed, 0u);
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kPlace), nodes);
  EXPECT_EQ(graph->num_edges(), edges);
  graph->for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind == scene_graph::NodeKind::kPlace) {
      EXPECT_FALSE(graph->place(n.id)->is_active);
    }
  });
  places->for_each_resource([](const memory::ResourceStats& s) { EXPECT_EQ(s.failed, 0u) << s.name; });
}

// An obstacle whose ESDF block leaves the window is still there: the distances left inside the window, and the
// clearance of the places there, stay as they were (Config::keep_distances_at_rim). The FIESTA rule for a vanished
// obstacle (the switch off) refills them from the obstacles still inside, so some grow: the test can tell.
TEST(PlacesTest, DistancesDoNotGrowWhenTheirObstacleLeavesTheWindow) {
  const auto grown_after_walking_away = [](bool keep, std::size_t* held, std::size_t* orphans, double* worst_m,
                                           std::size_t* places_grown) {
    Scanner scanner;
    std::string error;
    ASSERT_TRUE(scanner.init(testing::rooms_world({3.0, 3.0}, 3.0, true), 100.0, &error)) << error;
    Config config;
    config.keep_distances_at_rim = keep;
    auto places = make_places(config);
    ASSERT_TRUE(scanner.spin({1.5, 1.5, 1.2}, 8, every_frame(places.get(), &scanner)));
    ASSERT_TRUE(scanner.spin({4.6, 1.5, 1.2}, 8, every_frame(places.get(), &scanner)));
    const double s = places->voxel_size_m();
    std::vector<std::pair<Eigen::Vector3d, float>> before;
    for (double x = 0.1; x < 6.1; x += s)
      for (double y = 0.1; y < 3.0; y += s)
        for (double z = 0.1; z < kHeight; z += s) {
          float d = 0.0f;
          if (places->distance_at({x, y, z}, &d) && d < 10.0f) before.emplace_back(Eigen::Vector3d(x, y, z), d);
        }
    std::vector<PlaceInfo> places_before;
    places->places(&places_before);
    // The robot steps away along +x: the ESDF blocks up to x = 3.2 m (the first room and the wall between the
    // rooms) leave the 7 m window, those of the second room stay; free space beside that wall took its distance
    // from it.
    run_to_completion(places.get(), scanner.tsdf(), {10.5, 1.5, 1.2});
    ASSERT_GT(places->counters().blocks_freed, 0u);
    *held = 0;
    *worst_m = 0.0;
    for (const auto& [p, d] : before) {
      float now = 0.0f;
      if (!places->distance_at(p, &now)) continue;
      ++*held;
      *worst_m = std::max(*worst_m, static_cast<double>(now - d));
    }
    std::vector<PlaceInfo> places_after;
    places->places(&places_after);
    *places_grown = 0;
    for (const PlaceInfo& a : places_after)
      for (const PlaceInfo& b : places_before)
        if (a.id == b.id && a.clearance_m > b.clearance_m + 1e-6) ++*places_grown;
    *orphans = places->counters().voxels_orphaned;
  };
  std::size_t held = 0, orphans = 0, grown = 0;
  double worst = 0.0;
  grown_after_walking_away(true, &held, &orphans, &worst, &grown);
  std::printf("kept: %zu distances still in the window, %zu orphaned voxels, largest growth %.3f m, %zu places "
              "grew\n", held, orphans, worst, grown);
  EXPECT_GT(held, 100u);
  EXPECT_GT(orphans, 0u);
  EXPECT_LE(worst, 1e-6);
  EXPECT_EQ(grown, 0u);
  grown_after_walking_away(false, &held, &orphans, &worst, &grown);
  std::printf("raised (switch off): %zu distances still in the window, largest growth %.3f m, %zu places grew\n",
              held, worst, grown);
  EXPECT_EQ(orphans, 0u);
  EXPECT_GT(worst, 0.1) << "the set-up should have distances that the obstacles leaving the window would raise";
  EXPECT_GT(grown, 0u);
}

// The anytime split: the same work cut into many small calls gives exactly the result of one call, also over
// an incremental second scan.
TEST(PlacesTest, SplittingTheWorkAcrossCallsGivesTheSameResult) {
  Scanner scanner;
  std::string error;
  ASSERT_TRUE(scanner.init(testing::rooms_world({3.0, 3.0}, 3.0, true), 100.0, &error)) << error;
  auto whole = make_places();
  auto split = make_places();
  const auto compare = [&]() {
    std::vector<PlaceInfo> a, b;
    whole->places(&a);
    split->places(&b);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].id, b[i].id);
      EXPECT_EQ(a[i].position_m, b[i].position_m);
      EXPECT_EQ(a[i].clearance_m, b[i].clearance_m);
      EXPECT_EQ(a[i].edges, b[i].edges);
    }
    std::vector<GvdVoxelInfo> ga, gb;
    whole->gvd_voxels(&ga);
    split->gvd_voxels(&gb);
    ASSERT_EQ(ga.size(), gb.size());
    for (std::size_t i = 0; i < ga.size(); ++i) EXPECT_EQ(ga[i].position_m, gb[i].position_m);
  };
  for (const Eigen::Vector3d& view : {Eigen::Vector3d(1.5, 1.5, 1.2), Eigen::Vector3d(4.6, 1.5, 1.2)}) {
    int calls = 0;
    ASSERT_TRUE(scanner.spin(view, 8, [&](const Eigen::Vector3d& camera) {
      ASSERT_TRUE(whole->update(scanner.tsdf(), camera, Deadline::unlimited()).complete);
      while (!split->update(scanner.tsdf(), camera, Deadline::work_units(300)).complete) ++calls;
    }));
    EXPECT_GT(calls, 50) << "the work should need many small calls";
    compare();
  }
  EXPECT_GT(whole->num_places(), 4u);
}

// After start-up an update (and a sync) never touches the heap.
TEST(PlacesTest, UpdateAndSyncDoNotAllocate) {
  Scanner scanner;
  std::string error;
  ASSERT_TRUE(scanner.init(testing::rooms_world({4.0}, 3.0, false), 100.0, &error)) << error;
  auto places = make_places();
  auto graph = make_graph();
  ASSERT_TRUE(scanner.spin({1.3, 1.5, 1.2}, 8, every_frame(places.get(), &scanner)));
  places->sync(graph.get());
  const Eigen::Vector3d robot(2.7, 1.5, 1.2);
  ASSERT_TRUE(scanner.spin(robot, 4));
  UpdateResult r;
  EXPECT_NO_ALLOCATIONS(r = places->update(scanner.tsdf(), robot, Deadline::unlimited()));
  EXPECT_TRUE(r.complete);
  SyncResult s;
  EXPECT_NO_ALLOCATIONS(s = places->sync(graph.get()));
  EXPECT_GT(s.nodes_added + s.nodes_updated, 0u);
  // With a deadline callback too.
  ASSERT_TRUE(scanner.spin(robot, 4));
  int calls = 0;
  Deadline d;
  d.check_every = 16;
  d.context = &calls;
  d.expired = [](const void* c) { return ++*static_cast<int*>(const_cast<void*>(c)) > 3; };
  EXPECT_NO_ALLOCATIONS(r = places->update(scanner.tsdf(), robot, d));
  EXPECT_FALSE(r.complete);
  EXPECT_GT(calls, 3);
}

TEST(PlacesTest, FullStoresAreCountedNotFatal) {
  auto m = map_box_room();
  auto graph = make_graph(2);
  const SyncResult r = m->places->sync(graph.get());
  EXPECT_EQ(r.status, scene_graph::Status::kFull);
  EXPECT_GT(r.refused, 0u);
  EXPECT_EQ(graph->num_nodes(scene_graph::NodeKind::kPlace), 2u);
  EXPECT_GT(m->places->counters().graph_refused, 0u);
  // A cluster pool of two places: the rest of the GVD stays unclustered, counted.
  Capacities tiny = small_capacities();
  tiny.place_nodes = 2;
  auto places = make_places(Config{}, tiny);
  ASSERT_TRUE(m->scanner.spin({2.0, 1.5, 1.2}, 8, every_frame(places.get(), &m->scanner)));
  EXPECT_EQ(places->num_places(), 2u);
  EXPECT_GT(places->counters().clusters_refused, 0u);
}

TEST(PlacesTest, BadConfigAndBudgetAreRejectedWithAReason) {
  Places p;
  std::string error;
  Config bad;
  bad.voxel_factor = 3;
  EXPECT_FALSE(p.init(bad, small_capacities(), Places::plan(small_capacities()).total_bytes(), &error));
  EXPECT_NE(error.find("voxel_factor"), std::string::npos) << error;
  bad = Config{};
  bad.min_basis_angle_rad = -1.0;
  EXPECT_FALSE(p.init(bad, small_capacities(), Places::plan(small_capacities()).total_bytes(), &error));
  EXPECT_NE(error.find("min_basis_angle_rad"), std::string::npos) << error;
  EXPECT_FALSE(p.init(Config{}, small_capacities(), 1024, &error));
  EXPECT_NE(error.find("places"), std::string::npos) << error;
  Capacities zero;
  zero.max_blocks = 0;
  EXPECT_FALSE(p.init(Config{}, zero, 1 << 20, &error));
  EXPECT_NE(error.find("max_blocks"), std::string::npos) << error;
  EXPECT_TRUE(p.init(Config{}, small_capacities(), Places::plan(small_capacities()).total_bytes(), &error)) << error;
}

TEST(PlacesTest, TheBudgetTableHoldsTheArena) {
  const Capacities caps = capacities_from_budget();
  EXPECT_LE(Places::plan(caps).total_bytes(), arena_bytes_from_budget());
}

// --- Connectivity across the window and across GVD fragments -------------------------------------------------

struct WalkResult {
  std::size_t components = 0;
  std::size_t nodes = 0;
  std::size_t inactive = 0;
  Counters counters;
};

// Three rooms joined by doors, walked through with a small window (places leave it and stay inactive while the
// GVD at the window's edge is rebuilt), every keyframe updated.
WalkResult walk_three_rooms(const Config& config) {
  WalkResult out;
  Scanner scanner;
  std::string error;
  EXPECT_TRUE(scanner.init(testing::rooms_world({3.0, 3.0, 3.0}, 3.0, true), 100.0, &error)) << error;
  auto places = make_places(config);
  auto graph = make_graph();
  const auto hook = [&](const Eigen::Vector3d& camera) {
    run_to_completion(places.get(), scanner.tsdf(), camera);
    places->sync(graph.get());
  };
  for (const double x : {1.5, 3.05, 4.6, 6.15, 7.7}) EXPECT_TRUE(scanner.spin({x, 1.5, 1.2}, 6, hook));
  out.components = place_components(*graph);
  graph->for_each_node([&](const scene_graph::NodeRecord& n) {
    if (n.kind != scene_graph::NodeKind::kPlace) return;
    ++out.nodes;
    out.inactive += graph->place(n.id)->is_active ? 0 : 1;
  });
  out.counters = places->counters();
  return out;
}

Config small_window_config() {
  Config c;
  c.window_radius_m = 3.5;
  return c;
}

// One free-space region: one places component, although places leave the window (inactive) while the GVD at
// the window's edge is rebuilt: the edges of removed places to inactive ones move to their replacements.
TEST(PlacesTest, AWalkThroughThreeRoomsGivesOneComponentWithFreeSpaceEdgesAndRelinks) {
  // With the defaults, one component.
  const WalkResult defaults = walk_three_rooms(small_window_config());
  EXPECT_GT(defaults.inactive, 0u) << "the walk must move places out of the window";
  EXPECT_EQ(defaults.counters.relinks_refused, 0u);
  EXPECT_EQ(defaults.components, 1u);
  // Without unobserved space as an obstacle and without the rim guard, the GVD here
  // breaks up at the window's edge, which makes removed places next to inactive ones: the relinks under test.
  Config legacy = small_window_config();
  legacy.unobserved_is_obstacle = false;
  legacy.rim_guard = false;
  const WalkResult with = walk_three_rooms(legacy);
  std::printf("three rooms: %zu components (%zu nodes, %zu inactive, %llu free-space edges, %llu relinked); "
              "defaults: %zu components (%zu nodes, %zu inactive)\n",
              with.components, with.nodes, with.inactive, (unsigned long long)with.counters.free_space_edges,
              (unsigned long long)with.counters.relinked, defaults.components, defaults.nodes, defaults.inactive);
  EXPECT_GT(with.inactive, 0u) << "the walk must move places out of the window";
  EXPECT_GT(with.counters.relinked, 0u) << "removed places next to inactive ones must hand their edges over";
  EXPECT_EQ(with.counters.relinks_refused, 0u);
  EXPECT_EQ(with.components, 1u);
}

// Free-space edges follow their rule: neighbouring hash cells, no GVD edge between the two, a positive weight
// no larger than either place's clearance plus a voxel, and the same edge seen from both ends.
TEST(PlacesTest, FreeSpaceEdgesJoinNeighbouringPlacesWithOverlappingSpheres) {
  // A room with a low cabinet along one wall and a table top: GVD sheets above and beside them are cut apart by
  // the theta-SMA, and free-space edges join them.
  world::World w = testing::rooms_world({4.0}, 3.0, false);
  testing::add_box(&w, {0.0, 0.0, 0.0}, {0.8, 3.0, 0.9});
  testing::add_box(&w, {2.0, 0.8, 0.7}, {3.2, 2.0, 0.75});
  auto m = std::make_unique<Mapped>();
  std::string error;
  ASSERT_TRUE(m->scanner.init(w, 100.0, &error)) << error;
  m->places = make_places();
  ASSERT_TRUE(m->scanner.spin({1.5, 1.5, 1.2}, 8, every_frame(m->places.get(), &m->scanner)));
  ASSERT_TRUE(m->scanner.spin({3.0, 0.5, 1.2}, 8, every_frame(m->places.get(), &m->scanner)));
  ASSERT_TRUE(m->scanner.spin({3.0, 2.5, 0.4}, 8, every_frame(m->places.get(), &m->scanner)));
  std::vector<PlaceInfo> places;
  m->places->places(&places);
  const double cell = m->places->config().place_resolution_m;
  const double s = m->places->voxel_size_m();
  const auto cell_of = [cell](const Eigen::Vector3d& p) { return (p / cell).array().floor().cast<int>().eval(); };
  std::map<scene_graph::NodeId, const PlaceInfo*> by_id;
  for (const PlaceInfo& p : places) by_id[p.id] = &p;
  std::size_t free_edges = 0;
  for (const PlaceInfo& p : places)
    for (const auto& [other, weight] : p.free_space_edges) {
      ++free_edges;
      ASSERT_EQ(by_id.count(other), 1u);
      const PlaceInfo& q = *by_id[other];
      EXPECT_LE((cell_of(p.voxel_positions_m[0]) - cell_of(q.voxel_positions_m[0])).cwiseAbs().maxCoeff(), 1);
      const scene_graph::NodeId neighbour = other;  // clang cannot capture a structured binding (C++17)
      EXPECT_TRUE(std::none_of(p.edges.begin(), p.edges.end(), [&](const auto& e) { return e.first == neighbour; }));
      EXPECT_GT(weight, 0.0);
      // Some voxel of one overlaps the other's representative sphere (with the voxel of slack).
      const auto meets = [s](const PlaceInfo& a, const PlaceInfo& b) {
        for (std::size_t i = 0; i < a.num_voxels; ++i)
          if ((a.voxel_positions_m[i] - b.position_m).norm() < a.voxel_clearances_m[i] + b.clearance_m + s + 1e-6)
            return true;
        return false;
      };
      EXPECT_TRUE(meets(p, q) || meets(q, p));
      const auto back = std::find_if(q.free_space_edges.begin(), q.free_space_edges.end(),
                                     [&](const auto& e) { return e.first == p.id; });
      ASSERT_TRUE(back != q.free_space_edges.end()) << "free-space edge not symmetric";
      EXPECT_EQ(back->second, weight);
    }
  std::printf("room with furniture: %zu places, %zu free-space edges\n", places.size(), free_edges / 2);
  EXPECT_GT(free_edges, 0u);
  EXPECT_EQ(free_edges / 2, m->places->counters().free_space_edges);
  // Mirrored into the scene graph like the GVD edges.
  auto graph = make_graph();
  m->places->sync(graph.get());
  for (const PlaceInfo& p : places)
    for (const auto& [other, weight] : p.free_space_edges) {
      const scene_graph::EdgeRecord* e = graph->edge(p.id, other);
      ASSERT_NE(e, nullptr);
      EXPECT_NEAR(e->info.weight, weight, 1e-6);
    }
  EXPECT_EQ(place_components(*graph), 1u) << "one room, one free-space region";
}

// --- observe(): the free space of every keyframe, whatever the update cadence --------------------------------

struct CadenceResult {
  std::set<std::tuple<int, int, int>> gvd;
  std::size_t places = 0;
  std::size_t reached = 0;  // ESDF voxels with a distance
  std::size_t components = 0;
};

// Two rooms with a door scanned from three viewpoints; observe() after every keyframe when `observe`, update()
// every `every_n`th keyframe and once at the end.
CadenceResult run_cadence(int every_n, bool observe) {
  CadenceResult out;
  Scanner scanner;
  std::string error;
  EXPECT_TRUE(scanner.init(testing::rooms_world({3.0, 3.0}, 3.0, true), 100.0, &error)) << error;
  auto places = make_places();
  int frame = 0;
  Eigen::Vector3d last = Eigen::Vector3d::Zero();
  const auto hook = [&](const Eigen::Vector3d& camera) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = camera;
    if (observe) {
      EXPECT_TRUE(places->observe(scanner.tsdf(), T));
    }
    last = camera;
    if (frame++ % every_n == 0) run_to_completion(places.get(), scanner.tsdf(), camera);
  };
  for (const Eigen::Vector3d& v : {Eigen::Vector3d(1.5, 1.5, 1.2), Eigen::Vector3d(3.05, 1.5, 1.2),
                                   Eigen::Vector3d(4.6, 1.5, 1.2)})
    EXPECT_TRUE(scanner.spin(v, 8, hook));
  run_to_completion(places.get(), scanner.tsdf(), last);
  std::vector<GvdVoxelInfo> gvd;
  places->gvd_voxels(&gvd);
  const double s = places->voxel_size_m();
  for (const GvdVoxelInfo& v : gvd)
    out.gvd.insert({static_cast<int>(std::floor(v.position_m.x() / s)), static_cast<int>(std::floor(v.position_m.y() / s)),
                    static_cast<int>(std::floor(v.position_m.z() / s))});
  for (double x = 0.1; x < 6.1; x += s)
    for (double y = 0.1; y < 3.0; y += s)
      for (double z = 0.1; z < kHeight; z += s) {
        float d = 0.0f;
        out.reached += places->distance_at({x, y, z}, &d) ? 1 : 0;
      }
  out.places = places->num_places();
  auto graph = make_graph();
  places->sync(graph.get());
  out.components = place_components(*graph);
  return out;
}

std::size_t symmetric_difference(const std::set<std::tuple<int, int, int>>& a, const std::set<std::tuple<int, int, int>>& b) {
  std::size_t n = 0;
  for (const auto& k : a) n += b.count(k) == 0 ? 1 : 0;
  for (const auto& k : b) n += a.count(k) == 0 ? 1 : 0;
  return n;
}

TEST(PlacesTest, UpdatingEveryFifthKeyframeWithObserveMatchesEveryKeyframe) {
  const CadenceResult every = run_cadence(1, true);
  const CadenceResult fifth = run_cadence(5, true);
  const CadenceResult blind = run_cadence(5, false);  // the old way: 4 of 5 keyframes' free space missed
  const std::size_t diff = symmetric_difference(every.gvd, fifth.gvd);
  const std::size_t diff_blind = symmetric_difference(every.gvd, blind.gvd);
  std::printf("cadence: every keyframe %zu GVD voxels, %zu places, %zu reached; every 5th with observe: %zu GVD "
              "voxels (%zu differ), %zu places, %zu reached; without observe: %zu GVD voxels (%zu differ), %zu places, "
              "%zu reached\n",
              every.gvd.size(), every.places, every.reached, fifth.gvd.size(), diff, fifth.places, fifth.reached,
              blind.gvd.size(), diff_blind, blind.places, blind.reached);
  ASSERT_GT(every.gvd.size(), 100u);
  // Same free space: the ESDF reaches the same voxels (within 1 %), the GVD differs in at most 2 % of its voxels
  // (the TSDF a ray is cast through is a few frames newer), the place count within 10 %.
  EXPECT_NEAR(static_cast<double>(fifth.reached), static_cast<double>(every.reached), 0.01 * every.reached);
  EXPECT_LE(diff, every.gvd.size() / 50);
  EXPECT_NEAR(static_cast<double>(fifth.places), static_cast<double>(every.places), 0.1 * every.places);
  EXPECT_EQ(fifth.components, every.components);
  // Without observe() the difference is larger (this test can fail).
  EXPECT_GT(diff_blind + (every.reached - std::min(every.reached, blind.reached)), diff);
}

// observe() and an update after it stay off the heap.
TEST(PlacesTest, ObserveDoesNotAllocate) {
  Scanner scanner;
  std::string error;
  ASSERT_TRUE(scanner.init(testing::rooms_world({4.0}, 3.0, false), 100.0, &error)) << error;
  auto places = make_places();
  auto graph = make_graph();
  ASSERT_TRUE(scanner.spin({1.3, 1.5, 1.2}, 8, every_frame(places.get(), &scanner)));
  places->sync(graph.get());
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(2.7, 1.5, 1.2);
  int observed = 0;
  ASSERT_TRUE(scanner.spin(T.translation(), 4, [&](const Eigen::Vector3d&) {
    bool ok = false;
    EXPECT_NO_ALLOCATIONS(ok = places->observe(scanner.tsdf(), T));
    observed += ok ? 1 : 0;
  }));
  EXPECT_EQ(observed, 12);
  UpdateResult r;
  EXPECT_NO_ALLOCATIONS(r = places->update(scanner.tsdf(), T.translation(), Deadline::unlimited()));
  EXPECT_TRUE(r.complete);
  SyncResult sr;
  EXPECT_NO_ALLOCATIONS(sr = places->sync(graph.get()));
  EXPECT_GT(places->counters().rays_carved, 0u);
  EXPECT_EQ(places->counters().views_observed, 12u);
  EXPECT_EQ(places->counters().views_merged, 0u);
}

}  // namespace
}  // namespace qsg::places
