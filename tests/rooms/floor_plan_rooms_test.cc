// Tests of the 2D room benchmark tools: the max-overlap score, the classical distance-transform and morphological
// segmentations (the peers of rooms_eval) on a synthetic two-room plan, bad input, and two real benchmark plans.
#include "bench/rooms/floor_plan_rooms.h"

#include <gtest/gtest.h>

#include <set>
#include <vector>

#include "tests/support/test_data.h"

namespace qsg::bench {
namespace {

// 0.05 m cells, 300 x 160 (15 x 8 m): two 7.4 x 7.4 m rooms (55 m^2 each, more than the morphological method's
// 47 m^2 upper limit together or apart) behind a 0.2 m wall at columns 149-152 with a 1 m doorway in rows 70-89.
// Ground truth: left room 1, right room 2, the doorway in none.
struct TwoRooms {
  static constexpr int kCols = 300, kRows = 160;
  std::vector<std::uint8_t> free = std::vector<std::uint8_t>(kCols * kRows, 0);
  std::vector<std::int32_t> truth = std::vector<std::int32_t>(kCols * kRows, 0);
  TwoRooms() {
    for (int r = 4; r < kRows - 4; ++r)
      for (int c = 4; c < kCols - 4; ++c) {
        const bool wall = c >= 149 && c <= 152;
        const bool door = wall && r >= 70 && r < 90;
        free[at(c, r)] = !wall || door ? 1 : 0;
        truth[at(c, r)] = wall ? 0 : (c < 149 ? 1 : 2);
      }
  }
  static std::size_t at(int c, int r) { return static_cast<std::size_t>(r) * kCols + c; }
};

TEST(FloorPlanRooms, PerfectMergedAndEmptyEstimatesScoreAsTheBenchmarkDefines) {
  // Ground truth: room 1 is a quarter of the free cells, room 2 three quarters.
  const std::vector<std::uint8_t> free(8, 1);
  const std::vector<std::int32_t> truth{1, 1, 2, 2, 2, 2, 2, 2};
  const RoomSegmentationScore perfect = score_room_segmentation(free, truth, {5, 5, 7, 7, 7, 7, 7, 7});
  EXPECT_DOUBLE_EQ(perfect.precision_mean, 1.0);
  EXPECT_DOUBLE_EQ(perfect.recall_mean, 1.0);
  EXPECT_DOUBLE_EQ(perfect.precision_area, 1.0);
  EXPECT_EQ(perfect.rooms_found, 2u);
  EXPECT_EQ(perfect.rooms_truth, 2u);

  // One estimated room over both: precision 6/8 (mean and area alike), recall 1.
  const RoomSegmentationScore merged = score_room_segmentation(free, truth, std::vector<std::int32_t>(8, 3));
  EXPECT_DOUBLE_EQ(merged.precision_mean, 0.75);
  EXPECT_DOUBLE_EQ(merged.precision_area, 0.75);
  EXPECT_DOUBLE_EQ(merged.recall_mean, 1.0);
  EXPECT_EQ(merged.rooms_found, 1u);

  // Room 2 split in two halves of 3: mean precision 1, recall of room 2 is 1/2, area recall (2 + 3) / 8.
  const RoomSegmentationScore split = score_room_segmentation(free, truth, {5, 5, 7, 7, 7, 8, 8, 8});
  EXPECT_DOUBLE_EQ(split.precision_mean, 1.0);
  EXPECT_DOUBLE_EQ(split.recall_mean, 0.75);
  EXPECT_DOUBLE_EQ(split.recall_area, 5.0 / 8.0);

  // Nothing estimated: no room found, recall 0 (unlabelled cells count against recall).
  const RoomSegmentationScore empty = score_room_segmentation(free, truth, std::vector<std::int32_t>(8, 0));
  EXPECT_EQ(empty.rooms_found, 0u);
  EXPECT_DOUBLE_EQ(empty.recall_mean, 0.0);

  // Occupied cells and cells outside every room are not scored.
  std::vector<std::uint8_t> with_wall = free;
  with_wall[0] = 0;
  const RoomSegmentationScore walled = score_room_segmentation(with_wall, truth, {9, 5, 7, 7, 7, 7, 7, 7});
  EXPECT_DOUBLE_EQ(walled.precision_mean, 1.0);

  // Pooling over maps: sums, then ratios.
  RoomSegmentationScore pooled = perfect;
  pooled.add(merged);
  EXPECT_EQ(pooled.rooms_found, 3u);
  EXPECT_DOUBLE_EQ(pooled.precision_mean, (2.0 + 0.75) / 3.0);
  EXPECT_DOUBLE_EQ(pooled.precision_area, (8.0 + 6.0) / 16.0);

  // Mismatched sizes score nothing.
  EXPECT_EQ(score_room_segmentation(free, truth, {1}).rooms_truth, 0u);
}

DistanceSegmentationConfig plateau_config() {
  DistanceSegmentationConfig dc;
  dc.level = DistanceSegmentationConfig::Level::kPlateau;
  return dc;
}

TEST(FloorPlanRooms, TwoRoomsAreSplitAtTheirDoorByEveryPeer) {
  const TwoRooms plan;
  PlanSegmentation by_distance, by_plateau, by_erosion;
  const char* error = nullptr;
  ASSERT_TRUE(segment_by_distance_transform(plan.free, TwoRooms::kCols, TwoRooms::kRows, DistanceSegmentationConfig{},
                                            &by_distance, &error))
      << error;
  ASSERT_TRUE(segment_by_distance_transform(plan.free, TwoRooms::kCols, TwoRooms::kRows, plateau_config(),
                                            &by_plateau, &error))
      << error;
  ASSERT_TRUE(segment_by_erosion(plan.free, TwoRooms::kCols, TwoRooms::kRows, MorphologicalSegmentationConfig{},
                                 &by_erosion, &error))
      << error;
  for (const PlanSegmentation* seg : {&by_distance, &by_plateau, &by_erosion}) {
    EXPECT_EQ(seg->rooms, 2);
    // Every free cell is reached, and each room's cells carry one label, a different one per room.
    std::set<std::int32_t> left, right;
    for (int r = 0; r < TwoRooms::kRows; ++r)
      for (int c = 0; c < TwoRooms::kCols; ++c) {
        const std::size_t k = TwoRooms::at(c, r);
        if (!plan.free[k]) {
          EXPECT_EQ(seg->labels[k], 0);
          continue;
        }
        EXPECT_GT(seg->labels[k], 0);
        if (plan.truth[k] == 1) left.insert(seg->labels[k]);
        if (plan.truth[k] == 2) right.insert(seg->labels[k]);
      }
    ASSERT_EQ(left.size(), 1u);
    ASSERT_EQ(right.size(), 1u);
    EXPECT_NE(*left.begin(), *right.begin());
    const RoomSegmentationScore s = score_room_segmentation(plan.free, plan.truth, seg->labels);
    EXPECT_DOUBLE_EQ(s.precision_mean, 1.0);
    EXPECT_DOUBLE_EQ(s.recall_mean, 1.0);
  }
  // The distance transform splits them once the doorway (0.5 m from its jambs at most) is below the threshold.
  EXPECT_GE(by_distance.level_m, 0.5);
  EXPECT_LT(by_distance.level_m, 3.7);
  // Two regions at every level of [0.5, 1.2] m: one plateau, taken from its start.
  EXPECT_NEAR(by_plateau.level_m, 0.5, 1e-9);
}

TEST(FloorPlanRooms, PlateauLevelStaysInItsRange) {
  const TwoRooms plan;
  PlanSegmentation seg;
  const char* error = nullptr;
  // A one-level range forces that level, and the rooms still split there.
  DistanceSegmentationConfig dc = plateau_config();
  dc.plateau_min_level_m = 0.9;
  dc.plateau_max_level_m = 0.9;
  ASSERT_TRUE(segment_by_distance_transform(plan.free, TwoRooms::kCols, TwoRooms::kRows, dc, &seg, &error)) << error;
  EXPECT_NEAR(seg.level_m, 0.9, 1e-9);
  EXPECT_EQ(seg.rooms, 2);
  // A range above every level of the plan has no curve: no seeds, nothing labelled (the most-regions rule, which
  // has no range, still finds both rooms).
  dc.plateau_min_level_m = 50.0;
  dc.plateau_max_level_m = 60.0;
  ASSERT_TRUE(segment_by_distance_transform(plan.free, TwoRooms::kCols, TwoRooms::kRows, dc, &seg, &error)) << error;
  EXPECT_EQ(seg.rooms, 0);
  for (const std::int32_t l : seg.labels) EXPECT_EQ(l, 0);
  dc.level = DistanceSegmentationConfig::Level::kMostRooms;
  ASSERT_TRUE(segment_by_distance_transform(plan.free, TwoRooms::kCols, TwoRooms::kRows, dc, &seg, &error)) << error;
  EXPECT_EQ(seg.rooms, 2);
}

TEST(FloorPlanRooms, RoomsOutsideTheAreaRangeAreNotSeeds) {
  const TwoRooms plan;
  // An empty range (minimum above maximum) is refused.
  DistanceSegmentationConfig dc;
  dc.min_room_area_m2 = 60.0;
  dc.max_room_area_m2 = 10.0;
  PlanSegmentation seg;
  const char* error = nullptr;
  EXPECT_FALSE(segment_by_distance_transform(plan.free, TwoRooms::kCols, TwoRooms::kRows, dc, &seg, &error));
  ASSERT_NE(error, nullptr);
  EXPECT_NE(std::string(error).find("area range is empty"), std::string::npos) << error;

  // Seeds must be at least 200 m^2: none is, so nothing is labelled.
  dc.min_room_area_m2 = 200.0;
  dc.max_room_area_m2 = 400.0;
  ASSERT_TRUE(segment_by_distance_transform(plan.free, TwoRooms::kCols, TwoRooms::kRows, dc, &seg, &error)) << error;
  EXPECT_EQ(seg.rooms, 0);
  for (const std::int32_t l : seg.labels) EXPECT_EQ(l, 0);
}

TEST(FloorPlanRooms, BadInputGivesClearErrors) {
  const TwoRooms plan;
  PlanSegmentation seg;
  const char* error = nullptr;
  EXPECT_FALSE(segment_by_distance_transform(plan.free, TwoRooms::kCols + 1, TwoRooms::kRows,
                                             DistanceSegmentationConfig{}, &seg, &error));
  EXPECT_NE(std::string(error).find("does not match"), std::string::npos) << error;
  EXPECT_FALSE(segment_by_erosion(plan.free, TwoRooms::kCols, TwoRooms::kRows, MorphologicalSegmentationConfig{},
                                  nullptr, &error));
  MorphologicalSegmentationConfig mc;
  mc.resolution_m = 0.0;
  EXPECT_FALSE(segment_by_erosion(plan.free, TwoRooms::kCols, TwoRooms::kRows, mc, &seg, &error));
  EXPECT_NE(std::string(error).find("resolution_m"), std::string::npos) << error;
  DistanceSegmentationConfig dc;
  dc.step_m = -1.0;
  EXPECT_FALSE(segment_by_distance_transform(plan.free, TwoRooms::kCols, TwoRooms::kRows, dc, &seg, &error));
  EXPECT_NE(std::string(error).find("step_m"), std::string::npos) << error;
  dc = plateau_config();
  dc.plateau_alpha = 1.5;
  EXPECT_FALSE(segment_by_distance_transform(plan.free, TwoRooms::kCols, TwoRooms::kRows, dc, &seg, &error));
  EXPECT_NE(std::string(error).find("plateau_alpha"), std::string::npos) << error;
  dc = plateau_config();
  dc.plateau_max_level_m = 0.2;  // below the minimum, 0.5
  EXPECT_FALSE(segment_by_distance_transform(plan.free, TwoRooms::kCols, TwoRooms::kRows, dc, &seg, &error));
  EXPECT_NE(std::string(error).find("plateau range"), std::string::npos) << error;
  // A null error pointer is allowed.
  EXPECT_FALSE(segment_by_distance_transform(plan.free, 0, 0, DistanceSegmentationConfig{}, &seg, nullptr));

  PlanRaster raster;
  std::string why;
  EXPECT_FALSE(read_plan_raster("/nonexistent/plan.png", "/nonexistent/plan_gt_segmentation.png",
                                world::FloorPlanConfig{}, &raster, &why));
  EXPECT_NE(why.find("cannot read"), std::string::npos) << why;
}

// Real plans: the peers reproduce their measured quality on two benchmark plans (rooms_eval prints all six), so a
// change that breaks either method on real maps fails here.
TEST(FloorPlanRooms, PeersSegmentRealBenchmarkPlans) {
  struct Case {
    const char* map;
    double min_precision, min_recall;
  };
  // Measured (distance transform, the same with the plateau level / morphological), mean P and R: Freiburg52_scan
  // 0.946 / 1.000 for all three; office_e 0.999 / 0.999 for both distance levels and 0.952 / 0.994.
  for (const Case& c : {Case{"Freiburg52_scan", 0.9, 0.95}, Case{"office_e", 0.9, 0.95}}) {
    const std::string base = std::string("floorplans/ipa/") + c.map;
    QSG_REQUIRE_SHARED_DATA(occupancy, base + ".png");
    QSG_REQUIRE_SHARED_DATA(gt, base + "_gt_segmentation.png");
    PlanRaster raster;
    std::string why;
    ASSERT_TRUE(read_plan_raster(occupancy, gt, world::FloorPlanConfig{}, &raster, &why)) << why;
    std::set<std::int32_t> rooms(raster.truth.begin(), raster.truth.end());
    rooms.erase(0);
    EXPECT_EQ(rooms.size(), c.map == std::string("office_e") ? 32u : 10u);
    PlanSegmentation by_distance, by_plateau, by_erosion;
    const char* error = nullptr;
    ASSERT_TRUE(segment_by_distance_transform(raster.free, raster.cols, raster.rows, DistanceSegmentationConfig{},
                                              &by_distance, &error));
    ASSERT_TRUE(segment_by_distance_transform(raster.free, raster.cols, raster.rows, plateau_config(), &by_plateau,
                                              &error));
    ASSERT_TRUE(segment_by_erosion(raster.free, raster.cols, raster.rows, MorphologicalSegmentationConfig{},
                                   &by_erosion, &error));
    EXPECT_GE(by_plateau.level_m, 0.5 - 1e-9) << c.map;
    EXPECT_LE(by_plateau.level_m, 1.2 + 1e-9) << c.map;
    for (const PlanSegmentation* seg : {&by_distance, &by_plateau, &by_erosion}) {
      const RoomSegmentationScore s = score_room_segmentation(raster.free, raster.truth, seg->labels);
      EXPECT_GE(s.precision_mean, c.min_precision) << c.map;
      EXPECT_GE(s.recall_mean, c.min_recall) << c.map;
      EXPECT_GE(seg->rooms, 8) << c.map;
    }
  }
}

}  // namespace
}  // namespace qsg::bench
