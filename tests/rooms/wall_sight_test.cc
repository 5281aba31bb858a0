// WallSight: which slice walls are structure (long pieces) and which are furniture (short ones, thick islands),
// sight lines past them, slices per storey, bad input, and the place edges through walls that
// cut_edges_through_walls closes.
#include "core/doors/wall_sight.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "tests/scene_graph/test_graph.h"
#include "tests/support/allocation_counter.h"

namespace qsg::rooms {
namespace {

namespace sg = scene_graph;

// A raster of cols x rows cells of 0.05 m from the origin, with walls painted as axis-aligned boxes.
struct Walls {
  DoorRaster raster;
  std::vector<std::uint8_t> wall;
  Walls(int cols, int rows) {
    raster.lo = Eigen::Vector2d::Zero();
    raster.cols = cols;
    raster.rows = rows;
    raster.cell_m = 0.05;
    wall.assign(raster.cells(), 0);
  }
  // Cells whose centres lie in [x0, x1] x [y0, y1] (metres).
  void box(double x0, double y0, double x1, double y1) {
    for (int r = 0; r < raster.rows; ++r)
      for (int c = 0; c < raster.cols; ++c) {
        const Eigen::Vector2d p = raster.centre_of(c, r);
        if (p.x() >= x0 && p.x() <= x1 && p.y() >= y0 && p.y() <= y1)
          wall[static_cast<std::size_t>(r) * raster.cols + c] = 1;
      }
  }
};

Eigen::Vector3d at(double x, double y, double z = 1.0) { return Eigen::Vector3d(x, y, z); }

// The walls' sight lines as one slice at 1.2 m.
WallSight sight_of(const Walls& w, const DoorConfig& config = DoorConfig{}) {
  WallSight sight;
  std::string error;
  EXPECT_TRUE(sight.add_slice(w.raster, w.wall.data(), 1.2, config, &error)) << error;
  EXPECT_EQ(sight.slices(), 1u);
  return sight;
}

TEST(WallSightTest, LongWallsBlockAndFurnitureDoesNot) {
  // A 6 m x 4 m hall: a wall along x = 3 from y = 0 to 3 (3 m, structure), a 0.5 m post at (1.5, 2), a chair-sized
  // 0.4 m block at (4.5, 1). Nothing else.
  Walls w(120, 80);
  w.box(2.95, 0.0, 3.05, 3.0);
  w.box(1.25, 1.75, 1.75, 2.25);
  w.box(4.3, 0.8, 4.7, 1.2);
  const WallSight sight = sight_of(w);
  EXPECT_EQ(sight.components(0), 3u);
  EXPECT_EQ(sight.structure_components(0), 1u);
  EXPECT_GT(sight.structure_cells(0), 0u);
  // Across the wall: blocked; past its end (y > 3.2, beyond the 0.15 m thickening): clear.
  EXPECT_FALSE(sight.sees(at(1.0, 1.0), at(5.0, 1.5)));
  EXPECT_TRUE(sight.crosses_structure(at(1.0, 1.0), at(5.0, 1.5)));
  EXPECT_TRUE(sight.sees(at(1.0, 3.6), at(5.0, 3.6)));
  EXPECT_FALSE(sight.crosses_structure(at(1.0, 3.6), at(5.0, 3.6)));
  // Through the post and through the block: furniture, clear.
  EXPECT_TRUE(sight.sees(at(0.5, 2.0), at(2.5, 2.0)));
  EXPECT_TRUE(sight.sees(at(3.5, 1.0), at(5.5, 1.0)));
  // Either direction gives the same answer; a point is seen from itself.
  EXPECT_EQ(sight.sees(at(5.0, 1.5), at(1.0, 1.0)), sight.sees(at(1.0, 1.0), at(5.0, 1.5)));
  EXPECT_TRUE(sight.sees(at(0.5, 0.5), at(0.5, 0.5)));
  // A shorter wall limit makes the post structure; a longer one makes the 3 m wall furniture.
  DoorConfig strict;
  strict.sight_min_wall_m = 0.5;
  const WallSight posts = sight_of(w, strict);
  EXPECT_EQ(posts.structure_components(0), 3u);
  EXPECT_FALSE(posts.sees(at(0.5, 2.0), at(2.5, 2.0)));
  DoorConfig loose;
  loose.sight_min_wall_m = 5.0;
  const WallSight none = sight_of(w, loose);
  EXPECT_EQ(none.structure_components(0), 0u);
  EXPECT_TRUE(none.sees(at(1.0, 1.0), at(5.0, 1.5)));
}

TEST(WallSightTest, TheThickeningBridgesSmallGapsNotDoors) {
  // A wall along x = 3 over y in [0, 6.5], seen in pieces: a 0.2 m gap at y = 1 and a 0.9 m door at y in [4, 4.9].
  Walls w(120, 140);
  w.box(2.95, 0.0, 3.05, 0.9);
  w.box(2.95, 1.1, 3.05, 3.95);
  w.box(2.95, 4.95, 3.05, 6.5);
  const WallSight sight = sight_of(w);
  EXPECT_EQ(sight.components(0), 2u);  // the gap is bridged, the door is not
  EXPECT_EQ(sight.structure_components(0), 1u);
  EXPECT_FALSE(sight.sees(at(1.0, 1.0), at(5.0, 1.0)));   // through the small gap: bridged
  EXPECT_FALSE(sight.sees(at(1.0, 2.5), at(5.0, 2.5)));
  EXPECT_TRUE(sight.sees(at(1.0, 4.45), at(5.0, 4.45)));  // through the door: clear
  // Without the thickening the pieces stay apart, each shorter than 3 m: furniture, nothing blocks.
  DoorConfig thin;
  thin.sight_wall_dilation_m = 0.0;
  const WallSight raw = sight_of(w, thin);
  EXPECT_EQ(raw.components(0), 3u);
  EXPECT_EQ(raw.structure_components(0), 0u);
  EXPECT_TRUE(raw.sees(at(1.0, 2.5), at(5.0, 2.5)));
}

TEST(WallSightTest, ThickIslandsAreFurnitureThinOnesAndLongOnesAreWalls) {
  // A 12 m x 10 m hall: a row of desks standing free (4 m x 1 m, x in [1, 5] at y = 2: a thickened mean width of
  // about 1.3 m), a wall piece between two doors (4 m x 0.1 m at y = 6: about 0.4 m wide) and a long thick block
  // (9 m x 1 m at y = 8.5: beyond sight_furniture_max_m, a building's mass).
  Walls w(240, 200);
  w.box(1.0, 1.5, 5.0, 2.5);
  w.box(1.0, 5.95, 5.0, 6.05);
  w.box(1.0, 8.0, 10.0, 9.0);
  const WallSight sight = sight_of(w);
  EXPECT_EQ(sight.components(0), 3u);
  EXPECT_EQ(sight.structure_components(0), 2u);
  EXPECT_EQ(sight.furniture_islands(0), 1u);
  EXPECT_TRUE(sight.sees(at(3.0, 0.5), at(3.0, 4.0)));    // across the desks: clear
  EXPECT_FALSE(sight.sees(at(3.0, 4.0), at(3.0, 7.0)));   // across the thin wall piece: blocked
  EXPECT_FALSE(sight.sees(at(3.0, 7.0), at(3.0, 9.8)));   // across the long block: blocked
  // The rule off (sight_furniture_max_m 0), or a wider width limit: the desks block.
  DoorConfig off;
  off.sight_furniture_max_m = 0.0;
  const WallSight all = sight_of(w, off);
  EXPECT_EQ(all.structure_components(0), 3u);
  EXPECT_EQ(all.furniture_islands(0), 0u);
  EXPECT_FALSE(all.sees(at(3.0, 0.5), at(3.0, 4.0)));
  DoorConfig wide;
  wide.sight_furniture_min_width_m = 1.5;
  EXPECT_FALSE(sight_of(w, wide).sees(at(3.0, 0.5), at(3.0, 4.0)));
  // A shorter island limit than the block's length leaves the block as a wall; one beyond it makes it furniture.
  DoorConfig longer;
  longer.sight_furniture_max_m = 12.0;
  EXPECT_TRUE(sight_of(w, longer).sees(at(3.0, 7.0), at(3.0, 9.8)));
  // Bad values are refused.
  DoorConfig bad;
  bad.sight_furniture_min_width_m = 0.0;
  std::string error;
  WallSight refused;
  EXPECT_FALSE(refused.add_slice(w.raster, w.wall.data(), 1.2, bad, &error));
  EXPECT_NE(error.find("sight_furniture_min_width_m"), std::string::npos) << error;
  bad = DoorConfig{};
  bad.sight_furniture_max_m = std::nan("");
  EXPECT_FALSE(refused.add_slice(w.raster, w.wall.data(), 1.2, bad, &error));
  EXPECT_NE(error.find("sight_furniture_max_m"), std::string::npos) << error;
}

TEST(WallSightTest, EachStoreyHasItsSlice) {
  Walls w(120, 80);
  w.box(2.95, 0.0, 3.05, 4.0);
  WallSight sight = sight_of(w);
  std::string error;
  Walls open(120, 80);  // upstairs: no wall
  ASSERT_TRUE(sight.add_slice(open.raster, open.wall.data(), 4.2, DoorConfig{}, &error)) << error;
  EXPECT_EQ(sight.slice_of(at(1, 1, 1.0)), 0);
  EXPECT_EQ(sight.slice_of(at(1, 1, 4.0)), 1);
  EXPECT_EQ(sight.slice_of(at(1, 1, 9.0)), -1);
  EXPECT_EQ(sight.slice_of(at(1, 1, std::nan(""))), -1);
  EXPECT_FALSE(sight.sees(at(1, 1, 1.0), at(5, 1, 1.0)));
  EXPECT_TRUE(sight.sees(at(1, 1, 4.0), at(5, 1, 4.0)));
  // Ends on two storeys (or none) are never in sight, and such a segment is not judged to cross a wall.
  EXPECT_FALSE(sight.sees(at(1, 1, 1.0), at(1, 2, 4.0)));
  EXPECT_FALSE(sight.crosses_structure(at(1, 1, 1.0), at(5, 1, 4.0)));
  EXPECT_FALSE(sight.sees(at(1, 1, 9.0), at(1, 2, 9.0)));
  // An end outside the raster (not mapped) is not judged: not seen, not crossing; far away, no long walk either.
  EXPECT_FALSE(sight.sees(at(-5, 1, 4.0), at(5, 1, 4.0)));
  EXPECT_FALSE(sight.crosses_structure(at(-5, 1, 1.0), at(5, 1, 1.0)));
  EXPECT_FALSE(sight.sees(at(1, 1, 4.0), at(1e12, -1e12, 4.0)));
  EXPECT_FALSE(sight.crosses_structure(at(1, 1, 1.0), at(1e12, 1, 1.0)));
  sight.clear();
  EXPECT_EQ(sight.slices(), 0u);
  EXPECT_FALSE(sight.sees(at(1, 1), at(1, 2)));
}

TEST(WallSightTest, AWindowSliceIsBuiltInFixedBuffersAndCopiedOut) {
  // The online form: one slice in carved buffers, replaced without allocating; a piece that reaches the window's
  // edge is structure whatever its length inside.
  Walls w(120, 80);
  w.box(2.95, 0.0, 3.05, 1.0);   // a 1 m stub from the window's edge
  w.box(1.25, 1.75, 1.75, 2.25);  // a post
  memory::Arena arena;
  std::string error;
  const memory::ArenaPlan plan = WallSight::plan(120 * 80);
  ASSERT_TRUE(arena.create("sight", plan, plan.total_bytes(), &error)) << error;
  WallSight window;
  ASSERT_TRUE(window.carve(arena, 120 * 80));
  EXPECT_EQ(window.slices(), 0u);
  bool ok = false;
  EXPECT_NO_ALLOCATIONS(ok = window.set_window_slice(w.raster, w.wall.data(), 1.2, DoorConfig{}));
  ASSERT_TRUE(ok);
  ASSERT_EQ(window.slices(), 1u);
  EXPECT_TRUE(window.window());
  EXPECT_EQ(window.structure_components(0), 1u);  // the stub, not the post
  EXPECT_FALSE(window.sees(at(2.0, 0.5), at(4.0, 0.5)));
  EXPECT_TRUE(window.sees(at(0.5, 2.0), at(2.5, 2.0)));
  // The same walls offline, without the edge rule: the stub is furniture.
  EXPECT_EQ(sight_of(w).structure_components(0), 0u);
  // A copy of the window's slice (as rooms_eval keeps the last pass's) sees the same.
  WallSight copy;
  ASSERT_TRUE(copy.add_structure(window.raster(0), window.structure(0), window.slice_z(0), DoorConfig{}, &error))
      << error;
  EXPECT_EQ(copy.structure_cells(0), window.structure_cells(0));
  EXPECT_FALSE(copy.window()) << "a whole-map slice unless said otherwise";
  EXPECT_FALSE(copy.sees(at(2.0, 0.5), at(4.0, 0.5)));
  EXPECT_TRUE(copy.sees(at(0.5, 2.0), at(2.5, 2.0)));
  // Too large a raster for the buffers, or offline calls on a carved sight: refused, and the slice is empty.
  Walls big(200, 80);
  EXPECT_FALSE(window.set_window_slice(big.raster, big.wall.data(), 1.2, DoorConfig{}));
  EXPECT_EQ(window.slices(), 0u);
  EXPECT_FALSE(window.add_slice(w.raster, w.wall.data(), 1.2, DoorConfig{}, &error));
  WallSight uncarved;
  EXPECT_FALSE(uncarved.set_window_slice(w.raster, w.wall.data(), 1.2, DoorConfig{}));
}

TEST(WallSightTest, BadInputIsAnError) {
  Walls w(40, 40);
  WallSight sight;
  std::string error;
  EXPECT_FALSE(sight.add_slice(w.raster, nullptr, 1.2, DoorConfig{}, &error));
  EXPECT_NE(error.find("wall sight"), std::string::npos) << error;
  DoorRaster empty;
  EXPECT_FALSE(sight.add_slice(empty, w.wall.data(), 1.2, DoorConfig{}, &error));
  EXPECT_FALSE(sight.add_slice(w.raster, w.wall.data(), std::nan(""), DoorConfig{}, &error));
  DoorConfig bad;
  bad.sight_min_wall_m = -1.0;
  EXPECT_FALSE(sight.add_slice(w.raster, w.wall.data(), 1.2, bad, &error));
  EXPECT_NE(error.find("sight_min_wall_m"), std::string::npos) << error;
  bad = DoorConfig{};
  bad.sight_wall_dilation_m = std::nan("");
  EXPECT_FALSE(sight.add_slice(w.raster, w.wall.data(), 1.2, bad, &error));
  DoorConfig tiny;
  tiny.max_cells = 100;
  EXPECT_FALSE(sight.add_slice(w.raster, w.wall.data(), 1.2, tiny, &error));
  EXPECT_EQ(sight.slices(), 0u);
  EXPECT_EQ(cut_edges_through_walls(sight, nullptr), 0u);
}

TEST(WallSightTest, PlaceEdgesThroughAWallAreClosed) {
  // A wall at x = 3 with a door at y in [2.5, 3.4]; above the door it runs 3.6 m (structure), below it 2.45 m.
  Walls w(120, 140);
  w.box(2.95, 0.0, 3.05, 2.45);
  w.box(2.95, 3.45, 3.05, 7.0);
  const WallSight sight = sight_of(w);
  auto graph = sg::testing::make_graph();
  const auto place = [&](std::uint64_t i, double x, double y, double z) {
    sg::PlaceAttributes a;
    a.position_m = at(x, y, z);
    a.distance_m = 0.3;
    EXPECT_EQ(graph->add_place(sg::make_node_id(sg::kPlacePrefix, i), a), sg::Status::kOk);
    return sg::make_node_id(sg::kPlacePrefix, i);
  };
  const sg::NodeId a = place(0, 2.5, 5.0, 2.3), b = place(1, 3.5, 5.0, 2.3);  // through the wall, near the ceiling
  const sg::NodeId c = place(2, 2.5, 2.95, 1.0), d = place(3, 3.5, 2.95, 1.0);  // through the door
  const sg::NodeId e = place(4, 2.5, 4.5, 1.0), f = place(5, 2.0, 4.5, 1.0);    // beside the wall
  const sg::NodeId up = place(6, 3.5, 4.5, 4.0);                                 // a storey up: not judged
  const sg::NodeId g = place(7, 2.5, 6.0, 1.0), h = place(8, 3.5, 6.0, 1.0);    // through, but already closed
  sg::EdgeAttributes open;
  open.weighted = true;
  open.weight = 0.3;
  sg::EdgeAttributes shut = open;
  shut.weight = 0.0;
  for (const auto& [s, t] : {std::pair{a, b}, std::pair{c, d}, std::pair{e, f}, std::pair{e, up}})
    ASSERT_EQ(graph->add_edge(s, t, open), sg::Status::kOk);
  ASSERT_EQ(graph->add_edge(g, h, shut), sg::Status::kOk);
  EXPECT_EQ(cut_edges_through_walls(sight, graph.get()), 1u);
  EXPECT_EQ(graph->edge_info(a, b)->weight, 0.0);
  EXPECT_TRUE(graph->edge_info(a, b)->weighted);
  EXPECT_EQ(graph->edge_info(c, d)->weight, 0.3);
  EXPECT_EQ(graph->edge_info(e, f)->weight, 0.3);
  EXPECT_EQ(graph->edge_info(e, up)->weight, 0.3);
  EXPECT_EQ(graph->edge_info(g, h)->weight, 0.0);
  // Again: nothing left to close.
  EXPECT_EQ(cut_edges_through_walls(sight, graph.get()), 0u);
  EXPECT_EQ(cut_edges_through_walls(WallSight{}, graph.get()), 0u);
}

}  // namespace
}  // namespace qsg::rooms
