// Tests of floor-plan import: a small synthetic plan with known rooms and door, error handling, and the six
// benchmark plans (plain and furnished) against their ground-truth room counts.
#include "drivers/world/floor_plan_import.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "drivers/world/world_file.h"
#include "drivers/world/world_query.h"
#include "tests/support/temp_dir.h"
#include "tests/support/test_data.h"

namespace qsg::world {
namespace {

// 160x120 px (8 x 6 m): an outer wall, an inner wall at column 80 with a doorway in rows 50-69 (1 m).
struct SyntheticPlan {
  cv::Mat occupancy{120, 160, CV_8UC1, cv::Scalar(0)};
  cv::Mat ground_truth;
  SyntheticPlan() {
    cv::rectangle(occupancy, cv::Rect(4, 4, 152, 112), cv::Scalar(255), cv::FILLED);
    cv::rectangle(occupancy, cv::Rect(78, 4, 4, 112), cv::Scalar(0), cv::FILLED);
    cv::rectangle(occupancy, cv::Rect(78, 50, 4, 20), cv::Scalar(255), cv::FILLED);
    ground_truth = occupancy.clone();
    cv::line(ground_truth, cv::Point(80, 45), cv::Point(80, 75), cv::Scalar(0), 1);  // closes the doorway
  }
};

TEST(FloorPlanImport, SyntheticPlanGivesTwoRoomsOneDoorAndWalls) {
  const SyntheticPlan plan;
  FloorPlanStats stats;
  const WorldResult r = import_floor_plan(plan.occupancy, plan.ground_truth, FloorPlanConfig(), "synthetic", &stats);
  ASSERT_TRUE(r.ok) << r.error;
  const World& w = r.world;
  ASSERT_EQ(w.rooms.size(), 2u);
  EXPECT_EQ(stats.rooms, 2);
  EXPECT_LE(stats.wall_boxes, 12);  // merged rectangles, not pixels
  EXPECT_EQ(stats.occupied_px, 120 * 160 - 152 * 112 + 4 * 112 - 4 * 20);
  for (const Room& room : w.rooms) {
    ASSERT_EQ(room.footprint_m.size(), 1u);
    EXPECT_GT(polygon_signed_area(room.footprint_m[0]), 0.0);  // counter-clockwise
    EXPECT_EQ(room.label, semantics::kRoomUnknown);
  }
  // Image up is +y: room 0 (found first in raster order) is the left room; its area is about 3.7 x 5.6 m.
  EXPECT_NEAR(polygon_signed_area(w.rooms[0].footprint_m[0]), 3.7 * 5.6, 0.6);
  EXPECT_EQ(room_at(w, 2.0, 3.0, 1.0), 0);
  EXPECT_EQ(room_at(w, 6.0, 3.0, 1.0), 1);
  EXPECT_EQ(room_at(w, 2.0, 3.0, 3.0), -1);  // above the ceiling
  EXPECT_EQ(room_at(w, -1.0, 3.0, 1.0), -1);
  ASSERT_EQ(w.doors.size(), 1u);
  const Door& d = w.doors[0];
  EXPECT_EQ(d.room_a, 0);
  EXPECT_EQ(d.room_b, 1);
  EXPECT_NEAR(d.width_m(), 1.0, 0.1);
  EXPECT_NEAR(0.5 * (d.a_m + d.b_m).x(), 4.025, 0.06);
  EXPECT_NEAR(0.5 * (d.a_m + d.b_m).y(), 3.0, 0.06);  // rows 50-69 -> y 2.55-3.5
  // Walls stand where the image is occupied, the doorway is open.
  const FreeSpaceIndex index(w);
  EXPECT_FALSE(index.is_free(Eigen::Vector3d(4.0, 1.0, 1.0), 0.0));    // inner wall
  EXPECT_TRUE(index.is_free(Eigen::Vector3d(4.0, 3.0, 1.0), 0.3));     // doorway
  EXPECT_FALSE(index.is_free(Eigen::Vector3d(2.0, 3.0, -0.05), 0.0));  // floor
  EXPECT_FALSE(index.is_free(Eigen::Vector3d(2.0, 3.0, 2.55), 0.0));   // ceiling
  EXPECT_TRUE(index.is_free(Eigen::Vector3d(2.0, 3.0, 1.25), 1.0));
}

// A ground-truth room inside another one's ring (offices around a corridor loop, office_a and lab_intel): the
// ring's outer contour encloses the inner room, so without its hole the corridor's footprint would claim the inner
// room (and a tour would never enter it: its ground belongs to the corridor). 200x160 px (10 x 8 m): a ring
// corridor around a walled 4 x 3 m block (cols 60-139, rows 50-109) whose room opens by a 1 m door in its bottom
// wall; the ground truth closes the doorway.
TEST(FloorPlanImport, ARoomInsideARingCorridorIsCutOutOfTheCorridorsFootprint) {
  cv::Mat occupancy(160, 200, CV_8UC1, cv::Scalar(0));
  occupancy(cv::Rect(4, 4, 192, 152)).setTo(255);
  occupancy(cv::Rect(60, 50, 80, 60)).setTo(0);
  occupancy(cv::Rect(64, 54, 72, 52)).setTo(255);
  occupancy(cv::Rect(90, 106, 20, 4)).setTo(255);  // the door, x 4.5-5.5 m
  cv::Mat ground_truth = occupancy.clone();
  ground_truth(cv::Rect(86, 107, 28, 1)).setTo(0);
  FloorPlanStats stats;
  const WorldResult r = import_floor_plan(occupancy, ground_truth, FloorPlanConfig(), "ring", &stats);
  ASSERT_TRUE(r.ok) << r.error;
  const World& w = r.world;
  ASSERT_EQ(w.rooms.size(), 2u);
  EXPECT_EQ(stats.room_holes, 1);
  const std::int32_t ring = room_at(w, 1.0, 1.0, 1.0), inner = room_at(w, 5.0, 4.0, 1.0);
  ASSERT_GE(ring, 0);
  ASSERT_GE(inner, 0);
  EXPECT_NE(ring, inner);
  EXPECT_EQ(room_at(w, 5.0, 7.0, 1.0), ring);   // the corridor above the block
  EXPECT_EQ(room_at(w, 2.5, 4.0, 1.0), ring);   // and left of it
  EXPECT_EQ(room_at(w, 3.1, 4.0, 1.0), -1);     // the block's wall
  EXPECT_EQ(room_at(w, 6.5, 3.0, 1.0), inner);
  for (const Room& room : w.rooms) {
    ASSERT_EQ(room.footprint_m.size(), 1u);
    const double area = polygon_signed_area(room.footprint_m[0]);
    // Outer minus hole; contours run through boundary pixel centres, half a pixel inside the region.
    if (room.id == ring) EXPECT_NEAR(area, 9.6 * 7.6 - 4.0 * 3.0, 1.2);
    else EXPECT_NEAR(area, 3.6 * 2.6, 0.6);
  }
  const WorldResult back = parse_world_json(world_to_json(w), "ring.json");
  ASSERT_TRUE(back.ok) << back.error;
  EXPECT_EQ(room_at(back.world, 5.0, 4.0, 1.0), inner);
}

// Furniture pixels (a furniture mask) stand at furniture_height_m, labelled furniture; the walls keep theirs.
// Without the height (or without the mask) every occupied pixel is a wall, as the benchmark extrudes its plans.
TEST(FloorPlanImport, FurnitureOfTheMaskStandsAtItsOwnHeight) {
  const SyntheticPlan plan;
  cv::Mat furnished = plan.occupancy.clone();
  cv::rectangle(furnished, cv::Rect(30, 40, 20, 10), cv::Scalar(0), cv::FILLED);  // a 1 m x 0.5 m desk at x 2 m
  const cv::Mat mask = (furnished < 250) & (plan.occupancy >= 250);
  FloorPlanConfig config;
  config.furniture_height_m = 0.8;
  FloorPlanStats stats;
  WorldResult r = import_floor_plan(furnished, plan.ground_truth, config, "furnished", &stats, mask);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(stats.furniture_boxes, 1);
  EXPECT_EQ(stats.occupied_px, 120 * 160 - 152 * 112 + 4 * 112 - 4 * 20 + 20 * 10);
  const double desk_y = (120 - 45) * config.resolution_m_per_px;
  {
    const FreeSpaceIndex index(r.world);
    EXPECT_FALSE(index.is_free(Eigen::Vector3d(2.0, desk_y, 0.5), 0.0));  // in the desk
    EXPECT_TRUE(index.is_free(Eigen::Vector3d(2.0, desk_y, 1.5), 0.3));   // above it
    EXPECT_FALSE(index.is_free(Eigen::Vector3d(4.0, 1.0, 2.0), 0.0));     // the inner wall keeps its height
  }
  std::size_t furniture = 0;
  for (const Shape& s : r.world.shapes) furniture += s.material.label == semantics::kFurniture ? 1 : 0;
  EXPECT_EQ(furniture, 1u);
  // The benchmark's extrusion: no height, so the desk is a 2.5 m post.
  r = import_floor_plan(furnished, plan.ground_truth, FloorPlanConfig(), "furnished", &stats, mask);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(stats.furniture_boxes, 0);
  EXPECT_FALSE(FreeSpaceIndex(r.world).is_free(Eigen::Vector3d(2.0, desk_y, 1.5), 0.0));
  // A mask of the wrong size is a clear error.
  r = import_floor_plan(furnished, plan.ground_truth, config, "furnished", &stats, mask(cv::Rect(0, 0, 10, 10)).clone());
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("furniture mask"), std::string::npos) << r.error;
}

TEST(FloorPlanImport, ImportedPlanRoundTripsThroughTheWorldFile) {
  const SyntheticPlan plan;
  const WorldResult r = import_floor_plan(plan.occupancy, plan.ground_truth, FloorPlanConfig(), "synthetic");
  ASSERT_TRUE(r.ok) << r.error;
  const WorldResult back = parse_world_json(world_to_json(r.world), "synthetic.json");
  ASSERT_TRUE(back.ok) << back.error;
  std::string diff;
  EXPECT_TRUE(worlds_equal(r.world, back.world, &diff)) << diff;
}

TEST(FloorPlanImport, WithoutGroundTruthThereAreNoRooms) {
  const SyntheticPlan plan;
  const WorldResult r = import_floor_plan(plan.occupancy, cv::Mat(), FloorPlanConfig());
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_TRUE(r.world.rooms.empty());
  EXPECT_FALSE(r.world.shapes.empty());
}

TEST(FloorPlanImport, ColourInputIsConvertedToGrey) {
  const SyntheticPlan plan;
  cv::Mat bgr, bgra;
  cv::cvtColor(plan.occupancy, bgr, cv::COLOR_GRAY2BGR);
  cv::cvtColor(plan.ground_truth, bgra, cv::COLOR_GRAY2BGRA);
  const WorldResult r = import_floor_plan(bgr, bgra, FloorPlanConfig());
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.world.rooms.size(), 2u);
}

TEST(FloorPlanImport, BadInputGivesClearErrors) {
  const SyntheticPlan plan;
  WorldResult r = import_floor_plan(cv::Mat(), cv::Mat(), FloorPlanConfig());
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("empty"), std::string::npos) << r.error;
  r = import_floor_plan(plan.occupancy, plan.ground_truth(cv::Rect(0, 0, 80, 60)).clone(), FloorPlanConfig());
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("80x60"), std::string::npos) << r.error;
  r = import_floor_plan(cv::Mat(10, 10, CV_16UC1, cv::Scalar(0)), cv::Mat(), FloorPlanConfig());
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("8-bit"), std::string::npos) << r.error;
  r = import_floor_plan(cv::Mat(10, 10, CV_8UC1, cv::Scalar(0)), cv::Mat(), FloorPlanConfig());
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("no free pixels"), std::string::npos) << r.error;
  r = import_floor_plan_files("/nonexistent/plan.png", "", FloorPlanConfig());
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("/nonexistent/plan.png"), std::string::npos) << r.error;
}

// A PNG of only a signature and an IHDR chunk claiming width x height (nothing a decoder could use).
std::string png_header_only(std::uint32_t width, std::uint32_t height) {
  std::string bytes("\x89PNG\r\n\x1a\n", 8);
  const auto be32 = [&](std::uint32_t v) {
    for (int shift = 24; shift >= 0; shift -= 8) bytes.push_back(static_cast<char>((v >> shift) & 0xFF));
  };
  be32(13);
  bytes += "IHDR";
  be32(width);
  be32(height);
  bytes += std::string("\x08\x00\x00\x00\x00", 5);  // 8-bit grey
  be32(0);                                             // CRC (not checked before the size)
  return bytes;
}

// Regression (issue 36): a floor plan whose header claims 65535 x 65535 aborted the importer (OpenCV threw from
// imread). Its size is now read from the header and refused by name before anything is decoded.
TEST(FloorPlanImport, ImagesLargerThanTheLimitAreRefusedFromTheirHeader) {
  qsg::testing::TempDir dir("qsg_floor_plan");
  const std::string huge = dir.file("huge.png");
  std::ofstream(huge, std::ios::binary) << png_header_only(65535, 65535);
  int w = 0, h = 0;
  std::string error;
  ASSERT_TRUE(read_image_size(huge, &w, &h, &error)) << error;
  EXPECT_EQ(w, 65535);
  EXPECT_EQ(h, 65535);
  const std::string expected = huge + ": image of 65535 x 65535 px exceeds the floor-plan limit (max_image_side_px 8192, "
                                      "max_image_pixels 16777216)";
  WorldResult r = import_floor_plan_files(huge, "", FloorPlanConfig());
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.error, expected);
  r = import_furnished_floor_plan_files(huge, huge, "", FloorPlanConfig());
  EXPECT_EQ(r.error, expected);
  // Within the side limit but past the pixel limit.
  std::ofstream(dir.file("wide.png"), std::ios::binary) << png_header_only(8000, 4000);
  r = import_floor_plan_files(dir.file("wide.png"), "", FloorPlanConfig());
  EXPECT_NE(r.error.find("image of 8000 x 4000 px exceeds"), std::string::npos) << r.error;
  // The ground truth is bounded the same way.
  const SyntheticPlan plan;
  ASSERT_TRUE(cv::imwrite(dir.file("plan.png"), plan.occupancy));
  r = import_floor_plan_files(dir.file("plan.png"), huge, FloorPlanConfig());
  EXPECT_EQ(r.error, expected);
  // Not an image at all, and a header cut short.
  std::ofstream(dir.file("text.png")) << "{\"not\": \"an image\"}";
  r = import_floor_plan_files(dir.file("text.png"), "", FloorPlanConfig());
  EXPECT_NE(r.error.find("not a PNG, JPEG, BMP or PNM image"), std::string::npos) << r.error;
  std::ofstream(dir.file("cut.png"), std::ios::binary) << png_header_only(100, 100).substr(0, 20);
  r = import_floor_plan_files(dir.file("cut.png"), "", FloorPlanConfig());
  EXPECT_FALSE(r.ok);
  // In-memory images obey the same limit.
  FloorPlanConfig small;
  small.max_image_side_px = 64;
  r = import_floor_plan(plan.occupancy, plan.ground_truth, small);
  EXPECT_NE(r.error.find("occupancy image of 160 x 120 px exceeds the floor-plan limit (max_image_side_px 64"),
            std::string::npos)
      << r.error;
}

// The header reader agrees with the decoder for every format it knows; a plan within the limits still imports.
TEST(FloorPlanImport, ImageSizeFromTheHeaderOfEveryKnownFormat) {
  qsg::testing::TempDir dir("qsg_floor_plan");
  const SyntheticPlan plan;
  for (const char* name : {"plan.png", "plan.jpg", "plan.bmp", "plan.pgm"}) {
    const std::string path = dir.file(name);
    ASSERT_TRUE(cv::imwrite(path, plan.occupancy)) << name;
    int w = 0, h = 0;
    std::string error;
    ASSERT_TRUE(read_image_size(path, &w, &h, &error)) << name << ": " << error;
    EXPECT_EQ(w, plan.occupancy.cols) << name;
    EXPECT_EQ(h, plan.occupancy.rows) << name;
  }
  ASSERT_TRUE(cv::imwrite(dir.file("gt.png"), plan.ground_truth));
  const WorldResult r = import_floor_plan_files(dir.file("plan.png"), dir.file("gt.png"), FloorPlanConfig());
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.world.rooms.size(), 2u);
}

// Regression (fuzz, floor_plan): a PNM comment ended by '\r' made the header reader and OpenCV's decoder disagree
// on the size, so a header could pass the limit check as 1 x 1 while the decoder allocated 65535 x 65535. The header
// reader now reads PNM exactly as the decoder does; the size it reports is the size decoded.
TEST(FloorPlanImport, PnmHeaderIsReadAsTheDecoderReadsIt) {
  qsg::testing::TempDir dir("qsg_floor_plan");
  struct Case {
    const char* header;
    int w, h;
  };
  const Case cases[] = {
      {"P5\n# comment\r3 2\n255\n", 3, 2},          // comment ended by CR
      {"P5\n#\r3\v2\f255\n", 3, 2},                // vertical tab and form feed are whitespace
      {"P5 3 2 255\n", 3, 2},                         // plain
      {"P5\n#c\r\n# second\n3 2\n255\n", 3, 2},     // comments on consecutive lines
  };
  for (const Case& c : cases) {
    const std::string path = dir.file("plan.pgm");
    std::ofstream(path, std::ios::binary) << c.header << std::string(static_cast<std::size_t>(c.w * c.h), '\x80');
    int w = 0, h = 0;
    std::string error;
    ASSERT_TRUE(read_image_size(path, &w, &h, &error)) << error;
    EXPECT_EQ(w, c.w) << c.header;
    EXPECT_EQ(h, c.h) << c.header;
    cv::Mat grey;
    ASSERT_TRUE(read_floor_plan_image(path, "occupancy", FloorPlanConfig(), &grey, &error)) << error;
    EXPECT_EQ(grey.cols, c.w);
    EXPECT_EQ(grey.rows, c.h);
  }
  // A comment hiding the real size from a reader that ends comments only at '\n': refused by its real size.
  const std::string sneaky = dir.file("sneaky.pgm");
  std::ofstream(sneaky, std::ios::binary) << "P5\n#\r65535 65535\n1 1\n255\n" << std::string(16, '\0');
  int w = 0, h = 0;
  std::string error;
  ASSERT_TRUE(read_image_size(sneaky, &w, &h, &error)) << error;
  EXPECT_EQ(w, 65535);
  EXPECT_EQ(h, 65535);
  cv::Mat grey;
  EXPECT_FALSE(read_floor_plan_image(sneaky, "occupancy", FloorPlanConfig(), &grey, &error));
  EXPECT_NE(error.find("image of 65535 x 65535 px exceeds"), std::string::npos) << error;
  // A comment running to the end of the file has no size.
  std::ofstream(sneaky, std::ios::binary) << "P5\n# no end";
  EXPECT_FALSE(read_image_size(sneaky, &w, &h, &error));
}

TEST(FloorPlanImport, GroundTruthPathDropsTheFurnituresSuffix) {
  EXPECT_EQ(floor_plan_gt_path("/d/ipa/lab_ipa.png"), "/d/ipa/lab_ipa_gt_segmentation.png");
  EXPECT_EQ(floor_plan_gt_path("/d/ipa/lab_ipa_furnitures.png"), "/d/ipa/lab_ipa_gt_segmentation.png");
  EXPECT_EQ(floor_plan_gt_path("office_e"), "office_e_gt_segmentation.png");
}

// Independent reference: 8-connected white regions (> 250) larger than 100 px, by breadth-first flood fill.
int count_gt_rooms(const cv::Mat& gt) {
  cv::Mat seen = cv::Mat::zeros(gt.size(), CV_8U);
  int rooms = 0;
  std::vector<cv::Point> stack;
  for (int r = 0; r < gt.rows; ++r)
    for (int c = 0; c < gt.cols; ++c) {
      if (gt.at<std::uint8_t>(r, c) <= 250 || seen.at<std::uint8_t>(r, c)) continue;
      int area = 0;
      stack.assign(1, cv::Point(c, r));
      seen.at<std::uint8_t>(r, c) = 1;
      while (!stack.empty()) {
        const cv::Point p = stack.back();
        stack.pop_back();
        ++area;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const cv::Point q(p.x + dx, p.y + dy);
            if (q.x < 0 || q.y < 0 || q.x >= gt.cols || q.y >= gt.rows) continue;
            if (gt.at<std::uint8_t>(q) <= 250 || seen.at<std::uint8_t>(q)) continue;
            seen.at<std::uint8_t>(q) = 1;
            stack.push_back(q);
          }
      }
      if (area > 100) ++rooms;
    }
  return rooms;
}

struct BenchmarkMap {
  const char* name;
  int rooms;
};

void PrintTo(const BenchmarkMap& map, std::ostream* os) { *os << map.name << " (" << map.rooms << " rooms)"; }

class BenchmarkFloorPlan : public ::testing::TestWithParam<BenchmarkMap> {};

TEST_P(BenchmarkFloorPlan, RoomCountMatchesGroundTruth) {
  const BenchmarkMap map = GetParam();
  const std::string base = std::string("floorplans/ipa/") + map.name;
  QSG_REQUIRE_SHARED_DATA(plain, base + ".png");
  QSG_REQUIRE_SHARED_DATA(furnished, base + "_furnitures.png");
  QSG_REQUIRE_SHARED_DATA(gt, base + "_gt_segmentation.png");
  EXPECT_EQ(floor_plan_gt_path(plain), gt);
  EXPECT_EQ(floor_plan_gt_path(furnished), gt);
  EXPECT_EQ(count_gt_rooms(cv::imread(gt, cv::IMREAD_GRAYSCALE)), map.rooms);
  for (const std::string& occupancy : {plain, furnished}) {
    FloorPlanStats stats;
    const WorldResult r = import_floor_plan_files(occupancy, gt, FloorPlanConfig(), &stats);
    ASSERT_TRUE(r.ok) << r.error;
    EXPECT_EQ(static_cast<int>(r.world.rooms.size()), map.rooms) << occupancy;
    EXPECT_LT(stats.wall_boxes, 5000) << occupancy;
    EXPECT_GT(stats.doors, 0) << occupancy;
    for (const Room& room : r.world.rooms) {
      ASSERT_EQ(room.footprint_m.size(), 1u);
      EXPECT_GE(room.footprint_m[0].size(), 3u);
      EXPECT_GT(polygon_signed_area(room.footprint_m[0]), 0.25 * 0.9) << "room " << room.id;
    }
    for (const Door& d : r.world.doors) {
      EXPECT_NE(d.room_a, d.room_b);
      EXPECT_GE(d.width_m(), FloorPlanConfig().min_door_width_m);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Ipa, BenchmarkFloorPlan,
                         ::testing::Values(BenchmarkMap{"lab_ipa", 10}, BenchmarkMap{"Freiburg52_scan", 10},
                                           BenchmarkMap{"lab_c_scan", 17}, BenchmarkMap{"lab_intel", 26},
                                           BenchmarkMap{"office_a", 27}, BenchmarkMap{"office_e", 32}),
                         [](const ::testing::TestParamInfo<BenchmarkMap>& p) { return std::string(p.param.name); });

}  // namespace
}  // namespace qsg::world
