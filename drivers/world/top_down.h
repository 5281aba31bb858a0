// Top-down pictures of a World (rooms coloured by label, walls, doors, objects, scale bar) with a frame that maps
// world metres to pixels, so trajectories, places or anything else can be drawn over them.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "drivers/world/world.h"

namespace qsg::world {

struct TopDownStyle {
  double pixels_per_m = 40.0;
  int margin_px = 30;
  int floor_index = 0;     // the floor drawn (rooms, walls, objects at its height); -1 draws every floor
  int max_side_px = 6000;  // pixels_per_m is lowered when the picture would be larger than this
  bool fill_rooms = true;  // by room label; rooms of unknown label get a colour per room id instead
  bool draw_walls = true;
  bool draw_doors = true;
  bool draw_objects = true;
  bool draw_room_names = true;
  bool draw_scale_bar = true;
  std::array<std::uint8_t, 3> background_rgb{{255, 255, 255}};

  void print(std::FILE* out) const;
};

// World x grows to the right, world y grows up the picture.
struct TopDownFrame {
  double origin_x_m = 0.0;  // world x at the left edge of the image
  double origin_y_m = 0.0;  // world y at the top edge of the image
  double pixels_per_m = 40.0;
  int width_px = 0;
  int height_px = 0;

  cv::Point2d to_pixel(double x_m, double y_m) const {
    return {(x_m - origin_x_m) * pixels_per_m, (origin_y_m - y_m) * pixels_per_m};
  }
  Eigen::Vector2d to_world(const cv::Point2d& px) const {
    return {origin_x_m + px.x / pixels_per_m, origin_y_m - px.y / pixels_per_m};
  }
};

// The frame draw_top_down() uses: the world's x-y bounds (all floors, so every floor's picture lines up) plus the
// margin. Width = ceil(extent_x * pixels_per_m) + 2 * margin_px, likewise the height.
TopDownFrame top_down_frame(const World& world, const TopDownStyle& style);

// BGR, 8-bit, 3 channels. frame_out (optional) receives the frame used.
cv::Mat draw_top_down(const World& world, const TopDownStyle& style, TopDownFrame* frame_out = nullptr);

// Writes an image as PNG; false with *error ("<path>: ...") on failure.
bool write_png(const cv::Mat& image, const std::string& path, std::string* error);
// draw_top_down() then write_png().
bool write_top_down_png(const World& world, const TopDownStyle& style, const std::string& path, std::string* error);

// Overlays (x, y of each point; z is ignored). Colours are BGR.
void draw_polyline(cv::Mat& image, const std::vector<Eigen::Vector3d>& points_m, const TopDownFrame& frame,
                   const cv::Scalar& color_bgr = cv::Scalar(200, 60, 0), int thickness_px = 2);
void draw_points(cv::Mat& image, const std::vector<Eigen::Vector3d>& points_m, const TopDownFrame& frame,
                 const cv::Scalar& color_bgr = cv::Scalar(0, 0, 220), int radius_px = 3);

// Fill colour (BGR) of a room label in the picture; distinct for every label.
cv::Scalar room_label_color(semantics::RoomLabel label);

}  // namespace qsg::world
