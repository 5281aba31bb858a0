// Tests of the top-down picture: size from the frame, colours where rooms, walls and overlays are, PNG output.
#include "drivers/world/top_down.h"

#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <cstdio>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "drivers/world/building_generator.h"
#include "drivers/world/world_geometry.h"
#include "drivers/world/world_query.h"

namespace qsg::world {
namespace {

// Two rooms side by side (4 x 3 m each) with walls, a door and one object.
World small_world() {
  World w;
  w.name = "small";
  Room a;
  a.id = 0;
  a.label = semantics::kKitchen;
  a.footprint_m = {Rect{0.0, 0.0, 4.0, 3.0}.polygon()};
  Room b = a;
  b.id = 1;
  b.label = semantics::kBedroom;
  b.footprint_m = {Rect{4.0, 0.0, 8.0, 3.0}.polygon()};
  w.rooms = {a, b};
  Material wall;
  wall.label = semantics::kWall;
  for (const Rect& r : {Rect{-0.05, -0.05, 8.05, 0.05}, Rect{-0.05, 2.95, 8.05, 3.05}, Rect{-0.05, 0.0, 0.05, 3.0},
                        Rect{7.95, 0.0, 8.05, 3.0}, Rect{3.95, 0.0, 4.05, 1.0}, Rect{3.95, 2.0, 4.05, 3.0}})
    w.add_box(axis_box(r.x0, r.y0, 0.0, r.x1, r.y1, 2.5), wall);
  Door d;
  d.a_m = {4.0, 1.0};
  d.b_m = {4.0, 2.0};
  d.room_a = 0;
  d.room_b = 1;
  w.doors.push_back(d);
  Object o;
  o.id = 0;
  o.label = semantics::kTable;
  o.box = yaw_box({6.0, 1.5, 0.4}, {1.0, 0.6, 0.8}, 0.3);
  o.room_id = 1;
  w.objects.push_back(o);
  return w;
}

cv::Vec3b at(const cv::Mat& img, const TopDownFrame& f, double x, double y) {
  const cv::Point2d p = f.to_pixel(x, y);
  return img.at<cv::Vec3b>(static_cast<int>(p.y), static_cast<int>(p.x));
}

TEST(TopDown, SizeFollowsTheFrame) {
  const World w = small_world();
  TopDownStyle style;
  style.pixels_per_m = 20.0;
  style.margin_px = 10;
  TopDownFrame f;
  const cv::Mat img = draw_top_down(w, style, &f);
  // World x spans -0.05..8.05 (8.1 m), y -0.05..3.05 (3.1 m).
  EXPECT_EQ(img.cols, static_cast<int>(std::ceil(8.1 * 20.0)) + 20);
  EXPECT_EQ(img.rows, static_cast<int>(std::ceil(3.1 * 20.0)) + 20);
  EXPECT_EQ(img.type(), CV_8UC3);
  EXPECT_EQ(f.width_px, img.cols);
  EXPECT_EQ(f.height_px, img.rows);
  const Eigen::Vector2d back = f.to_world(f.to_pixel(1.25, -2.5));
  EXPECT_NEAR(back.x(), 1.25, 1e-9);
  EXPECT_NEAR(back.y(), -2.5, 1e-9);
}

TEST(TopDown, RoomsWallsDoorsAndObjectsAreWhereTheyBelong) {
  const World w = small_world();
  TopDownStyle style;
  style.draw_room_names = false;
  TopDownFrame f;
  const cv::Mat img = draw_top_down(w, style, &f);
  const cv::Scalar kitchen = room_label_color(semantics::kKitchen), bedroom = room_label_color(semantics::kBedroom);
  EXPECT_NE(kitchen, bedroom);
  const cv::Vec3b k = at(img, f, 1.0, 1.5), b = at(img, f, 6.0, 0.5);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(k[c], kitchen[c], 1);
    EXPECT_NEAR(b[c], bedroom[c], 1);
  }
  const cv::Vec3b wall = at(img, f, 4.0, 0.5);
  EXPECT_LT(wall[0] + wall[1] + wall[2], 3 * 60);
  const cv::Vec3b door = at(img, f, 4.0, 1.5);
  EXPECT_GT(door[1], door[0] + 60);  // green
  const cv::Vec3b table = at(img, f, 6.0, 1.5);
  const auto tc = semantics::object_label(semantics::kTable).color;  // RGB
  EXPECT_NEAR(table[2], tc[0], 2);
  EXPECT_NEAR(table[1], tc[1], 2);
  EXPECT_NEAR(table[0], tc[2], 2);
  // The scale bar is black, bottom left.
  bool black = false;
  for (int x = 0; x < img.cols / 3; ++x)
    for (int y = img.rows - f.height_px / 4; y < img.rows; ++y)
      black = black || img.at<cv::Vec3b>(y, x) == cv::Vec3b(0, 0, 0);
  EXPECT_TRUE(black);
}

TEST(TopDown, PolylineAndPointsOverlay) {
  const World w = small_world();
  TopDownFrame f;
  cv::Mat img = draw_top_down(w, TopDownStyle(), &f);
  const cv::Mat before = img.clone();
  draw_polyline(img, {{0.5, 0.5, 0.0}, {3.5, 0.5, 0.0}}, f, cv::Scalar(255, 0, 0), 3);
  draw_points(img, {{2.0, 2.5, 0.0}}, f, cv::Scalar(0, 0, 255), 4);
  EXPECT_EQ(at(img, f, 2.0, 0.5), cv::Vec3b(255, 0, 0));
  EXPECT_EQ(at(img, f, 2.0, 2.5), cv::Vec3b(0, 0, 255));
  EXPECT_EQ(at(img, f, 1.0, 1.5), at(before, f, 1.0, 1.5));
}

TEST(TopDown, LargeWorldsAreScaledDownToTheMaximumSide) {
  BuildingConfig c;
  c.num_rooms = 20;
  const World w = generate_building(c);
  TopDownStyle style;
  style.pixels_per_m = 1000.0;
  style.max_side_px = 800;
  const cv::Mat img = draw_top_down(w, style);
  EXPECT_LE(std::max(img.cols, img.rows), 801);
  EXPECT_GE(std::max(img.cols, img.rows), 790);
}

TEST(TopDown, WritesAPngOfTheExpectedSize) {
  BuildingConfig c;
  c.num_rooms = 10;
  c.two_floors = true;
  const World w = generate_building(c);
  TopDownStyle style;
  style.pixels_per_m = 20.0;
  style.floor_index = 1;
  const TopDownFrame f = top_down_frame(w, style);
  const std::string path = ::testing::TempDir() + "qsg_top_down_" + std::to_string(getpid()) + ".png";
  std::string error;
  ASSERT_TRUE(write_top_down_png(w, style, path, &error)) << error;
  const cv::Mat back = cv::imread(path, cv::IMREAD_COLOR);
  std::remove(path.c_str());
  EXPECT_EQ(back.cols, f.width_px);
  EXPECT_EQ(back.rows, f.height_px);
  EXPECT_FALSE(write_top_down_png(w, style, "/nonexistent_dir/x.png", &error));
  EXPECT_NE(error.find("/nonexistent_dir/x.png"), std::string::npos);
}

}  // namespace
}  // namespace qsg::world
