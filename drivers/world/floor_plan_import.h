// Turns a 2D occupancy floor plan (and optionally its ground-truth room segmentation) into a 3D World: occupied
// pixels become wall boxes, each ground-truth room becomes a Room footprint, thin separator lines become doors.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

#include <opencv2/core.hpp>

#include "drivers/world/world.h"
#include "drivers/world/world_result.h"

namespace qsg::world {

struct FloorPlanConfig {
  double resolution_m_per_px = 0.05;
  int free_threshold = 250;     // occupancy pixels >= this are free, everything else is occupied
  int gt_room_threshold = 250;  // ground-truth pixels > this are room interior
  int min_room_area_px = 101;   // ground-truth regions smaller than this (100 px or fewer) are ignored
  double wall_height_m = 2.5;
  double door_height_m = 2.0;
  double contour_epsilon_px = 1.0;  // polygon simplification tolerance
  // Holes in a ground-truth room (a block of rooms inside a ring corridor, a pillar) of at least this area are cut
  // out of its footprint; smaller ones (specks of noise) are filled.
  double min_hole_area_px = 20.0;
  int crop_margin_px = 10;          // occupied pixels farther than this outside the free area's bounds are dropped
  bool add_floor_and_ceiling = true;
  double min_door_width_m = 0.4;  // separator pieces shorter than this are not recorded as doors
  int separator_search_px = 2;    // how far from a separator pixel to look for the rooms it separates
  // > 0: pixels of a furniture mask (import_furnished_floor_plan_files: occupied in the furnished plan, free in the
  // plain one) are extruded to this height, as furniture, instead of to the walls' height. 0: every occupied pixel
  // is a wall (the benchmark's own use of its furnished plans: furniture as 2.5 m posts).
  double furniture_height_m = 0.0;
  // Images larger than this are refused from their header, before anything is decoded (a PNG may claim 65535 x
  // 65535 in a few bytes). The benchmark's largest plan is 1234 x 727 px. Ranges: 16 .. 32768 px a side,
  // 256 .. 2^28 pixels.
  int max_image_side_px = 8192;
  std::int64_t max_image_pixels = std::int64_t{16} << 20;

  void print(std::FILE* out) const;
};

// Statistics of the last import, for logs and tests.
struct FloorPlanStats {
  int occupied_px = 0;
  int wall_boxes = 0;
  int furniture_boxes = 0;
  int gt_regions = 0;  // 8-connected white regions before the size filter
  int rooms = 0;
  int doors = 0;
  int room_holes = 0;  // holes cut out of room footprints
};

// Image pixel (col, row) maps to world x = (col + 0.5) * res, y = (rows - row - 0.5) * res: the image's up is +y.
// The occupancy image must be 8-bit with 1-4 channels (converted to grey); ground truth may be empty (no rooms).
// furniture (optional, 8-bit, the occupancy image's size): non-zero pixels are furniture, extruded to
// config.furniture_height_m when that is > 0.
WorldResult import_floor_plan(const cv::Mat& occupancy, const cv::Mat& ground_truth, const FloorPlanConfig& config,
                              const std::string& name = "floor_plan", FloorPlanStats* stats = nullptr,
                              const cv::Mat& furniture = cv::Mat());

// Reads the images with cv::imread once their headers (PNG, JPEG, BMP or PNM; other formats are refused) show a
// size within max_image_side_px and max_image_pixels. gt_path may be empty (no rooms).
WorldResult import_floor_plan_files(const std::string& occupancy_path, const std::string& gt_path,
                                    const FloorPlanConfig& config, FloorPlanStats* stats = nullptr);

// A furnished plan with its furniture (occupied there, free in the plain plan) at config.furniture_height_m.
WorldResult import_furnished_floor_plan_files(const std::string& plain_path, const std::string& furnished_path,
                                              const std::string& gt_path, const FloorPlanConfig& config,
                                              FloorPlanStats* stats = nullptr);

// Width and height from an image file's header without decoding it (PNG, JPEG, BMP, PNM). False with *error
// ("<path>: ...") when the file cannot be read or is none of these formats.
bool read_image_size(const std::string& path, int* width_px, int* height_px, std::string* error);

// Decodes an image as grey once read_image_size() shows it within config.max_image_side_px and max_image_pixels;
// never throws. False with *error ("<path>: ...", naming the limit) otherwise. what: "occupancy", "ground-truth".
bool read_floor_plan_image(const std::string& path, const char* what, const FloorPlanConfig& config, cv::Mat* grey,
                           std::string* error);

// The benchmark's ground-truth file for a map: "<dir>/<map>_gt_segmentation.png", with a "_furnitures" suffix of the
// map name dropped (furnished variants share the plain map's ground truth).
std::string floor_plan_gt_path(const std::string& occupancy_path);

}  // namespace qsg::world
